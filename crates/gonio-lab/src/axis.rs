//! The measuring plan of a rotary axis tested to ISO 230-2 (TOML): the polygon's faces as the
//! targets, n runs in each direction, and the standard's test cycle with its overruns. Angles in
//! degrees, readings in arcseconds. See `docs/iso230-2.md`.
//!
//! ```toml
//! faces = 12                     # the polygon on the axis: its pitch spaces the targets
//! targets_deg = "faces"          # every face (default), or a list or START:STEP:END of multiples
//!                                # of the pitch: [0, 90, 180, 270]
//! full_turn = true               # with "faces": also 360°, face 1 again (default true)
//! runs = 5                       # runs in each direction (the standard's cycle: 5)
//! directions = "both"            # or "+" / "-": a unidirectional test
//! overrun_deg = 1                # how far beyond the first target of a pass the axis turns
//!                                # before approaching it
//! start_face = 1                 # the face at the autocollimator at 0°
//! repeatability_arcsec = 0.5     # the axis's expected σ of one approach: turns on the drift
//!                                # and closure checks, their limits widened by it
//! x_sign = 1                     # −1 if the autocollimator's X counts against the axis
//! mode = "any"                   # "absolute", "relative" or "any"
//! ```
//!
//! The cycle (the standard's linear test cycle): run 1 turns to the first target less the
//! overrun, approaches every target upwards, turns beyond the last by the overrun, approaches
//! every target downwards, then run 2 …; so every target is reached from its direction, the
//! first of a pass from the overrun, the others from the target before. Checks, when the plan
//! states the axis's expected repeatability (two approaches differ by the axis's own scatter as
//! well as the autocollimator's): every run against run 1 at the same target and direction
//! (drift), and a target read again a turn later in the same pass against the first reading
//! (closure). Errors are [`PlanError`]s naming the file, line and column.
//!
//! ```
//! use gonio_calib::axis::Direction;
//! use gonio_lab::axis::AxisPlan;
//! use gonio_lab::sequence::Sequence;
//! let p = AxisPlan::parse_text("a.toml", "faces = 4\nruns = 2\n").unwrap();
//! let v = p.positions();
//! assert_eq!(v.len(), 2 * 2 * 5);
//! assert_eq!((v[0].target_deg, v[0].from_deg, v[0].face), (0.0, -1.0, 1));
//! assert_eq!((v[5].target_deg, v[5].direction, v[5].from_deg), (360.0, Direction::Down, 361.0));
//! assert_eq!(v[6].from_deg, 360.0);
//! ```

use crate::plan::{MAX_PLANNED_READINGS, ModeRule, PlanError, sign_and_mode};
use crate::readings::Row;
use crate::sequence::{CheckKind, Sequence};
use gonio_calib::axis::{Direction, MAX_RUNS, MAX_TARGET_DEG, TargetKey};
use gonio_calib::shift_angle::{MAX_FACES, shift_range};
use gonio_core::bound::Num;
use serde::Deserialize;
use std::collections::HashMap;
use std::fmt::Write as _;
use std::path::Path;
use toml::Spanned;

/// Targets within this of a face's angle are at the face, degrees.
const AT_FACE_DEG: f64 = 1e-6;

/// Largest overrun, degrees.
pub const MAX_OVERRUN_DEG: f64 = 90.0;

/// Largest expected repeatability of an axis, arcsec (one degree).
pub const MAX_REPEATABILITY_ARCSEC: f64 = 3600.0;

/// One approach of the cycle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AxisPosition {
    /// Target, degrees.
    pub target_deg: f64,
    /// The sense of the approach.
    pub direction: Direction,
    /// Run (1-based).
    pub run: u32,
    /// The polygon face at the autocollimator.
    pub face: usize,
    /// Where the axis comes from: the target before, or the overrun beyond the first target of a
    /// pass, degrees.
    pub from_deg: f64,
}

/// A validated axis plan.
#[derive(Debug, Clone, PartialEq)]
pub struct AxisPlan {
    /// Polygon faces N.
    pub faces: usize,
    /// Targets, degrees, ascending.
    pub targets_deg: Vec<f64>,
    /// Runs in each direction.
    pub runs: u32,
    /// The directions, positive first.
    pub directions: Vec<Direction>,
    /// The overrun before the first target of a pass, degrees.
    pub overrun_deg: f64,
    /// The face at the autocollimator at 0°.
    pub start_face: usize,
    /// The axis's expected σ of one approach, arcsec: the drift and closure checks, with
    /// limits widened by it (none without it).
    pub repeatability_arcsec: Option<f64>,
    /// +1, or −1 when the autocollimator's X counts against the axis.
    pub x_sign: f64,
    /// Which readings the acquisition may take.
    pub mode: ModeRule,
}

