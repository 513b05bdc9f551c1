//! Inputs said plainly: a TIFF of several pages is refused (not read as its first page); `-`
//! for two inputs is refused; self-calibration turns of unequal length are named as such;
//! `demo --out` writes into a directory that holds files only with `--force`; interrupted
//! simulations leave nothing behind.

mod common;

use common::{gonio, simulated_lab, stderr};
use std::io::Write;
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

fn s(p: &Path) -> String {
    p.display().to_string()
}

fn refused(o: &std::process::Output, says: &str) {
    let e = stderr(o);
    assert_eq!(o.status.code(), Some(2), "{e}");
    assert_eq!(e.lines().count(), 1, "{e}");
    assert!(e.contains(says), "{e}");
}

/// A 64 × 48 grey TIFF whose first image directory links to another page (itself: a second
/// page as far as a reader that follows the chain knows).
fn two_page_tiff() -> Vec<u8> {
    let img = image::GrayImage::from_fn(64, 48, |x, y| image::Luma([((x + y) % 256) as u8]));
    let mut bytes = Vec::new();
    img.write_to(
        &mut std::io::Cursor::new(&mut bytes),
        image::ImageFormat::Tiff,
    )
    .unwrap();
    assert_eq!(&bytes[..4], b"II*\0", "little-endian classic TIFF");
    let ifd = u32::from_le_bytes(bytes[4..8].try_into().unwrap()) as usize;
    let n = u16::from_le_bytes(bytes[ifd..ifd + 2].try_into().unwrap()) as usize;
    let next = ifd + 2 + 12 * n;
    assert_eq!(&bytes[next..next + 4], &[0, 0, 0, 0], "one page");
    bytes[next..next + 4].copy_from_slice(&(ifd as u32).to_le_bytes());
    bytes
}

#[test]
fn a_tiff_of_several_pages_is_refused() {
    let d = tempfile::tempdir().unwrap();
    let multi = d.path().join("stack.tif");
    std::fs::write(&multi, two_page_tiff()).unwrap();
    refused(&gonio(&["detect", &s(&multi)]), "several pages");
    // The same image with one page is read (whatever the detector finds in it).
    let one = d.path().join("one.tif");
    let mut b = two_page_tiff();
    let ifd = u32::from_le_bytes(b[4..8].try_into().unwrap()) as usize;
    let n = u16::from_le_bytes(b[ifd..ifd + 2].try_into().unwrap()) as usize;
    b[ifd + 2 + 12 * n..ifd + 6 + 12 * n].fill(0);
    std::fs::write(&one, b).unwrap();
    let o = gonio(&["detect", &s(&one)]);
    assert!(!stderr(&o).contains("several pages"), "{}", stderr(&o));
}

