//! The few GigE Vision control-protocol exchanges (GVCP, UDP port 3956) gonio makes itself,
//! beside Aravis: whether a camera answers at an address at all ([`answers`], one register
//! read: before the station's camera is torn down, so that a camera that is gone is not waited
//! for), which camera it is ([`discover`], a unicast discovery: before a fake camera is started
//! on an address another already serves), and the register read the fake camera's watcher
//! sends (`wake`).
//!
//! Written here (std's UDP socket) because Aravis answers these only through a device it has
//! opened, whose teardown is what must not be waited on, and no crate speaks GVCP. Times are
//! the reply timeouts given; errors are not reported: a camera that does not answer within the
//! timeout is taken as absent ([`None`], `false`).
//!
//! ```no_run
//! use gonio_camera::gvcp::{GVCP_PORT, discover};
//! use std::time::Duration;
//! let at = std::net::SocketAddr::from(([127, 0, 0, 1], GVCP_PORT));
//! match discover(at, Duration::from_millis(300)) {
//!     Some(c) => println!("{} answers on {at}", c.id()),
//!     None => println!("no camera on {at}"),
//! }
//! ```

// Without `genicam` nothing tears a camera down or starts a fake one; the module stays compiled
// so its tests run in the default build.
#![cfg_attr(not(feature = "genicam"), allow(dead_code))]

use std::net::{SocketAddr, UdpSocket};
use std::time::{Duration, Instant};

/// The GVCP port of every GigE Vision camera.
pub const GVCP_PORT: u16 = 3956;

/// The GVCP command key, first byte of every command.
const KEY: u8 = 0x42;
/// Flags: an acknowledge is required.
const ACK_REQUIRED: u8 = 0x01;
const DISCOVERY_CMD: u16 = 0x0002;
const DISCOVERY_ACK: u16 = 0x0003;
const READREG_CMD: u16 = 0x0080;
const READREG_ACK: u16 = 0x0081;
/// The bootstrap registers a discovery acknowledge carries (0x0000 … 0x00F7).
const DISCOVERY_PAYLOAD: usize = 0xF8;

/// A command: key, flags, command, payload length, request id, then the payload.
fn command(cmd: u16, flags: u8, id: u16, payload: &[u8]) -> Vec<u8> {
    let mut p = vec![KEY, flags];
    p.extend(cmd.to_be_bytes());
    p.extend((payload.len() as u16).to_be_bytes());
    p.extend(id.to_be_bytes());
    p.extend(payload);
    p
}

/// `READREG_CMD` of register 0x0000 (the device's version; read-only), request `id`, without
/// asking for an acknowledge (the watcher's wake-up: it reads nothing back).
pub(crate) fn read_version_packet(id: u16) -> [u8; 12] {
    let p = command(READREG_CMD, 0, id, &[0, 0, 0, 0]);
    p.try_into().expect("12 bytes")
}

/// The camera that answered a discovery: its bootstrap registers' names.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Identity {
    /// Manufacturer name.
    pub manufacturer: String,
    /// Model name.
    pub model: String,
    /// Serial number.
    pub serial: String,
    /// The user-defined name (empty when unset).
    pub user_name: String,
}

impl Identity {
    /// Aravis's id of the camera: `Manufacturer-Model-Serial` (`Aravis-Fake-GONIO01`).
    pub fn id(&self) -> String {
        format!("{}-{}-{}", self.manufacturer, self.model, self.serial)
    }

    /// From a discovery acknowledge's payload (the bootstrap registers from 0x0000).
    fn parse(payload: &[u8]) -> Option<Identity> {
        if payload.len() < DISCOVERY_PAYLOAD {
            return None;
        }
        let text = |at: usize, len: usize| {
            let b = &payload[at..at + len];
            let end = b.iter().position(|&c| c == 0).unwrap_or(len);
            String::from_utf8_lossy(&b[..end]).trim().to_string()
        };
        Some(Identity {
            manufacturer: text(0x48, 32),
            model: text(0x68, 32),
            serial: text(0xD8, 16),
            user_name: text(0xE8, 16),
        })
    }
}

