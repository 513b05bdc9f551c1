//! Joint calibration: the polygon (shift-angle method) and the read heads (self-calibration) in
//! one least-squares estimate of the encoder error, blind only where both are blind.
//!
//! Each method alone misses some harmonics of the encoder error α(θ): an N-faced polygon the
//! multiples of N, a head arrangement the orders where every `e^{ikφ_h}` equals 1 (multiples of
//! 84 for SelfA). Both measure the same α, so one estimate over both data sets misses only the
//! orders neither sees (for 24 faces and SelfA: multiples of lcm(24, 84) = 168).
//!
//! Unknowns: α on the heads' encoder grid (NS positions), represented by its harmonics; the
//! pitch sums γ (β); the setup error of every run; the head offsets. The joint weighted least
//! squares is solved without ever forming an NS × NS system:
//!
//! 1. **Heads** (`heads_block`): one FFT per difference channel and a generalised least-squares
//!    fit per harmonic give the heads-alone estimate of every order they see with its variance
//!    `σ_h²·g_k` (independent between orders). One inverse FFT of `g_k` gives the covariance of
//!    that estimate between any two grid positions, hence its weight `W = C̃⁻¹` on α at the
//!    nq distinct polygon angles.
//! 2. **Polygon** (`polygon_block`): the shift-angle method's block-arrow normal equations,
//!    with each run's setup error eliminated shift by shift, leave the polygon's information on
//!    α at its angles and on γ.
//! 3. **Orders only the polygon sees** (`spectrum`): heads-blind orders that are not constant
//!    on every shift's angles and not aliased with one another on the polygon's angles become
//!    explicit unknowns `b` (cos, sin pairs), up to a cap (by default half the number of
//!    distinct angles).
//! 4. **Solve** (`solve`): minimise
//!
//!    ```text
//!    ‖polygon residuals‖²/σ_p² + (y − H_B·b − ŷ)ᵀ·W·(y − H_B·b − ŷ)/σ_h²
//!    ```
//!
//!    over y (α at the polygon angles), γ and b: a dense system of size nq + N − 1 + 2·nb
//!    (e.g. 360 + 23 + 2 for 24 faces at 15 one-degree shifts). Its inverse is the full
//!    covariance; the part due to each instrument's noise is `H⁻¹·H_i·H⁻¹`, from which every
//!    α gets its Welch–Satterthwaite degrees of freedom. Every order the heads see is then
//!    updated in closed form (see `spectrum`'s `harmonic_table`), which gives the per-order
//!    split of the information between the instruments.
//!
//! Each instrument is weighted by its own σ: stated, or estimated from its own residuals (the
//! polygon from the shift-angle least-squares fit, ν = readings − unknowns; the heads from the
//! per-harmonic fit, ν = readings − offsets − 2·orders fitted). The agreement of the two is
//! checked by the increase of χ² from the separate fits to the joint one ([`Consistency`]).
//!
//! Conventions: α has zero mean over the circle (like self-calibration), so at the polygon
//! angles it is not closed per shift; α is the error of head 1's reading (the encoder reading
//! the polygon calibrates).
//!
//! ```
//! use gonio_calib::joint::{calibrate, JointOptions};
//! use gonio_calib::selfcal::{Heads, Turn};
//! use gonio_calib::shift_angle::{Reading, ReadingSet};
//! // Order 4 is invisible to 4 equally spaced heads, order 12 also to a 6-face polygon.
//! let alpha = |t: f64| {
//!     let r = t.to_radians();
//!     0.08 * (3.0 * r).sin() + 0.1 * (4.0 * r).sin() + 0.05 * (12.0 * r + 1.0).sin()
//! };
//! let heads = Heads::preset("eda:4").unwrap();
//! let positions_deg: Vec<f64> = (0..360).map(f64::from).collect();
//! let differences_arcsec = heads.angles_deg()[1..].iter()
//!     .map(|&p| positions_deg.iter().map(|&t| alpha(t + p) - alpha(t)).collect())
//!     .collect();
//! let turns = [Turn { positions_deg, differences_arcsec }];
//! // Every run at shifts 0°, 10°, …, 50° (β = 0, U = 0).
//! let mut readings = Vec::new();
//! for shift in [0.0, 10.0, 20.0, 30.0, 40.0, 50.0] {
//!     for j in 1..=6 {
//!         for i in 1..=6 {
//!             readings.push(Reading::new(shift, j, i, alpha(shift + (i - 1) as f64 * 60.0)));
//!         }
//!     }
//! }
//! let set = ReadingSet::new(6, readings).unwrap();
//! let opts = JointOptions {
//!     sigma_polygon_arcsec: Some(0.01),
//!     sigma_heads_arcsec: Some(0.01),
//!     max_order: 18,
//!     ..JointOptions::default()
//! };
//! let cal = calibrate(&set, &heads, &turns, &opts).unwrap();
//! assert!((cal.harmonics[3].amplitude_arcsec - 0.1).abs() < 1e-9); // order 4, from the polygon
//! assert_eq!(cal.blind.joint, vec![12]); // blind to both
//! let a10 = cal.alpha[1]; // 10°: α without the invisible order 12
//! assert!((a10.value_arcsec - (0.08 * 0.5 + 0.1 * 40f64.to_radians().sin())).abs() < 1e-9);
//! //! ```