#[test]
fn standard_input_is_one_input_and_turns_have_one_length() {
    let d = tempfile::tempdir().unwrap();
    let (lab, _) = simulated_lab(d.path(), "3", &["--seed", "5"], &["--seed", "6"]);
    let cert = d.path().join("cal.json");
    let o = gonio(&["shift-angle", &s(&lab), "--json", &s(&cert)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let mut child = Command::new(env!("CARGO_BIN_EXE_gonio"))
        .args(["compare", "-", "-"])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let text = std::fs::read(&cert).unwrap();
    let mut stdin = child.stdin.take().unwrap();
    std::thread::spawn(move || {
        let _ = stdin.write_all(&text);
    });
    refused(
        &child.wait_with_output().unwrap(),
        "standard input is given for two inputs",
    );

    // Two turns, the second one row short: said as such.
    let sc = d.path().join("sc");
    let o = gonio(&[
        "simulate",
        "selfcal",
        "--heads",
        "eda:4",
        "--positions",
        "360",
        "--turns",
        "2",
        "--seed",
        "2",
        "--out",
        &s(&sc),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let readings = sc.join("readings.csv");
    let text = std::fs::read_to_string(&readings).unwrap();
    let mut lines: Vec<&str> = text.lines().collect();
    lines.pop();
    std::fs::write(&readings, lines.join("\n") + "\n").unwrap();
    refused(
        &gonio(&["selfcal", &s(&readings), "--heads", "eda:4"]),
        "turn 2 has 359 rows, turn 1 has 360",
    );
}

#[test]
fn demo_writes_into_a_directory_with_files_only_with_force() {
    let d = tempfile::tempdir().unwrap();
    std::fs::write(d.path().join("keep.txt"), "mine").unwrap();
    let t = Instant::now();
    refused(&gonio(&["demo", "--out", &s(d.path())]), "--force");
    // Refused before the work (the demo itself takes many seconds).
    assert!(t.elapsed() < Duration::from_secs(5), "{:?}", t.elapsed());
    assert_eq!(std::fs::read_dir(d.path()).unwrap().count(), 1);
}

/// Sends `signal` to a `gonio` started with `args` once `ready` holds (or after `after`), and
/// waits for it.
fn interrupt(args: &[&str], signal: &str, ready: impl Fn() -> bool) -> std::process::ExitStatus {
    let mut child = Command::new(env!("CARGO_BIN_EXE_gonio"))
        .args(args)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let t = Instant::now();
    while !ready() && t.elapsed() < Duration::from_secs(30) {
        if child.try_wait().unwrap().is_some() {
            break;
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    let _ = Command::new("kill")
        .args([signal, &child.id().to_string()])
        .status();
    let t = Instant::now();
    loop {
        if let Some(st) = child.try_wait().unwrap() {
            return st;
        }
        assert!(t.elapsed() < Duration::from_secs(30), "did not stop");
        std::thread::sleep(Duration::from_millis(10));
    }
}

#[test]
fn interrupted_simulations_and_recordings_leave_nothing_behind() {
    let d = tempfile::tempdir().unwrap();
    for (k, signal) in ["-INT", "-TERM"].iter().enumerate() {
        // simulate frames: the directory it created is removed again.
        let out = d.path().join(format!("frames{k}"));
        let o = s(&out);
        let st = interrupt(
            &[
                "simulate", "frames", "--count", "400", "--seed", "1", "--out", &o,
            ],
            signal,
            || out.exists(),
        );
        assert!(!st.success(), "{signal}: finished before the signal");
        assert!(!out.exists(), "{signal}: {o} left behind");

        // simulate selfcal, likewise.
        let out = d.path().join(format!("sc{k}"));
        let o = s(&out);
        let st = interrupt(
            &[
                "simulate",
                "selfcal",
                "--heads",
                "selfa12",
                "--positions",
                "200000",
                "--turns",
                "4",
                "--out",
                &o,
            ],
            signal,
            || out.exists(),
        );
        assert!(!st.success(), "{signal}: finished before the signal");
        assert!(!out.exists(), "{signal}: {o} left behind");

        // mount --record: no temporary part directory, and the record directory it made is
        // removed when it holds no part yet.
        let rec = d.path().join(format!("rec{k}"));
        let r = s(&rec);
        let st = interrupt(
            &[
                "mount",
                "--sim",
                "--seed",
                "1",
                "--parts",
                "3",
                "--fidelity",
                "frames",
                "--record",
                &r,
            ],
            signal,
            || {
                std::fs::read_dir(&rec).is_ok_and(|mut d| {
                    d.any(|e| {
                        e.is_ok_and(|e| e.file_name().to_string_lossy().starts_with(".part-"))
                    })
                })
            },
        );
        assert!(!st.success(), "{signal}: finished before the signal");
        let left: Vec<String> = std::fs::read_dir(&rec)
            .map(|d| {
                d.flatten()
                    .map(|e| e.file_name().to_string_lossy().into_owned())
                    .collect()
            })
            .unwrap_or_default();
        assert!(
            left.iter().all(|n| !n.starts_with('.')),
            "{signal}: {left:?} left in {r}"
        );
    }
}

#[test]
fn replay_reads_only_inside_its_record() {
    let d = tempfile::tempdir().unwrap();
    let rec = d.path().join("rec");
    let o = gonio(&[
        "mount",
        "--sim",
        "--parts",
        "1",
        "--fidelity",
        "frames",
        "--seed",
        "2",
        "--record",
        &s(&rec),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let part = rec.join("part-0001");
    let pj = part.join("part.json");
    let original = std::fs::read_to_string(&pj).unwrap();
    let v: serde_json::Value = serde_json::from_str(&original).unwrap();
    let data = v["turns"][0]["data"].as_str().unwrap().to_string();
    std::fs::copy(part.join(&data), d.path().join("outside.json")).unwrap();
    for (field, value, says) in [
        ("raw", "/etc/hostname", "inside the record"),
        ("data", "../../outside.json", "inside the record"),
        ("data", "", "inside the record"),
    ] {
        let mut w = v.clone();
        w["turns"][0][field] = value.into();
        std::fs::write(&pj, serde_json::to_string_pretty(&w).unwrap()).unwrap();
        let o = gonio(&["replay", &s(&rec)]);
        let e = stderr(&o);
        assert!(!o.status.success(), "{field} = {value}: {e}");
        assert!(e.contains(says), "{field} = {value}: {e}");
    }
    // A symbolic link inside the record that leads out of it.
    std::fs::write(&pj, &original).unwrap();
    std::fs::remove_file(part.join(&data)).unwrap();
    std::os::unix::fs::symlink(d.path().join("outside.json"), part.join(&data)).unwrap();
    let o = gonio(&["replay", &s(&rec)]);
    let e = stderr(&o);
    assert!(!o.status.success(), "{e}");
    assert!(e.contains("leads outside the record"), "{e}");
}

#[test]
fn limits_are_stated_and_enforced_before_work() {
    let d = tempfile::tempdir().unwrap();
    let db = s(&d.path().join("r.sqlite"));
    let t = Instant::now();
    for (args, says) in [
        (
            vec![
                "serve",
                "--db",
                &db,
                "--station",
                "sim",
                "--speed",
                "1e-300",
            ],
            "--speed",
        ),
        (
            vec!["serve", "--db", &db, "--station", "sim", "--speed", "1e300"],
            "--speed",
        ),
        (
            vec![
                "serve",
                "--db",
                &db,
                "--station",
                "sim",
                "--parts",
                "1000001",
            ],
            "'1000001' for '--parts <PARTS>': at most 1000000 parts",
        ),
        (
            vec!["mount", "--sim", "--parts", "1000001", "--seed", "1"],
            "'1000001' for '--parts <PARTS>': at most 1000000 parts",
        ),
    ] {
        refused(&gonio(&args), says);
    }
    let o = gonio(&["detect", "--threads", "4096", "x.png"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("--threads"), "{}", stderr(&o));
    // A readings file above the stated 256 MiB of every text input: refused by its size,
    // before reading (a sparse file: nothing is written).
    let big = d.path().join("big.csv");
    std::fs::File::create(&big)
        .unwrap()
        .set_len((256 << 20) + 1)
        .unwrap();
    refused(
        &gonio(&["selfcal", &s(&big), "--heads", "eda:4"]),
        "more than the limit of 268435456 bytes",
    );
    assert!(t.elapsed() < Duration::from_secs(20), "{:?}", t.elapsed());
    assert!(
        !Path::new(&db).exists(),
        "a refused serve created the store"
    );
}
