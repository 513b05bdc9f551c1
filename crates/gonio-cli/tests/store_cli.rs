//! The results store through the command line: a batch killed with SIGKILL mid-way and resumed
//! gives exactly the records of an uninterrupted run (no part lost, none duplicated, every
//! record identical but for its wall-clock times); `gonio parts` queries it.

mod common;

use common::gonio;
use gonio_store::PartQuery;
use serde_json::Value;
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// Standard output of a successful `gonio` run.
fn ok(args: &[&str]) -> String {
    common::ok(args).0
}

fn s(p: &Path) -> String {
    p.display().to_string()
}

/// `gonio parts --json` with the wall-clock times removed (they differ between two runs).
fn records(db: &str) -> Vec<Value> {
    let v: Value = serde_json::from_str(&ok(&["parts", "--db", db, "--json"])).unwrap();
    let mut parts = v.as_array().expect("a JSON array").clone();
    for p in &mut parts {
        let o = p.as_object_mut().unwrap();
        assert!(o.contains_key("part") && o.contains_key("final_e_um"));
        for k in ["started_at", "ended_at"] {
            assert!(o.remove(k).unwrap().as_str().unwrap().ends_with('Z'));
        }
    }
    parts
}

fn stored(db: &str) -> usize {
    // The dashboard's way: a second connection reading while the station writes.
    gonio_store::open(db)
        .and_then(|mut s| s.part_summaries(&PartQuery::default()))
        .map_or(0, |p| p.len())
}

#[test]
fn a_batch_killed_mid_way_and_resumed_equals_an_uninterrupted_one() {
    const PARTS: usize = 300;
    let d = tempfile::tempdir().unwrap();
    let (a, b) = (
        d.path().join("whole.sqlite"),
        d.path().join("killed.sqlite"),
    );
    let (a, b) = (s(&a), s(&b));
    let n = PARTS.to_string();
    let mount = |db: &str, extra: &[&str]| {
        let mut v = vec!["mount", "--sim", "--seed", "11", "--parts", &n, "--db", db];
        v.extend_from_slice(extra);
        v.into_iter().map(String::from).collect::<Vec<_>>()
    };
    ok(&mount(&a, &[])
        .iter()
        .map(String::as_str)
        .collect::<Vec<_>>());

    // The same batch, killed with SIGKILL once some parts are committed.
    let mut child = Command::new(env!("CARGO_BIN_EXE_gonio"))
        .args(mount(&b, &[]))
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let t0 = Instant::now();
    while stored(&b) < 40 {
        assert!(t0.elapsed() < Duration::from_secs(60), "no parts stored");
        assert!(
            child.try_wait().unwrap().is_none(),
            "finished before the kill"
        );
        std::thread::sleep(Duration::from_millis(2));
    }
    child.kill().unwrap(); // SIGKILL
    let status = child.wait().unwrap();
    assert!(!status.success(), "killed: {status:?}");
    let before = stored(&b);
    assert!(
        (40..PARTS).contains(&before),
        "killed mid-batch: {before} of {PARTS} parts stored"
    );

    // Resume: the same command with --resume.
    let o = gonio(
        &mount(&b, &["--resume"])
            .iter()
            .map(String::as_str)
            .collect::<Vec<_>>(),
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let msg = String::from_utf8_lossy(&o.stderr);
    assert!(
        msg.contains(&format!("at part {} of {PARTS}", before + 1)),
        "{msg}"
    );
    // Resuming a complete batch does nothing.
    let o = gonio(
        &mount(&b, &["--resume"])
            .iter()
            .map(String::as_str)
            .collect::<Vec<_>>(),
    );
    assert!(String::from_utf8_lossy(&o.stderr).contains("nothing to resume"));

    let (whole, resumed) = (records(&a), records(&b));
    assert_eq!(resumed.len(), PARTS, "no part lost, none duplicated");
    eprintln!(
        "SIGKILL after {before} of {PARTS} parts stored; resumed at part {}; {} records, each equal to the uninterrupted run's",
        before + 1,
        resumed.len()
    );
    for (i, (x, y)) in whole.iter().zip(&resumed).enumerate() {
        assert_eq!(y["batch_index"], i, "in order, once each");
        assert_eq!(y["serial"], format!("SIM-11-{:04}", i + 1));
        assert_eq!(x, y, "part {} differs after the resume", i + 1);
    }
    // A different seed is not the same batch: nothing to resume.
    let e = gonio(&[
        "mount", "--sim", "--seed", "12", "--parts", &n, "--db", &b, "--resume",
    ]);
    assert_eq!(e.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&e.stderr).contains("to resume: start it without --resume"));
}

#[test]
fn parts_filters_and_formats() {
    let d = tempfile::tempdir().unwrap();
    let db = s(&d.path().join("r.sqlite"));
    // A recipe whose threshold some parts miss within two pushes: passes and rejects.
    let recipe = d.path().join("tight.toml");
    std::fs::write(
        &recipe,
        "name = \"tight\"\nthreshold_um = 3.0\n[push]\nmax_pushes = 1\n",
    )
    .unwrap();
    ok(&[
        "mount",
        "--sim",
        "--seed",
        "5",
        "--parts",
        "12",
        "--db",
        &db,
        "--recipe",
        &s(&recipe),
        "--strategy",
        "learned",
    ]);
    let all: Value = serde_json::from_str(&ok(&["parts", "--db", &db, "--json"])).unwrap();
    let all = all.as_array().unwrap();
    assert_eq!(all.len(), 12);
    let rejects = all.iter().filter(|p| p["verdict"] == "reject").count();
    assert!(rejects > 0 && rejects < 12, "{rejects} rejects");
    let rej: Value = serde_json::from_str(&ok(&[
        "parts",
        "--db",
        &db,
        "--verdict",
        "reject",
        "--json",
    ]))
    .unwrap();
    assert_eq!(rej.as_array().unwrap().len(), rejects);
    for p in rej.as_array().unwrap() {
        assert!(p["reject_reason"].as_str().is_some_and(|r| !r.is_empty()));
        assert_eq!(p["recipe"], "tight");
        // Every turn with its frame counts, fit, focus and samples; every push with its stroke
        // and duration.
        let t = &p["turns"][0];
        for k in [
            "frames_taken",
            "valid_frames",
            "e_um",
            "theta_max_deg",
            "residual_rms_px",
            "focus_um",
            "samples",
        ] {
            assert!(!t[k].is_null(), "turn field {k}");
        }
        let q = &p["push_log"][0];
        for k in ["e_before_um", "e_after_um", "commanded_um", "duration_s"] {
            assert!(q[k].as_f64().is_some(), "push field {k}: {q}");
        }
    }
    let csv = ok(&["parts", "--db", &db, "--csv"]);
    assert!(csv.starts_with("part,serial,station,batch,batch_index"));
    assert_eq!(csv.lines().count(), 13);
    let out = d.path().join("p.json");
    ok(&[
        "parts",
        "--db",
        &db,
        "--json",
        "--limit",
        "3",
        "--out",
        &s(&out),
    ]);
    let last: Value = serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    assert_eq!(last[0]["serial"], "SIM-5-0010");
    let none = ok(&["parts", "--db", &db, "--since", "2999-01-01", "--json"]);
    assert_eq!(none.trim(), "[]");
    let e = gonio(&["parts", "--db", &db, "--verdict", "lost"]);
    assert_eq!(e.status.code(), Some(2));
    let msg = String::from_utf8_lossy(&e.stderr);
    assert_eq!(msg.lines().count(), 1, "{msg}");
    assert!(msg.contains("expected pass, reject"), "{msg}");
}
