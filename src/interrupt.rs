//! Clean interrupts: the first SIGINT or SIGTERM asks the run to stop at its next Newton
//! iteration or step boundary (all ranks agree there, one reduction each); a second one ends the
//! process at once with the conventional code (128 + signal).

use mpi::collective::SystemOperation;
use mpi::topology::SimpleCommunicator;
use mpi::traits::*;
use signal_hook::consts::{SIGINT, SIGTERM};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{Arc, OnceLock};

/// This process's handlers, once installed.
static INSTALLED: OnceLock<Interrupts> = OnceLock::new();

/// Installs the handlers for this process (once; later calls return the first result).
pub fn install() -> std::io::Result<()> {
    if INSTALLED.get().is_some() {
        return Ok(());
    }
    let i = Interrupts::install()?;
    let _ = INSTALLED.set(i);
    Ok(())
}

/// The signal any rank received since [`install`] (none if not installed), the same on every rank.
///
/// Collective.
pub fn agreed(comm: &SimpleCommunicator) -> Option<i32> {
    match INSTALLED.get() {
        Some(i) => i.agreed(comm),
        None => Interrupts::none().agreed(comm),
    }
}

/// The signals that stop a run.
const SIGNALS: [i32; 2] = [SIGINT, SIGTERM];

/// Exit code of a process ended by `signal` (the shells' convention: 130 for SIGINT, 143 for
/// SIGTERM).
pub fn exit_code(signal: i32) -> u8 {
    (128 + signal).clamp(0, 255) as u8
}

/// The name of a stopping signal.
pub fn signal_name(signal: i32) -> &'static str {
    match signal {
        SIGINT => "SIGINT",
        SIGTERM => "SIGTERM",
        _ => "a signal",
    }
}

/// The stop request of this process, set by the signal handlers.
#[derive(Clone)]
pub struct Interrupts {
    requested: Arc<AtomicBool>,
    signal: Arc<AtomicUsize>,
}

impl Interrupts {
    /// Installs the handlers: a first SIGINT/SIGTERM records itself, a second ends the process at
    /// once with `128 + signal`.
    pub fn install() -> std::io::Result<Interrupts> {
        let requested = Arc::new(AtomicBool::new(false));
        let signal = Arc::new(AtomicUsize::new(0));
        for sig in SIGNALS {
            // Registered first, so it sees the flag as the earlier signal left it.
            signal_hook::flag::register_conditional_shutdown(
                sig,
                i32::from(exit_code(sig)),
                Arc::clone(&requested),
            )?;
            signal_hook::flag::register_usize(sig, Arc::clone(&signal), sig as usize)?;
            signal_hook::flag::register(sig, Arc::clone(&requested))?;
        }
        Ok(Interrupts { requested, signal })
    }

    /// A request that no signal sets (for tests and library use).
    pub fn none() -> Interrupts {
        Interrupts {
            requested: Arc::new(AtomicBool::new(false)),
            signal: Arc::new(AtomicUsize::new(0)),
        }
    }

    /// The signal this process received, if any (not collective).
    pub fn local(&self) -> Option<i32> {
        self.requested
            .load(Ordering::SeqCst)
            .then(|| self.signal.load(Ordering::SeqCst) as i32)
    }

    /// The signal any rank received (the largest number if they differ), the same on every rank.
    ///
    /// Collective.
    pub fn agreed(&self, comm: &SimpleCommunicator) -> Option<i32> {
        let mine = self.local().unwrap_or(0);
        let mut any = 0i32;
        comm.all_reduce_into(&mine, &mut any, SystemOperation::max());
        (any != 0).then_some(any)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exit_codes_follow_the_shell_convention() {
        assert_eq!(exit_code(SIGINT), 130);
        assert_eq!(exit_code(SIGTERM), 143);
        assert_eq!(signal_name(SIGTERM), "SIGTERM");
    }
}
