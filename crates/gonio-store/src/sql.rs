//! The store written once over [`Backend`]: the same statements run on SQLite and PostgreSQL.

use crate::backend::{Backend, Value};
use crate::record::{
    BatchInfo, NewBatch, NewPart, PartQuery, PartStats, PartSummary, StoredCalibration, StoredPart,
    StoredTurn, Verdict,
};
use crate::{BatchStatus, Store, StoreError, sha256_hex, time};
use gonio_calib::certificate::Certificate;
use gonio_station::hal::{ApproachSpeed, DeviceErrorKind};
use gonio_station::record::{DeviceFault, PhaseTimes, PushRecord, TurnKind};
use gonio_station::strategy::Learned;
use std::collections::HashMap;

/// A store over one connection.
pub(crate) struct SqlStore {
    pub(crate) db: Box<dyn Backend>,
    pub(crate) version: u32,
}

/// The result names a `--verdict` may name besides `pass` and `reject`.
pub const RESULT_NAMES: [&str; 9] = [
    "accepted",
    "rejected_max_pushes",
    "rejected_ring_lost",
    "rejected_focus_failure",
    "rejected_timeout",
    "measurement_untrusted",
    "push_inconsistent",
    "rejected_device_error",
    "interrupted",
];

fn corrupt(
    table: &'static str,
    row: i64,
    column: &'static str,
    m: impl Into<String>,
) -> StoreError {
    StoreError::Corrupt {
        table,
        row,
        column,
        message: m.into(),
    }
}

/// Column access with the table and row named in errors.
struct Row<'a> {
    v: &'a [Value],
    table: &'static str,
    key: i64,
}

impl<'a> Row<'a> {
    /// The row `v` of `table`, keyed by its first column (-1 when that is not an integer).
    fn new(v: &'a [Value], table: &'static str) -> Self {
        let key = v[0].int().unwrap_or(-1);
        Row { v, table, key }
    }
    fn int(&self, i: usize, col: &'static str) -> Result<i64, StoreError> {
        self.v[i]
            .int()
            .ok_or_else(|| corrupt(self.table, self.key, col, "expected an integer"))
    }
    fn count(&self, i: usize, col: &'static str) -> Result<usize, StoreError> {
        let v = self.int(i, col)?;
        usize::try_from(v).map_err(|_| corrupt(self.table, self.key, col, "expected a count ≥ 0"))
    }
    fn text(&self, i: usize, col: &'static str) -> Result<String, StoreError> {
        self.v[i]
            .text()
            .map(str::to_string)
            .ok_or_else(|| corrupt(self.table, self.key, col, "expected text"))
    }
    fn opt_text(&self, i: usize) -> Option<String> {
        self.v[i].text().map(str::to_string)
    }
    fn real(&self, i: usize) -> f64 {
        self.v[i].real()
    }
    fn opt_real(&self, i: usize) -> Option<f64> {
        self.v[i].opt_real()
    }
    fn json<T: serde::de::DeserializeOwned>(
        &self,
        i: usize,
        col: &'static str,
    ) -> Result<T, StoreError> {
        let s = self.text(i, col)?;
        serde_json::from_str(&s).map_err(|e| corrupt(self.table, self.key, col, e.to_string()))
    }
}

fn name_of<T: serde::Serialize>(v: &T) -> String {
    serde_json::to_value(v)
        .ok()
        .and_then(|v| v.as_str().map(str::to_string))
        .unwrap_or_default()
}

fn parse_name<T: serde::de::DeserializeOwned>(
    s: &str,
    table: &'static str,
    row: i64,
    col: &'static str,
) -> Result<T, StoreError> {
    serde_json::from_value(serde_json::Value::String(s.to_string()))
        .map_err(|e| corrupt(table, row, col, e.to_string()))
}

