//! The polygon on the axis: the deviation at a target is the autocollimator's reading less the
//! term of the polygon face it looks at, from the polygon's calibration (a shift-angle or joint
//! certificate's pitch deviations β). gonio goes beyond ISO 230-2 here: the standard takes the
//! reference's readings as the deviations.
//!
//! In the reading model of the shift-angle method (Hsieh et al., 2022, and `docs/iso230-2.md`)
//! the face f at the autocollimator adds K(f) = β_1 + … + β_f (faces 1-based; K(N) = Σβ = 0);
//! the face at target 0° adds a constant to every reading, which no ISO 230-2 parameter sees.
//! The certificate gives each β's standard uncertainty but not their covariance: u(K(f)) is taken
//! as the root sum of squares over the shorter of the two sums that equal K(f) (faces 1…f, or
//! f+1…N with the sign changed), which for the closed polygon's covariance is never below the
//! exact value.
//!
//! ```
//! use gonio_calib::axis::Polygon;
//! let p = Polygon::new(&[0.5, -0.2, -0.3], &[0.01, 0.01, 0.02], f64::INFINITY, "cal.json").unwrap();
//! assert_eq!(p.face_at(240.0), Some(3));
//! assert_eq!(p.face_at(10.0), None);
//! let (k, u) = p.term(2);
//! // u: the shorter sum, faces 1…2 (0.01² + 0.01²) rather than face 3 (0.02²).
//! assert!((k - 0.3).abs() < 1e-15 && (u - 0.0002f64.sqrt()).abs() < 1e-15);
//! ```

use super::data::{AxisReading, Direction};
use super::error::AxisError;
use gonio_core::bound::Num;

/// Targets within this of a face's angle are at the face, degrees (1 µ°).
const AT_FACE_DEG: f64 = 1e-6;

/// Largest |pitch deviation| (and its u) of a polygon, arcsec (one degree: a polygon's faces
/// are flat to arcseconds; more is a certificate of something else, or a corrupt one).
pub const MAX_PITCH_DEVIATION_ARCSEC: f64 = 3600.0;

/// A calibrated polygon's face terms.
#[derive(Debug, Clone, PartialEq)]
pub struct Polygon {
    terms_arcsec: Vec<f64>,
    u_arcsec: Vec<f64>,
    /// Degrees of freedom of the β's uncertainties.
    pub dof: f64,
    /// Where the calibration came from (the certificate's path).
    pub source: String,
}

/// An autocollimator reading at a target, before the polygon's correction.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FaceReading {
    /// Target, degrees.
    pub target_deg: f64,
    /// Direction of approach.
    pub direction: Direction,
    /// Run (1-based).
    pub run: u32,
    /// The reading, arcsec.
    pub reading_arcsec: f64,
    /// The face at the autocollimator, if the file says (else from the target: face 1 at 0°).
    pub face: Option<i64>,
}

impl Polygon {
    /// A polygon from its pitch deviations β_1…β_N (arcsec) and their standard uncertainties,
    /// with `dof` degrees of freedom.
    ///
    /// # Errors
    /// [`AxisError::BadPolygon`]: fewer than 3 faces, lengths that differ, a value or u that is
    /// not finite (u < 0), a |β| or u above [`MAX_PITCH_DEVIATION_ARCSEC`], dof ≤ 0.
    pub fn new(
        beta_arcsec: &[f64],
        u_arcsec: &[f64],
        dof: f64,
        source: &str,
    ) -> Result<Polygon, AxisError> {
        let bad = |reason: String| Err(AxisError::BadPolygon { reason });
        let n = beta_arcsec.len();
        if n < 3 {
            return bad(format!(
                "{n} pitch deviations: a polygon has at least 3 faces"
            ));
        }
        if u_arcsec.len() != n {
            return bad(format!(
                "{n} pitch deviations but {} uncertainties",
                u_arcsec.len()
            ));
        }
        if let Some(f) = beta_arcsec.iter().position(|b| !b.is_finite()) {
            return bad(format!(
                "the pitch deviation of face {} is not a number",
                f + 1
            ));
        }
        if let Some(f) = beta_arcsec
            .iter()
            .position(|b| b.abs() > MAX_PITCH_DEVIATION_ARCSEC)
        {
            return bad(format!(
                "the pitch deviation of face {}, {}″, is out of range: expected −{MAX_PITCH_DEVIATION_ARCSEC} to {MAX_PITCH_DEVIATION_ARCSEC} arcsec",
                f + 1,
                Num(beta_arcsec[f])
            ));
        }
        if let Some(f) = u_arcsec
            .iter()
            .position(|u| u.is_finite() && *u > MAX_PITCH_DEVIATION_ARCSEC)
        {
            return bad(format!(
                "the uncertainty of face {}'s pitch deviation, {}″, is out of range: expected at most {MAX_PITCH_DEVIATION_ARCSEC} arcsec",
                f + 1,
                Num(u_arcsec[f])
            ));
        }
        if let Some(f) = u_arcsec.iter().position(|u| !(u.is_finite() && *u >= 0.0)) {
            return bad(format!(
                "face {}: its pitch deviation has no uncertainty (a calibration without residual degrees of freedom; calibrate with --sigma)",
                f + 1
            ));
        }
        if dof.is_nan() || dof <= 0.0 {
            return bad(format!("{dof} degrees of freedom: expected more than 0"));
        }
        let mut terms_arcsec = Vec::with_capacity(n);
        let mut sum = 0.0;
        for b in beta_arcsec {
            sum += b;
            terms_arcsec.push(sum);
        }
        let total: f64 = u_arcsec.iter().map(|u| u * u).sum();
        let mut head = 0.0;
        let u = u_arcsec
            .iter()
            .map(|v| {
                head += v * v;
                head.min(total - head).max(0.0).sqrt()
            })
            .collect();
        Ok(Polygon {
            terms_arcsec,
            u_arcsec: u,
            dof,
            source: source.to_string(),
        })
    }

