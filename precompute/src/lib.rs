//! The hair side of dualhair: everything that depends on fibers but not on a camera or lights.
//!
//! This crate holds the single-fiber scattering models (BCSDFs) and their samplers behind one
//! interface ([`fiber::FiberModel`]), the conventions they share ([`conventions`]), and the
//! quantities precomputed from them. It knows nothing about scenes, cameras or images; the
//! renderer crate (`dualhair`) builds on it.

pub mod conventions;
pub mod density;
pub mod fiber;
pub mod fibersim;
pub mod lobe;
pub mod quadrature;
pub mod special;
pub mod spectrum;
pub mod stability;
pub mod strands;
pub mod tables;
