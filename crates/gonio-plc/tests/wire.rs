//! The station through the wire, in one process: the simulated PLC on 127.0.0.1 (an ephemeral
//! port), its exposures through the in-process camera stand-in, the controller over the Modbus
//! link. One part mounted end to end, then every fault the link must survive: each ends the
//! part `rejected_device_error` naming the device, within 5 s, nothing left hanging.

use gonio_plc::link::Link;
use gonio_plc::map::RegisterMap;
use gonio_plc::sim::{SimConfig, SimFaults, SimServer, SimTriggered};
use gonio_plc::station::{PlcStation, StationOptions};
use gonio_station::{Controller, PartResult, Recipe, Strategy};
use std::time::{Duration, Instant};

fn opts(r: &Recipe) -> StationOptions {
    StationOptions {
        fps: r.measure.fps,
        exposure_s: r.measure.exposure_s,
        um_per_px: r.um_per_px,
    }
}

fn start(cfg: SimConfig) -> (SimServer, PlcStation<SimTriggered>) {
    let mut server = SimServer::start(cfg, "127.0.0.1:0".parse().unwrap()).unwrap();
    let camera = SimTriggered::new(server.take_frames().unwrap());
    let link = Link::connect(&server.addr().to_string(), RegisterMap::default()).unwrap();
    let station = PlcStation::new(link, camera, opts(&Recipe::default())).unwrap();
    (server, station)
}

#[test]
fn two_parts_through_the_wire_match_the_truth() {
    let (mut server, station) = start(SimConfig::new(11));
    let mut ctl = Controller::new(Recipe::default(), Strategy::Live);
    for k in 1..=2u32 {
        let part = station.wait_part(Duration::from_secs(10)).unwrap();
        assert_eq!(part, k);
        let rec = ctl
            .mount(&mut station.devices(), &format!("PLC-{part:04}"))
            .unwrap();
        let truth = server.truth();
        let t = truth.iter().find(|t| t.part == part).unwrap();
        assert_eq!(rec.result, PartResult::Accepted, "{rec:?}");
        // An accepted part has both eccentricities measured.
        let (initial_e_um, final_e_um) = (rec.initial_e_um.unwrap(), rec.final_e_um.unwrap());
        assert!(
            (final_e_um - t.true_final_e_um).abs() < 0.5,
            "measured {} µm, true {} µm",
            final_e_um,
            t.true_final_e_um
        );
        assert!(t.true_final_e_um < 3.0, "{t:?}");
        assert!(
            (initial_e_um - t.true_initial_e_um).abs() < 1.0,
            "initial {} vs {}",
            initial_e_um,
            t.true_initial_e_um
        );
        station.part_done().unwrap();
    }
    let c = station.pairing_counts();
    assert!(c.paired > 800, "{c:?}");
    let (p50, p99, n) = station.round_trip_ms();
    let (p50, p99) = (p50.expect("requests timed"), p99.expect("requests timed"));
    assert!(n > 100 && p50 > 0.0 && p99 >= p50, "{p50} {p99} {n}");
    server.stop();
}

/// What an observer was told, in order.
#[derive(Default)]
struct Told(Vec<String>);

impl gonio_station::observe::Observer for Told {
    fn part_started(&mut self, serial: &str) {
        self.0.push(format!("part {serial}"));
    }
    fn phase(&mut self, phase: gonio_station::observe::Phase) {
        self.0.push(format!("phase {phase:?}"));
    }
    fn frame(&mut self, _frame: &gonio_station::observe::LiveFrame) {
        if self.0.last().map(String::as_str) != Some("frames") {
            self.0.push("frames".into());
        }
    }
    fn turn(
        &mut self,
        _turn: &gonio_station::record::TurnRecord,
        _fit: Option<&gonio_station::fit::EccentricityFit>,
    ) {
        self.0.push("turn".into());
    }
    fn push(&mut self, _push: &gonio_station::record::PushRecord) {
        self.0.push("push".into());
    }
    fn part_finished(&mut self, r: &gonio_station::PartRecord) {
        self.0.push(format!("finished {}", r.serial));
    }
}

#[test]
fn a_batch_tells_its_observer_what_the_controller_does() {
    use gonio_plc::batch::{PartEnd, run_batch_observed};
    let (mut server, station) = start(SimConfig::new(11));
    let mut ctl = Controller::new(Recipe::default(), Strategy::Live);
    let mut told = Told::default();
    let mut ended = Vec::new();
    let report = run_batch_observed(&station, &mut ctl, 1, &mut told, &mut |d| {
        ended.push(d.record.serial.clone());
        PartEnd::Continue
    })
    .unwrap();
    server.stop();
    assert_eq!(ended, ["PLC-0001"]);
    let rec = &report.parts[0].record;
    assert_eq!(rec.result, PartResult::Accepted, "{rec:?}");
    let t = &told.0;
    assert_eq!(
        t.first().map(String::as_str),
        Some("part PLC-0001"),
        "{t:?}"
    );
    assert_eq!(
        t.last().map(String::as_str),
        Some("finished PLC-0001"),
        "{t:?}"
    );
    assert!(t.iter().any(|e| e == "phase Focus"), "{t:?}");
    assert!(t.iter().any(|e| e.starts_with("phase Measure")), "{t:?}");
    assert!(t.iter().any(|e| e == "frames"), "{t:?}");
    let turns = t.iter().filter(|e| *e == "turn").count();
    assert_eq!(turns, rec.turns.len(), "{t:?}");
    let pushes = t.iter().filter(|e| *e == "push").count();
    assert_eq!(pushes, rec.pushes as usize, "{t:?}");
}

