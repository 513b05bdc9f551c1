//! Read-head arrangements: head angles and the equal-division sets EDA and SelfA average over.

use super::SelfcalError;
use serde::{Deserialize, Serialize};

/// Tolerance (degrees) for "this head sits on an equal division" and "head 1 is at 0°".
pub const EQUAL_DIVISION_TOL_DEG: f64 = 1e-6;

/// A read-head arrangement: M ≥ 2 heads at angles φ_1 = 0 < φ_2 < … < φ_M < 360° (degrees),
/// and optionally the sets of equally spaced heads that EDA/SelfA average over (0-based head
/// indices, every set containing head 1, i.e. index 0).
///
/// ```
/// use gonio_calib::selfcal::Heads;
/// let h = Heads::selfa12();
/// assert_eq!(h.len(), 12);
/// assert_eq!(h.sets().len(), 3);
/// let e = Heads::preset("eda:4").unwrap();
/// assert_eq!(e.angles_deg(), &[0.0, 90.0, 180.0, 270.0]);
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Heads {
    angles_deg: Vec<f64>,
    sets: Vec<Vec<usize>>,
}

impl Heads {
    /// An arrangement from head angles in degrees (head 1 first, at 0°, then increasing).
    ///
    /// If all heads are equally spaced, they form one EDA set.
    ///
    /// # Errors
    /// [`SelfcalError::Heads`] for fewer than 2 heads, a non-finite angle, head 1 not at 0°, or
    /// angles not strictly increasing within [0°, 360°).
    pub fn new(angles_deg: Vec<f64>) -> Result<Self, SelfcalError> {
        let bad = |msg: String| Err(SelfcalError::Heads { message: msg });
        if angles_deg.len() < 2 {
            return bad(format!(
                "expected at least 2 head angles, found {}",
                angles_deg.len()
            ));
        }
        for (i, &a) in angles_deg.iter().enumerate() {
            if !a.is_finite() {
                return bad(format!("head {} angle is not finite ({a})", i + 1));
            }
        }
        if angles_deg[0].abs() > EQUAL_DIVISION_TOL_DEG {
            return bad(format!(
                "head 1 must be at 0° (the reference), found {}°",
                angles_deg[0]
            ));
        }
        for i in 1..angles_deg.len() {
            let (p, a) = (angles_deg[i - 1], angles_deg[i]);
            if a <= p || a >= 360.0 {
                return bad(format!(
                    "head {} at {a}°: expected angles strictly increasing in [0°, 360°) (after {p}°)",
                    i + 1
                ));
            }
        }
        let mut angles_deg = angles_deg;
        angles_deg[0] = 0.0;
        let all: Vec<usize> = (0..angles_deg.len()).collect();
        let mut h = Heads {
            angles_deg,
            sets: Vec::new(),
        };
        if h.check_set(&all).is_ok() {
            h.sets = vec![all];
        }
        Ok(h)
    }

    /// The same heads with explicit equal-division sets (0-based indices, each containing 0).
    ///
    /// # Errors
    /// [`SelfcalError::Heads`] if a set is empty, lacks head 1, has an index out of range or a
    /// repeated head, or its heads are not at `j·360°/NH` within 1e-6°.
    pub fn with_sets(mut self, sets: Vec<Vec<usize>>) -> Result<Self, SelfcalError> {
        for s in &sets {
            self.check_set(s)?;
        }
        self.sets = sets;
        Ok(self)
    }

    fn check_set(&self, set: &[usize]) -> Result<(), SelfcalError> {
        let names: Vec<String> = set.iter().map(|i| (i + 1).to_string()).collect();
        let bad = |msg: String| {
            Err(SelfcalError::Heads {
                message: format!("set {{{}}}: {msg}", names.join(",")),
            })
        };
        if set.len() < 2 {
            return bad("expected at least 2 heads".into());
        }
        if !set.contains(&0) {
            return bad("expected head 1 (the reference) in every set".into());
        }
        let mut ang: Vec<f64> = Vec::with_capacity(set.len());
        for &i in set {
            match self.angles_deg.get(i) {
                Some(&a) => ang.push(a),
                None => {
                    return bad(format!(
                        "head {} does not exist ({} heads)",
                        i + 1,
                        self.angles_deg.len()
                    ));
                }
            }
        }
        ang.sort_by(f64::total_cmp);
        let nh = set.len() as f64;
        for (j, &a) in ang.iter().enumerate() {
            let want = j as f64 * 360.0 / nh;
            if (a - want).abs() > EQUAL_DIVISION_TOL_DEG {
                return bad(format!(
                    "not equally spaced: expected a head at {want}°, found {a}° (tolerance {EQUAL_DIVISION_TOL_DEG}°)"
                ));
            }
        }
        Ok(())
    }

