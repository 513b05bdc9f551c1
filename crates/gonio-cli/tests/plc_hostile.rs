//! gonio's PLC link and batch (`gonio_plc`, as `gonio mount --plc` runs them) against a hostile
//! PLC in another process: `tests/plc/hostile_plc.py`, a Modbus server on pymodbus (a stack
//! gonio did not write) that acknowledges commands and then stays busy, takes its time, or is
//! stopped and killed under the link. The faults all come before the first camera frame, so no
//! camera is needed and these run in the default build; `plc_station_cli.rs` runs the whole
//! command with the simulated station's camera (feature `genicam`).

mod common;

use common::{HostilePlc, Taken};
use gonio_plc::batch::run_batch;
use gonio_plc::triggered::{TriggeredCamera, TriggeredFrame};
use gonio_plc::{Interrupt, Link, PlcStation, RegisterMap, StationOptions};
use gonio_station::hal::{DeviceError, DeviceErrorKind};
use gonio_station::{Controller, PartResult, Recipe, Strategy};
use std::time::{Duration, Instant};

/// A camera that is never reached: every fault here comes before the first frame.
struct NoFrames;

#[derive(Debug)]
struct NoFrame;

impl std::fmt::Display for NoFrame {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("this test's camera has no frames")
    }
}

impl DeviceError for NoFrame {
    fn kind(&self) -> DeviceErrorKind {
        DeviceErrorKind::Other
    }
}

impl TriggeredCamera for NoFrames {
    type Error = NoFrame;
    fn next_frame(&mut self, _: Duration) -> Result<Option<TriggeredFrame>, NoFrame> {
        Err(NoFrame)
    }
}

const MOVE_FOCUS: u16 = 4;
const STOP_SERVO: u16 = 3;
const RETRACT: u16 = 8;
const TRIGGER: u16 = 11;

/// The station over the PLC at `addr` with `map`, its trigger started.
fn station(addr: &str, map: RegisterMap) -> PlcStation<NoFrames> {
    let link = Link::connect(addr, map).expect("the hostile PLC accepts");
    let recipe = Recipe::default();
    let opts = StationOptions {
        fps: recipe.measure.fps,
        exposure_s: recipe.measure.exposure_s,
        um_per_px: recipe.um_per_px,
    };
    PlcStation::new(link, NoFrames, opts).expect("the station opens")
}

/// The commands taken after the first `cmd`, and that one.
fn after(taken: &[Taken], cmd: u16) -> (Taken, Vec<Taken>) {
    let i = taken
        .iter()
        .position(|t| t.cmd == cmd)
        .unwrap_or_else(|| panic!("command {cmd} never taken: {taken:?}"));
    (taken[i], taken[i + 1..].to_vec())
}

#[test]
fn a_plc_that_stays_busy_ends_the_part_and_its_safe_state_within_one_deadline() {
    // The focus move is acknowledged and stays busy, and so does every command after it.
    let plc = HostilePlc::start(&["--stuck-on", "4"]);
    let mut map = RegisterMap::default();
    map.timing.command_timeout_s = 3.0;
    map.timing.safe_state_ms = 500;
    let station = station(&plc.addr, map);
    let mut ctl = Controller::new(Recipe::default(), Strategy::Live);
    let t = Instant::now();
    let report = run_batch(&station, &mut ctl, 1, &mut |_| {
        gonio_plc::batch::PartEnd::Continue
    })
    .unwrap();
    let took = t.elapsed();
    println!("{took:?}: {report:#?}");
    // The stuck move's command timeout, then one safe-state deadline for every safe command
    // together (the controller's retract and stop, the batch's retract, stop, trigger off),
    // with 2 s of slack for the Modbus round trips of those commands on a loaded machine (3.0
    // s is typical with both cores busy; one workspace run on two cores took over a second
    // more): a second command timeout would already take 3.5 + 3 s, and one each 18 s.
    assert!(took < Duration::from_millis(3000 + 500 + 2000), "{took:?}");
    let p = &report.parts[0].record;
    assert_eq!(p.result, PartResult::RejectedDeviceError, "{p:?}");
    let why = p.reject_reason.as_deref().unwrap();
    assert!(why.contains("MoveFocus not done within 3 s"), "{why}");
    let stopped = report.stopped.as_deref().unwrap();
    assert!(
        stopped.contains("safe stop") && stopped.contains("safe state's 500 ms"),
        "{stopped}"
    );
    // Every safe-state command was still sent, and nothing else.
    let (stuck, rest) = after(&plc.taken(), MOVE_FOCUS);
    let cmds: Vec<(u16, i64)> = rest.iter().map(|t| (t.cmd, t.arg0)).collect();
    assert!(
        cmds.contains(&(RETRACT, 0))
            && cmds.contains(&(STOP_SERVO, 0))
            && cmds.contains(&(TRIGGER, 0)),
        "{cmds:?}"
    );
    assert!(
        cmds.iter()
            .all(|c| [(RETRACT, 0), (STOP_SERVO, 0), (TRIGGER, 0)].contains(c)),
        "{cmds:?}"
    );
    let last = rest.last().unwrap();
    assert!(last.t_s - stuck.t_s < 3.0 + 0.5 + 1.0, "{rest:?}");
}

