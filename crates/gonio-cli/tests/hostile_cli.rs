//! Hostile inputs through the binary (issue 13), one test per class: sizes from the input
//! (limits checked before allocating), outputs that cannot destroy (same file, device, symlink,
//! duplicate paths, a failing second output, umask, signals, stale simulation outputs), terminal
//! output (closed pipe, full disk), finite results, helpful messages. Every input is generated
//! here; none is large.

mod common;

use common::{gonio, stderr as err};
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_gonio"))
}

/// A refused run: exit code 2, one line `error: …` of at most 500 characters containing `want`.
#[track_caller]
fn refused(o: &Output, want: &str) -> String {
    let e = err(o);
    assert_eq!(o.status.code(), Some(2), "{e}");
    assert_eq!(e.lines().count(), 1, "{e}");
    assert!(e.starts_with("error: "), "{e}");
    assert!(e.chars().count() <= 510, "{} chars", e.chars().count());
    assert!(e.contains(want), "expected {want:?} in {e}");
    e
}

/// A small readings file (6 faces, 2 shifts, full matrices) in `dir`.
fn readings(dir: &Path) -> PathBuf {
    let out = dir.join("sim");
    let o = gonio(&[
        "simulate",
        "shift-angle",
        "--faces",
        "6",
        "--shifts",
        "0,5",
        "--rows",
        "full",
        "--seed",
        "3",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", err(&o));
    out.join("readings.csv")
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

fn files_in(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

// ---- 1. Sizes from the input -------------------------------------------------------------

#[test]
fn sizes_from_the_input_have_stated_limits() {
    let d = tempfile::tempdir().unwrap();
    let p = d.path().join("r.csv");
    std::fs::write(
        &p,
        "shift_deg,start_face,step,reading_arcsec\n0,1,1,0.5\n0,1,100000,0.1\n",
    )
    .unwrap();
    let e = refused(&gonio(&["shift-angle", s(&p)]), ":3:3: column 'step'");
    assert!(
        e.contains("step 100000 implies a 100000-face polygon; at most 1000 faces"),
        "{e}"
    );
    refused(
        &gonio(&["shift-angle", s(&p), "--faces", "0"]),
        "'0' for '--faces <FACES>': at least 3 faces",
    );
    refused(
        &gonio(&["shift-angle", s(&p), "--faces", "1000000000"]),
        "'1000000000' for '--faces <FACES>': at most 1000 faces",
    );
    for parts in ["1000000000", "18446744073709551615"] {
        refused(
            &gonio(&["mount", "--sim", "--seed", "1", "--parts", parts]),
            "at most 1000000 parts",
        );
    }
    let out = d.path().join("x");
    refused(
        &gonio(&[
            "simulate",
            "selfcal",
            "--heads",
            "eda:4",
            "--positions",
            "36000",
            "--turns",
            "1000000",
            "--out",
            s(&out),
        ]),
        "positions × turns × heads",
    );
    refused(
        &gonio(&[
            "simulate",
            "frames",
            "--count",
            "100000000",
            "--seed",
            "1",
            "--out",
            s(&out),
        ]),
        "'100000000' for '--count <COUNT>': at most 1000000 frames",
    );
    refused(
        &gonio(&[
            "simulate",
            "encoder",
            "--lines",
            "4000000000",
            "--out",
            s(&d.path().join("e.json")),
        ]),
        "lines",
    );
    refused(
        &gonio(&[
            "simulate",
            "selfcal",
            "--heads",
            "eda:1000000000",
            "--out",
            s(&out),
        ]),
        "eda:N with N from 2 to 360",
    );
    refused(
        &gonio(&[
            "simulate",
            "shift-angle",
            "--shifts",
            "0:1e-300:1",
            "--out",
            s(&out),
        ]),
        "at most 100000 shifts",
    );
    // Recipe sizes: frames per turn, focus steps.
    let r = d.path().join("r.toml");
    std::fs::write(&r, "[measure]\nfps = 1e12\nexposure_s = 1e-13\n").unwrap();
    refused(
        &gonio(&["mount", "--sim", "--seed", "1", "--recipe", s(&r)]),
        "r.toml:2:1: measure.fps",
    );
    std::fs::write(&r, "[focus]\nsteps = 4000000000\n").unwrap();
    refused(
        &gonio(&["mount", "--sim", "--seed", "1", "--recipe", s(&r)]),
        "r.toml:2:1: focus.steps",
    );
    // A heads file of 100,000 heads.
    let h = d.path().join("h.toml");
    let angles: Vec<String> = (0..100_000)
        .map(|k| format!("{}", k as f64 * 0.0036))
        .collect();
    std::fs::write(&h, format!("angles_deg = [{}]\n", angles.join(","))).unwrap();
    refused(
        &gonio(&["simulate", "selfcal", "--heads", s(&h), "--out", s(&out)]),
        "100000 heads, at most 360",
    );
    assert!(!out.exists(), "a refused simulation leaves no directory");
    // A scene file with a billion dust specks per frame, and one with a million scratches.
    let sc = d.path().join("scene.toml");
    std::fs::write(&sc, "read_noise_grey = 3.0\ndust_per_frame = 1000000000\n").unwrap();
    refused(
        &gonio(&[
            "simulate",
            "frames",
            "--count",
            "1",
            "--scene-file",
            s(&sc),
            "--seed",
            "1",
            "--out",
            s(&out),
        ]),
        "scene.toml:2:1: ",
    );
    let scratches = "[[scratches]]\nx_px = 1.0\ny_px = 1.0\nangle_deg = 0.0\nwidth_px = 1.0\ndepth_grey = 9.0\n"
        .repeat(20_000);
    std::fs::write(&sc, scratches).unwrap();
    refused(
        &gonio(&[
            "mount",
            "--sim",
            "--seed",
            "1",
            "--fidelity",
            "frames",
            "--scene-file",
            s(&sc),
        ]),
        "scratches",
    );
}

#[test]
fn dust_and_defocus_do_not_hang() {
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("f");
    refused(
        &gonio(&[
            "simulate",
            "frames",
            "--count",
            "1",
            "--dust",
            "1000000000",
            "--seed",
            "1",
            "--out",
            s(&out),
        ]),
        "'1000000000' for '--dust <DUST>': at most 10000",
    );
    // A defocus whose blur is far wider than the frame costs one frame, not the blur's extent.
    let t = Instant::now();
    let o = gonio(&[
        "simulate",
        "frames",
        "--count",
        "1",
        "--dust",
        "40",
        "--defocus",
        "1e6",
        "--seed",
        "1",
        "--out",
        s(&out),
    ]);
    assert!(o.status.success(), "{}", err(&o));
    assert!(t.elapsed() < Duration::from_secs(60), "{:?}", t.elapsed());
    refused(
        &gonio(&[
            "simulate",
            "frames",
            "--count",
            "1",
            "--defocus",
            "1e12",
            "--seed",
            "1",
            "--out",
            s(&d.path().join("g")),
        ]),
        "'1e12' for '--defocus <DEFOCUS>': at most 1000000 µm",
    );
}

// ---- 2. Outputs that cannot destroy ------------------------------------------------------

#[test]
fn an_output_that_is_an_input_is_refused() {
    let d = tempfile::tempdir().unwrap();
    let r = readings(d.path());
    let before = std::fs::read(&r).unwrap();
    refused(
        &gonio(&["shift-angle", s(&r), "--json", s(&r)]),
        "is also an input of this command",
    );
    // Another name of the same file: a hard link, and a path through `..`.
    let link = d.path().join("link.csv");
    std::fs::hard_link(&r, &link).unwrap();
    refused(
        &gonio(&["shift-angle", s(&r), "--compensation", s(&link)]),
        "is also an input",
    );
    let dotted = r.parent().unwrap().join("../sim/readings.csv");
    refused(
        &gonio(&["shift-angle", s(&r), "--json", s(&dotted)]),
        "is also an input",
    );
    assert_eq!(std::fs::read(&r).unwrap(), before, "the input is intact");
    // A certificate compared with itself, written over itself.
    let cert = d.path().join("c.json");
    assert!(
        gonio(&["shift-angle", s(&r), "--json", s(&cert)])
            .status
            .success()
    );
    refused(
        &gonio(&["compare", s(&cert), s(&cert), "--json", s(&cert)]),
        "is also an input",
    );
    // A frame written over by detect's JSON lines.
    let frames = d.path().join("frames");
    let o = gonio(&[
        "simulate",
        "frames",
        "--count",
        "1",
        "--seed",
        "1",
        "--out",
        s(&frames),
    ]);
    assert!(o.status.success(), "{}", err(&o));
    let png = frames.join("frame_00000.png");
    let png_before = std::fs::read(&png).unwrap();
    refused(
        &gonio(&["detect", s(&png), "--json-lines", s(&png)]),
        "is also an input",
    );
    assert_eq!(std::fs::read(&png).unwrap(), png_before);
    assert_eq!(
        files_in(&frames),
        ["angles.csv", "frame_00000.png", "truth.json"]
    );
}

#[test]
fn devices_directories_symlinks_and_duplicate_outputs_are_refused() {
    let d = tempfile::tempdir().unwrap();
    let r = readings(d.path());
    // /dev/null is refused, never replaced (as root a rename would replace the device node).
    refused(
        &gonio(&["shift-angle", s(&r), "--json", "/dev/null"]),
        "is a device",
    );
    let m = std::fs::metadata("/dev/null").unwrap();
    assert!(std::os::unix::fs::FileTypeExt::is_char_device(
        &m.file_type()
    ));
    refused(
        &gonio(&["shift-angle", s(&r), "--json", s(d.path())]),
        "is a directory",
    );
    let target = d.path().join("t.json");
    std::fs::write(&target, "keep").unwrap();
    let link = d.path().join("l.json");
    std::os::unix::fs::symlink(&target, &link).unwrap();
    refused(
        &gonio(&["shift-angle", s(&r), "--json", s(&link)]),
        "is a symbolic link",
    );
    assert_eq!(std::fs::read_to_string(&target).unwrap(), "keep");
    let x = d.path().join("x");
    refused(
        &gonio(&[
            "shift-angle",
            s(&r),
            "--json",
            s(&x),
            "--compensation",
            s(&x),
        ]),
        "the same file as --json",
    );
    refused(
        &gonio(&["shift-angle", s(&r), "--json", "-", "--compensation", "-"]),
        "two outputs to standard output",
    );
    assert!(!x.exists());
}

#[test]
fn outputs_are_written_as_a_set_with_the_umask() {
    let d = tempfile::tempdir().unwrap();
    let r = readings(d.path());
    let json = d.path().join("cal.json");
    let missing = d.path().join("no/such/dir/comp.csv");
    let e = refused(
        &gonio(&[
            "shift-angle",
            s(&r),
            "--json",
            s(&json),
            "--compensation",
            s(&missing),
        ]),
        "comp.csv",
    );
    assert!(
        !e.contains(".gonio-"),
        "names the user's path, not the temp file: {e}"
    );
    assert!(!json.exists(), "no --json without its --compensation");
    // The umask decides the mode (was 0600 whatever the umask).
    let comp = d.path().join("comp.csv");
    for (mask, mode) in [("022", 0o644), ("077", 0o600), ("002", 0o664)] {
        let o = Command::new("sh")
            .arg("-c")
            .arg(format!(
                "umask {mask}; exec \"$0\" shift-angle \"$1\" --json \"$2\" --compensation \"$3\""
            ))
            .arg(env!("CARGO_BIN_EXE_gonio"))
            .args([s(&r), s(&json), s(&comp)])
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", err(&o));
        for p in [&json, &comp] {
            let m = std::os::unix::fs::PermissionsExt::mode(
                &std::fs::metadata(p).unwrap().permissions(),
            );
            assert_eq!(m & 0o777, mode, "umask {mask}: {}", p.display());
        }
    }
    let leftovers: Vec<String> = files_in(d.path())
        .into_iter()
        .filter(|f| f.starts_with(".gonio-"))
        .collect();
    assert!(leftovers.is_empty(), "{leftovers:?}");
}

#[test]
fn simulations_refuse_a_non_empty_directory_and_force_removes_stale_frames() {
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("frames");
    let run = |count: &str, force: bool| {
        let mut a = vec![
            "simulate",
            "frames",
            "--count",
            count,
            "--seed",
            "2",
            "--out",
            s(&out),
        ];
        if force {
            a.push("--force");
        }
        gonio(&a)
    };
    assert!(run("3", false).status.success());
    refused(&run("2", false), "the directory is not empty");
    assert!(run("2", true).status.success());
    assert_eq!(
        files_in(&out),
        [
            "angles.csv",
            "frame_00000.png",
            "frame_00001.png",
            "truth.json"
        ],
        "the third frame of the earlier run is gone"
    );
}

#[test]
fn sigterm_mid_simulation_leaves_the_old_set_and_no_temp_file() {
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("frames");
    assert!(
        gonio(&[
            "simulate",
            "frames",
            "--count",
            "2",
            "--seed",
            "1",
            "--out",
            s(&out)
        ])
        .status
        .success()
    );
    let before = files_in(&out);
    let truth_before = std::fs::read(out.join("truth.json")).unwrap();
    let mut child = bin()
        .args([
            "simulate",
            "frames",
            "--count",
            "100000",
            "--seed",
            "9",
            "--force",
            "--out",
            s(&out),
        ])
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    // Wait until the run has temporary frames on disk, then stop it.
    let t = Instant::now();
    while files_in(&out)
        .iter()
        .filter(|f| f.starts_with(".gonio-"))
        .count()
        < 5
    {
        assert!(t.elapsed() < Duration::from_secs(60), "no progress");
        std::thread::sleep(Duration::from_millis(20));
    }
    let kill = Command::new("kill")
        .args(["-TERM", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(kill.success());
    let status = child.wait().unwrap();
    assert_eq!(status.code(), Some(128 + 15), "{status:?}");
    assert_eq!(files_in(&out), before, "old set intact, no temp file");
    assert_eq!(std::fs::read(out.join("truth.json")).unwrap(), truth_before);
}

// ---- 3. Terminal output ------------------------------------------------------------------

#[test]
fn a_closed_pipe_ends_quietly_and_a_full_disk_is_an_error() {
    let budget = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../examples/budgets/hsieh2022-shift-angle.toml"
    );
    let mut child = bin()
        .args(["budget", budget])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take()); // the reader goes away before gonio writes (`| head -0`)
    let o = child.wait_with_output().unwrap();
    assert_eq!(o.status.code(), Some(0), "{}", err(&o));
    assert!(err(&o).is_empty(), "{}", err(&o));
    // Files are still written when standard output is gone.
    let d = tempfile::tempdir().unwrap();
    let json = d.path().join("b.json");
    let mut child = bin()
        .args(["budget", budget, "--json", s(&json)])
        .stdout(Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take());
    assert!(child.wait().unwrap().success());
    assert!(json.exists());
    // A full disk.
    let full = std::fs::OpenOptions::new()
        .write(true)
        .open("/dev/full")
        .unwrap();
    let o = bin()
        .args(["budget", budget])
        .stdout(full)
        .output()
        .unwrap();
    refused(&o, "cannot write standard output: No space left on device");
}

// ---- 4. Finite in, finite out ------------------------------------------------------------

#[test]
fn overflowing_results_are_errors_naming_what_overflowed() {
    let d = tempfile::tempdir().unwrap();
    let p = d.path().join("turn.csv");
    let mut text = String::from("theta_deg,c_px\n");
    for i in 0..100 {
        let t = 3.6 * i as f64;
        text += &format!("{t},{}\n", 700.0 + 10.0 * t.to_radians().cos());
    }
    std::fs::write(&p, text).unwrap();
    let json = d.path().join("e.json");
    refused(
        &gonio(&[
            "eccentricity",
            s(&p),
            "--um-per-px",
            "1e308",
            "--json",
            s(&json),
        ]),
        // The scale that made e_um overflow is refused by its bound before the fit.
        "'1e308' for '--um-per-px <UM_PER_PX>': at most 1000 µm/px",
    );
    assert!(!json.exists());
    // A reading of 1e308: the least squares overflow is an error, not U = inf with exit code 0.
    let r = readings(d.path());
    let text = std::fs::read_to_string(&r).unwrap();
    let bad: String = text
        .lines()
        .enumerate()
        .map(|(i, l)| {
            if i == 3 {
                let mut f: Vec<&str> = l.split(',').collect();
                *f.last_mut().unwrap() = "1e308";
                f.join(",") + "\n"
            } else {
                format!("{l}\n")
            }
        })
        .collect();
    std::fs::write(&r, bad).unwrap();
    let o = gonio(&["shift-angle", s(&r), "--json", s(&json)]);
    refused(&o, "readings.csv");
    assert!(!json.exists());
    // Duplicate shifts are refused before a file is written that shift-angle would refuse.
    refused(
        &gonio(&[
            "simulate",
            "shift-angle",
            "--shifts",
            "0,0,5",
            "--out",
            s(&d.path().join("dup")),
        ]),
        "0° is given twice",
    );
    // Recipe and optics values range-checked with the key named.
    let rc = d.path().join("r.toml");
    std::fs::write(&rc, "name = \"x\"\n[fit]\nhuber_k = 0.0\n").unwrap();
    refused(
        &gonio(&["eccentricity", s(&p), "--recipe", s(&rc)]),
        "r.toml:3:1: fit.huber_k = 0",
    );
    let op = d.path().join("o.toml");
    std::fs::write(&op, "pixel_pitch_um = 3.45\n\nmagnification = -1.0\n").unwrap();
    refused(
        &gonio(&["detect", "--raw", "1440x540", "--optics", s(&op)]),
        "o.toml:3:1: magnification = -1",
    );
}

// ---- 5. Helpful messages -----------------------------------------------------------------

#[test]
fn messages_locate_and_hint() {
    let d = tempfile::tempdir().unwrap();
    let p = d.path().join("r.csv");
    // Latin-1 on line 3.
    std::fs::write(
        &p,
        b"shift_deg,start_face,step,reading_arcsec\n0,1,1,0.5\n# Messung \xFCber Nacht\n"
            .as_slice(),
    )
    .unwrap();
    refused(
        &gonio(&["shift-angle", s(&p)]),
        "r.csv:3:11: invalid UTF-8 (byte 0xFC)",
    );
    // A BOM before a comment: the header is still the header.
    std::fs::write(
        &p,
        "\u{feff}# readings\nshift_deg,start_face,step,reading_arcsec\n0,1,x,0.5\n",
    )
    .unwrap();
    refused(&gonio(&["shift-angle", s(&p)]), "r.csv:3:3: column 'step'");
    // A `;` separator and a decimal comma.
    std::fs::write(&p, "shift_deg;start_face;step;reading_arcsec\n0;1;1;0,5\n").unwrap();
    refused(&gonio(&["shift-angle", s(&p)]), "`;`");
    std::fs::write(&p, "shift_deg,start_face,step,reading_arcsec\n0,1,1,0,5\n").unwrap();
    refused(&gonio(&["shift-angle", s(&p)]), "decimal comma");
    // A recipe value the file does not set is named as a default, never at line 0.
    let r = d.path().join("r.toml");
    // (A 540-row window: the camera's 100 fps, below the default 240 fps.)
    std::fs::write(&r, "window_px = [1440, 540]\n").unwrap();
    let e = refused(
        &gonio(&["mount", "--sim", "--seed", "1", "--recipe", s(&r)]),
        "r.toml: measure.fps = 240 (the default",
    );
    assert!(!e.contains("line 0") && !e.contains(":0:0"), "{e}");
    // An error that would echo a megabyte stays one short line.
    std::fs::write(
        &p,
        format!(
            "shift_deg,start_face,step,reading_arcsec\n0,1,1,{}\n",
            "9".repeat(1 << 20) + "x"
        ),
    )
    .unwrap();
    refused(&gonio(&["shift-angle", s(&p)]), "r.csv:2:4");
}
