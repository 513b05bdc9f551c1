//! One measuring turn from what the devices gave: each frame's ring column stamped with its
//! angle from the servo's log, the fit and the quality gate's verdict. The controller measures
//! turns with it and an offline replay ([`crate::record`], `gonio replay`) re-evaluates recorded
//! turns with the very same code, so a replay of the same frames gives the same bits.
//!
//! ```
//! use gonio_station::hal::CameraFrame;
//! use gonio_station::interval::AngleSample;
//! use gonio_station::record::TurnKind;
//! use gonio_station::turn::evaluate_turn;
//! use gonio_station::{Recipe, Strategy};
//! // 200 frames of a grating 30 µm off-centre (0.75 µm/px) at 180°/s and 100 fps.
//! let r = Recipe::default();
//! let frames: Vec<CameraFrame> = (0..200)
//!     .map(|i| {
//!         let t = i as f64 * 0.01;
//!         let th = (180.0 * (t + 0.0005)).to_radians();
//!         CameraFrame {
//!             start_s: t,
//!             exposure_s: 0.001,
//!             c_px: Some(720.0 + 40.0 * th.cos() + 0.05 * (7.0 * th).sin()),
//!             invalid_reason: None,
//!             focus_measure: 40.0,
//!         }
//!     })
//!     .collect();
//! let log = (0..=2002).map(|k| AngleSample { t_s: k as f64 * 1e-3, theta_deg: 0.18 * k as f64 }).collect();
//! let (turn, fit) =
//!     evaluate_turn(&r, Strategy::Learned, &frames, log, 0.0, TurnKind::Initial, Some(0.0), None);
//! assert_eq!(turn.samples.len(), 200);
//! let e = turn.e_um.unwrap();
//! assert!((e - 30.0).abs() < 0.1, "{e}");
//! assert!(fit.is_some());
//! ```

use crate::Strategy;
use crate::fit::{EccentricityFit, FitOptions, Sample, fit_judged_with};
use crate::hal::CameraFrame;
use crate::interval::{AngleLog, AngleSample};
use crate::recipe::Recipe;
use crate::record::{TurnKind, TurnRecord};
use crate::ring::RoundnessPrior;

/// The fit options of a strategy under a recipe: the recipe's settings with the strategy's
/// method.
pub fn fit_options(recipe: &Recipe, strategy: Strategy) -> FitOptions {
    FitOptions {
        method: strategy.fit_method(),
        ..recipe.fit.clone()
    }
}

/// Evaluates one measuring turn: stamps every valid frame's column with its angle (as the
/// strategy stamps), keeps angles strictly increasing, fits and judges the turn.
///
/// `t_start_s` is the turn's start relative to the part's start, `focus_um` the focus position
/// during the turn (`None` when autofocus never succeeded), `carried` the ring's roundness from
/// the part's earlier full turn when this turn covers part of a revolution
/// ([`crate::fit::fit_judged_with`]). Returns the turn's record and, when the ring was found
/// in enough frames (the recipe's `measure.min_valid_fraction`) and the fit succeeded, the fit;
/// `None` means the ring was lost.
#[allow(clippy::too_many_arguments)]
pub fn evaluate_turn(
    recipe: &Recipe,
    strategy: Strategy,
    frames: &[CameraFrame],
    log: Vec<AngleSample>,
    t_start_s: f64,
    kind: TurnKind,
    focus_um: Option<f64>,
    carried: Option<&RoundnessPrior>,
) -> (TurnRecord, Option<EccentricityFit>) {
    let n = frames.len();
    let mut rec = TurnRecord {
        t_start_s,
        kind,
        frames_taken: n,
        samples: Vec::with_capacity(n),
        invalid_frames: 0,
        e_um: None,
        u_e_um: None,
        theta_max_deg: None,
        c0_px: None,
        residual_rms_px: None,
        outliers: 0,
        focus_um,
        quality: None,
        carried_roundness: carried.cloned(),
    };
    let Ok(log) = AngleLog::new(log) else {
        rec.invalid_frames = n;
        return (rec, None);
    };
    for f in frames {
        match f.c_px {
            Some(c) if c.is_finite() => {
                match log.stamp(f.start_s, f.exposure_s, strategy.stamping()) {
                    // Keep angles strictly increasing (a stalled servo repeats angles).
                    Ok(theta)
                        if rec
                            .samples
                            .last()
                            .is_none_or(|s: &Sample| theta > s.theta_deg) =>
                    {
                        rec.samples.push(Sample {
                            theta_deg: theta,
                            c_px: c,
                        });
                    }
                    _ => rec.invalid_frames += 1,
                }
            }
            _ => rec.invalid_frames += 1,
        }
    }
    let valid = rec.samples.len();
    if valid < 3 || (valid as f64) < recipe.measure.min_valid_fraction * n as f64 {
        return (rec, None);
    }
    let limits = recipe.quality_limits();
    match fit_judged_with(
        &rec.samples,
        n,
        &fit_options(recipe, strategy),
        &limits,
        carried,
    ) {
        Ok(f) => {
            let um = recipe.um_per_px;
            rec.e_um = Some(f.e_px * um);
            rec.u_e_um = f.u_e_px.map(|u| u * um);
            rec.theta_max_deg = Some(f.theta_max_deg);
            rec.c0_px = Some(f.c0_px);
            rec.residual_rms_px = Some(f.residual_rms_px);
            rec.outliers = f.outliers.len();
            rec.quality = Some(f.quality.clone());
            (rec, Some(f))
        }
        Err(_) => (rec, None),
    }
}
