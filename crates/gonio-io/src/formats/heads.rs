//! Read heads: the arrangement (`selfa12`, `eda:N`, or a TOML/JSON heads file) and the
//! head readings CSV (`position_deg,head_2,…,head_M[,turn]`) of `gonio selfcal` and `gonio joint`.

use super::csv::CsvTable;
use anyhow::{Result, anyhow, bail};
use gonio_calib::selfcal::{Heads, SelfcalError, Turn};
use serde::Deserialize;
use std::path::Path;

/// Most read heads in a heads file (real encoders have 1 to 24).
pub const MAX_HEADS: usize = 360;

/// Most head sets in a heads file.
pub const MAX_SETS: usize = 64;

/// A heads file (TOML or JSON).
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HeadsFile {
    /// Nominal head angles, degrees.
    pub angles_deg: Vec<f64>,
    #[serde(default)]
    /// Mounting offsets (for the simulator), arcsec.
    pub offsets_arcsec: Option<Vec<f64>>,
    #[serde(default)]
    /// Head sets (1-based), each an equal division.
    pub sets: Option<Vec<Vec<usize>>>,
}

/// Loads a head arrangement (`selfa12`, `eda:N` or a TOML/JSON file) and the file's optional
/// mounting offsets (arcsec, one per head; used by the simulator).
pub fn load(inputs: &crate::input::Inputs, spec: &str) -> Result<(Heads, Option<Vec<f64>>)> {
    if let Some(n) = spec.strip_prefix("eda:") {
        match n.trim().parse::<usize>() {
            Ok(n) if (2..=MAX_HEADS).contains(&n) => {}
            _ => bail!(
                "--heads {:?}: expected eda:N with N from 2 to {MAX_HEADS} heads",
                gonio_core::text::short(spec)
            ),
        }
    }
    if spec == "selfa12" || spec.starts_with("eda:") {
        return Ok((
            Heads::preset(spec).map_err(|e| anyhow!("--heads {spec}: {e}"))?,
            None,
        ));
    }
    let path = Path::new(spec);
    if !path.exists() {
        bail!(
            "--heads {:?}: expected selfa12, eda:N or a heads file (no such file)",
            gonio_core::text::short(spec)
        );
    }
    let text = inputs.read_text(path)?;
    let is_json = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("json"));
    parse(spec, &text, is_json)
}

/// Parses a heads file's text (JSON when `is_json`, else TOML); `name` names it in errors.
///
/// # Errors
/// Syntax, unknown keys, more than [`MAX_HEADS`] heads or [`MAX_SETS`] sets, head numbers out of
/// range, angles the estimators refuse.
pub fn parse(name: &str, text: &str, is_json: bool) -> Result<(Heads, Option<Vec<f64>>)> {
    let spec = name;
    let f: HeadsFile = if is_json {
        serde_json::from_str(text)
            .map_err(|e| super::json_error(spec, &e, "expected a heads file: angles_deg = [...]"))?
    } else {
        super::parse_toml(spec, text)?
    };
    if f.angles_deg.len() > MAX_HEADS {
        bail!(
            "{spec}: angles_deg: {} heads, at most {MAX_HEADS}",
            f.angles_deg.len()
        );
    }
    if let Some(sets) = &f.sets {
        if sets.len() > MAX_SETS {
            bail!("{spec}: sets: {} sets, at most {MAX_SETS}", sets.len());
        }
        let m = f.angles_deg.len();
        if let Some(h) = sets.iter().flatten().find(|&&h| h > m) {
            bail!("{spec}: sets: head {h} is not one of the {m} heads (1..={m})");
        }
    }
    let mut heads = Heads::new(f.angles_deg).map_err(|e| anyhow!("{spec}: angles_deg: {e}"))?;
    if let Some(sets) = f.sets {
        let mut z = Vec::with_capacity(sets.len());
        for s in sets {
            if s.contains(&0) {
                bail!("{spec}: sets: head numbers are 1-based, found 0");
            }
            z.push(s.into_iter().map(|h| h - 1).collect());
        }
        heads = heads
            .with_sets(z)
            .map_err(|e| anyhow!("{spec}: sets: {e}"))?;
    }
    if let Some(o) = &f.offsets_arcsec {
        if o.len() != heads.len() {
            bail!(
                "{spec}: offsets_arcsec: expected {} values (one per head), found {}",
                heads.len(),
                o.len()
            );
        }
        if let Some((i, v)) = o.iter().enumerate().find(|(_, v)| !v.is_finite()) {
            bail!("{spec}: offsets_arcsec[{i}] = {v}: expected a finite number");
        }
    }
    Ok((heads, f.offsets_arcsec))
}

/// One turn's rows: positions, head columns, CSV lines.
type TurnRows = (Vec<f64>, Vec<Vec<f64>>, Vec<u64>);

/// Readings per turn with the CSV line of every row.
pub struct ReadTurns {
    /// Turns in order of their number.
    pub turns: Vec<Turn>,
    /// `lines[t][i]`: CSV line of row i of turn t.
    pub lines: Vec<Vec<u64>>,
}