    /// NH heads equally spaced, `(j−1)·360°/NH`, as one EDA set.
    ///
    /// # Errors
    /// [`SelfcalError::Heads`] for NH < 2.
    pub fn equal_division(nh: usize) -> Result<Self, SelfcalError> {
        if nh < 2 {
            return Err(SelfcalError::Heads {
                message: format!("eda:{nh}: expected at least 2 heads"),
            });
        }
        Heads::new((0..nh).map(|j| j as f64 * 360.0 / nh as f64).collect())
    }

    /// The SelfA twelve-head arrangement of Hsieh et al., 2022 (the union of 3, 4 and 7 equal
    /// divisions), with its sets {1,5,9}, {1,3,7,11} and {1,2,4,6,8,10,12} (1-based).
    pub fn selfa12() -> Self {
        let s = 360.0 / 7.0;
        let angles = vec![
            0.0,
            s,
            90.0,
            2.0 * s,
            120.0,
            3.0 * s,
            180.0,
            4.0 * s,
            240.0,
            5.0 * s,
            270.0,
            6.0 * s,
        ];
        let sets = vec![vec![0, 4, 8], vec![0, 2, 6, 10], vec![0, 1, 3, 5, 7, 9, 11]];
        Heads::new(angles)
            .and_then(|h| h.with_sets(sets))
            .expect("the SelfA preset is valid")
    }

    /// A named preset: `selfa12` or `eda:N`.
    ///
    /// # Errors
    /// [`SelfcalError::Heads`] for an unknown name or a bad N.
    pub fn preset(name: &str) -> Result<Self, SelfcalError> {
        if name == "selfa12" {
            return Ok(Self::selfa12());
        }
        if let Some(n) = name.strip_prefix("eda:") {
            let nh: usize = n.trim().parse().map_err(|_| SelfcalError::Heads {
                message: format!("{name}: expected eda:N with N a whole number ≥ 2"),
            })?;
            return Self::equal_division(nh);
        }
        Err(SelfcalError::Heads {
            message: format!("unknown preset {name:?}: expected selfa12 or eda:N"),
        })
    }

    /// Number of heads M.
    pub fn len(&self) -> usize {
        self.angles_deg.len()
    }

    /// Always false (an arrangement has at least 2 heads); for clippy's `len_without_is_empty`.
    pub fn is_empty(&self) -> bool {
        self.angles_deg.is_empty()
    }

    /// Head angles in degrees.
    pub fn angles_deg(&self) -> &[f64] {
        &self.angles_deg
    }

    /// The equal-division sets (0-based head indices).
    pub fn sets(&self) -> &[Vec<usize>] {
        &self.sets
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn presets_and_errors() {
        let s = Heads::selfa12();
        assert!((s.angles_deg()[1] - 51.43).abs() < 0.005);
        assert!((s.angles_deg()[11] - 308.57).abs() < 0.005);
        assert!(Heads::preset("eda:1").is_err());
        assert!(Heads::preset("eda:x").is_err());
        assert!(Heads::preset("nope").is_err());
        assert!(Heads::new(vec![1.0, 2.0]).is_err());
        assert!(Heads::new(vec![0.0, 200.0, 100.0]).is_err());
        assert!(Heads::new(vec![0.0, 360.0]).is_err());
        // Rounded SelfA angles are not an equal division within tolerance.
        let h = Heads::new(vec![0.0, 51.43, 102.86, 154.29, 205.71, 257.14, 308.57]).unwrap();
        assert!(h.sets().is_empty());
        assert!(h.clone().with_sets(vec![(0..7).collect()]).is_err());
        let e = Heads::new(vec![0.0, 120.0, 240.0]).unwrap();
        assert_eq!(e.sets(), &[vec![0, 1, 2]]);
    }
}
