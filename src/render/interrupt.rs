//! Ctrl-C and SIGTERM: the first asks the work in progress to stop at the next safe point (a
//! render drops its unfinished pass and writes the finished ones); a second ends the process at
//! once. Nothing is asked until [`install`] is called, so library users keep the default handling.

use std::sync::atomic::{AtomicBool, Ordering};

static REQUESTED: AtomicBool = AtomicBool::new(false);

/// The exit status of a process stopped by an interrupt: 128 + SIGINT, as shells report it.
pub const EXIT_STATUS: u8 = 130;

/// Installs the handler for SIGINT and SIGTERM (once per process; later calls do nothing).
pub fn install() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        let handler = || {
            if REQUESTED.swap(true, Ordering::SeqCst) {
                eprintln!("\ninterrupted again: stopping at once");
                std::process::exit(EXIT_STATUS.into());
            }
            eprintln!("\ninterrupted: stopping at the next safe point (interrupt again to stop at once)");
        };
        // Without a handler the default action (terminate) still stops the process; only the
        // finished passes are lost, so a failure here is not fatal.
        if let Err(e) = ctrlc::set_handler(handler) {
            eprintln!("warning: cannot catch Ctrl-C ({e}); an interrupt will lose the render");
        }
    });
}

/// Whether an interrupt has been asked for.
pub fn requested() -> bool {
    REQUESTED.load(Ordering::Relaxed)
}
