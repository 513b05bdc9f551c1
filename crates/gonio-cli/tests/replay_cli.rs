//! Replay: `gonio mount --fidelity frames --record DIR` keeps a part's raw frames, stamps and
//! angle log with its record; `gonio replay DIR` runs the frames through the detector and the
//! turns through the fit again and finds them bit-identical to the record; a changed angle log
//! is reported as a difference.

mod common;

use common::gonio;
use serde_json::Value;
use std::path::Path;
use std::process::Output;

fn text(o: &Output) -> (String, String) {
    (
        String::from_utf8_lossy(&o.stdout).into_owned(),
        String::from_utf8_lossy(&o.stderr).into_owned(),
    )
}

fn s(p: &Path) -> String {
    p.display().to_string()
}

#[test]
fn a_recorded_part_replays_bit_identical_and_a_change_is_reported() {
    let d = tempfile::tempdir().unwrap();
    let rec = d.path().join("rec");
    let batch = d.path().join("batch.json");
    // Two parts at full fidelity (rendered frames through the detector); only the second is
    // recorded (about 150 MB a turn).
    let o = gonio(&[
        "mount",
        "--sim",
        "--fidelity",
        "frames",
        "--parts",
        "2",
        "--seed",
        "4",
        "--record",
        &s(&rec),
        "--record-parts",
        "2",
        "--json",
        &s(&batch),
    ]);
    let (_, err) = text(&o);
    assert!(o.status.success(), "{err}");
    assert!(err.contains("recorded 1 part(s) in "), "{err}");
    assert!(!rec.join("part-0001").exists());
    let part = rec.join("part-0002");
    let pj: Value =
        serde_json::from_str(&std::fs::read_to_string(part.join("part.json")).unwrap()).unwrap();
    assert_eq!(pj["format"], "gonio.replay/1");
    assert_eq!(pj["serial"], "SIM-4-0002");
    let (w, h) = (
        pj["width"].as_u64().unwrap(),
        pj["height"].as_u64().unwrap(),
    );
    let turns = pj["turns"].as_array().unwrap();
    assert!(!turns.is_empty());
    // The raw stream format of `detect --raw`: width × height bytes a frame, back to back.
    for t in turns {
        let raw = std::fs::metadata(part.join(t["raw"].as_str().unwrap())).unwrap();
        assert_eq!(raw.len(), t["frames"].as_u64().unwrap() * w * h);
    }
    // The record in the directory is the part's record in the batch's JSON.
    let b: Value = serde_json::from_str(&std::fs::read_to_string(&batch).unwrap()).unwrap();
    let from_batch = &b["parts"][1];
    assert_eq!(pj["record"]["serial"], from_batch["serial"]);
    assert_eq!(pj["record"]["turns"], from_batch["turns"]);
    assert_eq!(pj["record"]["final_e_um"], from_batch["final_e_um"]);

    // The replay: every frame's detector result and every turn bit-identical.
    let report = d.path().join("replay.json");
    let o = gonio(&["replay", &s(&rec), "--json", &s(&report)]);
    let (out, err) = text(&o);
    assert!(o.status.success(), "{out}{err}");
    assert!(
        out.contains("SIM-4-0002") && out.contains("identical to the record"),
        "{out}"
    );
    assert!(
        out.contains("1 part(s), ") && out.contains("bit-identical"),
        "{out}"
    );
    let r: Value = serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
    let rt = r[0]["turns"].as_array().unwrap();
    assert_eq!(rt.len(), turns.len());
    // Every frame of every turn replayed: as many as the record's turn took (258 for the
    // default recipe's full turn from rest, fewer for a 300° verify turn).
    let taken = pj["record"]["turns"].as_array().unwrap();
    assert_eq!(taken[0]["frames_taken"], 258);
    for (t, r) in rt.iter().zip(taken) {
        assert_eq!(t["frames"], r["frames_taken"]);
        assert_eq!(t["frames_differing"], 0);
        assert!(t["differences"].as_array().unwrap().is_empty());
    }

    // One angle of the first turn's log moved by 1 nanodegree: the replay says where.
    let tj = part.join("turn-1.json");
    let mut t: Value = serde_json::from_str(&std::fs::read_to_string(&tj).unwrap()).unwrap();
    let log = t["log"].as_array_mut().unwrap();
    for s in log.iter_mut() {
        let th = s["theta_deg"].as_f64().unwrap();
        s["theta_deg"] = Value::from(th + 1e-9);
    }
    std::fs::write(&tj, serde_json::to_string(&t).unwrap()).unwrap();
    let o = gonio(&["replay", &s(&part)]);
    let (out, err) = text(&o);
    assert_eq!(o.status.code(), Some(2), "{out}{err}");
    assert!(out.contains("DIFFERS from the record"), "{out}");
    assert!(out.contains("turn 1 sample 0 (θ, c)"), "{out}");
    assert!(
        err.contains("the replay differs from the record in 1 of 1 part(s)"),
        "{err}"
    );
    // Turns 2 and later are untouched: no difference listed for them.
    assert!(!out.contains("  turn 2 "), "{out}");
}

#[test]
fn recording_needs_frames_and_valid_part_numbers() {
    let d = tempfile::tempdir().unwrap();
    let rec = s(&d.path().join("rec"));
    for (args, want) in [
        (vec!["--record", &rec], "--record needs --fidelity frames"),
        (
            vec![
                "--fidelity",
                "frames",
                "--record",
                &rec,
                "--record-parts",
                "3,x",
            ],
            "--record-parts 3,x: \"x\" is not a part number",
        ),
        (
            vec![
                "--fidelity",
                "frames",
                "--record",
                &rec,
                "--record-parts",
                "26",
            ],
            "part 26 is not in the batch (1 to 25)",
        ),
    ] {
        let mut a = vec!["mount", "--sim", "--seed", "1"];
        a.extend(args);
        let o = gonio(&a);
        let (_, err) = text(&o);
        assert_eq!(o.status.code(), Some(2), "{a:?}: {err}");
        assert_eq!(err.lines().count(), 1, "{err}");
        assert!(err.contains(want), "{a:?}: {err}");
    }
    let o = gonio(&["replay", &s(d.path())]);
    let (_, err) = text(&o);
    assert_eq!(o.status.code(), Some(2));
    assert!(err.contains("no recorded part"), "{err}");
}