/// Mounts one part against a station with `faults`; returns the record and how long the part
/// took to end after the fault time.
fn faulted(faults: SimFaults, at_s: f64) -> (gonio_station::PartRecord, f64) {
    let mut cfg = SimConfig::new(5);
    cfg.faults = faults;
    let (_server, station) = start(cfg);
    let t0 = Instant::now();
    let mut ctl = Controller::new(Recipe::default(), Strategy::Live);
    let part = station.wait_part(Duration::from_secs(10)).unwrap();
    let rec = ctl
        .mount(&mut station.devices(), &format!("PLC-{part:04}"))
        .unwrap();
    let after = t0.elapsed().as_secs_f64() - at_s;
    (rec, after)
}

fn assert_device_error(rec: &gonio_station::PartRecord, after_s: f64, device: &str, says: &str) {
    assert_eq!(rec.result, PartResult::RejectedDeviceError, "{rec:?}");
    let d = rec.device_error.as_ref().unwrap();
    assert_eq!(d.device, device, "{d:?}");
    assert!(d.message.contains(says), "{d:?}");
    assert!(after_s < 5.0, "ended {after_s:.1} s after the fault");
}

#[test]
fn refused_connection_names_the_plc() {
    let port = {
        let l = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
        l.local_addr().unwrap().port()
    };
    let t = Instant::now();
    let e = Link::connect(&format!("127.0.0.1:{port}"), RegisterMap::default()).unwrap_err();
    assert!(e.to_string().contains(&format!("127.0.0.1:{port}")), "{e}");
    assert!(e.to_string().contains("cannot connect"), "{e}");
    assert!(t.elapsed() < Duration::from_secs(5));
}

#[test]
fn plc_reset_mid_part() {
    let f = SimFaults {
        reset_at_s: Some(3.0),
        ..SimFaults::default()
    };
    let (rec, after) = faulted(f, 3.0);
    assert_eq!(rec.result, PartResult::RejectedDeviceError, "{rec:?}");
    assert!(after < 5.0, "{after}");
}

#[test]
fn plc_silent_mid_part() {
    let f = SimFaults {
        silent_at_s: Some(3.0),
        ..SimFaults::default()
    };
    let (rec, after) = faulted(f, 3.0);
    assert_eq!(rec.result, PartResult::RejectedDeviceError, "{rec:?}");
    let d = rec.device_error.as_ref().unwrap();
    assert!(
        d.message.contains("no reply") || d.message.contains("link down"),
        "{d:?}"
    );
    assert!(after < 5.0, "{after}");
}

#[test]
fn plc_heartbeat_stops() {
    let f = SimFaults {
        heartbeat_stops_at_s: Some(3.0),
        ..SimFaults::default()
    };
    let (rec, after) = faulted(f, 3.0);
    assert_eq!(rec.result, PartResult::RejectedDeviceError, "{rec:?}");
    let d = rec.device_error.as_ref().unwrap();
    assert!(d.message.contains("heartbeat"), "{d:?}");
    assert!(after < 5.0, "{after}");
}

#[test]
fn drive_fault_bit() {
    let f = SimFaults {
        drive_fault: Some((2, 3.0)),
        ..SimFaults::default()
    };
    let (rec, after) = faulted(f, 3.0);
    assert_eq!(rec.result, PartResult::RejectedDeviceError, "{rec:?}");
    let d = rec.device_error.as_ref().unwrap();
    assert!(d.message.contains("servo drive fault"), "{d:?}");
    assert!(after < 5.0, "{after}");
}

#[test]
fn emergency_stop() {
    let f = SimFaults {
        estop_at_s: Some(3.0),
        ..SimFaults::default()
    };
    let (rec, after) = faulted(f, 3.0);
    assert_eq!(rec.result, PartResult::RejectedDeviceError, "{rec:?}");
    let d = rec.device_error.as_ref().unwrap();
    assert!(d.message.contains("emergency stop"), "{d:?}");
    assert!(after < 5.0, "{after}");
}

#[test]
fn camera_lost() {
    let f = SimFaults {
        camera_lost_at_s: Some(3.0),
        ..SimFaults::default()
    };
    let (rec, after) = faulted(f, 3.0);
    assert_device_error(&rec, after, "camera", "no frame");
}

#[test]
fn frame_without_a_latched_angle() {
    let f = SimFaults {
        no_latch_from: Some(300),
        ..SimFaults::default()
    };
    let (rec, after) = faulted(f, 3.0);
    assert_device_error(&rec, after, "camera", "has no latched angle");
}

#[test]
fn watchdog_expires_when_gonio_goes_quiet() {
    // gonio's heartbeat stops (the mount process hangs): the PLC stops the servo, retracts the
    // rod and latches the watchdog fault; gonio's next command sees it.
    let (mut server, station) = start(SimConfig::new(9));
    let part = station.wait_part(Duration::from_secs(10)).unwrap();
    assert_eq!(part, 1);
    std::thread::sleep(Duration::from_millis(2600));
    let s = station.status().unwrap();
    assert!(s.has(gonio_plc::link::bits::WATCHDOG), "{s:?}");
    let mut ctl = Controller::new(Recipe::default(), Strategy::Live);
    let t = Instant::now();
    let rec = ctl.mount(&mut station.devices(), "PLC-0001").unwrap();
    assert_device_error(&rec, t.elapsed().as_secs_f64(), "focus drive", "watchdog");
    server.stop();
}
