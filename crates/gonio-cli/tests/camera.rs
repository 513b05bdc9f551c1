//! The camera commands end to end (`gonio camera list`, `gonio detect --camera`, `gonio simulate
//! camera`), against Aravis's own fake GigE Vision camera and against gonio's. Every test that
//! starts a camera re-runs itself in its own network namespace (`unshare -n`, loopback up): one
//! GigE Vision camera per address, and other engineers run camera tests on this machine at the
//! same time. Built without `--features genicam`, one test checks the clear error instead and the
//! others are ignored, saying what they need (`.ci/cam.sh` runs them with the feature).

use std::process::{Child, Command, Output, Stdio};
use std::time::{Duration, Instant};

fn gonio() -> Command {
    Command::new(env!("CARGO_BIN_EXE_gonio"))
}

#[cfg(not(feature = "genicam"))]
#[test]
fn without_the_feature_the_camera_commands_say_how_to_build_them() {
    for args in [
        vec!["camera", "list"],
        vec!["detect", "--camera", "X", "--frames", "3"],
        vec!["simulate", "camera", "--duration-s", "1"],
    ] {
        let out = gonio().args(&args).output().unwrap();
        assert_eq!(out.status.code(), Some(2), "{args:?}");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains("--features genicam"), "{args:?}: {err}");
        assert_eq!(err.lines().count(), 1, "{err}");
        assert!(out.stdout.is_empty());
    }
}

/// Set in the child that runs inside the namespace.
const INSIDE: &str = "GONIO_CAMERA_TEST_NETNS";

/// Runs the test `name` again inside a new network namespace; true in the child (go on), false
/// in the parent (the child's verdict has been asserted).
#[allow(dead_code)]
fn in_own_netns(name: &str) -> bool {
    if std::env::var_os(INSIDE).is_some() {
        return true;
    }
    let exe = std::env::current_exe().expect("test executable");
    let out = Command::new("timeout")
        .args(["-k", "5", "240", "unshare", "-n", "--", "sh", "-c"])
        .arg("ip link set lo up && exec \"$0\" \"$@\"")
        .arg(exe)
        .args([name, "--exact", "--nocapture", "--test-threads=1"])
        .env(INSIDE, "1")
        .output()
        .expect("run unshare -n (util-linux) for the camera test");
    let stdout = String::from_utf8_lossy(&out.stdout);
    let stderr = String::from_utf8_lossy(&out.stderr);
    println!("--- {name} in its own network namespace ---\n{stdout}\n{stderr}");
    assert!(
        out.status.success(),
        "{name} failed in its namespace ({})",
        out.status
    );
    assert!(
        stdout.contains("1 passed"),
        "{name} did not run in its namespace"
    );
    false
}

/// A child process killed when dropped.
struct Killed(Child);

impl Drop for Killed {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// `arv-fake-gv-camera-0.8 -i 127.0.0.1 -s SERIAL [extra]`.
#[allow(dead_code)]
fn aravis_fake(serial: &str, extra: &[&str]) -> Killed {
    let c = Command::new("arv-fake-gv-camera-0.8")
        .args(["-i", "127.0.0.1", "-s", serial])
        .args(extra)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .expect("arv-fake-gv-camera-0.8 (aravis-tools) must be installed");
    std::thread::sleep(Duration::from_millis(300));
    Killed(c)
}

/// `gonio camera list --json` until `id` shows (at most 10 s).
#[allow(dead_code)]
fn wait_listed(id: &str) -> serde_json::Value {
    let t0 = Instant::now();
    loop {
        let out = gonio().args(["camera", "list", "--json"]).output().unwrap();
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        if v.as_array().unwrap().iter().any(|c| c["id"] == id) {
            return v;
        }
        assert!(
            t0.elapsed() < Duration::from_secs(10),
            "{id} not listed: {v}"
        );
    }
}

#[allow(dead_code)]
fn lines(out: &Output) -> Vec<serde_json::Value> {
    String::from_utf8_lossy(&out.stdout)
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect()
}

#[test]
#[cfg_attr(
    not(feature = "genicam"),
    ignore = "needs the genicam feature (libaravis, arv-fake-gv-camera-0.8): .ci/cam.sh"
)]
fn camera_list_json_shows_aravis_fake_camera() {
    if !in_own_netns("camera_list_json_shows_aravis_fake_camera") {
        return;
    }
    let _cam = aravis_fake("LISTCLI", &[]);
    let v = wait_listed("Aravis-Fake-LISTCLI");
    let c = v
        .as_array()
        .unwrap()
        .iter()
        .find(|c| c["id"] == "Aravis-Fake-LISTCLI")
        .unwrap();
    assert_eq!(c["vendor"], "Aravis");
    assert_eq!(c["model"], "Fake");
    assert_eq!(c["serial"], "LISTCLI");
    assert_eq!(c["address"], "127.0.0.1");
    assert_eq!(c["protocol"], "GigEVision");
}

