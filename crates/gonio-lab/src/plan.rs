//! The measuring plan of a shift-angle measurement (TOML): which readings an autocollimator log
//! holds, and which position the operator sets next, in which order. Angles in degrees (shifts);
//! faces and steps 1-based. See `docs/measuring-plan.md`.
//!
//! ```toml
//! faces = 24
//! shifts_deg = "0:1:14"          # or a list, [0, 5, 10]
//! start_faces = [1]              # "all" (default) or a list, in the order they are measured
//! steps = "all"                  # "all" (default) or a list of steps 1..N
//! repeats = 1                    # readings of every (shift, start face, step)
//! order = ["shift", "start_face", "step", "repeat"]   # loop nesting, outermost first
//! closure = false                # an extra reading after step N (step N+1 = step 1 again)
//! x_sign = 1                     # −1 if the autocollimator's X counts the other way
//! mode = "any"                   # "absolute", "relative" or "any" (but not mixed)
//!
//! [[shift]]                      # optional, per shift: start_faces, steps, repeats
//! shift_deg = 0
//! start_faces = "all"
//! ```
//!
//! Errors are [`PlanError`]s naming the file, line and column.
//!
//! ```
//! use gonio_lab::plan::Plan;
//! let p = Plan::parse_text("p.toml", "faces = 4\nshifts_deg = [0, 10]\nstart_faces = [1]\n").unwrap();
//! assert_eq!(p.readings().len(), 2 * 4);
//! let e = Plan::parse_text("p.toml", "faces = 2\nshifts_deg = [0]\n").unwrap_err();
//! assert!(e.to_string().starts_with("p.toml:1:9: faces = 2"));
//! ```

use gonio_calib::shift_angle::{MAX_FACES, SHIFT_DEG, ShiftKey};
use gonio_core::bound::Num;
use serde::Deserialize;
use std::fmt::Write as _;
use std::path::Path;
use toml::Spanned;

/// Most repeats of one reading (the readings CSV's limit).
pub const MAX_REPEAT: i64 = 1_000_000;

pub use gonio_calib::shift_angle::{MAX_SHIFTS, shift_range};

/// A plan that cannot be used, located in its file.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{name}:{line}:{column}: {message}")]
#[non_exhaustive]
pub struct PlanError {
    /// The plan's name (its path) as given.
    pub name: String,
    /// Line, 1-based.
    pub line: usize,
    /// Column (in characters), 1-based.
    pub column: usize,
    /// What is wrong.
    pub message: String,
}

type Result<T> = std::result::Result<T, PlanError>;

/// A parser's message cut to at most 500 characters (its beginning and end), as the CLI cuts
/// every error line.
pub(crate) fn cap(s: &str) -> String {
    let n = s.chars().count();
    if n <= 500 {
        return s.to_string();
    }
    let head: String = s.chars().take(300).collect();
    let tail: String = s.chars().skip(n - 150).collect();
    format!("{head} … ({n} characters) … {tail}")
}

/// Most readings a plan may describe (an hour of readings at 1 kHz is 3.6 million).
pub const MAX_PLANNED_READINGS: u64 = 10_000_000;

/// A loop of the measuring sequence.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Level {
    /// The shift angle.
    Shift,
    /// The start face (the run).
    StartFace,
    /// The rotation step.
    Step,
    /// The repeat.
    Repeat,
}

impl Level {
    const ALL: [(&'static str, Level); 4] = [
        ("shift", Level::Shift),
        ("start_face", Level::StartFace),
        ("step", Level::Step),
        ("repeat", Level::Repeat),
    ];

    /// The loop's name in a plan's `order`.
    pub fn name(self) -> &'static str {
        Level::ALL
            .iter()
            .find(|(_, l)| *l == self)
            .map_or("?", |(n, _)| n)
    }
}

/// Which kind of autocollimator reading the log may hold.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ModeRule {
    /// Absolute or relative, but one kind in the whole log.
    Any,
    /// Absolute readings only.
    Absolute,
    /// Relative readings only.
    Relative,
}

