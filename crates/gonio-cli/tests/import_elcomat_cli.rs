//! `gonio import elcomat`: simulated and hand-written autocollimator logs into readings CSVs.

mod common;

use common::{gonio, stderr};
use std::path::Path;
use std::process::Command;

/// The file without its `#` comment lines.
fn data(p: &Path) -> String {
    std::fs::read_to_string(p)
        .unwrap()
        .lines()
        .filter(|l| !l.starts_with('#'))
        .map(|l| format!("{l}\n"))
        .collect()
}

#[test]
fn simulated_log_imports_to_the_simulators_readings() {
    let d = tempfile::tempdir().unwrap();
    for (k, extra) in [
        vec!["--shifts", "0:1:14", "--rows", "seed"],
        vec![
            "--faces",
            "12",
            "--shifts",
            "0,10,20",
            "--rows",
            "full",
            "--repeats",
            "2",
            "--elcomat-mode",
            "relative",
        ],
    ]
    .into_iter()
    .enumerate()
    {
        let lab = d.path().join(format!("lab{k}"));
        let log = lab.join("elcomat.log");
        let mut args = vec![
            "simulate",
            "shift-angle",
            "--seed",
            "5",
            "--out",
            lab.to_str().unwrap(),
            "--elcomat-log",
            log.to_str().unwrap(),
        ];
        args.extend(extra);
        let o = gonio(&args);
        assert!(o.status.success(), "{}", stderr(&o));
        let out = lab.join("imported.csv");
        let o = gonio(&[
            "import",
            "elcomat",
            log.to_str().unwrap(),
            "--plan",
            lab.join("plan.toml").to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
        let want = data(&lab.join("readings.csv"));
        assert!(want.lines().count() > 100);
        assert_eq!(data(&out), want, "case {k}");
    }
}

#[test]
fn realistic_log_variations_follow_the_plan() {
    let d = tempfile::tempdir().unwrap();
    // 3 faces, shift 0° with runs from faces 2 and 1 (in that order), steps nested inside
    // repeats, a closure reading after step 3, X counted the other way.
    let plan = "faces = 3\nshifts_deg = [0]\nstart_faces = [2, 1]\nrepeats = 2\n\
                order = [\"shift\", \"start_face\", \"repeat\", \"step\"]\nclosure = true\n\
                x_sign = -1\nmode = \"relative\"\n";
    // CR LF, CR and LF endings, a logger's header, tabs, a detached sign, leading zeros, '+'.
    let log = "# COM3 9600 8N1\r\n2 103 +0001.250 +0.010\r\n2 103 -0.5 0.0\r2\t103\t+ 0.25\t-0.1\n\
               2 103  1.00 0.00\r\n\
               2 103 +1.255 0\r2 103 -0.505 0\r2 103 +0.245 0\r2 103 +1.003 0\r\n\
               2 103 0.100 0\r2 103 0.200 0\r2 103 0.300 0\r2 103 0.110 0\r\
               2 103 0.101 0\r2 103 0.201 0\r2 103 0.301 0\r2 103 0.111 0\r";
    std::fs::write(d.path().join("plan.toml"), plan).unwrap();
    std::fs::write(d.path().join("run.log"), log).unwrap();
    let out = d.path().join("r.csv");
    let o = gonio(&[
        "import",
        "elcomat",
        d.path().join("run.log").to_str().unwrap(),
        "--plan",
        d.path().join("plan.toml").to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let want = "shift_deg,start_face,step,repeat,reading_arcsec\n\
                0,2,1,1,-1.250\n0,2,2,1,0.5\n0,2,3,1,-0.25\n0,2,1,3,-1.00\n\
                0,2,1,2,-1.255\n0,2,2,2,0.505\n0,2,3,2,-0.245\n0,2,1,4,-1.003\n\
                0,1,1,1,-0.100\n0,1,2,1,-0.200\n0,1,3,1,-0.300\n0,1,1,3,-0.110\n\
                0,1,1,2,-0.101\n0,1,2,2,-0.201\n0,1,3,2,-0.301\n0,1,1,4,-0.111\n";
    assert_eq!(data(&out), want);
}

/// Runs the import on `log` with `plan`; returns (exit code, stderr).
fn import(dir: &Path, log: &str, plan: &str) -> (i32, String) {
    std::fs::write(dir.join("p.toml"), plan).unwrap();
    std::fs::write(dir.join("x.log"), log).unwrap();
    let o = Command::new(env!("CARGO_BIN_EXE_gonio"))
        .current_dir(dir)
        .args([
            "import", "elcomat", "x.log", "--plan", "p.toml", "--out", "o.csv",
        ])
        .output()
        .unwrap();
    (o.status.code().unwrap_or(-1), stderr(&o))
}

#[test]
fn bad_lines_and_wrong_counts_are_errors_naming_the_line() {
    let d = tempfile::tempdir().unwrap();
    let plan = "faces = 3\nshifts_deg = [0]\nstart_faces = [1]\n";
    let (code, e) = import(d.path(), "4 003 1 0\r4 011 2 0\r4 003 3 0\r", plan);
    assert_eq!(code, 2);
    assert!(e.contains("x.log:2:1: status `4 011`"), "{e}");
    let (code, e) = import(d.path(), "4 003 1 0\r\nERR 7\r\n4 003 3 0\r\n", plan);
    assert_eq!(code, 2);
    assert!(e.contains("x.log:2:"), "{e}");
    let (code, e) = import(d.path(), "4 003 1 0\r4 003 2 0\r", plan);
    assert_eq!(code, 2);
    assert!(
        e.contains("x.log: 2 readings, the plan p.toml expects 3"),
        "{e}"
    );
    assert!(
        e.contains("next planned reading is shift 0°, start face 1, step 3"),
        "{e}"
    );
    let (code, e) = import(
        d.path(),
        "4 003 1 0\r4 003 2 0\r4 003 3 0\r4 003 4 0\r",
        plan,
    );
    assert_eq!(code, 2);
    assert!(
        e.contains("x.log:4:1: reading 4 is beyond the plan's 3 readings"),
        "{e}"
    );
    let (code, e) = import(d.path(), "4 003 1 0\r2 103 2 0\r4 003 3 0\r", plan);
    assert_eq!(code, 2);
    assert!(
        e.contains("x.log:2:1: a relative reading, expected absolute"),
        "{e}"
    );
    let (code, e) = import(
        d.path(),
        "4 003 1 0\r",
        "faces = 3\nshifts_deg = [0]\nrepeats = 0\n",
    );
    assert_eq!(code, 2);
    assert!(e.contains("p.toml:3:11: repeats = 0"), "{e}");
    // Line noise on the serial link (a byte that is not UTF-8) is named, not skipped.
    std::fs::write(d.path().join("p.toml"), plan).unwrap();
    std::fs::write(
        d.path().join("x.log"),
        b"4 003 1 0\r4 003 \xff2 0\r4 003 3 0\r",
    )
    .unwrap();
    let o = Command::new(env!("CARGO_BIN_EXE_gonio"))
        .current_dir(d.path())
        .args([
            "import", "elcomat", "x.log", "--plan", "p.toml", "--out", "o.csv",
        ])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("x.log:2:7: X"), "{}", stderr(&o));
}
