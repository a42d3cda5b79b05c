//! The commands' report on stdout.
//!
//! Rust ignores SIGPIPE, so `println!` panics when the reader of stdout has gone (`dualhair lobe
//! ... | head`). A command-line tool should end quietly there, and only after finishing the files
//! it writes: [`say!`] drops its line once stdout is closed and passes every other error on.

use std::io::{ErrorKind, Write};

/// Writes one line to stdout; a closed pipe is not an error (the line is dropped).
pub fn line(args: std::fmt::Arguments) -> std::io::Result<()> {
    let mut out = std::io::stdout().lock();
    match out.write_fmt(args).and_then(|()| out.write_all(b"\n")).and_then(|()| out.flush()) {
        Err(e) if e.kind() == ErrorKind::BrokenPipe => Ok(()),
        other => other,
    }
}

/// `println!` for the commands' report: `say!("wrote {}", path)?`, quiet on a closed stdout.
#[macro_export]
macro_rules! say {
    ($($arg:tt)*) => {
        $crate::cli::console::line(format_args!($($arg)*))
    };
}