impl ModeRule {
    /// `any`, `absolute` or `relative`, as a plan writes it.
    pub fn parse(s: &str) -> Option<ModeRule> {
        match s {
            "any" => Some(ModeRule::Any),
            "absolute" => Some(ModeRule::Absolute),
            "relative" => Some(ModeRule::Relative),
            _ => None,
        }
    }
}

/// The runs at one shift.
#[derive(Debug, Clone, PartialEq)]
pub struct ShiftPlan {
    /// Shift angle, degrees.
    pub shift_deg: f64,
    /// Start faces (1-based), in the order they are measured.
    pub start_faces: Vec<usize>,
    /// Steps (1-based), in the order they are measured.
    pub steps: Vec<usize>,
    /// Readings of every (start face, step).
    pub repeats: u32,
}

/// A validated measuring plan.
#[derive(Debug, Clone, PartialEq)]
pub struct Plan {
    /// Polygon faces N.
    pub faces: usize,
    /// Every shift with its runs, in the order listed.
    pub shifts: Vec<ShiftPlan>,
    /// Loop nesting, outermost first.
    pub order: [Level; 4],
    /// An extra reading after step N of every run (step N+1, the start face again).
    pub closure: bool,
    /// +1, or −1 when the autocollimator's X axis counts against the readings' sign convention.
    pub x_sign: f64,
    /// Which readings the log may hold.
    pub mode: ModeRule,
}

/// One planned reading, as it goes into the readings CSV.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlannedReading {
    /// Shift angle, degrees.
    pub shift_deg: f64,
    /// Start face (1-based).
    pub start_face: usize,
    /// Step (1-based; a closure reading is step 1 with a repeat number after the others).
    pub step: usize,
    /// Repeat (1-based).
    pub repeat: u32,
    /// Whether it is the closure reading (step N+1) of its run.
    pub closure: bool,
}

#[derive(Debug, Deserialize)]
#[serde(untagged)]
enum ListOrAll {
    Word(String),
    List(Vec<i64>),
}

