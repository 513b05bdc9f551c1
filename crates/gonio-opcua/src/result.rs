//! A stored part as an OPC 40001-101 result: its `ResultMetaData` (id, part, product,
//! state, evaluation, times, whether simulated) and, as its content, gonio's
//! `MountingResultDataType` with the store's numbers unchanged.
//!
//! - `ResultId`: `<station>/<part id>` (the store's id, unique in a store, with the station's
//!   name, so ids from a fleet's stations read apart);
//! - `ResultState`: 1 Completed, or 3 Aborted for a part ended by a device error;
//! - `ResultEvaluation`: OK for an accepted part, NotOK for a rejected one (the reason in
//!   `ResultEvaluationDetails`);
//! - `CreationTime` and `ProcessingTimes`: the part's wall-clock start and end (UTC), and its
//!   measuring turns' time as the acquisition duration (ms).

use crate::codec::Codec;
use gonio_store::{StoredPart, Verdict};
use opcua::types::{DateTime, ExtensionObject, LocalizedText, Variant, VariantScalarTypeId};

/// `ResultState` of a finished result.
const COMPLETED: i32 = 1;
/// `ResultState` of a result stopped before completion.
const ABORTED: i32 = 3;
/// `ResultEvaluationEnum`.
const OK: i32 = 1;
/// `ResultEvaluationEnum`.
const NOT_OK: i32 = 2;

/// Whether a stored part came from the digital twin, as the store recorded it when the part was
/// committed (`StoredPart::simulated`: the twin in the process, or a PLC that said it is
/// simulated).
pub fn is_simulated(part: &StoredPart) -> bool {
    part.simulated
}

/// A result's id: `<station>/<part id>`.
pub(crate) fn result_id(part: &StoredPart) -> String {
    format!("{}/{}", part.station, part.part)
}

/// A result id's station and part id (`None`: not of the form `<station>/<part id>`).
pub(crate) fn parse_result_id(id: &str) -> Option<(&str, i64)> {
    let (station, part) = id.rsplit_once('/')?;
    let part: i64 = part.parse().ok()?;
    (!station.is_empty() && part > 0 && !id.starts_with('/')).then_some((station, part))
}

/// A store time (RFC 3339, UTC) as an OPC UA time.
fn time(s: &str) -> Result<DateTime, String> {
    DateTime::parse_from_rfc3339(s).map_err(|e| format!("store time {s:?}: {e}"))
}

/// A number, or absent.
fn opt(x: Option<f64>) -> Variant {
    x.filter(|v| v.is_finite())
        .map_or(Variant::Empty, Variant::Double)
}

/// The trusted turn that gave the part's final e: the last turn that passed the quality gate,
/// when its e is the record's final e.
fn final_turn(part: &StoredPart) -> Option<&gonio_store::StoredTurn> {
    let last = part.turns.iter().rev().find(|t| {
        t.quality
            .as_ref()
            .and_then(|q| q.get("ok"))
            .and_then(serde_json::Value::as_bool)
            == Some(true)
    })?;
    (last.e_um.is_some() && last.e_um == part.final_e_um).then_some(last)
}

/// The part's `ResultMetaDataType` fields other than `ProcessingTimes`, by name (what
/// `GetResultIdListFiltered`'s filter compares too).
pub(crate) fn meta_fields(part: &StoredPart) -> Result<Vec<(&'static str, Variant)>, String> {
    let end = time(&part.ended_at)?;
    let accepted = part.verdict == Verdict::Pass;
    let mut fields = vec![
        ("ResultId", Variant::from(result_id(part))),
        ("IsSimulated", Variant::Boolean(is_simulated(part))),
        (
            "ResultState",
            Variant::Int32(if part.device_error.is_some() {
                ABORTED
            } else {
                COMPLETED
            }),
        ),
        ("PartId", Variant::from(part.serial.as_str())),
        ("ProductId", Variant::from(part.recipe.as_str())),
        ("InternalRecipeId", Variant::from(part.recipe_hash.as_str())),
        (
            "JobId",
            Variant::from(format!("{}/batch/{}", part.station, part.batch)),
        ),
        ("CreationTime", Variant::DateTime(Box::new(end))),
        (
            "ResultEvaluation",
            Variant::Int32(if accepted { OK } else { NOT_OK }),
        ),
    ];
    if !accepted {
        let why = match &part.reject_reason {
            Some(r) => format!("{}: {r}", part.result),
            None => part.result.clone(),
        };
        fields.push((
            "ResultEvaluationDetails",
            Variant::from(LocalizedText::new("en", &why)),
        ));
    }
    Ok(fields)
}

