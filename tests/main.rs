//! The integration tests of the `dualhair` crate, as one test binary (one link of the crate,
//! not one per file): each module is one area, `common` holds the helpers they share.

mod common;

mod blender_export;
mod calibrate;
mod converge;
mod convert_cli;
mod cycles;
mod dual;
mod fibers;
mod fibersim_cli;
mod fuzz_replay;
mod layout;
mod lobe_cli;
mod lookup;
mod meshes;
mod pipes;
mod precompute_cli;
mod render;
mod split;
mod stability_cli;