mod error;
mod heads_block;
mod polygon_block;
mod result;
mod solve;
mod spectrum;

pub use error::JointError;
pub use result::{
    BlindOrders, Consistency, JointAlpha, JointCalibration, JointHarmonic, PolygonResiduals,
    SeenBy, SigmaUsed,
};
pub use spectrum::Invisible;

use crate::selfcal::{Heads, NoiseModel, Turn};
use crate::shift_angle::{self, Method, Options, ReadingSet, residual_stats, undetectable_orders};
use gonio_uncertainty::{Term, combine};
use heads_block::HeadsBlock;
use polygon_block::{PolygonGrid, PolygonSystem};
use solve::{HeadsPrior, solve};
use spectrum::{TableInputs, harmonic_table, select_blind};

/// Which head angles the heads' model uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum HeadAngles {
    /// The nominal angles of the arrangement.
    Nominal,
    /// The nominal angles plus each head's mean difference to head 1 (its measured
    /// displacement); which orders the heads cannot see is still decided by the nominal angles.
    #[default]
    Measured,
}

gonio_core::choices!(HeadAngles {
    Measured => "measured",
    Nominal => "nominal",
});

/// How the heads' model places the scale error between the sampled rotation positions (for
/// heads that do not sit on them).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Interpolation {
    /// Linear between neighbouring positions (gonio's encoder model between graduation lines,
    /// when the positions are the lines).
    #[default]
    Linear,
    /// A band-limited (trigonometric) series, the self-calibration's model.
    Trigonometric,
}

gonio_core::choices!(Interpolation {
    Linear => "linear",
    Trigonometric => "trigonometric",
});

/// Options of [`calibrate`].
#[derive(Debug, Clone, PartialEq)]
pub struct JointOptions {
    /// σ of one polygon reading, arcsec, if known (else estimated from the polygon-alone
    /// least-squares residuals).
    pub sigma_polygon_arcsec: Option<f64>,
    /// σ of one head reading (or difference, per `noise_model`), arcsec, if known (else
    /// estimated from the heads-alone residuals).
    pub sigma_heads_arcsec: Option<f64>,
    /// How the heads' noise enters the differences.
    pub noise_model: NoiseModel,
    /// Which head angles the heads' model uses.
    pub head_angles: HeadAngles,
    /// How the heads' model places the error between sampled positions.
    pub interpolation: Interpolation,
    /// Largest order of the harmonic table and of the blind lists.
    pub max_order: u32,
    /// Highest heads-blind order the polygon is asked to resolve; default half the number of
    /// distinct polygon angles (the Nyquist order of a regular angle grid).
    pub blind_max_order: Option<u32>,
    /// Coverage probability of the expanded uncertainties.
    pub coverage: f64,
}

