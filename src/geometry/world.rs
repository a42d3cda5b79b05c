//! What rays meet in a scene: the hair (`fibers.rs`) and the meshes (`meshes.rs`), one query for
//! both, so that every integrator and the forward-transmittance lookup see the same occluders.

use crate::geometry::meshes::{MeshHit, Meshes};
use crate::geometry::strands::{Fibers, Hit};
use glam::Vec3;

#[derive(Clone, Copy)]
pub struct World<'a> {
    pub fibers: &'a Fibers,
    pub meshes: &'a Meshes,
}

/// The first thing a ray meets.
#[derive(Clone, Copy, Debug)]
pub enum Surface {
    Fiber(Hit),
    Mesh(MeshHit),
}

impl World<'_> {
    /// The closest hit of hair or mesh along the ray within `t_max` (world units), if any.
    pub fn closest_hit(&self, origin: Vec3, dir: Vec3, t_max: f32) -> Option<Surface> {
        let fiber = self.fibers.closest_hit(origin, dir, t_max);
        let t_max = fiber.map_or(t_max, |h| h.t);
        match self.meshes.closest_hit(origin, dir, t_max) {
            Some(mesh) => Some(Surface::Mesh(mesh)),
            None => fiber.map(Surface::Fiber),
        }
    }

    /// The closest fiber hit, if no mesh is in front of it.
    pub fn closest_fiber(&self, origin: Vec3, dir: Vec3) -> Option<Hit> {
        match self.closest_hit(origin, dir, f32::INFINITY)? {
            Surface::Fiber(hit) => Some(hit),
            Surface::Mesh(_) => None,
        }
    }

    /// Whether hair or a mesh blocks the ray before `t_max` (world units).
    pub fn occluded(&self, origin: Vec3, dir: Vec3, t_max: f32) -> bool {
        self.meshes.occluded(origin, dir, t_max) || self.fibers.occluded(origin, dir, t_max)
    }
}