#[test]
#[cfg_attr(
    not(feature = "genicam"),
    ignore = "needs the genicam feature (libaravis, arv-fake-gv-camera-0.8): .ci/cam.sh"
)]
fn detect_forty_frames_from_aravis_fake_camera() {
    if !in_own_netns("detect_forty_frames_from_aravis_fake_camera") {
        return;
    }
    let _cam = aravis_fake("D40", &[]);
    wait_listed("Aravis-Fake-D40");
    let out = gonio()
        .args(["detect", "--camera", "Aravis-Fake-D40", "--frames", "40"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    println!("{err}");
    assert!(out.status.success(), "{err}");
    let l = lines(&out);
    assert_eq!(l.len(), 40);
    for w in l.windows(2) {
        assert!(w[1]["frame_id"].as_u64().unwrap() > w[0]["frame_id"].as_u64().unwrap());
        assert!(w[1]["timestamp_ns"].as_u64().unwrap() > w[0]["timestamp_ns"].as_u64().unwrap());
        assert_eq!(
            w[1]["frame"].as_u64().unwrap(),
            w[0]["frame"].as_u64().unwrap() + 1
        );
    }
    // Its diagonal ramp has no ring.
    assert!(l.iter().all(|x| x["valid"] == false && x["c_px"].is_null()));
    assert!(err.contains("camera Aravis-Fake-D40: 40 frames"), "{err}");
}

#[test]
#[cfg_attr(
    not(feature = "genicam"),
    ignore = "needs the genicam feature (libaravis, arv-fake-gv-camera-0.8): .ci/cam.sh"
)]
fn twenty_percent_packet_loss_ends_cleanly_with_no_valid_frame() {
    if !in_own_netns("twenty_percent_packet_loss_ends_cleanly_with_no_valid_frame") {
        return;
    }
    let _cam = aravis_fake("LOSSCLI", &["-r", "200"]);
    wait_listed("Aravis-Fake-LOSSCLI");
    let t0 = Instant::now();
    let out = gonio()
        .args([
            "detect",
            "--camera",
            "Aravis-Fake-LOSSCLI",
            "--frames",
            "30",
        ])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    println!("{err} in {:?}", t0.elapsed());
    assert!(out.status.success(), "{err}");
    let l = lines(&out);
    assert_eq!(l.len(), 30);
    assert!(l.iter().all(|x| x["valid"] == false));
    // Every line is a frame (complete, incomplete) or a missing one, with its reason.
    assert!(l.iter().all(|x| x["reason"].is_string()));
    assert!(err.contains("packets resent"), "{err}");
    // Slots 0 … 29 in order; an incomplete frame keeps the detector's fields but no column; a
    // missing one has no detector fields and no timestamp; the lines agree with the summary.
    for (i, x) in l.iter().enumerate() {
        assert_eq!(x["frame"], i, "{x}");
        assert!(x["c_px"].is_null() && x["c_um"].is_null(), "{x}");
    }
    let with = |reason: &str| -> Vec<&serde_json::Value> {
        l.iter().filter(|x| x["reason"] == reason).collect()
    };
    let (incomplete, missing) = (with("incomplete_frame"), with("missing_frame"));
    assert!(
        incomplete
            .iter()
            .all(|x| x["focus"].is_number() && x["frame_id"].is_u64())
    );
    assert!(
        missing
            .iter()
            .all(|x| x.get("focus").is_none() && x["timestamp_ns"].is_null())
    );
    let counted = format!(" incomplete), {} missing", missing.len());
    assert!(
        err.contains(&format!("{} incomplete), ", incomplete.len())) && err.contains(&counted),
        "{} incomplete and {} missing lines, but: {err}",
        incomplete.len(),
        missing.len()
    );
}