/// WHERE clause and parameters of a part query (parameters from `$first`).
fn part_filter(q: &PartQuery) -> Result<(String, Vec<Value>), StoreError> {
    let mut cond = Vec::new();
    let mut p: Vec<Value> = Vec::new();
    if let Some(s) = &q.since {
        p.push(s.as_str().into());
        cond.push(format!("started_at >= ${}", p.len()));
    }
    if let Some(v) = &q.verdict {
        let v = v.trim().to_ascii_lowercase();
        match v.as_str() {
            "pass" | "passed" | "accept" => {
                p.push("pass".into());
                cond.push(format!("verdict = ${}", p.len()));
            }
            "reject" | "rejected" => {
                p.push("reject".into());
                cond.push(format!("verdict = ${}", p.len()));
            }
            r if RESULT_NAMES.contains(&r) => {
                p.push(r.into());
                cond.push(format!("result = ${}", p.len()));
            }
            _ => {
                return Err(StoreError::Invalid {
                    what: "verdict",
                    value: v,
                    expected: "pass, reject, or a result: accepted, rejected_max_pushes, rejected_ring_lost, rejected_focus_failure, rejected_timeout, measurement_untrusted, push_inconsistent, rejected_device_error, interrupted",
                });
            }
        }
    }
    if let Some(s) = &q.serial {
        p.push(s.as_str().into());
        cond.push(format!("serial = ${}", p.len()));
    }
    if let Some(s) = &q.station {
        p.push(s.as_str().into());
        cond.push(format!("station = ${}", p.len()));
    }
    if let Some(b) = q.batch {
        p.push(b.into());
        cond.push(format!("batch_id = ${}", p.len()));
    }
    if let Some(a) = q.after {
        p.push(a.into());
        cond.push(format!("id > ${}", p.len()));
    }
    if let Some(t) = q.through {
        p.push(t.into());
        cond.push(format!("id <= ${}", p.len()));
    }
    let w = if cond.is_empty() {
        String::new()
    } else {
        format!(" WHERE {}", cond.join(" AND "))
    };
    Ok((w, p))
}

/// The columns of a part summary: the first columns of [`PART_COLS`].
macro_rules! summary_cols {
    () => {
        "id, serial, station, batch_id, batch_index, recipe_name, strategy, started_at, ended_at, \
         initial_e_um, final_e_um, pushes, time_s, result, verdict, reject_reason, remeasured_turns, \
         simulated"
    };
}

const SUMMARY_COLS: &str = summary_cols!();

const PART_COLS: &str = concat!(
    summary_cols!(),
    ", recipe_hash, software_version, focus_um, focus_s, measure_s, push_s, device, \
     device_error_kind, device_error_message, learned_gain, learned_offset_deg, \
     learned_gain_observations, learned_offset_observations, true_initial_e_um, true_final_e_um, \
     align_s, approach_s, stroke_s, retract_s"
);

const TURN_COLS: &str = "part_id, turn_index, kind, t_start_s, frames_taken, valid_frames, \
    invalid_frames, e_um, u_e_um, theta_max_deg, c0_px, residual_rms_px, outliers, focus_um, \
    quality_json, samples_json";

const PUSH_COLS: &str = "part_id, push_index, t_start_s, duration_s, e_before_um, e_after_um, \
    commanded_um, angle_deg, approach, steps, gain, predicted_move_um, predicted_e_after_um, \
    tolerance_um, deviation_um, consistent";

fn verdict_of(s: &str, key: i64) -> Result<Verdict, StoreError> {
    match s {
        "pass" => Ok(Verdict::Pass),
        "reject" => Ok(Verdict::Reject),
        _ => Err(corrupt("parts", key, "verdict", "expected pass or reject")),
    }
}

/// A whole part's row ([`PART_COLS`]): its summary, then the rest.
fn part_row(v: &[Value]) -> Result<StoredPart, StoreError> {
    let r = Row::new(v, "parts");
    let key = r.key;
    let device_error = match r.opt_text(24) {
        Some(device) => Some(DeviceFault {
            device,
            kind: parse_name::<DeviceErrorKind>(
                &r.text(25, "device_error_kind")?,
                "parts",
                key,
                "device_error_kind",
            )?,
            message: r.opt_text(26).unwrap_or_default(),
        }),
        None => None,
    };
    let s = summary_row(v)?;
    Ok(StoredPart {
        part: s.part,
        serial: s.serial,
        station: s.station,
        simulated: s.simulated,
        batch: s.batch,
        batch_index: s.batch_index,
        recipe: s.recipe,
        recipe_hash: r.text(18, "recipe_hash")?,
        strategy: s.strategy,
        software_version: r.text(19, "software_version")?,
        started_at: s.started_at,
        ended_at: s.ended_at,
        initial_e_um: s.initial_e_um,
        final_e_um: s.final_e_um,
        pushes: s.pushes,
        time_s: s.time_s,
        result: s.result,
        verdict: s.verdict,
        reject_reason: s.reject_reason,
        remeasured_turns: s.remeasured_turns,
        focus_um: r.opt_real(20),
        phase_times: PhaseTimes {
            focus_s: r.real(21),
            measure_s: r.real(22),
            push_s: r.real(23),
            align_s: r.opt_real(33),
            approach_s: r.opt_real(34),
            stroke_s: r.opt_real(35),
            retract_s: r.opt_real(36),
        },
        device_error,
        turns: Vec::new(),
        push_log: Vec::new(),
        learned: Learned {
            gain: r.real(27),
            offset_deg: r.real(28),
            gain_observations: r.count(29, "learned_gain_observations")? as u32,
            offset_observations: r.count(30, "learned_offset_observations")? as u32,
        },
        true_initial_e_um: r.opt_real(31),
        true_final_e_um: r.opt_real(32),
    })
}

