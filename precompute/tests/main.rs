//! The precompute crate's integration tests, in one test binary: each module was a binary of its
//! own, and shared helpers live in `common`. A test that needs a process of its own (environment
//! variables, the working directory, process-wide state) belongs in a `[[test]]` target of its
//! own in Cargo.toml instead; none does today.

mod common;

mod curves;
mod density;
mod deon2014;
mod fiber;
mod fibersim;
mod lobe;
mod marschner;
mod models;
mod sadeghi;
mod stability;
mod strands;
mod tables;
mod vdb;