#[test]
#[cfg_attr(
    not(feature = "genicam"),
    ignore = "needs the genicam feature (libaravis, arv-fake-gv-camera-0.8): .ci/cam.sh"
)]
fn a_camera_killed_mid_stream_ends_with_exit_2_naming_it() {
    use std::io::{BufRead, BufReader};
    if !in_own_netns("a_camera_killed_mid_stream_ends_with_exit_2_naming_it") {
        return;
    }
    let mut cam = aravis_fake("KILLCLI", &[]);
    wait_listed("Aravis-Fake-KILLCLI");
    let mut det = Killed(
        gonio()
            .args(["detect", "--camera", "Aravis-Fake-KILLCLI"])
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap(),
    );
    let mut rd = BufReader::new(det.0.stdout.take().unwrap());
    let mut line = String::new();
    for _ in 0..5 {
        line.clear();
        assert!(rd.read_line(&mut line).unwrap() > 0, "no frames");
    }
    cam.0.kill().unwrap();
    let t0 = Instant::now();
    // Drain the rest of the lines while waiting.
    std::thread::spawn(move || {
        let mut s = String::new();
        while rd.read_line(&mut s).unwrap_or(0) > 0 {
            s.clear();
        }
    });
    let status = loop {
        if let Some(s) = det.0.try_wait().unwrap() {
            break s;
        }
        assert!(t0.elapsed() < Duration::from_secs(15), "still running");
        std::thread::sleep(Duration::from_millis(50));
    };
    let dt = t0.elapsed();
    let mut err = String::new();
    use std::io::Read;
    det.0
        .stderr
        .take()
        .unwrap()
        .read_to_string(&mut err)
        .unwrap();
    println!("{err} after {dt:?}");
    assert_eq!(status.code(), Some(2), "{err}");
    let last = err.lines().last().unwrap_or("");
    assert!(
        last.starts_with("error: ") && last.contains("Aravis-Fake-KILLCLI"),
        "{err}"
    );
    assert!(dt < Duration::from_secs(5), "{dt:?}");
}

#[test]
#[cfg_attr(
    not(feature = "genicam"),
    ignore = "needs the genicam feature (libaravis, arv-fake-gv-camera-0.8): .ci/cam.sh"
)]
fn no_camera_of_that_id_and_exposure_out_of_range_are_one_line_errors() {
    if !in_own_netns("no_camera_of_that_id_and_exposure_out_of_range_are_one_line_errors") {
        return;
    }
    let out = gonio()
        .args(["detect", "--camera", "Nobody-Here-7", "--frames", "3"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains("Nobody-Here-7") && err.contains("not found"),
        "{err}"
    );
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(out.stdout.is_empty());
    let _cam = aravis_fake("EXPO", &[]);
    wait_listed("Aravis-Fake-EXPO");
    let out = gonio()
        .args([
            "detect",
            "--camera",
            "Aravis-Fake-EXPO",
            "--frames",
            "3",
            "--exposure-us",
            // Within the flag's bound (1e8 µs), above the fake camera's ExposureTime (10 s).
            "5e7",
        ])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains("Aravis-Fake-EXPO") && err.contains("ExposureTime"),
        "{err}"
    );
    assert_eq!(err.lines().count(), 1, "{err}");
    // A window the camera cannot give: an optics file with a window wider than its sensor.
    let dir = tempfile::tempdir().unwrap();
    let optics = dir.path().join("optics.toml");
    std::fs::write(
        &optics,
        "sensor_width_px = 4096\nsensor_height_px = 3000\nwindow_width_px = 3000\nwindow_height_px = 540\n",
    )
    .unwrap();
    let out = gonio()
        .args([
            "detect",
            "--camera",
            "Aravis-Fake-EXPO",
            "--frames",
            "3",
            "--optics",
        ])
        .arg(&optics)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains("Aravis-Fake-EXPO") && err.contains("refuses"),
        "{err}"
    );
}

