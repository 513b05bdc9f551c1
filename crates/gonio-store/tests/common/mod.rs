//! The checks every database of the store must pass.

use gonio_station::fit::Sample;
use gonio_station::hal::{ApproachSpeed, DeviceErrorKind};
use gonio_station::record::{DeviceFault, PhaseTimes, PushRecord, TurnKind, TurnRecord};
use gonio_station::strategy::Learned;
use gonio_station::{PartRecord, PartResult, Recipe};
use gonio_store::{BatchStatus, NewBatch, NewPart, PartQuery, Store, StoreError};

fn turn(e: f64) -> TurnRecord {
    TurnRecord {
        t_start_s: 2.0,
        kind: TurnKind::Initial,
        frames_taken: 200,
        samples: (0..5)
            .map(|i| Sample {
                theta_deg: 0.1 + 72.0 * i as f64,
                c_px: 720.0 + (i as f64).sin() / 3.0,
            })
            .collect(),
        invalid_frames: 195,
        e_um: Some(e),
        u_e_um: None,
        theta_max_deg: Some(12.5),
        c0_px: Some(720.25),
        residual_rms_px: Some(0.3),
        outliers: 1,
        focus_um: Some(-3.5),
        quality: None,
        carried_roundness: None,
    }
}

fn record(serial: &str, result: PartResult) -> PartRecord {
    let mut r = PartRecord::new(serial, "default", "learned");
    r.initial_e_um = Some(120.0);
    r.final_e_um = (result == PartResult::Accepted).then_some(2.5);
    r.result = result;
    r.time_s = Some(15.25);
    r.pushes = 1;
    r.phase_times = PhaseTimes {
        focus_s: 0.375,
        measure_s: 2.75,
        push_s: 7.5,
        align_s: Some(1.25),
        approach_s: Some(2.5),
        stroke_s: Some(2.0),
        retract_s: Some(1.75),
    };
    r.turns = vec![turn(120.0), turn(2.5)];
    r.push_log = vec![PushRecord {
        t_start_s: 4.8,
        e_before_um: 120.0,
        commanded_um: 118.0,
        angle_deg: 33.0,
        approach: ApproachSpeed::Fast,
        steps: 1,
        gain: 1.0,
        predicted_move_um: 119.0,
        predicted_e_after_um: 1.0,
        tolerance_um: 3.0,
        e_after_um: Some(2.5),
        deviation_um: Some(1.5),
        consistent: Some(true),
        duration_s: Some(7.2),
    }];
    if result == PartResult::RejectedDeviceError {
        r.device_error = Some(DeviceFault {
            device: "push rod".into(),
            kind: DeviceErrorKind::Fault,
            message: "overload".into(),
        });
        r.reject_reason = Some("push rod: Fault error: overload".into());
    }
    r
}

fn store_part(
    s: &mut dyn Store,
    station: &str,
    batch: i64,
    i: usize,
    rec: &PartRecord,
    learned: &Learned,
) -> Result<i64, StoreError> {
    s.insert_part(&NewPart {
        batch,
        batch_index: i,
        station,
        software_version: "gonio test",
        recipe: &Recipe::default(),
        started_at: "2026-05-20T10:00:00.000000Z",
        ended_at: "2026-05-20T10:00:15.000000Z",
        record: rec,
        learned,
        truth: Some((121.0, 2.0)),
        simulated: true,
    })
}