/// Sends `packet` to `camera` and waits up to `timeout` for the acknowledge `ack` to request
/// `id`; its payload.
fn exchange(
    camera: SocketAddr,
    packet: &[u8],
    ack: u16,
    id: u16,
    timeout: Duration,
) -> Option<Vec<u8>> {
    let local: SocketAddr = match camera {
        SocketAddr::V4(_) => ([0, 0, 0, 0], 0).into(),
        SocketAddr::V6(_) => (std::net::Ipv6Addr::UNSPECIFIED, 0).into(),
    };
    let socket = UdpSocket::bind(local).ok()?;
    socket.connect(camera).ok()?;
    socket.send(packet).ok()?;
    let end = Instant::now() + timeout;
    let mut buf = [0u8; 1024];
    loop {
        let left = end.checked_duration_since(Instant::now())?;
        socket
            .set_read_timeout(Some(left.max(Duration::from_millis(1))))
            .ok()?;
        // A refused port (nothing listens) and a timeout end alike: no answer.
        let n = socket.recv(&mut buf).ok()?;
        let b = &buf[..n];
        if n >= 8
            && u16::from_be_bytes([b[2], b[3]]) == ack
            && u16::from_be_bytes([b[6], b[7]]) == id
        {
            // Status 0: success.
            return (u16::from_be_bytes([b[0], b[1]]) == 0).then(|| b[8..].to_vec());
        }
    }
}

/// A request id for one exchange (never 0).
fn request_id() -> u16 {
    let nanos = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(1, |d| d.subsec_nanos());
    (nanos % 0xFFFF) as u16 + 1
}

/// Whether a GigE Vision device at `camera` (its GVCP port) answers a register read within
/// `timeout`.
pub fn answers(camera: SocketAddr, timeout: Duration) -> bool {
    let id = request_id();
    let p = command(READREG_CMD, ACK_REQUIRED, id, &[0, 0, 0, 0]);
    exchange(camera, &p, READREG_ACK, id, timeout).is_some()
}

/// The camera that answers a discovery sent to `camera` (its GVCP port) within `timeout`.
pub fn discover(camera: SocketAddr, timeout: Duration) -> Option<Identity> {
    let id = request_id();
    let p = command(DISCOVERY_CMD, ACK_REQUIRED, id, &[]);
    Identity::parse(&exchange(camera, &p, DISCOVERY_ACK, id, timeout)?)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_packets_are_gvcp_commands() {
        let p = read_version_packet(0x1234);
        assert_eq!(p[0], 0x42, "GVCP command key");
        assert_eq!(p[1], 0, "no acknowledge asked");
        assert_eq!(u16::from_be_bytes([p[2], p[3]]), 0x0080, "READREG_CMD");
        assert_eq!(u16::from_be_bytes([p[4], p[5]]), 4, "one register address");
        assert_eq!(u16::from_be_bytes([p[6], p[7]]), 0x1234, "request id");
        assert_eq!(
            u32::from_be_bytes([p[8], p[9], p[10], p[11]]),
            0,
            "register 0x0000"
        );
        let d = command(DISCOVERY_CMD, ACK_REQUIRED, 7, &[]);
        assert_eq!(d, [0x42, 0x01, 0x00, 0x02, 0x00, 0x00, 0x00, 0x07]);
    }

    /// A device on a loopback socket that acknowledges a discovery as a camera does; nothing on
    /// another port.
    #[test]
    fn a_discovery_names_the_camera_and_silence_is_no_camera() {
        let cam = UdpSocket::bind("127.0.0.1:0").unwrap();
        let at = cam.local_addr().unwrap();
        let device = std::thread::spawn(move || {
            let mut buf = [0u8; 64];
            for _ in 0..2 {
                let (n, from) = cam.recv_from(&mut buf).unwrap();
                let cmd = u16::from_be_bytes([buf[2], buf[3]]);
                let id = [buf[6], buf[7]];
                assert!(
                    n >= 8 && buf[0] == 0x42 && buf[1] & 1 == 1,
                    "{:?}",
                    &buf[..n]
                );
                let (ack, payload) = if cmd == DISCOVERY_CMD {
                    let mut regs = vec![0u8; DISCOVERY_PAYLOAD];
                    regs[0x48..0x48 + 6].copy_from_slice(b"Aravis");
                    regs[0x68..0x68 + 4].copy_from_slice(b"Fake");
                    regs[0xD8..0xD8 + 12].copy_from_slice(b"TESTCAMERA01");
                    (DISCOVERY_ACK, regs)
                } else {
                    (READREG_ACK, vec![0, 1, 0, 2])
                };
                let mut r = vec![0, 0];
                r.extend(ack.to_be_bytes());
                r.extend((payload.len() as u16).to_be_bytes());
                r.extend(id);
                r.extend(payload);
                cam.send_to(&r, from).unwrap();
            }
        });
        let c = discover(at, Duration::from_secs(5)).expect("the device answers");
        assert_eq!(c.id(), "Aravis-Fake-TESTCAMERA01");
        assert_eq!(c.user_name, "");
        assert!(answers(at, Duration::from_secs(5)));
        device.join().unwrap();
        // Nothing listens there any more: no answer, within the timeout.
        let t = Instant::now();
        assert!(!answers(at, Duration::from_millis(200)));
        assert!(discover(at, Duration::from_millis(200)).is_none());
        assert!(t.elapsed() < Duration::from_secs(2), "{:?}", t.elapsed());
    }
}