/// The forms `targets_deg` takes, for its errors.
const TARGETS_FORMS: &str = "\"faces\", START:STEP:END (e.g. \"0:30:360\") or a list of degrees";

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawPlan {
    faces: Spanned<i64>,
    targets_deg: Option<Spanned<toml::Value>>,
    full_turn: Option<Spanned<bool>>,
    runs: Option<Spanned<i64>>,
    directions: Option<Spanned<String>>,
    overrun_deg: Option<Spanned<f64>>,
    start_face: Option<Spanned<i64>>,
    repeatability_arcsec: Option<Spanned<f64>>,
    x_sign: Option<Spanned<i64>>,
    mode: Option<Spanned<String>>,
}

impl AxisPlan {
    /// Parses and validates a plan; errors are `FILE:LINE:COL: …`.
    ///
    /// # Errors
    /// As [`AxisPlan::parse_text`].
    pub fn parse(path: &Path, text: &str) -> Result<AxisPlan, PlanError> {
        Self::parse_text(&path.display().to_string(), text)
    }

    /// Parses and validates plan text; `name` names it in errors.
    ///
    /// # Errors
    /// Syntax, unknown keys, a value out of its bound (named), a target that is not at a face,
    /// a target twice, fewer than 2 targets, more than [`MAX_PLANNED_READINGS`] approaches.
    pub fn parse_text(name: &str, text: &str) -> Result<AxisPlan, PlanError> {
        let at = |span: std::ops::Range<usize>, message: String| {
            let (line, column) = gonio_core::text::line_col(text, span.start);
            PlanError {
                name: name.to_string(),
                line,
                column,
                message,
            }
        };
        let raw: RawPlan = toml::from_str(text).map_err(|e| {
            at(
                e.span().unwrap_or(0..0),
                crate::plan::cap(&e.message().trim_end().replace('\n', " ")),
            )
        })?;
        let faces = *raw.faces.get_ref();
        if !(3..=MAX_FACES as i64).contains(&faces) {
            return Err(at(
                raw.faces.span(),
                format!("faces = {faces}: expected a polygon of 3 to {MAX_FACES} faces"),
            ));
        }
        let faces = faces as usize;
        let pitch = 360.0 / faces as f64;
        let full_turn = raw.full_turn.as_ref().map(|v| *v.get_ref());
        let targets_deg: Vec<f64> = match &raw.targets_deg {
            None => faces_targets(faces, full_turn.unwrap_or(true)),
            Some(v) => {
                let span = v.span();
                let bad = |m: String| Err(at(span.clone(), m));
                let list = match v.get_ref() {
                    toml::Value::String(w) if w == "faces" => {
                        faces_targets(faces, full_turn.unwrap_or(true))
                    }
                    toml::Value::String(w) => shift_range(w).ok_or_else(|| {
                        at(
                            span.clone(),
                            format!("targets_deg = {w:?}: expected {TARGETS_FORMS}"),
                        )
                    })?,
                    toml::Value::Array(l) => l
                        .iter()
                        .map(|x| match x {
                            toml::Value::Integer(i) => Some(*i as f64),
                            toml::Value::Float(f) if f.is_finite() => Some(*f),
                            _ => None,
                        })
                        .collect::<Option<Vec<f64>>>()
                        .filter(|l| !l.is_empty())
                        .ok_or_else(|| {
                            at(
                                span.clone(),
                                "targets_deg: expected a non-empty list of numbers of degrees"
                                    .into(),
                            )
                        })?,
                    other => {
                        return bad(format!(
                            "targets_deg: expected {TARGETS_FORMS}, found a {}",
                            other.type_str()
                        ));
                    }
                };
                if let (Some(f), toml::Value::Array(_)) = (&raw.full_turn, v.get_ref()) {
                    return Err(at(
                        f.span(),
                        "full_turn applies to targets_deg = \"faces\": list 360 among the targets instead".into(),
                    ));
                }
                let mut list = list;
                list.sort_by(f64::total_cmp);
                if let Some(t) = list.iter().find(|t| t.abs() > MAX_TARGET_DEG) {
                    return bad(format!(
                        "targets_deg: {}° is out of range: expected −{MAX_TARGET_DEG} to {MAX_TARGET_DEG} degrees",
                        Num(*t)
                    ));
                }
                if let Some(t) = list.iter().find(|t| {
                    let k = *t / pitch;
                    ((k - k.round()) * pitch).abs() > AT_FACE_DEG
                }) {
                    return bad(format!(
                        "targets_deg: {t}° is not at a face of the {faces}-face polygon: expected multiples of its pitch {pitch}°"
                    ));
                }
                if let Some(w) = list
                    .windows(2)
                    .find(|w| TargetKey::of(w[0]) == TargetKey::of(w[1]))
                {
                    return bad(format!("targets_deg: {}° is listed twice", w[0]));
                }
                list
            }
        };
        if targets_deg.len() < 2 {
            let span = raw
                .targets_deg
                .as_ref()
                .map_or(raw.faces.span(), |v| v.span());
            return Err(at(span, "expected at least 2 targets".into()));
        }
        let runs = match &raw.runs {
            None => 5,
            Some(v) => {
                let r = *v.get_ref();
                if !(2..=i64::from(MAX_RUNS)).contains(&r) {
                    return Err(at(
                        v.span(),
                        format!("runs = {r}: expected 2 to {MAX_RUNS} runs in each direction"),
                    ));
                }
                r as u32
            }
        };
        let directions = match &raw.directions {
            None => Direction::BOTH.to_vec(),
            Some(v) => match v.get_ref().as_str() {
                "both" => Direction::BOTH.to_vec(),
                d => vec![Direction::parse(d).ok_or_else(|| {
                    at(
                        v.span(),
                        format!("directions = {d:?}: expected \"both\", \"+\" or \"-\""),
                    )
                })?],
            },
        };
        let overrun_deg = match &raw.overrun_deg {
            None => 1.0,
            Some(v) => {
                let o = *v.get_ref();
                if !(o > 0.0 && o <= MAX_OVERRUN_DEG) {
                    return Err(at(
                        v.span(),
                        format!(
                            "overrun_deg = {}: expected more than 0 and at most {MAX_OVERRUN_DEG} degrees",
                            Num(o)
                        ),
                    ));
                }
                o
            }
        };
        let start_face = match &raw.start_face {
            None => 1,
            Some(v) => {
                let f = *v.get_ref();
                if !(1..=faces as i64).contains(&f) {
                    return Err(at(
                        v.span(),
                        format!("start_face = {f}: expected 1 to {faces}"),
                    ));
                }
                f as usize
            }
        };
        let repeatability_arcsec = match &raw.repeatability_arcsec {
            None => None,
            Some(v) => {
                let r = *v.get_ref();
                if !(0.0..=MAX_REPEATABILITY_ARCSEC).contains(&r) {
                    return Err(at(
                        v.span(),
                        format!(
                            "repeatability_arcsec = {}: expected 0 to {MAX_REPEATABILITY_ARCSEC} arcsec",
                            Num(r)
                        ),
                    ));
                }
                Some(r)
            }
        };
        let (x_sign, mode) = sign_and_mode(raw.x_sign.as_ref(), raw.mode.as_ref(), &at)?;
        let total = targets_deg.len() as u64 * u64::from(runs) * directions.len() as u64;
        if total > MAX_PLANNED_READINGS {
            return Err(at(
                raw.faces.span(),
                format!("the plan has {total} approaches: at most {MAX_PLANNED_READINGS}"),
            ));
        }
        Ok(AxisPlan {
            faces,
            targets_deg,
            runs,
            directions,
            overrun_deg,
            start_face,
            repeatability_arcsec,
            x_sign,
            mode,
        })
    }