    /// Faces N.
    pub fn faces(&self) -> usize {
        self.terms_arcsec.len()
    }

    /// Pitch 360°/N, degrees.
    pub fn pitch_deg(&self) -> f64 {
        360.0 / self.faces() as f64
    }

    /// The face at the autocollimator at `target_deg` with face 1 at 0°; `None` off the faces.
    pub fn face_at(&self, target_deg: f64) -> Option<usize> {
        self.steps_at(target_deg)
            .map(|k| k.rem_euclid(self.faces() as i64) as usize + 1)
    }

    /// Pitches from 0° to `target_deg`; `None` off the faces.
    fn steps_at(&self, target_deg: f64) -> Option<i64> {
        let k = target_deg / self.pitch_deg();
        let r = k.round();
        (((k - r) * self.pitch_deg()).abs() <= AT_FACE_DEG).then_some(r as i64)
    }

    /// The term K(f) of face `face` (1-based) and its standard uncertainty, arcsec.
    ///
    /// # Panics
    /// For a face outside 1..=N.
    pub fn term(&self, face: usize) -> (f64, f64) {
        (self.terms_arcsec[face - 1], self.u_arcsec[face - 1])
    }

    /// The deviations of autocollimator readings: each reading less its face's term, with the
    /// face. Faces given with the readings must advance by one a pitch, as the polygon's do
    /// (the face at 0° is then any face).
    ///
    /// # Errors
    /// [`AxisError::FaceOutOfRange`]; [`AxisError::NotAtFace`] (a target that is not a multiple
    /// of the pitch); [`AxisError::FaceOffTarget`] (a face that does not follow the pitch from the
    /// first reading's: a certificate of another polygon, or a wrong face).
    pub fn correct(&self, rows: &[FaceReading]) -> Result<Vec<(AxisReading, usize)>, AxisError> {
        let n = self.faces() as i64;
        // The face at 0° (0-based) that the first reading with a face implies.
        let mut zero: Option<(i64, usize)> = None;
        rows.iter()
            .enumerate()
            .map(|(index, r)| {
                let steps = self.steps_at(r.target_deg).ok_or(AxisError::NotAtFace {
                    index,
                    target_deg: r.target_deg,
                    faces: self.faces(),
                    pitch_deg: self.pitch_deg(),
                })?;
                let face = match r.face {
                    Some(f) if f < 1 || f > n => {
                        return Err(AxisError::FaceOutOfRange {
                            index,
                            face: f,
                            faces: self.faces(),
                        });
                    }
                    Some(f) => {
                        let z = (f - 1 - steps).rem_euclid(n);
                        match zero {
                            None => zero = Some((z, index)),
                            Some((z0, first)) if z0 != z => {
                                return Err(AxisError::FaceOffTarget {
                                    index,
                                    face: f as usize,
                                    target_deg: r.target_deg,
                                    expected: (z0 + steps).rem_euclid(n) as usize + 1,
                                    first,
                                    pitch_deg: self.pitch_deg(),
                                });
                            }
                            Some(_) => {}
                        }
                        f as usize
                    }
                    None => steps.rem_euclid(n) as usize + 1,
                };
                Ok((
                    AxisReading {
                        target_deg: r.target_deg,
                        direction: r.direction,
                        run: r.run,
                        deviation_arcsec: r.reading_arcsec - self.term(face).0,
                    },
                    face,
                ))
            })
            .collect()
    }
}
