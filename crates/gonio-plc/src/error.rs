//! [`PlcError`]: every error of the station over the wire (the link, the PLC's faults, the
//! pairing of frames with angles, the camera, the push rod's contact), each naming the PLC's
//! address or the device; its [`DeviceError::kind`] says timeout, communication or fault.

use crate::protocol::FaultCode;
use gonio_station::hal::{DeviceError, DeviceErrorKind};
use thiserror::Error;

/// An error of the PLC link.
#[derive(Debug, Error, Clone, PartialEq)]
#[non_exhaustive]
pub enum PlcError {
    /// The connection could not be made (refused, unreachable).
    #[error("PLC at {addr}: cannot connect: {message}")]
    Connect {
        /// The PLC's address.
        addr: String,
        /// Why.
        message: String,
    },
    /// A request failed on the wire (reset, closed).
    #[error("PLC at {addr}: {message}")]
    Io {
        /// The PLC's address.
        addr: String,
        /// Why.
        message: String,
    },
    /// No reply in time.
    #[error("PLC at {addr}: no reply within {timeout_ms} ms")]
    NoReply {
        /// The PLC's address.
        addr: String,
        /// The reply timeout.
        timeout_ms: u64,
    },
    /// The PLC closed the connection.
    #[error("PLC at {addr}: the PLC closed the connection ({what})")]
    Closed {
        /// The PLC's address.
        addr: String,
        /// The request.
        what: String,
    },
    /// The connection was reset (the PLC restarted, or the network dropped it).
    #[error("PLC at {addr}: the connection was reset by the PLC or the network ({what})")]
    Reset {
        /// The PLC's address.
        addr: String,
        /// The request.
        what: String,
    },
    /// The PLC answered with a Modbus exception.
    #[error("PLC at {addr}: Modbus exception {code} on {what}")]
    Exception {
        /// The PLC's address.
        addr: String,
        /// The exception.
        code: String,
        /// The request.
        what: String,
    },
    /// The PLC's heartbeat stopped while it still answered.
    #[error("PLC at {addr}: its heartbeat has not changed for {ms} ms")]
    Silent {
        /// The PLC's address.
        addr: String,
        /// How long.
        ms: u64,
    },
    /// The PLC reports a fault.
    #[error("PLC at {addr}: {what}: {}", code.describe())]
    Fault {
        /// The PLC's address.
        addr: String,
        /// During what.
        what: String,
        /// The fault.
        code: FaultCode,
    },
    /// The emergency stop is pressed.
    #[error("PLC at {addr}: emergency stop pressed during {what}")]
    EStop {
        /// The PLC's address.
        addr: String,
        /// During what.
        what: String,
    },
    /// A command stayed busy too long.
    #[error("PLC at {addr}: {what} not done within {timeout_s} s")]
    CommandTimeout {
        /// The PLC's address.
        addr: String,
        /// The command.
        what: String,
        /// The limit.
        timeout_s: f64,
    },
    /// A safe-state command did not finish before the safe state's deadline.
    #[error(
        "PLC at {addr}: {what} not done within the safe state's {budget_ms} ms (sent; the PLC stays busy)"
    )]
    SafeStateTimeout {
        /// The PLC's address.
        addr: String,
        /// The command.
        what: String,
        /// The time all safe-state commands had together, ms.
        budget_ms: u64,
    },
    /// A motion command after the sequence was aborted to the safe state.
    #[error("PLC at {addr}: {what} refused: the sequence was aborted to the safe state")]
    Aborted {
        /// The PLC's address.
        addr: String,
        /// The command.
        what: String,
    },
    /// The run was asked to stop (a signal: Ctrl-C, SIGTERM).
    #[error("interrupted by {}", crate::abort::signal_name(*signal))]
    Interrupted {
        /// The signal's number.
        signal: i32,
    },
    /// An earlier failure took the link down.
    #[error("PLC at {addr}: link down after an earlier failure ({first})")]
    LinkDown {
        /// The PLC's address.
        addr: String,
        /// The first failure.
        first: String,
    },
    /// A frame could not be given an angle.
    #[error("{message}")]
    Pairing {
        /// Why.
        message: String,
    },
    /// The camera failed.
    #[error("camera: {message}")]
    Camera {
        /// The camera's message.
        message: String,
        /// The camera error's kind.
        kind: DeviceErrorKind,
    },
    /// The push rod found no contact.
    #[error("push rod: {message}")]
    NoContact {
        /// Why.
        message: String,
    },
}

impl DeviceError for PlcError {
    fn kind(&self) -> DeviceErrorKind {
        match self {
            PlcError::Connect { .. }
            | PlcError::Io { .. }
            | PlcError::Closed { .. }
            | PlcError::Reset { .. }
            | PlcError::LinkDown { .. } => DeviceErrorKind::Communication,
            PlcError::NoReply { .. }
            | PlcError::Silent { .. }
            | PlcError::CommandTimeout { .. }
            | PlcError::SafeStateTimeout { .. } => DeviceErrorKind::Timeout,
            PlcError::Interrupted { .. } => DeviceErrorKind::Interrupted,
            PlcError::Aborted { .. } => DeviceErrorKind::Other,
            PlcError::Fault { .. }
            | PlcError::EStop { .. }
            | PlcError::NoContact { .. }
            | PlcError::Pairing { .. } => DeviceErrorKind::Fault,
            PlcError::Camera { kind, .. } => *kind,
            PlcError::Exception { .. } => DeviceErrorKind::Other,
        }
    }
}
