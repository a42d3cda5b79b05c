//! dualhair: a hair renderer that makes multiple scattering cheap.
//!
//! This crate is the renderer side: command-line arguments, image output and the commands of the
//! `dualhair` binary. The fiber models and everything precomputed from them live in the
//! `precompute` crate.

pub mod cache;
pub mod calibrate_cmd;
pub mod camera;
pub mod compare;
pub mod compare_cmd;
pub mod console;
pub mod converge_cmd;
pub mod convert_cmd;
pub mod dual;
pub mod fiber_args;
pub mod fibers;
pub mod fibersim_cmd;
pub mod film;
pub mod integrator;
pub mod interrupt;
pub mod light;
pub mod lobe_cmd;
pub mod memory;
pub mod merge_cmd;
pub mod meshes;
pub mod output;
pub mod partial;
pub mod plot;
pub mod precompute_cmd;
pub mod render;
pub mod render_cmd;
pub mod resolve_cmd;
pub mod sampler;
pub mod scene;
pub mod stability_cmd;
pub mod tables_chart;
pub mod transmittance;
pub mod world;
