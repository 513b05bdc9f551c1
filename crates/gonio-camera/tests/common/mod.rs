//! Test helpers: every test that starts a GigE Vision camera runs in its own network namespace.
#![allow(dead_code)]

use std::process::{Child, Command, Stdio};
use std::time::Duration;

/// Set in the child that runs inside the namespace.
const INSIDE: &str = "GONIO_CAMERA_TEST_NETNS";

/// Runs the test `name` of this binary again inside a new network namespace (`unshare -n`,
/// loopback up) and checks that it passed there. Returns true in the child (go on with the
/// test), false in the parent (the child's verdict has been asserted).
pub fn in_own_netns(name: &str) -> bool {
    if std::env::var_os(INSIDE).is_some() {
        return true;
    }
    let exe = std::env::current_exe().expect("test executable");
    let out = Command::new("timeout")
        .args(["-k", "5", "180", "unshare", "-n", "--", "sh", "-c"])
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
        "{name} failed in its network namespace ({})",
        out.status
    );
    assert!(
        stdout.contains("1 passed"),
        "{name} did not run in its network namespace"
    );
    false
}

/// A child process killed when dropped.
pub struct Killed(pub Child);

impl Drop for Killed {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// Starts `arv-fake-gv-camera-0.8 -i 127.0.0.1 -s SERIAL [extra]` and waits until it listens.
pub fn aravis_fake_camera(serial: &str, extra: &[&str]) -> Killed {
    let child = Command::new("arv-fake-gv-camera-0.8")
        .args(["-i", "127.0.0.1", "-s", serial])
        .args(extra)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .expect("arv-fake-gv-camera-0.8 (aravis-tools) must be installed");
    let cam = Killed(child);
    // Its sockets are bound within milliseconds; discovery then finds it (callers list until
    // it shows, bounded).
    std::thread::sleep(Duration::from_millis(300));
    cam
}

/// The body of the ignored test that stands for `name`'s tests in a build without cameras: run
/// anyway (`--ignored`), it fails saying what is missing.
pub fn not_built(name: &str) -> ! {
    panic!(
        "{name}: built without the `genicam` feature: cargo test -p gonio-camera --features genicam (.ci/cam.sh)"
    );
}