#[test]
#[cfg_attr(
    not(feature = "genicam"),
    ignore = "needs the genicam feature (libaravis, arv-fake-gv-camera-0.8): .ci/cam.sh"
)]
fn one_turn_served_and_detected_gives_the_served_eccentricity() {
    if !in_own_netns("one_turn_served_and_detected_gives_the_served_eccentricity") {
        return;
    }
    let e_served = 40.0;
    let _sim = Killed(
        gonio()
            .args([
                "simulate",
                "camera",
                "--serial",
                "TURN1",
                "--eccentricity-um",
                &e_served.to_string(),
                "--seed",
                "3",
                "--duration-s",
                "120",
            ])
            .stdout(Stdio::null())
            .stderr(Stdio::inherit())
            .spawn()
            .unwrap(),
    );
    // Rendering the turn first takes a few seconds.
    let t0 = Instant::now();
    loop {
        let out = gonio().args(["camera", "list", "--json"]).output().unwrap();
        if String::from_utf8_lossy(&out.stdout).contains("Aravis-Fake-TURN1") {
            break;
        }
        assert!(
            t0.elapsed() < Duration::from_secs(90),
            "gonio simulate camera never showed"
        );
        std::thread::sleep(Duration::from_millis(200));
    }
    let out = gonio()
        .args([
            "detect",
            "--camera",
            "Aravis-Fake-TURN1",
            "--frames",
            "200",
            "--speed-deg-s",
            "180",
            "--fps",
            "100",
        ])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    println!("{err}");
    assert!(out.status.success(), "{err}");
    let l = lines(&out);
    assert_eq!(l.len(), 200);
    let mut csv = String::from("theta_deg,c_px\n");
    let mut valid = 0;
    for x in &l {
        if x["valid"] == true {
            csv += &format!("{},{}\n", x["theta_deg"], x["c_px"]);
            valid += 1;
        }
    }
    assert!(valid >= 190, "{valid} valid of 200");
    let dir = tempfile::tempdir().unwrap();
    let turn = dir.path().join("turn.csv");
    std::fs::write(&turn, csv).unwrap();
    let out = gonio()
        .args(["eccentricity", "--um-per-px", "0.75", "--json", "-"])
        .arg(&turn)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let e = v["e_um"]
        .as_f64()
        .unwrap_or_else(|| panic!("no e_um in {v}"));
    println!("served e = {e_served} µm, measured e = {e} µm");
    assert!(
        (e - e_served).abs() < 0.1,
        "e = {e} µm, served {e_served} µm"
    );
}

/// A one-line refusal (exit 2, `error: …`) of `gonio args`, run to its end.
#[allow(dead_code)]
fn refused(args: &[&str]) -> String {
    let t = Instant::now();
    let out = gonio().args(args).stdin(Stdio::null()).output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    println!("{args:?} after {:?}: {err}", t.elapsed());
    assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(err.starts_with("error: "), "{err}");
    assert!(t.elapsed() < Duration::from_secs(20), "{:?}", t.elapsed());
    err
}

#[test]
#[cfg_attr(
    not(feature = "genicam"),
    ignore = "needs the genicam feature (libaravis, arv-fake-gv-camera-0.8): .ci/cam.sh"
)]
fn a_second_fake_camera_on_the_same_address_is_refused_naming_both() {
    if !in_own_netns("a_second_fake_camera_on_the_same_address_is_refused_naming_both") {
        return;
    }
    // Aravis's own fake camera first: `simulate camera` on its address is refused.
    let arv = aravis_fake("ARV1", &[]);
    wait_listed("Aravis-Fake-ARV1");
    let err = refused(&[
        "simulate",
        "camera",
        "--serial",
        "SECOND",
        "--fps",
        "10",
        "--speed-deg-s",
        "360",
        "--duration-s",
        "30",
    ]);
    assert!(
        err.contains("Aravis-Fake-ARV1") && err.contains("Aravis-Fake-SECOND"),
        "{err}"
    );
    assert!(
        err.contains("one GigE Vision camera per address and port"),
        "{err}"
    );
    drop(arv);
    // gonio's fake camera next: a second one, and a simulated station (whose camera would be
    // the second), are refused; the first keeps serving.
    let mut first = Killed(
        gonio()
            .args(["simulate", "camera", "--serial", "FIRST"])
            .args(["--fps", "10", "--speed-deg-s", "360", "--duration-s", "60"])
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap(),
    );
    wait_listed("Aravis-Fake-FIRST");
    let err = refused(&[
        "simulate",
        "camera",
        "--serial",
        "SECOND",
        "--fps",
        "10",
        "--speed-deg-s",
        "360",
        "--duration-s",
        "30",
    ]);
    assert!(
        err.contains("Aravis-Fake-FIRST") && err.contains("Aravis-Fake-SECOND"),
        "{err}"
    );
    let err = refused(&["simulate", "station", "--plc", "127.0.0.1:0"]);
    assert!(
        err.contains("Aravis-Fake-FIRST") && err.contains("Aravis-Fake-GONIOSTATION"),
        "{err}"
    );
    assert!(
        first.0.try_wait().unwrap().is_none(),
        "the first camera ended"
    );
    let listed = wait_listed("Aravis-Fake-FIRST");
    assert!(
        !listed.to_string().contains("SECOND") && !listed.to_string().contains("GONIOSTATION"),
        "{listed}"
    );
}
