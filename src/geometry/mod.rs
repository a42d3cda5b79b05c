//! What rays hit: the strands (capsules in a BVH), triangle meshes, and the world of both.

pub mod meshes;
pub mod strands;
pub mod world;