/// A part summary's row ([`SUMMARY_COLS`], also the first columns of [`PART_COLS`]).
fn summary_row(v: &[Value]) -> Result<PartSummary, StoreError> {
    let r = Row::new(v, "parts");
    let key = r.key;
    Ok(PartSummary {
        part: key,
        serial: r.text(1, "serial")?,
        station: r.text(2, "station")?,
        batch: r.int(3, "batch_id")?,
        batch_index: r.count(4, "batch_index")?,
        recipe: r.text(5, "recipe_name")?,
        strategy: r.text(6, "strategy")?,
        started_at: r.text(7, "started_at")?,
        ended_at: r.text(8, "ended_at")?,
        initial_e_um: r.opt_real(9),
        final_e_um: r.opt_real(10),
        pushes: r.count(11, "pushes")? as u32,
        time_s: r.opt_real(12),
        result: r.text(13, "result")?,
        verdict: verdict_of(&r.text(14, "verdict")?, key)?,
        reject_reason: r.opt_text(15),
        remeasured_turns: r.count(16, "remeasured_turns")? as u32,
        simulated: r.int(17, "simulated")? != 0,
    })
}

fn turn_row(v: &[Value]) -> Result<(i64, StoredTurn), StoreError> {
    let r = Row::new(v, "turns");
    let key = r.key;
    let quality = match r.opt_text(14) {
        Some(_) => Some(r.json::<serde_json::Value>(14, "quality_json")?),
        None => None,
    };
    Ok((
        key,
        StoredTurn {
            t_start_s: r.real(3),
            kind: parse_name::<TurnKind>(&r.text(2, "kind")?, "turns", key, "kind")?,
            frames_taken: r.count(4, "frames_taken")?,
            valid_frames: r.count(5, "valid_frames")?,
            invalid_frames: r.count(6, "invalid_frames")?,
            e_um: r.opt_real(7),
            u_e_um: r.opt_real(8),
            theta_max_deg: r.opt_real(9),
            c0_px: r.opt_real(10),
            residual_rms_px: r.opt_real(11),
            outliers: r.count(12, "outliers")?,
            focus_um: r.opt_real(13),
            quality,
            samples: r.json(15, "samples_json")?,
        },
    ))
}

fn push_row(v: &[Value]) -> Result<(i64, PushRecord), StoreError> {
    let r = Row::new(v, "pushes");
    let key = r.key;
    Ok((
        key,
        PushRecord {
            t_start_s: r.real(2),
            duration_s: r.opt_real(3),
            e_before_um: r.real(4),
            e_after_um: r.opt_real(5),
            commanded_um: r.real(6),
            angle_deg: r.real(7),
            approach: parse_name::<ApproachSpeed>(
                &r.text(8, "approach")?,
                "pushes",
                key,
                "approach",
            )?,
            steps: r.count(9, "steps")? as u32,
            gain: r.real(10),
            predicted_move_um: r.real(11),
            predicted_e_after_um: r.real(12),
            tolerance_um: r.real(13),
            deviation_um: r.opt_real(14),
            consistent: r.v[15].int().map(|c| c != 0),
        },
    ))
}

fn batch_row(v: &[Value]) -> Result<BatchInfo, StoreError> {
    let r = Row::new(v, "batches");
    let key = r.key;
    let seed = match r.opt_text(2) {
        Some(s) => Some(
            s.parse::<u64>()
                .map_err(|_| corrupt("batches", key, "seed", "expected a whole number"))?,
        ),
        None => None,
    };
    Ok(BatchInfo {
        batch: key,
        station: r.text(1, "station")?,
        seed,
        config_hash: r.text(3, "config_hash")?,
        parts_planned: r.count(4, "parts_planned")?,
        status: r.text(5, "status")?,
        stop_reason: r.opt_text(6),
        started_at: r.text(7, "started_at")?,
        parts_stored: 0,
        learned: None,
    })
}

