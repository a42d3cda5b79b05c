//! dualhair: a hair renderer that makes multiple scattering cheap.
//!
//! The renderer as a library, in the order a render flows: a [`scene`] file describes the hair,
//! meshes, [`camera`] and [`lights`]; [`geometry`] holds the strands' BVH and the meshes;
//! [`integrators`] estimate the light along camera rays (`single`, `path`, and `dual` with what it
//! precomputes); the [`render`] loop adds samples into sums that the [`film`] turns into images,
//! written by [`output`]. [`analysis`] holds the comparison tools built on it (convergence runs,
//! calibration, stability, lobe images, image metrics and charts). The fiber models and
//! everything precomputed from them live in the `precompute` crate; the `dualhair` binary
//! (`src/main.rs`, `src/cli/`) parses arguments and prints.

pub mod analysis;
pub mod camera;
pub mod error;
pub mod film;
pub mod fingerprint;
pub mod geometry;
pub mod integrators;
pub mod job;
pub mod lights;
pub mod memory;
pub mod output;
pub mod progress;
pub mod render;
pub mod sampler;
pub mod scene;
