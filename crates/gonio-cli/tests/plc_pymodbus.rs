//! A client gonio did not write: pymodbus (PyPI, in its own virtualenv under target/) drives
//! `gonio simulate station` through the registers of docs/plc-interface.md
//! (examples/plc/pymodbus_check.py): status block, heartbeat, command handshake with the
//! sequence counter, units and scaling, the camera trigger's latch ring, the watchdog, fault
//! reset. The station listens on 127.0.0.1 port 0 and is killed when the test ends.

mod common;

use common::{Guard, plc_venv_python, repo, wait_for_line};
use std::process::{Command, Stdio};
use std::time::Duration;

#[test]
fn pymodbus_drives_the_simulated_station_through_the_documented_registers() {
    let py = plc_venv_python();
    let mut child = Command::new(env!("CARGO_BIN_EXE_gonio"))
        .args(["simulate", "station", "--plc", "127.0.0.1:0", "--seed", "3"])
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("gonio runs");
    let line = wait_for_line(&mut child, "station PLC on ", Duration::from_secs(20));
    let _guard = Guard(child);
    let addr = line
        .split("station PLC on ")
        .nth(1)
        .and_then(|s| s.split_whitespace().next())
        .expect("the address is printed");
    let (host, port) = addr.rsplit_once(':').expect("HOST:PORT");
    let out = Command::new(&py)
        .arg(repo("examples/plc/pymodbus_check.py"))
        .args([host, port])
        .output()
        .expect("python runs");
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success() && text.contains("all checks passed"),
        "pymodbus check failed:\n{text}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
}