/// The part's `ResultMetaDataType`.
pub(crate) fn meta_data(codec: &Codec, part: &StoredPart) -> Result<ExtensionObject, String> {
    let (start, end) = (time(&part.started_at)?, time(&part.ended_at)?);
    let times = codec.make(
        &codec.times,
        vec![
            ("StartTime", Variant::DateTime(Box::new(start))),
            ("EndTime", Variant::DateTime(Box::new(end))),
            (
                "AcquisitionDuration",
                Variant::Double(part.phase_times.measure_s * 1000.0),
            ),
        ],
    )?;
    let mut fields = meta_fields(part)?;
    fields.push(("ProcessingTimes", Variant::from(times)));
    codec.make(&codec.meta, fields)
}

/// The part's `MountingResultDataType` (the store's numbers).
pub(crate) fn content(codec: &Codec, part: &StoredPart) -> Result<ExtensionObject, String> {
    let turn = final_turn(part);
    let mut fields = vec![
        ("StorePartId", Variant::Int64(part.part)),
        ("Station", Variant::from(part.station.as_str())),
        ("BatchId", Variant::Int64(part.batch)),
        ("BatchIndex", Variant::UInt32(part.batch_index as u32)),
        ("Strategy", Variant::from(part.strategy.as_str())),
        ("InitialE_um", opt(part.initial_e_um)),
        ("FinalE_um", opt(part.final_e_um)),
        ("FinalU_um", opt(turn.and_then(|t| t.u_e_um))),
        ("FinalThetaMax_deg", opt(turn.and_then(|t| t.theta_max_deg))),
        ("Pushes", Variant::UInt32(part.pushes)),
        ("RemeasuredTurns", Variant::UInt32(part.remeasured_turns)),
        ("CycleTime_s", opt(part.time_s)),
        ("FocusTime_s", Variant::Double(part.phase_times.focus_s)),
        ("MeasureTime_s", Variant::Double(part.phase_times.measure_s)),
        ("PushTime_s", Variant::Double(part.phase_times.push_s)),
        ("Focus_um", opt(part.focus_um)),
        ("Verdict", Variant::from(part.verdict.name())),
        ("Result", Variant::from(part.result.as_str())),
        ("RecipeHash", Variant::from(part.recipe_hash.as_str())),
        (
            "SoftwareVersion",
            Variant::from(part.software_version.as_str()),
        ),
    ];
    if let Some(r) = &part.reject_reason {
        fields.push(("RejectReason", Variant::from(r.as_str())));
    }
    codec.make(&codec.mounting, fields)
}

/// The part as a `ResultDataType`: its metadata and, as the only element of its content,
/// its `MountingResultDataType`.
pub(crate) fn result_data(codec: &Codec, part: &StoredPart) -> Result<ExtensionObject, String> {
    let content = Variant::Variant(Box::new(Variant::from(content(codec, part)?)));
    codec.make(
        &codec.result,
        vec![
            ("ResultMetaData", Variant::from(meta_data(codec, part)?)),
            (
                "ResultContent",
                Variant::from((VariantScalarTypeId::Variant, vec![content])),
            ),
        ],
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn result_ids_carry_the_station_and_the_part() {
        assert_eq!(parse_result_id("sim/42"), Some(("sim", 42)));
        assert_eq!(parse_result_id("line/3/7"), Some(("line/3", 7)));
        assert_eq!(parse_result_id("sim/"), None);
        assert_eq!(parse_result_id("/42"), None);
        assert_eq!(parse_result_id("sim/0"), None);
        assert_eq!(parse_result_id("sim/4x"), None);
        assert_eq!(parse_result_id("42"), None);
    }
}