#[derive(Debug, Deserialize)]
#[serde(untagged)]
enum ShiftsValue {
    Range(String),
    List(Vec<toml::Value>),
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawShift {
    shift_deg: Spanned<toml::Value>,
    start_faces: Option<Spanned<ListOrAll>>,
    steps: Option<Spanned<ListOrAll>>,
    repeats: Option<Spanned<i64>>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawPlan {
    faces: Spanned<i64>,
    shifts_deg: Spanned<ShiftsValue>,
    start_faces: Option<Spanned<ListOrAll>>,
    steps: Option<Spanned<ListOrAll>>,
    repeats: Option<Spanned<i64>>,
    order: Option<Spanned<Vec<String>>>,
    closure: Option<bool>,
    x_sign: Option<Spanned<i64>>,
    mode: Option<Spanned<String>>,
    #[serde(default)]
    shift: Vec<RawShift>,
}

/// A TOML number (integer or finite float).
fn number(v: &toml::Value) -> Option<f64> {
    match v {
        toml::Value::Integer(i) => Some(*i as f64),
        toml::Value::Float(f) if f.is_finite() => Some(*f),
        _ => None,
    }
}

impl Plan {
    /// Parses and validates a plan; errors are `FILE:LINE:COL: …`.
    ///
    /// # Errors
    /// Syntax, unknown keys, values out of range, more than [`MAX_PLANNED_READINGS`] readings.
    pub fn parse(path: &Path, text: &str) -> Result<Plan> {
        Self::parse_text(&path.display().to_string(), text)
    }

    /// Parses and validates plan text; `name` names it in errors.
    ///
    /// # Errors
    /// As [`Plan::parse`].
    pub fn parse_text(name: &str, text: &str) -> Result<Plan> {
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
                cap(&e.message().trim_end().replace('\n', " ")),
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
        let list_of = |v: &Spanned<ListOrAll>, what: &str| -> Result<Vec<usize>> {
            let bad = |msg: String| Err(at(v.span(), msg));
            match v.get_ref() {
                ListOrAll::Word(w) if w == "all" => Ok((1..=faces).collect()),
                ListOrAll::Word(w) => bad(format!(
                    "{what} = {w:?}: expected \"all\" or a list of numbers in 1..={faces}"
                )),
                ListOrAll::List(l) => {
                    if l.is_empty() {
                        return bad(format!("{what}: expected at least one number"));
                    }
                    let mut seen = Vec::with_capacity(l.len());
                    for &x in l {
                        if x < 1 || x > faces as i64 {
                            return bad(format!(
                                "{what}: {x} is out of range: expected 1..={faces}"
                            ));
                        }
                        if seen.contains(&(x as usize)) {
                            return bad(format!("{what}: {x} is listed twice"));
                        }
                        seen.push(x as usize);
                    }
                    Ok(seen)
                }
            }
        };
        let repeats_of = |v: &Spanned<i64>| -> Result<u32> {
            let r = *v.get_ref();
            if !(1..=MAX_REPEAT).contains(&r) {
                return Err(at(
                    v.span(),
                    format!("repeats = {r}: expected 1 to {}", MAX_REPEAT),
                ));
            }
            Ok(r as u32)
        };
        let all: Vec<usize> = (1..=faces).collect();
        let start_faces = match &raw.start_faces {
            Some(v) => list_of(v, "start_faces")?,
            None => all.clone(),
        };
        let steps = match &raw.steps {
            Some(v) => list_of(v, "steps")?,
            None => all,
        };
        let repeats = match &raw.repeats {
            Some(v) => repeats_of(v)?,
            None => 1,
        };
        let shifts_deg: Vec<f64> = match raw.shifts_deg.get_ref() {
            ShiftsValue::Range(s) => shift_range(s).ok_or_else(|| {
                at(
                    raw.shifts_deg.span(),
                    format!("shifts_deg = {s:?}: expected START:STEP:END (e.g. \"0:1:14\") or a list of degrees"),
                )
            })?,
            ShiftsValue::List(l) => l
                .iter()
                .map(number)
                .collect::<Option<Vec<f64>>>()
                .filter(|v| !v.is_empty())
                .ok_or_else(|| {
                    at(
                        raw.shifts_deg.span(),
                        "shifts_deg: expected a non-empty list of numbers of degrees".into(),
                    )
                })?,
        };
        if let Some((s, e)) = shifts_deg
            .iter()
            .find_map(|&s| SHIFT_DEG.check(s).err().map(|e| (s, e)))
        {
            return Err(at(
                raw.shifts_deg.span(),
                format!("shifts_deg: a shift of {}° is out of range: {e}", Num(s)),
            ));
        }
        let per_shift = (start_faces.len() + steps.len()) as u64;
        if shifts_deg.len() as u64 * per_shift.max(1) > MAX_PLANNED_READINGS {
            return Err(at(
                raw.shifts_deg.span(),
                format!(
                    "shifts_deg: {} shifts of {} start faces and {} steps: more than {MAX_PLANNED_READINGS} planned readings",
                    shifts_deg.len(),
                    start_faces.len(),
                    steps.len()
                ),
            ));
        }
        let mut keys: Vec<ShiftKey> = Vec::with_capacity(shifts_deg.len());
        let mut seen = std::collections::HashSet::with_capacity(shifts_deg.len());
        for &s in &shifts_deg {
            let k = ShiftKey::of(s);
            if !seen.insert(k) {
                return Err(at(
                    raw.shifts_deg.span(),
                    format!("shifts_deg: {s}° is listed twice"),
                ));
            }
            keys.push(k);
        }
        let mut shifts: Vec<ShiftPlan> = shifts_deg
            .iter()
            .map(|&shift_deg| ShiftPlan {
                shift_deg,
                start_faces: start_faces.clone(),
                steps: steps.clone(),
                repeats,
            })
            .collect();
        let index_of: std::collections::HashMap<ShiftKey, usize> =
            keys.iter().enumerate().map(|(i, k)| (*k, i)).collect();
        let mut overridden = std::collections::HashSet::new();
        for o in &raw.shift {
            let s = number(o.shift_deg.get_ref()).ok_or_else(|| {
                at(
                    o.shift_deg.span(),
                    "shift_deg: expected a number of degrees".into(),
                )
            })?;
            let Some(&i) = index_of.get(&ShiftKey::of(s)) else {
                return Err(at(
                    o.shift_deg.span(),
                    format!("[[shift]] shift_deg = {s}: not one of shifts_deg"),
                ));
            };
            if !overridden.insert(i) {
                return Err(at(
                    o.shift_deg.span(),
                    format!("[[shift]] shift_deg = {s}: given twice"),
                ));
            }
            if let Some(v) = &o.start_faces {
                shifts[i].start_faces = list_of(v, "start_faces")?;
            }
            if let Some(v) = &o.steps {
                shifts[i].steps = list_of(v, "steps")?;
            }
            if let Some(v) = &o.repeats {
                shifts[i].repeats = repeats_of(v)?;
            }
        }
        let order = match &raw.order {
            None => [Level::Shift, Level::StartFace, Level::Step, Level::Repeat],
            Some(v) => {
                let names: Vec<Option<Level>> = v
                    .get_ref()
                    .iter()
                    .map(|n| Level::ALL.iter().find(|(a, _)| a == n).map(|(_, l)| *l))
                    .collect();
                let levels: Vec<Level> = names.iter().flatten().copied().collect();
                let complete = levels.len() == 4
                    && names.len() == 4
                    && Level::ALL.iter().all(|(_, l)| levels.contains(l));
                if !complete {
                    return Err(at(
                        v.span(),
                        format!(
                            "order = {:?}: expected the four loops shift, start_face, step, repeat, each once, outermost first",
                            v.get_ref()
                        ),
                    ));
                }
                [levels[0], levels[1], levels[2], levels[3]]
            }
        };
        let (x_sign, mode) = sign_and_mode(raw.x_sign.as_ref(), raw.mode.as_ref(), &at)?;
        let closure = u64::from(raw.closure.unwrap_or(false));
        let total: u64 = shifts
            .iter()
            .map(|s| {
                s.start_faces.len() as u64 * (s.steps.len() as u64 + closure) * u64::from(s.repeats)
            })
            .sum();
        if total > MAX_PLANNED_READINGS {
            return Err(at(
                raw.faces.span(),
                format!("the plan has {total} readings: at most {MAX_PLANNED_READINGS}"),
            ));
        }
        Ok(Plan {
            faces,
            shifts,
            order,
            closure: raw.closure.unwrap_or(false),
            x_sign,
            mode,
        })
    }

    /// Every planned reading in measuring order.
    pub fn readings(&self) -> Vec<PlannedReading> {
        let mut keyed: Vec<([usize; 4], PlannedReading)> = Vec::new();
        for (si, s) in self.shifts.iter().enumerate() {
            let nsteps = s.steps.len() + usize::from(self.closure);
            for (fi, &face) in s.start_faces.iter().enumerate() {
                for ti in 0..nsteps {
                    let closure = ti == s.steps.len();
                    for r in 0..s.repeats {
                        let (step, repeat) = if closure {
                            (1, s.repeats + 1 + r)
                        } else {
                            (s.steps[ti], r + 1)
                        };
                        let index = |l: Level| match l {
                            Level::Shift => si,
                            Level::StartFace => fi,
                            Level::Step => ti,
                            Level::Repeat => r as usize,
                        };
                        let key = self.order.map(index);
                        keyed.push((
                            key,
                            PlannedReading {
                                shift_deg: s.shift_deg,
                                start_face: face,
                                step,
                                repeat,
                                closure,
                            },
                        ));
                    }
                }
            }
        }
        keyed.sort_by_key(|(k, _)| *k);
        keyed.into_iter().map(|(_, r)| r).collect()
    }

    /// The polygon face at the autocollimator for `step` (1-based) of the run started at
    /// `start_face`: the operator turns the polygon to it.
    ///
    /// ```
    /// use gonio_lab::plan::Plan;
    /// let p = Plan::parse_text("p", "faces = 24\nshifts_deg = [0]\n").unwrap();
    /// assert_eq!(p.face_at(1, 7), 7);
    /// assert_eq!(p.face_at(20, 7), 2);
    /// ```
    pub fn face_at(&self, start_face: usize, step: usize) -> usize {
        (start_face + step + 2 * self.faces - 2) % self.faces + 1
    }

    /// Whether the readings CSV of this plan has a `repeat` column (a reading is repeated, or
    /// the plan has closure readings).
    pub fn has_repeats(&self) -> bool {
        self.closure || self.shifts.iter().any(|s| s.repeats > 1)
    }

    /// A fingerprint of what the plan asks for (faces, X sign, every planned reading in order):
    /// a journal written for one plan is refused for another.
    pub fn fingerprint(&self) -> u64 {
        let mut f = crate::journal::Fingerprint::new();
        f.eat(&(self.faces as u64).to_le_bytes());
        f.eat(&self.x_sign.to_bits().to_le_bytes());
        for r in self.readings() {
            f.eat(&r.shift_deg.to_bits().to_le_bytes());
            f.eat(&(r.start_face as u64).to_le_bytes());
            f.eat(&(r.step as u64).to_le_bytes());
            f.eat(&u64::from(r.repeat).to_le_bytes());
            f.eat(&[u8::from(r.closure)]);
        }
        f.finish()
    }

    /// The plan as TOML (the simulator writes the plan its log follows).
    pub fn to_toml(&self, comment: &str) -> String {
        let faces_text = |v: &[usize]| {
            if v.len() == self.faces && v.iter().enumerate().all(|(i, &f)| f == i + 1) {
                "\"all\"".to_string()
            } else {
                format!(
                    "[{}]",
                    v.iter()
                        .map(|f| f.to_string())
                        .collect::<Vec<_>>()
                        .join(", ")
                )
            }
        };
        let first = &self.shifts[0];
        let mut s = String::new();
        for line in comment.lines() {
            let _ = writeln!(s, "# {line}");
        }
        let _ = writeln!(s, "faces = {}", self.faces);
        let _ = writeln!(
            s,
            "shifts_deg = [{}]",
            self.shifts
                .iter()
                .map(|x| format!("{:?}", x.shift_deg))
                .collect::<Vec<_>>()
                .join(", ")
        );
        // The most common runs become the defaults; the others are listed per shift.
        let common = self
            .shifts
            .iter()
            .max_by_key(|a| {
                self.shifts
                    .iter()
                    .filter(|b| (b.start_faces == a.start_faces) && b.steps == a.steps)
                    .count()
            })
            .unwrap_or(first);
        let _ = writeln!(s, "start_faces = {}", faces_text(&common.start_faces));
        let _ = writeln!(s, "steps = {}", faces_text(&common.steps));
        let _ = writeln!(s, "repeats = {}", common.repeats);
        let _ = writeln!(
            s,
            "order = [{}]",
            self.order
                .iter()
                .map(|l| format!("\"{}\"", l.name()))
                .collect::<Vec<_>>()
                .join(", ")
        );
        let _ = writeln!(s, "closure = {}", self.closure);
        let _ = writeln!(s, "x_sign = {}", self.x_sign as i64);
        let mode = match self.mode {
            ModeRule::Any => "any",
            ModeRule::Absolute => "absolute",
            ModeRule::Relative => "relative",
        };
        let _ = writeln!(s, "mode = \"{mode}\"");
        for x in &self.shifts {
            if x.start_faces != common.start_faces
                || x.steps != common.steps
                || x.repeats != common.repeats
            {
                let _ = writeln!(s, "\n[[shift]]\nshift_deg = {:?}", x.shift_deg);
                let _ = writeln!(s, "start_faces = {}", faces_text(&x.start_faces));
                let _ = writeln!(s, "steps = {}", faces_text(&x.steps));
                let _ = writeln!(s, "repeats = {}", x.repeats);
            }
        }
        s
    }
}

/// A plan's `x_sign` (1 or −1; default 1) and `mode` rule (default any), each located by `at`
/// when it is neither: shared by the shift-angle plan and the axis test cycle.
pub(crate) fn sign_and_mode(
    x_sign: Option<&Spanned<i64>>,
    mode: Option<&Spanned<String>>,
    at: &dyn Fn(std::ops::Range<usize>, String) -> PlanError,
) -> std::result::Result<(f64, ModeRule), PlanError> {
    let x_sign = match x_sign {
        None => 1.0,
        Some(v) => match *v.get_ref() {
            1 => 1.0,
            -1 => -1.0,
            x => return Err(at(v.span(), format!("x_sign = {x}: expected 1 or -1"))),
        },
    };
    let mode = match mode {
        None => ModeRule::Any,
        Some(v) => ModeRule::parse(v.get_ref()).ok_or_else(|| {
            at(
                v.span(),
                format!(
                    "mode = {:?}: expected \"absolute\", \"relative\" or \"any\"",
                    v.get_ref()
                ),
            )
        })?,
    };
    Ok((x_sign, mode))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<Plan> {
        Plan::parse(Path::new("p.toml"), text)
    }

    #[test]
    fn defaults_and_order() {
        let p = parse("faces = 3\nshifts_deg = [0, 10]\n").unwrap();
        let r = p.readings();
        assert_eq!(r.len(), 2 * 3 * 3);
        assert_eq!((r[0].shift_deg, r[0].start_face, r[0].step), (0.0, 1, 1));
        assert_eq!((r[1].start_face, r[1].step), (1, 2));
        assert_eq!((r[3].start_face, r[3].step), (2, 1));
        assert_eq!(r[9].shift_deg, 10.0);
        // Steps outermost, then repeats, then faces; one shift measured with two faces only.
        let p = parse(
            "faces = 4\nshifts_deg = \"0:5:5\"\nrepeats = 2\norder = [\"shift\", \"step\", \"repeat\", \"start_face\"]\n\
             [[shift]]\nshift_deg = 5\nstart_faces = [3, 1]\n",
        )
        .unwrap();
        let r = p.readings();
        assert_eq!(r.len(), 4 * 4 * 2 + 2 * 4 * 2);
        assert_eq!((r[0].step, r[0].repeat, r[0].start_face), (1, 1, 1));
        assert_eq!((r[1].step, r[1].repeat, r[1].start_face), (1, 1, 2));
        assert_eq!((r[4].step, r[4].repeat, r[4].start_face), (1, 2, 1));
        let s5: Vec<_> = r.iter().filter(|x| x.shift_deg == 5.0).collect();
        assert_eq!((s5[0].start_face, s5[1].start_face), (3, 1));
        // Round trip through TOML.
        assert_eq!(parse(&p.to_toml("test")).unwrap(), p);
    }

    #[test]
    fn closure_reading_is_a_later_repeat_of_step_one() {
        let p = parse("faces = 3\nshifts_deg = [0]\nstart_faces = [2]\nclosure = true\n").unwrap();
        let r = p.readings();
        assert_eq!(r.len(), 4);
        assert!(r[3].closure && r[3].step == 1 && r[3].repeat == 2 && r[3].start_face == 2);
    }

    #[test]
    fn errors_name_line_and_column() {
        let e = parse("faces = 3\nshifts_deg = [0, 1e300]\n").unwrap_err();
        assert_eq!(
            e.to_string(),
            "p.toml:2:14: shifts_deg: a shift of 1e300° is out of range: below 360°"
        );
        let e = parse("faces = 3\nshifts_deg = [0]\nstart_faces = [1, 4]\n").unwrap_err();
        assert_eq!(
            e.to_string(),
            "p.toml:3:15: start_faces: 4 is out of range: expected 1..=3"
        );
        let e = parse("faces = 3\nshifts_deg = \"0:x:4\"\n").unwrap_err();
        assert!(e.to_string().starts_with("p.toml:2:14: shifts_deg"), "{e}");
        let e = parse("faces = 3\nshifts_deg = [0]\norder = [\"shift\", \"step\"]\n").unwrap_err();
        assert!(e.to_string().starts_with("p.toml:3:9: order"), "{e}");
        let e = parse("faces = 3\nshifts_deg = [0]\n[[shift]]\nshift_deg = 2\n").unwrap_err();
        assert!(e.to_string().contains("p.toml:4:13"), "{e}");
        let e = parse("faces = 3\nshifts_deg = [0]\nsteps = 1\n").unwrap_err();
        assert!(e.to_string().starts_with("p.toml:3:"), "{e}");
        let e = parse("faces = 3\nshift_deg = [0]\n").unwrap_err();
        assert!(e.to_string().starts_with("p.toml:"), "{e}");
        let e = parse("faces = 3\nshifts_deg = [0]\nx_sign = 2\n").unwrap_err();
        assert!(e.to_string().contains("expected 1 or -1"), "{e}");
    }
}
