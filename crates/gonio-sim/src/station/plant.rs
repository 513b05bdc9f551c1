//! The default plant of the simulated station (the station of Yu et al., 2024, as modelled here): the
//! parts, the push rod's behaviour, the detector's noise and the durations of every action.

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use serde::{Deserialize, Serialize};

/// The plant's parameters. The defaults are the spec's (assumptions, plausible, not measured).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct PlantConfig {
    /// Rayleigh scale of the initial eccentricity, µm.
    pub e_scale_um: f64,
    /// Initial eccentricity clipped to at least this, µm.
    pub e_min_um: f64,
    /// … and at most this, µm (the ring must stay in the field of view).
    pub e_max_um: f64,
    /// Detector noise per frame (in focus), px.
    pub noise_px: f64,
    /// Amplitude of each roundness harmonic (orders 2–4), px.
    pub roundness_px: f64,
    /// Per-station push-direction offset drawn from U(−x, x), degrees.
    pub station_offset_max_deg: f64,
    /// Per-push direction scatter, degrees (standard deviation).
    pub push_angle_sd_deg: f64,
    /// Per-station gain drawn from U(lo, hi).
    pub station_gain_range: [f64; 2],
    /// Per-push gain scatter (standard deviation).
    pub gain_sd: f64,
    /// Overshoot on fast contact: |N(0, x)|, µm.
    pub overshoot_fast_sd_um: f64,
    /// Overshoot on slow contact: |N(0, x)|, µm.
    pub overshoot_slow_sd_um: f64,
    /// Stick-slip at the start of a push: U(0, x), µm.
    pub slip_max_um: f64,
    /// No motion when k·d is below this, µm (stiction).
    pub stiction_um: f64,
    /// Contact error: N(0, x), µm.
    pub contact_error_sd_um: f64,
    /// Spring-back: U(0, x) of the move.
    pub spring_back_max: f64,
    /// Column of the ring with the grating centred, px.
    pub c_centre_px: f64,
    /// Radius of the ring, µm (the default recipe's `ring_radius_mm`, which the full fidelity
    /// renders): the camera sees the ring where its row line crosses it, so an offset across
    /// that line moves the column by −offset²/2R (the ring's chord).
    pub ring_radius_um: f64,
    /// Window width, px (a ring outside it is not found).
    pub window_width_px: f64,
    /// Best focus position scatter between parts, µm (standard deviation).
    pub focus_sd_um: f64,
    /// Depth of focus (Gaussian width of the focus measure), µm.
    pub focus_depth_um: f64,
    /// The focus measure at best focus.
    pub focus_peak: f64,
    /// Servo angle log period, s.
    pub log_period_s: f64,
    /// Durations of the actions.
    pub timing: Timing,
}

/// Durations of the station's actions, s. The defaults add up to the spec's time model:
/// focus 2.0 s, measurement 2.8 s, 10 s per push cycle (align 1.0 + approach 2.5 + push 2.0 +
/// retract 1.7 + measurement 2.8), +1.5 s for a slow contact.
///
/// The servo's ramps are those of a constant acceleration: `ramp_s` to `ramp_speed_deg_per_s`
/// (0.2 s to 180°/s, 900°/s²), longer to a faster speed ([`Timing::ramp_at`]); the spin-up and
/// the stop add their settling (0.1 s, and 0.3 s with the fit) to the ramp.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Timing {
    /// One focus-drive move (a 19-step sweep + final move + 19 frames ≈ 2.0 s).
    pub focus_move_s: f64,
    /// Servo spin-up to `ramp_speed_deg_per_s`.
    pub spin_up_s: f64,
    /// Of which the acceleration ramp.
    pub ramp_s: f64,
    /// Servo stop from `ramp_speed_deg_per_s`, settle and fit (with 2.0 s of frames and the
    /// spin-up: 2.8 s).
    pub stop_s: f64,
    /// Align: a settle-limited positioning move.
    pub align_s: f64,
    /// Fast approach to contact.
    pub approach_fast_s: f64,
    /// Extra for a slow approach.
    pub slow_extra_s: f64,
    /// The first push after contact.
    pub push_s: f64,
    /// Each further feedback step.
    pub push_step_s: f64,
    /// Retract.
    pub retract_s: f64,
    /// The speed `ramp_s` accelerates to, °/s.
    pub ramp_speed_deg_per_s: f64,
}

impl Timing {
    /// The ramp to or from `speed_deg_per_s`, s (the acceleration of `ramp_s` to
    /// `ramp_speed_deg_per_s`).
    pub fn ramp_at(&self, speed_deg_per_s: f64) -> f64 {
        self.ramp_s * speed_deg_per_s.abs() / self.ramp_speed_deg_per_s
    }

    /// Spin-up to `speed_deg_per_s`, its settling included, s.
    pub fn spin_up_at(&self, speed_deg_per_s: f64) -> f64 {
        self.spin_up_s - self.ramp_s + self.ramp_at(speed_deg_per_s)
    }

    /// Stop from `speed_deg_per_s`, settling and fit included, s.
    pub fn stop_at(&self, speed_deg_per_s: f64) -> f64 {
        self.stop_s - self.ramp_s + self.ramp_at(speed_deg_per_s)
    }
}

