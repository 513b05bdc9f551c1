//! The PLC's side of the interface as gonio reads and writes it (docs/plc-interface.md): the
//! status word's [`bits`], the [`FaultCode`]s, the [`Command`]s of the command word and one read
//! of the status block ([`Status`]: PLC time in s, angles in degrees, lengths in µm).
//!
//! ```
//! use gonio_plc::protocol::{Command, FaultCode};
//! assert_eq!(Command::from_u16(Command::Push.to_u16()), Some(Command::Push));
//! assert_eq!(FaultCode::from_u16(5), FaultCode::TravelLimit);
//! ```

/// Status word bits.
pub mod bits {
    /// A command is running.
    pub const BUSY: u16 = 1 << 0;
    /// The acknowledged command has finished.
    pub const DONE: u16 = 1 << 1;
    /// A fault is latched (see the fault code); cleared by [`super::Command::ResetFault`].
    pub const FAULT: u16 = 1 << 2;
    /// The emergency stop is pressed.
    pub const ESTOP: u16 = 1 << 3;
    /// The watchdog on gonio's heartbeat expired (also a fault).
    pub const WATCHDOG: u16 = 1 << 4;
    /// A part is on the shaft, ready to mount.
    pub const PART_PRESENT: u16 = 1 << 5;
    /// The camera trigger is running.
    pub const TRIGGERING: u16 = 1 << 6;
    /// The PLC says it is a simulation (`gonio simulate station`): its parts are the digital
    /// twin's, and its camera runs free, paced by the PLC's exposures, with each frame's
    /// trigger count in its first pixels. A real PLC leaves it 0.
    pub const SIMULATED: u16 = 1 << 7;
}

/// The PLC's fault codes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum FaultCode {
    /// No fault.
    None,
    /// gonio's heartbeat stopped (watchdog).
    Watchdog,
    /// The servo drive faulted.
    ServoDrive,
    /// The push-rod drive faulted.
    RodDrive,
    /// The focus drive faulted.
    FocusDrive,
    /// The rod reached its travel limit without contact.
    TravelLimit,
    /// Emergency stop.
    EStop,
    /// A command word the PLC does not know, or a bad argument.
    BadCommand,
    /// A motion was asked with no part on the shaft.
    NoPart,
    /// Another code.
    Other(u16),
}

impl FaultCode {
    /// From the wire.
    pub fn from_u16(c: u16) -> Self {
        match c {
            0 => FaultCode::None,
            1 => FaultCode::Watchdog,
            2 => FaultCode::ServoDrive,
            3 => FaultCode::RodDrive,
            4 => FaultCode::FocusDrive,
            5 => FaultCode::TravelLimit,
            6 => FaultCode::EStop,
            7 => FaultCode::BadCommand,
            8 => FaultCode::NoPart,
            x => FaultCode::Other(x),
        }
    }

    /// To the wire.
    pub fn to_u16(self) -> u16 {
        match self {
            FaultCode::None => 0,
            FaultCode::Watchdog => 1,
            FaultCode::ServoDrive => 2,
            FaultCode::RodDrive => 3,
            FaultCode::FocusDrive => 4,
            FaultCode::TravelLimit => 5,
            FaultCode::EStop => 6,
            FaultCode::BadCommand => 7,
            FaultCode::NoPart => 8,
            FaultCode::Other(x) => x,
        }
    }

    /// What it means, for a message.
    pub fn describe(self) -> String {
        match self {
            FaultCode::None => "no fault".into(),
            FaultCode::Watchdog => "watchdog expired (gonio's heartbeat stopped)".into(),
            FaultCode::ServoDrive => "servo drive fault".into(),
            FaultCode::RodDrive => "push-rod drive fault".into(),
            FaultCode::FocusDrive => "focus drive fault".into(),
            FaultCode::TravelLimit => "push rod at its travel limit without contact".into(),
            FaultCode::EStop => "emergency stop".into(),
            FaultCode::BadCommand => "bad command or argument".into(),
            FaultCode::NoPart => "no part on the shaft".into(),
            FaultCode::Other(x) => format!("fault code {x}"),
        }
    }
}

/// The commands of the command word.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum Command {
    /// Nothing.
    None,
    /// Servo to `arg0` (angle counts), done when there and settled.
    MoveServo,
    /// Servo accelerates to `arg0` (speed counts), done when at speed; keeps turning.
    Turn,
    /// Servo decelerates to a stop, done when stopped.
    StopServo,
    /// Focus drive to `arg0` (length counts), done when there.
    MoveFocus,
    /// Rod: fast to `arg1` (length counts), then creeps at `arg0` (length counts per s) until
    /// [`Command::StopRod`] or the travel limit (fault). Busy while moving.
    Approach,
    /// Rod stops where it is (contact seen), done when stopped.
    StopRod,
    /// Rod pushes a further `arg0` (length counts), done when there.
    Push,
    /// Rod back home, done when there.
    Retract,
    /// Clears a latched fault (not while the e-stop is pressed).
    ResetFault,
    /// The part is finished: the PLC unloads it and loads the next (part present again).
    PartDone,
    /// Camera trigger at `arg0` (frames per 1000 s; 0 = off); the trigger count restarts at 0.
    Trigger,
}

impl Command {
    /// To the wire.
    pub fn to_u16(self) -> u16 {
        match self {
            Command::None => 0,
            Command::MoveServo => 1,
            Command::Turn => 2,
            Command::StopServo => 3,
            Command::MoveFocus => 4,
            Command::Approach => 5,
            Command::StopRod => 6,
            Command::Push => 7,
            Command::Retract => 8,
            Command::ResetFault => 9,
            Command::PartDone => 10,
            Command::Trigger => 11,
        }
    }

    /// From the wire.
    pub fn from_u16(c: u16) -> Option<Self> {
        Some(match c {
            0 => Command::None,
            1 => Command::MoveServo,
            2 => Command::Turn,
            3 => Command::StopServo,
            4 => Command::MoveFocus,
            5 => Command::Approach,
            6 => Command::StopRod,
            7 => Command::Push,
            8 => Command::Retract,
            9 => Command::ResetFault,
            10 => Command::PartDone,
            11 => Command::Trigger,
            _ => return None,
        })
    }
}

/// One read of the status block.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Status {
    /// The status word ([`bits`]).
    pub word: u16,
    /// The last acknowledged sequence.
    pub ack: u16,
    /// The fault code.
    pub fault: FaultCode,
    /// The PLC's heartbeat counter.
    pub heartbeat: u16,
    /// PLC time, s.
    pub time_s: f64,
    /// Servo angle, degrees.
    pub angle_deg: f64,
    /// Focus position, µm.
    pub focus_um: f64,
    /// Rod position, µm.
    pub rod_um: f64,
    /// Triggers since the trigger was switched on.
    pub trigger_count: u32,
    /// The part number on the shaft (1-based; 0 before the first).
    pub part: u32,
    /// Angle samples written so far.
    pub sample_count: u32,
    /// Servo speed, °/s.
    pub speed_deg_per_s: f64,
}

impl Status {
    /// A bit of the status word.
    pub fn has(&self, bit: u16) -> bool {
        self.word & bit != 0
    }
}
