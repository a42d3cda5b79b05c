//! The library's errors. Every message names what it is about (the file, the scene field, the
//! setting), and the kind tells a caller what to do: fix an input ([`Error::Invalid`], the errors
//! of the readers and models of `precompute`), look at the file system ([`Error::Io`]), or resume
//! an interrupted render ([`Error::Interrupted`]).
//!
//! `bail!`, `ensure!` and [`Context`] build them as `anyhow`'s namesakes would, so that a
//! message reads the same whichever way it is printed: a context and its cause on one line,
//! `context: cause`, never a cause twice.

use precompute::density::VdbError;
use precompute::fiber::ParamError;
use precompute::strands::{GenerateError, ReadError, StrandError};
use precompute::tables::TablesFormatError;
use std::fmt::Display;

/// What went wrong.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// An input that cannot be used: a scene field, a setting, a file's contents.
    #[error("{0}")]
    Invalid(String),
    /// The operating system refused a read or write.
    #[error(transparent)]
    Io(#[from] std::io::Error),
    /// The render was interrupted (Ctrl-C); the message says what was kept.
    #[error("{0}")]
    Interrupted(String),
    /// Fiber parameters out of range.
    #[error(transparent)]
    Fiber(#[from] ParamError),
    /// Hair that cannot be read, generated or used.
    #[error(transparent)]
    Hair(#[from] HairError),
    /// An OpenVDB file that cannot be read.
    #[error(transparent)]
    Vdb(#[from] VdbError),
    /// Dual-scattering tables that cannot be read.
    #[error(transparent)]
    Tables(#[from] TablesFormatError),
    /// A JSON file that does not parse.
    #[error(transparent)]
    Json(#[from] serde_json::Error),
    /// An EXR file that cannot be read or written.
    #[error(transparent)]
    Exr(#[from] exr::error::Error),
    /// A PNG or HDR image that cannot be read or written.
    #[error(transparent)]
    Image(#[from] image::ImageError),
    /// The worker threads could not start.
    #[error(transparent)]
    Threads(#[from] rayon::ThreadPoolBuildError),
    /// What was being done (`context`) when `cause` happened, printed `context: cause`.
    #[error("{context}: {cause}")]
    Context { context: String, cause: Box<Error> },
}

/// Text written into a `String` cannot fail; a report written with `write!` gets this for its `?`.
impl From<std::fmt::Error> for Error {
    fn from(e: std::fmt::Error) -> Error {
        Error::Io(std::io::Error::other(e))
    }
}

/// The errors of the hair readers and generators of `precompute`.
#[derive(Debug, thiserror::Error)]
pub enum HairError {
    #[error(transparent)]
    Read(#[from] ReadError),
    #[error(transparent)]
    Strand(#[from] StrandError),
    #[error(transparent)]
    Generate(#[from] GenerateError),
}

macro_rules! hair_error {
    ($($t:ty),*) => {$(
        impl From<$t> for Error {
            fn from(e: $t) -> Error {
                Error::Hair(e.into())
            }
        }
    )*};
}
hair_error!(ReadError, StrandError, GenerateError);

/// The library's results.
pub type Result<T, E = Error> = std::result::Result<T, E>;

/// Adds what was being done to an error (or turns a `None` into an error saying it).
pub trait Context<T> {
    fn context(self, context: impl Display) -> Result<T>;

    fn with_context<C: Display>(self, context: impl FnOnce() -> C) -> Result<T>;
}

impl<T, E: Into<Error>> Context<T> for std::result::Result<T, E> {
    fn context(self, context: impl Display) -> Result<T> {
        self.map_err(|e| Error::Context { context: context.to_string(), cause: Box::new(e.into()) })
    }

    fn with_context<C: Display>(self, context: impl FnOnce() -> C) -> Result<T> {
        self.map_err(|e| Error::Context { context: context().to_string(), cause: Box::new(e.into()) })
    }
}

impl<T> Context<T> for Option<T> {
    fn context(self, context: impl Display) -> Result<T> {
        self.ok_or_else(|| Error::Invalid(context.to_string()))
    }

    fn with_context<C: Display>(self, context: impl FnOnce() -> C) -> Result<T> {
        self.ok_or_else(|| Error::Invalid(context().to_string()))
    }
}

/// An [`Error::Invalid`] with a formatted message.
macro_rules! invalid {
    ($($arg:tt)*) => {
        $crate::error::Error::Invalid(format!($($arg)*))
    };
}

/// Returns an [`Error::Invalid`] with a formatted message.
macro_rules! bail {
    ($($arg:tt)*) => {
        return Err($crate::error::invalid!($($arg)*).into())
    };
}

/// Returns an [`Error::Invalid`] with a formatted message unless `cond` holds.
macro_rules! ensure {
    ($cond:expr, $($arg:tt)*) => {{
        // Bound first: `!` on a comparison of floats reads wrong (clippy).
        let holds: bool = $cond;
        if !holds {
            $crate::error::bail!($($arg)*);
        }
    }};
}

pub(crate) use {bail, ensure, invalid};

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_context_and_its_cause_print_once_on_one_line() {
        let io = std::io::Error::new(std::io::ErrorKind::NotFound, "no such file");
        let e = Err::<(), _>(io).context("a.json: cannot read").context("scene").unwrap_err();
        assert_eq!(e.to_string(), "scene: a.json: cannot read: no such file");
        // Printed through anyhow's chain (as the command line does), nothing repeats.
        assert_eq!(format!("{:#}", anyhow::Error::from(e)), "scene: a.json: cannot read: no such file");
        let none: Result<()> = None.context("no hair");
        assert!(matches!(none, Err(Error::Invalid(m)) if m == "no hair"));
    }
}
