//! SIGINT (Ctrl-C) and SIGTERM during a render: the handler only records
//! the signal; the render looks for it between chunks of samples
//! (`twintrace::render::Chunking`), writes the samples done as a partial
//! film and exits with 128 + the signal's number (130, 143). A second
//! signal ends the process at once with that status: files already
//! written stay whole (every output is renamed into place complete), and
//! a write in progress leaves at most its hidden temporary file.
//!
//! Linux only (through `libc`); elsewhere nothing is installed and the
//! signals keep their default action.

use std::sync::atomic::{AtomicI32, Ordering};

/// The first signal received, 0 for none.
static RECEIVED: AtomicI32 = AtomicI32::new(0);

/// A signal the render was stopped by.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Signal(i32);

impl Signal {
    /// `SIGINT` or `SIGTERM`.
    pub fn name(self) -> &'static str {
        #[cfg(target_os = "linux")]
        if self.0 == libc::SIGINT {
            return "SIGINT";
        }
        "SIGTERM"
    }

    /// The exit status a shell gives a process the signal ended: 128 + its
    /// number (SIGINT 130, SIGTERM 143).
    pub fn exit_code(self) -> u8 {
        (128 + self.0).clamp(0, 255) as u8
    }
}

/// The signal received since [`install`], if any.
pub fn received() -> Option<Signal> {
    match RECEIVED.load(Ordering::SeqCst) {
        0 => None,
        n => Some(Signal(n)),
    }
}

/// Installs the handler of SIGINT and SIGTERM for the rest of the process.
#[cfg(target_os = "linux")]
pub fn install() -> anyhow::Result<()> {
    for signal in [libc::SIGINT, libc::SIGTERM] {
        // SAFETY: `on_signal` is async-signal-safe (an atomic swap, and on
        // a second signal write(2) and _exit(2)); the sigaction struct is
        // zeroed and filled as sigaction(2) documents. SA_RESTART: the
        // render's threads' system calls are not cut short.
        let failed = unsafe {
            let mut action: libc::sigaction = std::mem::zeroed();
            action.sa_sigaction = on_signal as extern "C" fn(libc::c_int) as libc::sighandler_t;
            action.sa_flags = libc::SA_RESTART;
            libc::sigemptyset(&mut action.sa_mask);
            libc::sigaction(signal, &action, std::ptr::null_mut()) != 0
        };
        if failed {
            anyhow::bail!(
                "cannot install the interrupt handler: {}",
                std::io::Error::last_os_error()
            );
        }
    }
    Ok(())
}

#[cfg(not(target_os = "linux"))]
pub fn install() -> anyhow::Result<()> {
    Ok(())
}

#[cfg(target_os = "linux")]
extern "C" fn on_signal(signal: libc::c_int) {
    let first = RECEIVED.compare_exchange(0, signal, Ordering::SeqCst, Ordering::SeqCst);
    if first.is_err() {
        const LINE: &[u8] =
            b"\ninterrupted again: exiting at once (files written before are intact)\n";
        // SAFETY: write(2) and _exit(2) are async-signal-safe; the buffer
        // is a static.
        unsafe {
            libc::write(2, LINE.as_ptr().cast(), LINE.len());
            libc::_exit(128 + signal);
        }
    }
}