const BATCH_COLS: &str =
    "id, station, seed, config_hash, parts_planned, status, stop_reason, started_at";

const CAL_COLS: &str = "id, item, procedure, method, calibration_date, max_abs_error_arcsec, \
    max_expanded_arcsec, source, software_version, stored_at";

fn calibration_row(v: &[Value], with_cert: bool) -> Result<StoredCalibration, StoreError> {
    let r = Row::new(v, "calibrations");
    let key = r.key;
    Ok(StoredCalibration {
        calibration: key,
        item: r.opt_text(1),
        procedure: r.text(2, "procedure")?,
        method: r.text(3, "method")?,
        calibration_date: r.opt_text(4),
        max_abs_error_arcsec: r.real(5),
        max_expanded_arcsec: r.opt_real(6),
        source: r.text(7, "source")?,
        software_version: r.text(8, "software_version")?,
        stored_at: r.text(9, "stored_at")?,
        certificate: if with_cert {
            Some(r.json(10, "certificate_json")?)
        } else {
            None
        },
    })
}

impl SqlStore {
    /// Runs `f` in one transaction: all of it is stored or none.
    fn in_transaction<T>(
        &mut self,
        f: impl FnOnce(&mut dyn Backend) -> Result<T, StoreError>,
    ) -> Result<T, StoreError> {
        self.db.begin()?;
        match f(self.db.as_mut()) {
            Ok(v) => {
                self.db.commit()?;
                Ok(v)
            }
            Err(e) => {
                self.db.rollback();
                Err(e)
            }
        }
    }

    /// Fills in the turns and pushes of `parts` (ids ascending).
    fn attach_details(&mut self, parts: &mut [StoredPart]) -> Result<(), StoreError> {
        let (Some(lo), Some(hi)) = (parts.first().map(|p| p.part), parts.last().map(|p| p.part))
        else {
            return Ok(());
        };
        let index: HashMap<i64, usize> =
            parts.iter().enumerate().map(|(i, p)| (p.part, i)).collect();
        let turns = self.db.query(
            &format!(
                "SELECT {TURN_COLS} FROM turns WHERE part_id >= $1 AND part_id <= $2 ORDER BY part_id, turn_index"
            ),
            &[lo.into(), hi.into()],
        )?;
        for t in &turns {
            let (id, turn) = turn_row(t)?;
            if let Some(&i) = index.get(&id) {
                parts[i].turns.push(turn);
            }
        }
        let pushes = self.db.query(
            &format!(
                "SELECT {PUSH_COLS} FROM pushes WHERE part_id >= $1 AND part_id <= $2 ORDER BY part_id, push_index"
            ),
            &[lo.into(), hi.into()],
        )?;
        for p in &pushes {
            let (id, push) = push_row(p)?;
            if let Some(&i) = index.get(&id) {
                parts[i].push_log.push(push);
            }
        }
        Ok(())
    }

    fn query_parts(&mut self, cols: &str, q: &PartQuery) -> Result<Vec<Vec<Value>>, StoreError> {
        let (w, p) = part_filter(q)?;
        let mut rows = match q.limit {
            Some(n) => {
                let mut r = self.db.query(
                    &format!("SELECT {cols} FROM parts{w} ORDER BY id DESC LIMIT {n}"),
                    &p,
                )?;
                r.reverse();
                r
            }
            None => self
                .db
                .query(&format!("SELECT {cols} FROM parts{w} ORDER BY id"), &p)?,
        };
        rows.shrink_to_fit();
        Ok(rows)
    }
}