impl Default for JointOptions {
    fn default() -> Self {
        JointOptions {
            sigma_polygon_arcsec: None,
            sigma_heads_arcsec: None,
            noise_model: NoiseModel::Readings,
            head_angles: HeadAngles::Measured,
            interpolation: Interpolation::Linear,
            max_order: 360,
            blind_max_order: None,
            coverage: 0.95,
        }
    }
}

fn check_sigma(instrument: &'static str, s: Option<f64>) -> Result<(), JointError> {
    match s {
        Some(v) if !(v > 0.0 && v.is_finite()) => Err(JointError::InvalidSigma {
            instrument,
            sigma_arcsec: v,
        }),
        _ => Ok(()),
    }
}

/// Calibrates the encoder from polygon readings and head readings of the same encoder jointly.
///
/// The polygon angles must lie on the heads' grid (positions θ_0 + m·360°/NS).
///
/// # Errors
/// [`JointError::Polygon`] / [`JointError::Heads`] for invalid readings of either instrument,
/// [`JointError::OffGrid`], [`JointError::InvalidSigma`], [`JointError::SigmaNeeded`] when a σ is
/// neither stated nor estimable, [`JointError::Undetermined`] naming what the readings leave
/// open, [`JointError::Option`] for a coverage outside (0, 1).
pub fn calibrate(
    set: &ReadingSet,
    heads: &Heads,
    turns: &[Turn],
    opts: &JointOptions,
) -> Result<JointCalibration, JointError> {
    check_sigma("polygon", opts.sigma_polygon_arcsec)?;
    check_sigma("heads", opts.sigma_heads_arcsec)?;
    if !(opts.coverage > 0.0 && opts.coverage < 1.0) {
        return Err(JointError::Option {
            name: "coverage",
            found: opts.coverage.to_string(),
            expected: "a probability strictly between 0 and 1",
        });
    }
    let n = set.faces();
    let g = n - 1;

    // The heads alone: spectra, per-order fit, σ.
    let hb = HeadsBlock::new(
        heads,
        turns,
        opts.noise_model,
        opts.head_angles,
        opts.interpolation,
    )?;
    let sigma_heads = match opts.sigma_heads_arcsec {
        Some(s) => SigmaUsed {
            sigma_arcsec: s,
            stated: true,
            dof: f64::INFINITY,
            readings: hb.count,
        },
        None if hb.dof > 0 && hb.sigma_hat() > 0.0 => SigmaUsed {
            sigma_arcsec: hb.sigma_hat(),
            stated: false,
            dof: hb.dof as f64,
            readings: hb.count,
        },
        None => {
            return Err(JointError::SigmaNeeded {
                instrument: "heads",
                reason: format!("{} degrees of freedom, σ̂ = {}", hb.dof, hb.sigma_hat()),
            });
        }
    };

    // The polygon alone: its σ and its own u, for comparison.
    let alone = shift_angle::calibrate(
        set,
        &Options {
            method: Method::LeastSquares,
            sigma_arcsec: opts.sigma_polygon_arcsec,
            ..Options::default()
        },
    );
    let sigma_polygon = match (opts.sigma_polygon_arcsec, &alone) {
        (Some(s), _) => SigmaUsed {
            sigma_arcsec: s,
            stated: true,
            dof: f64::INFINITY,
            readings: set.len(),
        },
        (None, Ok(cal)) if cal.residuals.dof > 0 && cal.residuals.sigma_hat_arcsec > 0.0 => {
            SigmaUsed {
                sigma_arcsec: cal.residuals.sigma_hat_arcsec,
                stated: false,
                dof: cal.residuals.dof as f64,
                readings: set.len(),
            }
        }
        (None, Ok(cal)) => {
            return Err(JointError::SigmaNeeded {
                instrument: "polygon",
                reason: format!(
                    "the polygon-alone fit has {} residual degrees of freedom",
                    cal.residuals.dof
                ),
            });
        }
        (None, Err(e)) => {
            return Err(JointError::SigmaNeeded {
                instrument: "polygon",
                reason: format!("the polygon alone cannot be solved: {e}"),
            });
        }
    };
    let (sp, sh) = (sigma_polygon.sigma_arcsec, sigma_heads.sigma_arcsec);

    // Geometry, the orders only the polygon sees, both blocks, the solve.
    let grid = PolygonGrid::new(set, &hb)?;
    let nq = grid.len();
    let cap = opts.blind_max_order.unwrap_or((nq / 2) as u32);
    let selection = select_blind(&hb, &grid, cap, opts.max_order);
    let nb = selection.design.ncols(); // 2 per order
    let poly = PolygonSystem::new(set, &grid);
    let (kernel, estimate) = hb.kernel_and_estimate();
    let prior = HeadsPrior::new(&kernel, &estimate, &grid);
    let nyg = nq + g;
    let names = |i: usize| -> String {
        if i < nq {
            format!("α({}°)", grid.angles_deg[i])
        } else if i < nyg {
            format!("β_1 + … + β_{}", i - nq + 1)
        } else {
            let e = (i - nyg) / 2;
            let part = if (i - nyg).is_multiple_of(2) {
                "cos"
            } else {
                "sin"
            };
            format!("order {} ({part})", selection.estimated[e])
        }
    };
    let sol = solve(&poly, &prior, &selection.design, sp, sh, names)?;

    // α at the polygon angles.
    let u_heads_alone = sh * kernel[0].max(0.0).sqrt();
    let mut u_polygon_alone: Vec<Option<f64>> = vec![None; nq];
    if let Ok(cal) = &alone {
        for (s, shift) in cal.shifts.iter().enumerate() {
            for (i, &u) in shift.u_alpha_arcsec.iter().enumerate() {
                let q = grid.q_of[s][i];
                u_polygon_alone[q] = Some(u_polygon_alone[q].map_or(u, |v: f64| v.min(u)));
            }
        }
    }
    let mut alpha = Vec::with_capacity(nq);
    for (q, &u_alone) in u_polygon_alone.iter().enumerate() {
        let var = sol.cov[(q, q)].max(0.0);
        let vp = sol.var_polygon[q].clamp(0.0, var);
        let (up, uh) = (vp.sqrt(), (var - vp).sqrt());
        let c = combine(
            &[
                Term {
                    u: uh,
                    c: 1.0,
                    nu: sigma_heads.dof,
                },
                Term {
                    u: up,
                    c: 1.0,
                    nu: sigma_polygon.dof,
                },
            ],
            &[],
            opts.coverage,
        )
        .expect("finite terms and a checked coverage");
        alpha.push(JointAlpha {
            angle_deg: grid.angles_deg[q],
            value_arcsec: sol.x[q],
            u_arcsec: var.sqrt(),
            u_heads_arcsec: uh,
            u_polygon_arcsec: up,
            nu_eff: c.nu_eff,
            k: c.k,
            expanded_arcsec: c.expanded,
            u_heads_alone_arcsec: u_heads_alone,
            u_polygon_alone_arcsec: u_alone,
        });
    }
    let covariance_alpha = sol.cov.view((0, 0), (nq, nq)).clone_owned();

    // β from the pitch sums B(m) = γ_m (B(0) = B(N) = 0).
    let bidx = |m: usize| (m > 0 && m < n).then(|| nq + m - 1);
    let bval = |m: usize| bidx(m).map_or(0.0, |i| sol.x[i]);
    let bcov = |p: usize, q: usize| match (bidx(p), bidx(q)) {
        (Some(a), Some(b)) => sol.cov[(a, b)],
        _ => 0.0,
    };
    let beta_arcsec: Vec<f64> = (1..=n).map(|k| bval(k) - bval(k - 1)).collect();
    let u_beta_arcsec: Vec<f64> = (1..=n)
        .map(|k| {
            (bcov(k, k) + bcov(k - 1, k - 1) - 2.0 * bcov(k, k - 1))
                .max(0.0)
                .sqrt()
        })
        .collect();

    // Setup errors.
    let y: Vec<f64> = sol.x.rows(0, nq).iter().copied().collect();
    let gamma = sol.x.rows(nq, g).clone_owned();
    let cov_wg = sol.cov.view((0, 0), (nyg, nyg)).clone_owned();
    let setup_grid = poly.setup_errors(set, &grid, &y, &gamma, &cov_wg, sp);
    let setup: Vec<_> = setup_grid.iter().flatten().flatten().copied().collect();

    // Residuals and the agreement of the two instruments.
    let alpha_per_shift: Vec<Vec<f64>> = grid
        .q_of
        .iter()
        .map(|q| q.iter().map(|&i| y[i]).collect())
        .collect();
    let setup_values: Vec<Vec<Option<f64>>> = setup_grid
        .iter()
        .map(|r| r.iter().map(|u| u.map(|u| u.value_arcsec)).collect())
        .collect();
    let res = residual_stats(set, &alpha_per_shift, &beta_arcsec, &setup_values, 0, None);
    let rss_polygon = res.rms_arcsec.powi(2) * res.count as f64;
    let design = &selection.design;
    let yv = sol.x.rows(0, nq) - design * sol.x.rows(nyg, nb);
    let dy = &yv - &prior.yhat;
    let heads_increase = dy.dot(&(&prior.w_krig * &dy));
    let consistency = alone.as_ref().ok().and_then(|cal| {
        let dof = (set.shifts_deg().len() * (n - 1)).checked_sub(nb)?;
        if dof == 0 {
            return None;
        }
        let rss_alone = cal.residuals.rms_arcsec.powi(2) * cal.residuals.count as f64;
        let chi2 = heads_increase / (sh * sh) + (rss_polygon - rss_alone) / (sp * sp);
        let p_upper = gonio_core::special::chi2_sf(chi2.max(0.0), dof as f64);
        Some(Consistency {
            chi2,
            dof,
            p_upper,
            consistent: (0.025..=0.975).contains(&p_upper),
        })
    });
    let heads_rss = hb.rss + heads_increase;

    let harmonics = harmonic_table(&TableInputs {
        heads: &hb,
        grid: &grid,
        selection: &selection,
        prior: &prior,
        solution: &sol,
        nyg,
        sigma_heads: sh,
        faces: n,
        max_order: opts.max_order,
    });
    let max_order = opts.max_order;
    let blind = BlindOrders {
        max_order,
        polygon: undetectable_orders(n, max_order as usize)
            .into_iter()
            .filter(|&k| k <= max_order)
            .collect(),
        heads: harmonics
            .iter()
            .filter(|h| matches!(h.seen_by, SeenBy::Polygon | SeenBy::Neither))
            .map(|h| h.order)
            .collect(),
        joint: harmonics
            .iter()
            .filter(|h| !h.estimated)
            .map(|h| h.order)
            .collect(),
        from_polygon: selection
            .estimated
            .iter()
            .copied()
            .filter(|&k| k <= max_order)
            .collect(),
        polygon_resolution_cap: cap,
    };

    Ok(JointCalibration {
        faces: n,
        shifts_deg: set.shifts_deg().to_vec(),
        polygon_readings: set.len(),
        positions: hb.ns,
        heads_deg: heads.angles_deg().to_vec(),
        noise_model: opts.noise_model,
        head_angles: opts.head_angles,
        interpolation: opts.interpolation,
        coverage: opts.coverage,
        alpha,
        covariance_alpha,
        beta_arcsec,
        u_beta_arcsec,
        setup,
        head_offsets_arcsec: hb.offsets_arcsec.clone(),
        harmonics,
        blind,
        sigma_polygon,
        sigma_heads,
        residuals_polygon: PolygonResiduals {
            count: res.count,
            rms_arcsec: res.rms_arcsec,
            max_abs_arcsec: res.max_abs_arcsec,
        },
        residuals_heads_rms_arcsec: (heads_rss / hb.count.max(1) as f64).sqrt(),
        consistency,
    })
}