impl Default for Timing {
    fn default() -> Self {
        Timing {
            focus_move_s: 0.0905,
            spin_up_s: 0.3,
            ramp_s: 0.2,
            stop_s: 0.5,
            align_s: 1.0,
            approach_fast_s: 2.5,
            slow_extra_s: 1.5,
            push_s: 2.0,
            push_step_s: 0.1,
            retract_s: 1.7,
            ramp_speed_deg_per_s: 180.0,
        }
    }
}

impl Default for PlantConfig {
    fn default() -> Self {
        PlantConfig {
            e_scale_um: 100.0,
            e_min_um: 8.0,
            e_max_um: 450.0,
            noise_px: 0.3,
            roundness_px: 0.5,
            station_offset_max_deg: 1.0,
            push_angle_sd_deg: 0.2,
            station_gain_range: [0.90, 1.05],
            gain_sd: 0.08,
            overshoot_fast_sd_um: 3.0,
            overshoot_slow_sd_um: 0.5,
            slip_max_um: 1.5,
            stiction_um: 1.0,
            contact_error_sd_um: 0.75,
            spring_back_max: 0.03,
            c_centre_px: 720.0,
            ring_radius_um: 20_000.0,
            window_width_px: 1440.0,
            focus_sd_um: 30.0,
            focus_depth_um: 25.0,
            focus_peak: 40.0,
            log_period_s: 1e-3,
            timing: Timing::default(),
        }
    }
}

/// The station's own constants, drawn once per simulated station.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct StationTruth {
    /// Mean push gain k_station.
    pub gain: f64,
    /// Offset of the actual push direction from the commanded one (camera-to-rod), degrees.
    pub offset_deg: f64,
}

impl StationTruth {
    /// Draws the station's constants.
    pub fn draw(p: &PlantConfig, rng: &mut ChaCha8Rng) -> Self {
        let [lo, hi] = p.station_gain_range;
        StationTruth {
            gain: lo + (hi - lo) * rng.random::<f64>(),
            offset_deg: p.station_offset_max_deg * (2.0 * rng.random::<f64>() - 1.0),
        }
    }
}

/// One part as placed on the shaft: its true offset and ring.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PartTruth {
    /// Offset of the grating's centre from the shaft axis, in servo-angle coordinates
    /// (the camera sees `offset · (cos θ, sin θ)` at servo angle θ), µm.
    pub offset_um: [f64; 2],
    /// Roundness harmonics 2, 3, 4: phases, degrees.
    pub roundness_phase_deg: [f64; 3],
    /// Best focus position, µm.
    pub best_focus_um: f64,
    /// Servo angle when the part is loaded, degrees.
    pub start_angle_deg: f64,
    /// Phase of the servo's 1 ms log relative to the clock, s.
    pub log_phase_s: f64,
    /// Seed of the part's own random stream (detector noise, push scatter) while it is mounted.
    pub noise_seed: u64,
}

impl PartTruth {
    /// Draws part `index` of a batch from its own stream (the same parts for every strategy).
    pub fn draw(p: &PlantConfig, seed: u64, index: u64) -> Self {
        let mut rng = ChaCha8Rng::seed_from_u64(
            seed ^ 0x005e_ed0f_9a47_u64.wrapping_mul(index.wrapping_add(1)),
        );
        // Rayleigh(σ) = σ·√(−2 ln U), clipped.
        let u: f64 = rng.random::<f64>().max(1e-300);
        let e = (p.e_scale_um * (-2.0 * u.ln()).sqrt()).clamp(p.e_min_um, p.e_max_um);
        let a = rng.random_range(0.0..std::f64::consts::TAU);
        let ph = [
            rng.random_range(0.0..360.0),
            rng.random_range(0.0..360.0),
            rng.random_range(0.0..360.0),
        ];
        let focus = Normal::new(0.0, p.focus_sd_um.max(0.0))
            .map(|n| n.sample(&mut rng))
            .unwrap_or(0.0);
        PartTruth {
            offset_um: [e * a.cos(), e * a.sin()],
            roundness_phase_deg: ph,
            best_focus_um: focus,
            start_angle_deg: rng.random_range(0.0..360.0),
            log_phase_s: rng.random_range(0.0..p.log_period_s),
            noise_seed: rng.random::<u64>(),
        }
    }

    /// The true eccentricity, µm.
    pub fn e_um(&self) -> f64 {
        self.offset_um[0].hypot(self.offset_um[1])
    }

    /// The ring's true column at servo angle θ (degrees), without noise: the offset's
    /// projection on the camera's row line, the chord of the ring of radius R crossing it
    /// (−(perpendicular offset)²/2R, exactly), and the roundness.
    pub fn column_px(&self, p: &PlantConfig, um_per_px: f64, theta_deg: f64) -> f64 {
        let t = theta_deg.to_radians();
        let proj = self.offset_um[0] * t.cos() + self.offset_um[1] * t.sin();
        let across = -self.offset_um[0] * t.sin() + self.offset_um[1] * t.cos();
        let r = p.ring_radius_um;
        let chord = if r > across.abs() {
            (r * r - across * across).sqrt() - r
        } else {
            -r
        };
        let mut c = p.c_centre_px + (proj + chord) / um_per_px;
        for (j, ph) in self.roundness_phase_deg.iter().enumerate() {
            c += p.roundness_px * ((j as f64 + 2.0) * theta_deg - ph).to_radians().cos();
        }
        c
    }
}