    /// The pitch 360°/N, degrees.
    pub fn pitch_deg(&self) -> f64 {
        360.0 / self.faces as f64
    }

    /// The face at the autocollimator at `target_deg`.
    pub fn face_at(&self, target_deg: f64) -> usize {
        let k = (target_deg / self.pitch_deg()).round() as i64;
        (k + self.start_face as i64 - 1).rem_euclid(self.faces as i64) as usize + 1
    }
}

/// 0°, the pitch, … (N − 1)·pitch, and 360° with `full_turn`.
fn faces_targets(faces: usize, full_turn: bool) -> Vec<f64> {
    let pitch = 360.0 / faces as f64;
    let mut v: Vec<f64> = (0..faces).map(|k| k as f64 * pitch).collect();
    if full_turn {
        v.push(360.0);
    }
    v
}

impl Sequence for AxisPlan {
    type Position = AxisPosition;

    fn command(&self) -> &'static str {
        "axis"
    }

    fn positions(&self) -> Vec<AxisPosition> {
        let mut out = Vec::new();
        for run in 1..=self.runs {
            for &d in &self.directions {
                let order: Vec<f64> = match d {
                    Direction::Up => self.targets_deg.clone(),
                    Direction::Down => self.targets_deg.iter().rev().copied().collect(),
                };
                let mut from = order[0] - d.factor() * self.overrun_deg;
                for t in order {
                    out.push(AxisPosition {
                        target_deg: t,
                        direction: d,
                        run,
                        face: self.face_at(t),
                        from_deg: from,
                    });
                    from = t;
                }
            }
        }
        out
    }

    fn fingerprint(&self) -> u64 {
        let mut f = crate::journal::Fingerprint::new();
        f.eat(b"axis");
        f.eat(&(self.faces as u64).to_le_bytes());
        f.eat(&self.x_sign.to_bits().to_le_bytes());
        for p in self.positions() {
            f.eat(&p.target_deg.to_bits().to_le_bytes());
            f.eat(p.direction.sign().as_bytes());
            f.eat(&u64::from(p.run).to_le_bytes());
            f.eat(&(p.face as u64).to_le_bytes());
        }
        f.finish()
    }

    fn x_sign(&self) -> f64 {
        self.x_sign
    }

    fn mode(&self) -> ModeRule {
        self.mode
    }

    fn describe(&self, p: &AxisPosition) -> String {
        format!(
            "target {}°, {} approach, run {}, face {}",
            p.target_deg,
            p.direction.word(),
            p.run,
            p.face
        )
    }

    fn fields(&self, p: &AxisPosition) -> String {
        format!(
            "target_deg={} direction={} run={} face={} from_deg={}",
            p.target_deg,
            p.direction.sign(),
            p.run,
            p.face,
            p.from_deg
        )
    }

    fn instruction(&self, p: &AxisPosition) -> String {
        format!(
            "run {}: move the axis from {}° to {}° ({} approach), face {} at the autocollimator",
            p.run,
            p.from_deg,
            p.target_deg,
            p.direction.word(),
            p.face
        )
    }

    /// Every run against run 1 (drift); a target a turn after another in the same pass against
    /// it (closure); none without the axis's expected repeatability.
    fn partners(&self, positions: &[AxisPosition]) -> Vec<Option<(CheckKind, usize)>> {
        if self.repeatability_arcsec.is_none() {
            return vec![None; positions.len()];
        }
        let first_run = 1;
        let index: HashMap<(TargetKey, Direction, u32), usize> = positions
            .iter()
            .enumerate()
            .map(|(i, p)| ((TargetKey::of(p.target_deg), p.direction, p.run), i))
            .collect();
        positions
            .iter()
            .enumerate()
            .map(|(i, p)| {
                let turn = -p.direction.factor() * 360.0;
                let closure = index
                    .get(&(TargetKey::of(p.target_deg + turn), p.direction, p.run))
                    .filter(|&&j| j < i)
                    .map(|&j| (CheckKind::Closure, j));
                let drift = (p.run > first_run)
                    .then(|| index.get(&(TargetKey::of(p.target_deg), p.direction, first_run)))
                    .flatten()
                    .map(|&j| (CheckKind::Drift, j));
                closure.or(drift)
            })
            .collect()
    }

    /// √(instrument² + (3·√2·σ_axis)²): two approaches of the axis differ by its own scatter too.
    fn check_limit_arcsec(&self, instrument_arcsec: f64) -> f64 {
        let axis = 3.0 * std::f64::consts::SQRT_2 * self.repeatability_arcsec.unwrap_or(0.0);
        instrument_arcsec.hypot(axis)
    }

    fn csv(&self, comment: &str, rows: &[Row<AxisPosition>]) -> String {
        let mut s = String::with_capacity(rows.len() * 28 + comment.len() + 64);
        s.push_str(comment);
        s.push('\n');
        s.push_str("target_deg,direction,run,face,reading_arcsec\n");
        for r in rows {
            let (p, v, d) = (&r.planned, r.value_arcsec, r.decimals);
            let _ = writeln!(
                s,
                "{},{},{},{},{v:.d$}",
                p.target_deg,
                p.direction.sign(),
                p.run,
                p.face
            );
        }
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_cycle_and_its_checks() {
        let p = AxisPlan::parse_text(
            "a.toml",
            "faces = 8\ntargets_deg = [0, 90, 180, 270, 360]\nruns = 3\nstart_face = 3\nrepeatability_arcsec = 0.1\n",
        )
        .unwrap();
        let v = p.positions();
        assert_eq!(v.len(), 5 * 3 * 2);
        // Face 3 at 0°, two faces a quarter turn: 3, 5, 7, 1, 3.
        let faces: Vec<usize> = v[..5].iter().map(|x| x.face).collect();
        assert_eq!(faces, [3, 5, 7, 1, 3]);
        let partners = p.partners(&v);
        // 360° up is the closure of 0° up; 0° down the closure of 360° down (read first).
        assert_eq!(partners[4], Some((CheckKind::Closure, 0)));
        assert_eq!(partners[9], Some((CheckKind::Closure, 5)));
        assert_eq!(partners[1], None);
        // Run 2, 90° up against run 1.
        assert_eq!(partners[11], Some((CheckKind::Drift, 1)));
        assert!((p.check_limit_arcsec(0.3) - 0.3f64.hypot(0.3 * 2f64.sqrt())).abs() < 1e-15);
        // A unidirectional test, one pass a run.
        let u = AxisPlan::parse_text(
            "a.toml",
            "faces = 4\ndirections = \"-\"\nfull_turn = false\n",
        )
        .unwrap();
        let v = u.positions();
        assert_eq!(v.len(), 4 * 5);
        assert_eq!((v[0].target_deg, v[0].from_deg), (270.0, 271.0));
        assert_eq!(
            u.csv("# c", &[]),
            "# c\ntarget_deg,direction,run,face,reading_arcsec\n"
        );
        assert!(u.partners(&v).iter().all(Option::is_none));
    }

    #[test]
    fn errors_name_line_and_column() {
        let e = |t: &str| AxisPlan::parse_text("a.toml", t).unwrap_err().to_string();
        assert_eq!(
            e("faces = 8\ntargets_deg = [0, 10]\n"),
            "a.toml:2:15: targets_deg: 10° is not at a face of the 8-face polygon: expected multiples of its pitch 45°"
        );
        assert!(e("faces = 8\nruns = 1\n").starts_with("a.toml:2:8: runs = 1: expected 2 to 1000"));
        assert!(e("faces = 8\noverrun_deg = 0.0\n").starts_with("a.toml:2:15: overrun_deg"));
        assert!(e("faces = 8\ndirections = \"up\"\n").starts_with("a.toml:2:14: directions"));
        assert!(
            e("faces = 8\ntargets_deg = [0, 45]\nfull_turn = true\n")
                .starts_with("a.toml:3:13: full_turn")
        );
        assert!(e("faces = 8\ntargets_deg = [0, 0]\n").contains("listed twice"));
        assert!(e("faces = 8\nrun = 5\n").starts_with("a.toml:2:1: unknown field"));
        // A table where a value belongs, and huge numbers, named the short way.
        assert_eq!(
            e("faces = 8\ntargets_deg = {a = 1}\n"),
            "a.toml:2:15: targets_deg: expected \"faces\", START:STEP:END (e.g. \"0:30:360\") or a list of degrees, found a table"
        );
        assert_eq!(
            e("faces = 8\nrepeatability_arcsec = 1e300\n"),
            "a.toml:2:24: repeatability_arcsec = 1e300: expected 0 to 3600 arcsec"
        );
        assert!(
            e("faces = 8\ntargets_deg = [0, 1e300]\n")
                .starts_with("a.toml:2:15: targets_deg: 1e300° is out of range")
        );
        assert!(
            e("faces = 8\noverrun_deg = 1e300\n").starts_with("a.toml:2:15: overrun_deg = 1e300:")
        );
    }
}
