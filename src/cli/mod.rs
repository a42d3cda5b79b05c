//! The `dualhair` command line: one file per command, each parsing its flags, calling the
//! library and printing what it did; [`progress`] draws the library's progress reports.

pub mod calibrate;
pub mod compare;
pub mod console;
pub mod converge;
pub mod convert;
pub mod fiber_args;
pub mod fibersim;
pub mod lobe;
pub mod merge;
pub mod precompute;
pub mod progress;
pub mod render;
pub mod resolve;
pub mod stability;

use clap::builder::{PossibleValue, PossibleValuesParser, TypedValueParser};
use dualhair::integrators::Choice;

/// The parser of a flag that takes one of the library's [`Choice`]s by name, with each choice's
/// description in `--help`.
pub fn choice<T: Choice + Clone>() -> impl TypedValueParser<Value = T> {
    let values = T::choices().into_iter().map(|(_, name, help)| PossibleValue::new(name).help(help.trim()));
    PossibleValuesParser::new(values).map(|name| T::named(&name).expect("clap accepts only the choices' names"))
}