/// Stores two parts and reads them back every way the store offers, at `loc`.
pub fn round_trip(loc: &str) {
    let mut s = gonio_store::open(loc).unwrap();
    let b = s
        .begin_batch(&NewBatch {
            station: "sim",
            seed: Some(u64::MAX),
            config_json: "{\"parts\":3}",
            parts_planned: 3,
            software_version: "gonio test",
        })
        .unwrap();
    let l1 = Learned {
        gain: 0.97,
        offset_deg: 0.4,
        gain_observations: 1,
        offset_observations: 1,
    };
    let a = record("S-1", PartResult::Accepted);
    let r = record("S-2", PartResult::RejectedDeviceError);
    let id1 = store_part(s.as_mut(), "sim", b, 0, &a, &l1).unwrap();
    let l2 = Learned {
        gain: 0.953_125_000_000_1,
        ..l1
    };
    let id2 = store_part(s.as_mut(), "sim", b, 1, &r, &l2).unwrap();
    assert!(id2 > id1);
    // A part stored twice in one batch is refused, and nothing of it is kept.
    let dup = store_part(s.as_mut(), "sim", b, 1, &r, &l2).unwrap_err();
    assert!(
        matches!(dup, StoreError::Duplicate { index: 1, .. }),
        "{dup}"
    );
    assert_eq!(s.parts(&PartQuery::default()).unwrap().len(), 2);

    let all = s.parts(&PartQuery::default()).unwrap();
    let p = &all[0];
    assert_eq!((p.part, p.serial.as_str(), p.batch_index), (id1, "S-1", 0));
    assert_eq!(p.turns.len(), 2);
    assert_eq!(p.turns[0].samples, a.turns[0].samples, "samples bit-exact");
    assert_eq!(p.turns[0].valid_frames, 5);
    assert!(
        p.turns[0].u_e_um.is_none(),
        "undefined comes back undefined"
    );
    assert_eq!(p.turns[0].focus_um, Some(-3.5));
    assert_eq!(p.push_log, a.push_log);
    assert_eq!(p.phase_times, a.phase_times, "every phase time kept");
    assert_eq!(p.true_initial_e_um, Some(121.0));
    assert!(p.simulated, "stored as the twin's");
    assert_eq!(p.recipe_hash.len(), 64);
    let q = &all[1];
    assert!(q.final_e_um.is_none());
    assert_eq!(q.device_error, r.device_error);
    assert_eq!(q.result, "rejected_device_error");
    // JSON: NaN as null, the contract's fields present.
    let j = serde_json::to_value(q).unwrap();
    assert_eq!(j["part"], id2);
    assert!(j["final_e_um"].is_null());
    assert_eq!(j["verdict"], "reject");
    assert_eq!(j["simulated"], true);

    // Filters.
    let rej = s
        .parts(&PartQuery {
            verdict: Some("reject".into()),
            ..PartQuery::default()
        })
        .unwrap();
    assert_eq!(rej.len(), 1);
    assert_eq!(rej[0].serial, "S-2");
    let by_result = s
        .part_summaries(&PartQuery {
            verdict: Some("rejected_device_error".into()),
            ..PartQuery::default()
        })
        .unwrap();
    assert_eq!(by_result.len(), 1);
    let bad = s
        .parts(&PartQuery {
            verdict: Some("lost".into()),
            ..PartQuery::default()
        })
        .unwrap_err();
    assert!(bad.to_string().contains("expected pass, reject"), "{bad}");
    let since = |t: &str| PartQuery {
        since: Some(gonio_store::time::parse_since(t).unwrap()),
        ..PartQuery::default()
    };
    assert_eq!(s.parts(&since("2026-05-20")).unwrap().len(), 2);
    assert_eq!(s.parts(&since("2026-05-21")).unwrap().len(), 0);
    let last = s
        .parts(&PartQuery {
            limit: Some(1),
            ..PartQuery::default()
        })
        .unwrap();
    assert_eq!(last[0].part, id2);
    let st = s.stats(&PartQuery::default()).unwrap();
    assert_eq!(
        (st.parts, st.pass, st.reject, st.max_pushes),
        (2, 1, 1, Some(1))
    );
    assert_eq!(
        st.mean_final_e_um,
        Some(2.5),
        "the NULL final e is left out"
    );

    // What --resume needs: parts stored and the learned state after the last, bit-exact.
    let info = s.latest_batch("sim", "{\"parts\":3}").unwrap().unwrap();
    assert_eq!(info.seed, Some(u64::MAX));
    assert_eq!(info.next_index(), 2);
    assert_eq!(info.learned, Some(l2));
    assert!(s.latest_batch("sim", "{\"parts\":4}").unwrap().is_none());
    s.end_batch(b, BatchStatus::Complete, None).unwrap();
    assert_eq!(s.batch(b).unwrap().unwrap().status, "complete");

    // A second connection (the dashboard) reads while this one is open.
    let mut reader = gonio_store::open(loc).unwrap();
    assert_eq!(reader.part(id1).unwrap().unwrap().serial, "S-1");
    assert!(reader.part(999).unwrap().is_none());
}

/// Stores `n` parts of one batch of `station`, each with its own serial and e; returns the ids.
pub fn write_batch(loc: &str, station: &str, n: usize) -> Vec<i64> {
    let mut s = gonio_store::open(loc).unwrap();
    let cfg = format!("{{\"station\":\"{station}\"}}");
    let b = s
        .begin_batch(&NewBatch {
            station,
            seed: None,
            config_json: &cfg,
            parts_planned: n,
            software_version: "gonio test",
        })
        .unwrap();
    (0..n)
        .map(|i| {
            let mut r = record(&format!("{station}-{i}"), PartResult::Accepted);
            r.initial_e_um = Some(100.0 + i as f64);
            r.turns[0].e_um = r.initial_e_um;
            store_part(s.as_mut(), station, b, i, &r, &Learned::default()).unwrap()
        })
        .collect()
}

/// Every batch written by [`write_batch`] is whole and unmixed.
pub fn check_batches(loc: &str, batches: usize, n: usize) {
    let mut s = gonio_store::open(loc).unwrap();
    let all = s.parts(&PartQuery::default()).unwrap();
    assert_eq!(all.len(), batches * n);
    for p in &all {
        let (station, i) = p.serial.rsplit_once('-').unwrap();
        assert_eq!(p.station, station, "part {} in the wrong station", p.part);
        assert_eq!(p.batch_index.to_string(), i);
        assert_eq!(p.initial_e_um, Some(100.0 + p.batch_index as f64));
        assert_eq!(p.turns.len(), 2, "part {}", p.part);
        assert_eq!(p.turns[0].e_um, p.initial_e_um, "turn of another part");
        assert_eq!(p.push_log.len(), 1);
    }
}