#[test]
fn an_interrupt_mid_part_leaves_the_station_safe_and_ends_the_part_interrupted() {
    // A focus move that takes half a minute; every other command is done at once.
    let plc = HostilePlc::start(&["--slow", "4=30"]);
    let mut map = RegisterMap::default();
    map.timing.safe_state_ms = 1000;
    let station = station(&plc.addr, map);
    let interrupt = Interrupt::new();
    station.set_interrupt(interrupt.clone());
    let mut ctl = Controller::new(Recipe::default(), Strategy::Live);
    let raise = interrupt.clone();
    let signaller = std::thread::spawn(move || {
        std::thread::sleep(Duration::from_millis(1000));
        raise.raise(2);
        Instant::now()
    });
    let mut handed = Vec::new();
    let report = run_batch(&station, &mut ctl, 2, &mut |d| {
        handed.push(d.record.result);
        gonio_plc::batch::PartEnd::Continue
    })
    .unwrap();
    let took = signaller.join().unwrap().elapsed();
    println!("{took:?} after the interrupt: {report:#?}");
    // Within a poll of the interrupt, then three safe commands done at once.
    assert!(took < Duration::from_millis(1000), "{took:?}");
    // The part in progress is handed over (for the store) as interrupted, with no device
    // error; the batch stops there.
    assert_eq!(handed, [PartResult::Interrupted]);
    let p = &report.parts[0].record;
    assert_eq!(p.result, PartResult::Interrupted, "{p:?}");
    assert!(p.device_error.is_none(), "{p:?}");
    let why = p.reject_reason.as_deref().unwrap();
    assert_eq!(why, "focus drive: interrupted by SIGINT");
    let stopped = report.stopped.as_deref().unwrap();
    assert!(
        stopped.contains("interrupted by SIGINT") && !stopped.contains("safe stop"),
        "{stopped}"
    );
    // Retract and stop (the controller's), then trigger off (the batch's: the other two were
    // done already), each done before the next was sent.
    let (_, rest) = after(&plc.taken(), MOVE_FOCUS);
    let cmds: Vec<(u16, i64)> = rest.iter().map(|t| (t.cmd, t.arg0)).collect();
    assert_eq!(cmds, [(RETRACT, 0), (STOP_SERVO, 0), (TRIGGER, 0)]);
}

#[test]
fn a_closed_reset_or_silent_connection_is_named_as_what_happened() {
    let map = || {
        let mut m = RegisterMap::default();
        m.timing.reply_timeout_ms = 500;
        m
    };
    // Closed: the PLC's process ends (its socket closes with nothing unread).
    let plc = HostilePlc::start(&[]);
    let mut link = Link::connect(&plc.addr, map()).unwrap();
    link.status().unwrap();
    plc.signal("-KILL");
    std::thread::sleep(Duration::from_millis(200));
    let t = Instant::now();
    let e = link.status().unwrap_err().to_string();
    println!("closed: {e} ({:?})", t.elapsed());
    assert!(e.contains("the PLC closed the connection"), "{e}");
    assert!(!e.contains("os error"), "{e}");
    assert!(
        t.elapsed() < Duration::from_millis(500),
        "{:?}",
        t.elapsed()
    );
    // And the link stays down, saying why.
    let e = link.status().unwrap_err().to_string();
    assert!(
        e.contains("link down") && e.contains("closed the connection"),
        "{e}"
    );

    // Silent: the PLC's process is stopped; the request gets no reply.
    let plc = HostilePlc::start(&[]);
    let mut link = Link::connect(&plc.addr, map()).unwrap();
    plc.signal("-STOP");
    let e = link.status().unwrap_err().to_string();
    println!("silent: {e}");
    assert!(e.contains("no reply within 500 ms"), "{e}");
    drop(plc);

    // Reset: the stopped PLC is killed with the request unread in its socket, which the
    // kernel answers with a reset.
    let plc = HostilePlc::start(&[]);
    let mut m = map();
    m.timing.reply_timeout_ms = 10_000;
    let mut link = Link::connect(&plc.addr, m).unwrap();
    plc.signal("-STOP");
    let waiting = std::thread::spawn(move || {
        let t = Instant::now();
        (link.status().unwrap_err().to_string(), t.elapsed())
    });
    std::thread::sleep(Duration::from_millis(500));
    plc.signal("-KILL");
    let (e, took) = waiting.join().unwrap();
    println!("reset: {e} ({took:?})");
    assert!(e.contains("the connection was reset"), "{e}");
    assert!(!e.contains("os error"), "{e}");
    assert!(took < Duration::from_secs(5), "{took:?}");
}