/// Reads a readings CSV for `heads` (differences, or raw readings with `raw`).
pub fn read_turns(table: &CsvTable, heads: &Heads, raw: bool) -> Result<ReadTurns> {
    let m = heads.len();
    let first = if raw { 1 } else { 2 };
    let want: Vec<String> = (first..=m).map(|h| format!("head_{h}")).collect();
    let expected_header = format!(
        "position_deg,{}{}",
        if want.len() > 3 {
            format!("{},…,{}", want[0], want[want.len() - 1])
        } else {
            want.join(",")
        },
        " (optional: turn)"
    );
    let pos_col = table.require("position_deg", &expected_header)?;
    let turn_col = table.column("turn");
    let found: Vec<&String> = table
        .headers
        .iter()
        .filter(|h| h.starts_with("head_"))
        .collect();
    let missing: Vec<&String> = want.iter().filter(|w| table.column(w).is_none()).collect();
    let extra: Vec<&&String> = found.iter().filter(|f| !want.contains(f)).collect();
    if !missing.is_empty() || !extra.is_empty() {
        bail!(
            "{}:{}: {} head columns for {} heads{}: expected {}, found {}{}",
            table.name,
            table.header_line,
            found.len(),
            m,
            if raw {
                " (raw readings)"
            } else {
                " (differences to head 1)"
            },
            want.join(","),
            found
                .iter()
                .map(|s| s.as_str())
                .collect::<Vec<_>>()
                .join(","),
            if !raw && table.column("head_1").is_some() {
                " (head_1 present: use --raw for raw readings in degrees)"
            } else {
                ""
            }
        );
    }
    let cols: Vec<usize> = want.iter().map(|w| table.column(w).unwrap()).collect();
    // Group rows by turn, in file order.
    let mut order: Vec<i64> = Vec::new();
    let mut groups: std::collections::HashMap<i64, TurnRows> = std::collections::HashMap::new();
    for (line, f) in &table.rows {
        let t = match turn_col {
            Some(c) => {
                let t = table.int_at(*line, f, c)?;
                if t < 1 {
                    return Err(table.error_at(*line, c, "expected a turn number ≥ 1"));
                }
                t
            }
            None => 1,
        };
        let g = groups.entry(t).or_insert_with(|| {
            order.push(t);
            (Vec::new(), vec![Vec::new(); cols.len()], Vec::new())
        });
        g.0.push(table.f64_at(*line, f, pos_col)?);
        for (k, &c) in cols.iter().enumerate() {
            g.1[k].push(table.f64_at(*line, f, c)?);
        }
        g.2.push(*line);
    }
    if order.is_empty() {
        bail!(
            "{}:{}: no readings: expected rows after the header",
            table.name,
            table.header_line
        );
    }
    order.sort_unstable();
    let mut turns = Vec::new();
    let mut lines = Vec::new();
    for t in order {
        let (positions_deg, cols, l) = groups.remove(&t).expect("grouped");
        let turn = if raw {
            Turn::from_raw(heads, positions_deg, &cols)
                .map_err(|e| anyhow!("{}: {e}", table.name))?
        } else {
            Turn {
                positions_deg,
                differences_arcsec: cols,
            }
        };
        turns.push(turn);
        lines.push(l);
    }
    Ok(ReadTurns { turns, lines })
}

/// Turns a library error into a one-line message with the file and line.
pub fn locate(e: SelfcalError, table: &CsvTable, lines: &[Vec<u64>]) -> anyhow::Error {
    let at = |turn: usize, index: usize| {
        lines
            .get(turn.wrapping_sub(1))
            .and_then(|l| l.get(index))
            .copied()
            .unwrap_or(table.header_line)
    };
    // Turns of unequal length: say so (not a spacing "found 0°, expected 0°" at their first row).
    let len = |t: usize| lines.get(t.wrapping_sub(1)).map_or(0, Vec::len);
    if let SelfcalError::Spacing { turn, .. } = e
        && turn > 1
        && len(turn) != len(1)
    {
        return anyhow!(
            "{}:{}: turn {turn} has {} rows, turn 1 has {}: every turn reads the same positions (one full turn in equal steps), so every turn needs as many rows",
            table.name,
            lines
                .get(turn - 1)
                .and_then(|l| l.first())
                .copied()
                .unwrap_or(table.header_line),
            len(turn),
            len(1)
        );
    }
    match e {
        SelfcalError::Spacing {
            turn,
            index,
            found_deg,
            expected_deg,
        } => {
            let ns = lines.get(turn - 1).map_or(0, |l| l.len());
            anyhow!(
                "{}:{}: column 'position_deg': found {found_deg}°, expected {expected_deg}° ({ns} rows in turn {turn}: positions must be equally spaced by 360°/{ns} = {}° over one full turn, in order)",
                table.name,
                at(turn, index),
                360.0 / ns.max(1) as f64
            )
        }
        SelfcalError::TooFewPositions {
            turn,
            expected,
            found,
        } => anyhow!(
            "{}:{}: turn {turn}: expected at least {expected} rotation positions, found {found}",
            table.name,
            lines
                .get(turn - 1)
                .and_then(|l| l.last())
                .copied()
                .unwrap_or(table.header_line)
        ),
        SelfcalError::NotFinite {
            turn, index, head, ..
        } => anyhow!(
            "{}:{}: head {head}: expected a finite number",
            table.name,
            at(turn, index)
        ),
        other => anyhow!("{}: {other}", table.name),
    }
}