fn insert_part_in(db: &mut dyn Backend, p: &NewPart<'_>) -> Result<i64, StoreError> {
    let rec = p.record;
    let recipe_json =
        serde_json::to_string(p.recipe).map_err(|e| StoreError::db("insert part: recipe", e))?;
    let recipe_hash = sha256_hex(recipe_json.as_bytes());
    db.exec(
        "INSERT INTO recipes (hash, name, recipe_json) VALUES ($1, $2, $3) ON CONFLICT (hash) DO NOTHING",
        &[
            recipe_hash.as_str().into(),
            p.recipe.name.as_str().into(),
            recipe_json.into(),
        ],
    )?;
    let dup = db.query(
        "SELECT id FROM parts WHERE batch_id = $1 AND batch_index = $2",
        &[p.batch.into(), p.batch_index.into()],
    )?;
    if !dup.is_empty() {
        return Err(StoreError::Duplicate {
            batch: p.batch,
            index: p.batch_index,
        });
    }
    let fault = rec.device_error.as_ref();
    let params: Vec<Value> = vec![
        p.batch.into(),
        p.batch_index.into(),
        p.station.into(),
        rec.serial.as_str().into(),
        rec.recipe.as_str().into(),
        recipe_hash.into(),
        rec.strategy.as_str().into(),
        p.software_version.into(),
        p.started_at.into(),
        p.ended_at.into(),
        rec.initial_e_um.into(),
        rec.final_e_um.into(),
        rec.pushes.into(),
        rec.time_s.into(),
        rec.result.name().into(),
        Verdict::of(rec.result).name().into(),
        rec.reject_reason.clone().into(),
        rec.remeasured_turns.into(),
        rec.focus_um.into(),
        rec.phase_times.focus_s.into(),
        rec.phase_times.measure_s.into(),
        rec.phase_times.push_s.into(),
        fault.map(|f| f.device.clone()).into(),
        fault.map(|f| name_of(&f.kind)).into(),
        fault.map(|f| f.message.clone()).into(),
        p.learned.gain.into(),
        p.learned.offset_deg.into(),
        p.learned.gain_observations.into(),
        p.learned.offset_observations.into(),
        p.truth.map(|t| t.0).into(),
        p.truth.map(|t| t.1).into(),
        p.simulated.into(),
        rec.phase_times.align_s.into(),
        rec.phase_times.approach_s.into(),
        rec.phase_times.stroke_s.into(),
        rec.phase_times.retract_s.into(),
    ];
    let placeholders: Vec<String> = (1..=params.len()).map(|i| format!("${i}")).collect();
    let cols = "batch_id, batch_index, station, serial, recipe_name, recipe_hash, strategy, \
        software_version, started_at, ended_at, initial_e_um, final_e_um, pushes, time_s, result, \
        verdict, reject_reason, remeasured_turns, focus_um, focus_s, measure_s, push_s, device, \
        device_error_kind, device_error_message, learned_gain, learned_offset_deg, \
        learned_gain_observations, learned_offset_observations, true_initial_e_um, true_final_e_um, \
        simulated, align_s, approach_s, stroke_s, retract_s";
    let id = db
        .query(
            &format!(
                "INSERT INTO parts ({cols}) VALUES ({}) RETURNING id",
                placeholders.join(", ")
            ),
            &params,
        )?
        .first()
        .and_then(|r| r.first())
        .and_then(Value::int)
        .ok_or_else(|| StoreError::db("insert part", "no id returned"))?;
    let turn_sql = format!(
        "INSERT INTO turns ({TURN_COLS}, quality_ok) VALUES ($1, $2, $3, $4, $5, $6, $7, $8, $9, $10, $11, $12, $13, $14, $15, $16, $17)"
    );
    for (i, t) in rec.turns.iter().enumerate() {
        let quality = match &t.quality {
            Some(q) => Some(
                serde_json::to_string(q).map_err(|e| StoreError::db("insert turn: quality", e))?,
            ),
            None => None,
        };
        let samples = serde_json::to_string(&t.samples)
            .map_err(|e| StoreError::db("insert turn: samples", e))?;
        db.exec(
            &turn_sql,
            &[
                id.into(),
                i.into(),
                name_of(&t.kind).into(),
                t.t_start_s.into(),
                t.frames_taken.into(),
                t.samples.len().into(),
                t.invalid_frames.into(),
                t.e_um.into(),
                t.u_e_um.into(),
                t.theta_max_deg.into(),
                t.c0_px.into(),
                t.residual_rms_px.into(),
                t.outliers.into(),
                t.focus_um.into(),
                quality.into(),
                samples.into(),
                t.quality.as_ref().map(|q| q.ok).into(),
            ],
        )?;
    }
    let push_sql = format!(
        "INSERT INTO pushes ({PUSH_COLS}) VALUES ($1, $2, $3, $4, $5, $6, $7, $8, $9, $10, $11, $12, $13, $14, $15, $16)"
    );
    for (i, q) in rec.push_log.iter().enumerate() {
        db.exec(
            &push_sql,
            &[
                id.into(),
                i.into(),
                q.t_start_s.into(),
                q.duration_s.into(),
                q.e_before_um.into(),
                q.e_after_um.into(),
                q.commanded_um.into(),
                q.angle_deg.into(),
                name_of(&q.approach).into(),
                q.steps.into(),
                q.gain.into(),
                q.predicted_move_um.into(),
                q.predicted_e_after_um.into(),
                q.tolerance_um.into(),
                q.deviation_um.into(),
                q.consistent.into(),
            ],
        )?;
    }
    Ok(id)
}

