//! The published figures of Yu et al., 2024 (Sci. Rep., s41598-024-72452-6) that gonio's
//! mounting batches are compared with, in one place: the station's 25 real parts (Table 3)
//! and the two references the paper compares it with. Times in s, eccentricities in µm.
//!
//! ```
//! use gonio_station::published::YU_2024;
//! assert_eq!((YU_2024.parts, YU_2024.mean_time_s, YU_2024.max_pushes), (25, 25.1, 5));
//! ```

/// A mounting method's published figures.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PublishedMounting {
    /// Who published them, for a table's heading.
    pub source: &'static str,
    /// Parts mounted.
    pub parts: usize,
    /// Mean time per part, s.
    pub mean_time_s: f64,
    /// Mean pushes per part.
    pub mean_pushes: f64,
    /// Most pushes on one part.
    pub max_pushes: u32,
    /// Mean final eccentricity, µm.
    pub mean_final_e_um: f64,
    /// Parts rejected.
    pub rejected: usize,
    /// Manual mounting, as the paper reports it: final eccentricity, µm, and the time per part,
    /// s (a range).
    pub manual_final_e_um: f64,
    /// Manual mounting's time per part, s: from, to.
    pub manual_time_s: (f64, f64),
    /// Wang et al.'s station, as the paper reports it: final eccentricity, µm.
    pub wang_final_e_um: f64,
    /// Wang et al.'s station: time per part, s.
    pub wang_time_s: f64,
}

/// Yu et al., 2024: the station's 25 real parts.
pub const YU_2024: PublishedMounting = PublishedMounting {
    source: "Yu et al., 2024 (25 real parts)",
    parts: 25,
    mean_time_s: 25.1,
    mean_pushes: 2.1,
    max_pushes: 5,
    mean_final_e_um: 3.8,
    rejected: 0,
    manual_final_e_um: 13.7,
    manual_time_s: (30.0, 40.0),
    wang_final_e_um: 6.0,
    wang_time_s: 32.4,
};
