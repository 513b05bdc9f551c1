//! Aborting a sequence to the safe state: the caller's [`Interrupt`] (the number of the signal
//! that asked the run to stop, set from outside, e.g. by a SIGINT handler's flag) and the
//! [`SafeState`] the link enters after a device error, an interrupt or the batch's end.
//!
//! In the safe state only the commands that leave the station safe are sent
//! ([`is_safe_command`]: retract, stop servo, stop rod, trigger off), and all of them together
//! wait at most `timing.safe_state_ms` (one deadline from the abort on, not a command timeout
//! each): a PLC that acknowledges commands but stays busy holds the run for one command timeout
//! plus that deadline. Past the deadline a safe command is still written, and given up after one
//! status read.
//!
//! ```
//! use gonio_plc::abort::{Interrupt, signal_name};
//! let stop = Interrupt::new();
//! assert_eq!(stop.signal(), None);
//! stop.raise(2);
//! stop.raise(15); // the first signal is kept
//! assert_eq!(stop.signal(), Some(2));
//! assert_eq!(signal_name(2), "SIGINT");
//! ```

use crate::protocol::Command;
use std::sync::Arc;
use std::sync::atomic::{AtomicI32, Ordering};
use std::time::{Duration, Instant};

/// A request from outside to stop the run: the signal's number once one came (0 before).
#[derive(Debug, Clone, Default)]
pub struct Interrupt(Arc<AtomicI32>);

impl Interrupt {
    /// No interrupt yet.
    pub fn new() -> Self {
        Interrupt::default()
    }

    /// The flag itself, for a handler that stores the signal's number into it (0: none yet).
    pub fn flag(&self) -> Arc<AtomicI32> {
        self.0.clone()
    }

    /// Asks the run to stop because of `signal` (only the first request is kept).
    pub fn raise(&self, signal: i32) {
        let _ = self
            .0
            .compare_exchange(0, signal.max(1), Ordering::AcqRel, Ordering::Acquire);
    }

    /// The signal that asked the run to stop, if one did.
    pub fn signal(&self) -> Option<i32> {
        match self.0.load(Ordering::Acquire) {
            0 => None,
            s => Some(s),
        }
    }
}

/// A signal's usual name (`SIGINT` for 2, `SIGTERM` for 15), or `signal N`.
pub fn signal_name(signal: i32) -> String {
    match signal {
        1 => "SIGHUP".into(),
        2 => "SIGINT".into(),
        3 => "SIGQUIT".into(),
        15 => "SIGTERM".into(),
        n => format!("signal {n}"),
    }
}

/// Whether `cmd` with first argument `arg0` leaves the station safe (sent in the safe state).
pub fn is_safe_command(cmd: Command, arg0: i32) -> bool {
    match cmd {
        Command::Retract | Command::StopServo | Command::StopRod | Command::None => true,
        Command::Trigger => arg0 == 0,
        _ => false,
    }
}

/// The link's safe state: its deadline and the safe commands done since it began.
#[derive(Debug, Clone)]
pub struct SafeState {
    deadline: Instant,
    budget: Duration,
    done: Vec<(Command, i32)>,
}

impl SafeState {
    /// The safe state from now on, its commands within `budget`.
    pub fn begin(budget: Duration) -> Self {
        SafeState {
            deadline: Instant::now() + budget,
            budget,
            done: Vec::new(),
        }
    }

    /// When the safe-state commands are given up.
    pub fn deadline(&self) -> Instant {
        self.deadline
    }

    /// The whole time the safe-state commands have.
    pub fn budget(&self) -> Duration {
        self.budget
    }

    /// `cmd` (with `arg0`) finished in the safe state.
    pub fn done(&mut self, cmd: Command, arg0: i32) {
        if !self.was_done(cmd, arg0) {
            self.done.push((cmd, arg0));
        }
    }

    /// Whether `cmd` (with `arg0`) finished since the safe state began.
    pub fn was_done(&self, cmd: Command, arg0: i32) -> bool {
        self.done.contains(&(cmd, arg0))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_the_commands_that_leave_the_station_safe_are_safe() {
        for (cmd, arg0, safe) in [
            (Command::Retract, 0, true),
            (Command::StopServo, 0, true),
            (Command::StopRod, 0, true),
            (Command::Trigger, 0, true),
            (Command::Trigger, 100_000, false),
            (Command::MoveServo, 0, false),
            (Command::Turn, 0, false),
            (Command::Approach, 0, false),
            (Command::Push, 0, false),
            (Command::MoveFocus, 0, false),
            (Command::PartDone, 0, false),
            (Command::ResetFault, 0, false),
        ] {
            assert_eq!(is_safe_command(cmd, arg0), safe, "{cmd:?} {arg0}");
        }
    }

    #[test]
    fn the_safe_state_remembers_what_it_did_within_one_deadline() {
        let t = Instant::now();
        let mut s = SafeState::begin(Duration::from_millis(1500));
        assert!(s.deadline() >= t + Duration::from_millis(1500));
        assert!(s.deadline() <= Instant::now() + Duration::from_millis(1500));
        assert!(!s.was_done(Command::Retract, 0));
        s.done(Command::Retract, 0);
        s.done(Command::Retract, 0);
        assert!(s.was_done(Command::Retract, 0));
        assert!(!s.was_done(Command::Trigger, 0));
        assert_eq!(s.done.len(), 1);
    }

    #[test]
    fn an_interrupt_keeps_its_first_signal_and_is_shared_by_its_clones() {
        let i = Interrupt::new();
        let j = i.clone();
        assert_eq!(j.signal(), None);
        i.flag().store(15, Ordering::Release);
        assert_eq!(j.signal(), Some(15));
        j.raise(2);
        assert_eq!(i.signal(), Some(15));
        assert_eq!(signal_name(15), "SIGTERM");
        assert_eq!(signal_name(9), "signal 9");
    }
}