impl Store for SqlStore {
    fn schema_version(&self) -> u32 {
        self.version
    }

    fn begin_batch(&mut self, b: &NewBatch<'_>) -> Result<i64, StoreError> {
        let now = time::now_utc();
        let hash = sha256_hex(b.config_json.as_bytes());
        let rows = self.db.query(
            "INSERT INTO batches (station, seed, config_json, config_hash, parts_planned, software_version, started_at, status) \
             VALUES ($1, $2, $3, $4, $5, $6, $7, 'running') RETURNING id",
            &[
                b.station.into(),
                b.seed.map(|s| s.to_string()).into(),
                b.config_json.into(),
                hash.into(),
                b.parts_planned.into(),
                b.software_version.into(),
                now.into(),
            ],
        )?;
        rows.first()
            .and_then(|r| r.first())
            .and_then(Value::int)
            .ok_or_else(|| StoreError::db("begin batch", "no id returned"))
    }

    fn batch(&mut self, id: i64) -> Result<Option<BatchInfo>, StoreError> {
        let rows = self.db.query(
            &format!("SELECT {BATCH_COLS} FROM batches WHERE id = $1"),
            &[id.into()],
        )?;
        let Some(row) = rows.first() else {
            return Ok(None);
        };
        let mut b = batch_row(row)?;
        let agg = self.db.query(
            "SELECT COUNT(*), MAX(batch_index) FROM parts WHERE batch_id = $1",
            &[id.into()],
        )?;
        let stored = agg.first().and_then(|r| r[0].int()).unwrap_or(0) as usize;
        if stored > 0 {
            let last = agg.first().and_then(|r| r[1].int()).unwrap_or(-1);
            if last != stored as i64 - 1 {
                return Err(StoreError::Gap {
                    batch: id,
                    stored,
                    last: last.max(0) as usize,
                });
            }
            let l = self.db.query(
                "SELECT learned_gain, learned_offset_deg, learned_gain_observations, learned_offset_observations \
                 FROM parts WHERE batch_id = $1 AND batch_index = $2",
                &[id.into(), last.into()],
            )?;
            if let Some(r) = l.first() {
                let row = Row {
                    v: r,
                    table: "parts",
                    key: last,
                };
                b.learned = Some(Learned {
                    gain: row.real(0),
                    offset_deg: row.real(1),
                    gain_observations: row.count(2, "learned_gain_observations")? as u32,
                    offset_observations: row.count(3, "learned_offset_observations")? as u32,
                });
            }
        }
        b.parts_stored = stored;
        Ok(Some(b))
    }

    fn latest_batch(
        &mut self,
        station: &str,
        config_json: &str,
    ) -> Result<Option<BatchInfo>, StoreError> {
        let hash = sha256_hex(config_json.as_bytes());
        let rows = self.db.query(
            "SELECT id FROM batches WHERE station = $1 AND config_hash = $2 ORDER BY id DESC LIMIT 1",
            &[station.into(), hash.into()],
        )?;
        match rows.first().and_then(|r| r[0].int()) {
            Some(id) => self.batch(id),
            None => Ok(None),
        }
    }

    fn end_batch(
        &mut self,
        id: i64,
        status: BatchStatus,
        reason: Option<&str>,
    ) -> Result<(), StoreError> {
        let now = time::now_utc();
        self.db.exec(
            "UPDATE batches SET status = $1, stop_reason = $2, ended_at = $3 WHERE id = $4",
            &[status.name().into(), reason.into(), now.into(), id.into()],
        )?;
        Ok(())
    }

    fn insert_part(&mut self, p: &NewPart<'_>) -> Result<i64, StoreError> {
        self.in_transaction(|db| insert_part_in(db, p))
    }

    fn parts(&mut self, q: &PartQuery) -> Result<Vec<StoredPart>, StoreError> {
        let rows = self.query_parts(PART_COLS, q)?;
        let mut parts = rows
            .iter()
            .map(|r| part_row(r))
            .collect::<Result<Vec<_>, _>>()?;
        self.attach_details(&mut parts)?;
        Ok(parts)
    }

    fn part_summaries(&mut self, q: &PartQuery) -> Result<Vec<PartSummary>, StoreError> {
        let rows = self.query_parts(SUMMARY_COLS, q)?;
        rows.iter().map(|r| summary_row(r)).collect()
    }

    fn part_ids(&mut self, q: &PartQuery) -> Result<Vec<i64>, StoreError> {
        let rows = self.query_parts("id", q)?;
        rows.iter()
            .map(|r| {
                r.first()
                    .and_then(Value::int)
                    .ok_or_else(|| StoreError::db("part ids", "an id that is not an integer"))
            })
            .collect()
    }

    fn part(&mut self, id: i64) -> Result<Option<StoredPart>, StoreError> {
        let rows = self.db.query(
            &format!("SELECT {PART_COLS} FROM parts WHERE id = $1"),
            &[id.into()],
        )?;
        let Some(r) = rows.first() else {
            return Ok(None);
        };
        let mut parts = vec![part_row(r)?];
        self.attach_details(&mut parts)?;
        Ok(parts.pop())
    }

    fn stats(&mut self, q: &PartQuery) -> Result<PartStats, StoreError> {
        let (w, p) = part_filter(q)?;
        let rows = self.db.query(
            &format!(
                "SELECT COUNT(*), SUM(CASE WHEN verdict = 'pass' THEN 1 ELSE 0 END), AVG(time_s), \
                 AVG(CAST(pushes AS DOUBLE PRECISION)), MAX(pushes), AVG(final_e_um) FROM parts{w}"
            ),
            &p,
        )?;
        let r = rows
            .first()
            .ok_or_else(|| StoreError::db("stats", "no row"))?;
        let parts = r[0].int().unwrap_or(0).max(0) as u64;
        let pass = r[1].int().unwrap_or(0).max(0) as u64;
        Ok(PartStats {
            parts,
            pass,
            reject: parts - pass.min(parts),
            mean_time_s: r[2].opt_real(),
            mean_pushes: r[3].opt_real(),
            max_pushes: r[4].int().map(|v| v.max(0) as u32),
            mean_final_e_um: r[5].opt_real(),
        })
    }

    fn insert_calibration(
        &mut self,
        cert: &Certificate,
        source: &str,
        software_version: &str,
    ) -> Result<i64, StoreError> {
        let json =
            serde_json::to_string(cert).map_err(|e| StoreError::db("insert calibration", e))?;
        let ix = cert.index_fields();
        let now = time::now_utc();
        let rows = self.db.query(
            "INSERT INTO calibrations (item, procedure, method, calibration_date, max_abs_error_arcsec, max_expanded_arcsec, source, software_version, stored_at, certificate_json) \
             VALUES ($1, $2, $3, $4, $5, $6, $7, $8, $9, $10) RETURNING id",
            &[
                ix.item.into(),
                ix.procedure.name().into(),
                ix.method.into(),
                ix.calibration_date.into(),
                ix.max_abs_error_arcsec.into(),
                ix.max_expanded_arcsec.into(),
                source.into(),
                software_version.into(),
                now.into(),
                json.into(),
            ],
        )?;
        rows.first()
            .and_then(|r| r.first())
            .and_then(Value::int)
            .ok_or_else(|| StoreError::db("insert calibration", "no id returned"))
    }

    fn calibrations(&mut self) -> Result<Vec<StoredCalibration>, StoreError> {
        let rows = self.db.query(
            &format!("SELECT {CAL_COLS} FROM calibrations ORDER BY id"),
            &[],
        )?;
        rows.iter().map(|r| calibration_row(r, false)).collect()
    }

    fn calibration(&mut self, id: i64) -> Result<Option<StoredCalibration>, StoreError> {
        let rows = self.db.query(
            &format!("SELECT {CAL_COLS}, certificate_json FROM calibrations WHERE id = $1"),
            &[id.into()],
        )?;
        rows.first().map(|r| calibration_row(r, true)).transpose()
    }
}
