//! Triangle meshes in a scene (a head under the hair): read from Wavefront OBJ files, each with a
//! diffuse (Lambertian) color, and a BVH (obvhs CwBvh) for ray queries beside the hair's.
//!
//! Surfaces are two-sided: a hit's normal faces the ray's origin, so a mesh need not be closed or
//! consistently wound. As for the hair (`fibers.rs`), the BVH works in fiber units (world
//! coordinates over the mean fiber radius), so that CwBvh's hard-coded 1e-4 cut-off is 1e-4 fiber
//! radii: a ray from a hair root at the scalp still meets the scalp. Callers see world units.
//! Triangles of zero area (which no ray can hit) are dropped when read.

use crate::error::{Context, Result, bail};
use glam::{DVec3, Vec3, Vec3A};
use obvhs::BvhBuildParams;
use obvhs::aabb::Aabb;
use obvhs::cwbvh::CwBvh;
use obvhs::ray::{Ray, RayHit};
use precompute::spectrum::Rgb;
use std::path::Path;
use std::time::Duration;

/// One mesh: triangles in world units and the diffuse albedo of its surface.
#[derive(Clone, Debug)]
pub struct Mesh {
    pub triangles: Vec<[Vec3; 3]>,
    pub albedo: Rgb,
}

/// A triangle as stored: a vertex and the two edges from it, world units, with its mesh.
#[derive(Clone, Copy, Debug)]
struct Stored {
    p0: Vec3,
    e1: Vec3,
    e2: Vec3,
    mesh: u32,
}

/// A ray-mesh hit, in world units.
#[derive(Clone, Copy, Debug)]
pub struct MeshHit {
    pub t: f32,
    pub point: Vec3,
    /// Unit geometric normal, on the side the ray came from.
    pub normal: Vec3,
    /// Diffuse albedo at the hit.
    pub albedo: Rgb,
}

/// The meshes of a scene, ready for ray queries (possibly none).
#[derive(Default)]
pub struct Meshes {
    bvh: Option<CwBvh>,
    /// Triangles in BVH leaf order.
    triangles: Vec<Stored>,
    albedos: Vec<Rgb>,
    /// World units to BVH units.
    scale: f64,
}

/// Ray-triangle intersection (Moller and Trumbore 1997) in f64: the distance along the unit
/// direction `d` to the hit, if there is one at `t > t_min`.
fn intersect(o: DVec3, d: DVec3, tri: &Stored, t_min: f64) -> Option<f64> {
    let (p0, e1, e2) = (tri.p0.as_dvec3(), tri.e1.as_dvec3(), tri.e2.as_dvec3());
    let p = d.cross(e2);
    let det = e1.dot(p);
    if det == 0.0 || !det.is_finite() {
        return None;
    }
    let inv = 1.0 / det;
    let s = o - p0;
    let u = s.dot(p) * inv;
    if !(0.0..=1.0).contains(&u) {
        return None;
    }
    let q = s.cross(e1);
    let v = d.dot(q) * inv;
    if v < 0.0 || u + v > 1.0 {
        return None;
    }
    let t = e2.dot(q) * inv;
    (t > t_min).then_some(t)
}

impl Meshes {
    /// Builds the BVH over every mesh's triangles; `scale` turns world units into the BVH's (the
    /// hair's: [`crate::geometry::strands::Fibers::scale`]).
    pub fn new(meshes: &[Mesh], scale: f64) -> Meshes {
        let all: Vec<Stored> = meshes
            .iter()
            .enumerate()
            .flat_map(|(m, mesh)| {
                mesh.triangles.iter().map(move |&[a, b, c]| Stored { p0: a, e1: b - a, e2: c - a, mesh: m as u32 })
            })
            .collect();
        let albedos = meshes.iter().map(|m| m.albedo).collect();
        if all.is_empty() {
            return Meshes { bvh: None, triangles: all, albedos, scale };
        }
        let aabbs: Vec<Aabb> = all
            .iter()
            .map(|t| {
                let corners = [t.p0, t.p0 + t.e1, t.p0 + t.e2].map(|p| p.as_dvec3() * scale);
                let (lo, hi) = (corners[0].min(corners[1]).min(corners[2]), corners[0].max(corners[1]).max(corners[2]));
                // Padded so the f32 box surely holds the f64 triangle.
                let pad = DVec3::splat(1e-6 * lo.abs().max(hi.abs()).max_element() + 1e-6);
                Aabb::new(Vec3A::from((lo - pad).as_vec3()), Vec3A::from((hi + pad).as_vec3()))
            })
            .collect();
        let mut build_time = Duration::ZERO;
        let bvh = obvhs::cwbvh::builder::build_cwbvh(&aabbs, BvhBuildParams::medium_build(), &mut build_time);
        let triangles = bvh.primitive_indices.iter().map(|&i| all[i as usize]).collect();
        Meshes { bvh: Some(bvh), triangles, albedos, scale }
    }

    pub fn is_empty(&self) -> bool {
        self.triangles.is_empty()
    }

    pub fn triangle_count(&self) -> usize {
        self.triangles.len()
    }

    /// Every triangle's vertices and its mesh's index, in a fixed order (for cache keys).
    pub fn triangles(&self) -> impl Iterator<Item = ([Vec3; 3], u32)> + '_ {
        self.triangles.iter().map(|t| ([t.p0, t.p0 + t.e1, t.p0 + t.e2], t.mesh))
    }

    /// The BVH's ray in its units, and the ray in world units in f64 (unit direction).
    fn rays(&self, origin: Vec3, dir: Vec3, t_max: f32) -> (Ray, DVec3, DVec3) {
        let (o, d) = (origin.as_dvec3(), dir.as_dvec3().normalize());
        let t_max = (t_max as f64 * self.scale) as f32;
        let ray = Ray::new(Vec3A::from((o * self.scale).as_vec3()), Vec3A::from(d.as_vec3()), 0.0, t_max);
        (ray, o, d)
    }

    /// The closest mesh hit along the ray within `t_max` (world units), if any.
    pub fn closest_hit(&self, origin: Vec3, dir: Vec3, t_max: f32) -> Option<MeshHit> {
        let bvh = self.bvh.as_ref()?;
        let (ray, o, d) = self.rays(origin, dir, t_max);
        let (mut hit, mut best) = (RayHit::none(), f64::INFINITY);
        bvh.ray_traverse(ray, &mut hit, |r, slot| match intersect(o, d, &self.triangles[slot], 0.0) {
            Some(t) if ((t * self.scale) as f32) < r.tmax => {
                best = t;
                (t * self.scale) as f32
            }
            _ => f32::INFINITY,
        });
        if hit.primitive_id == obvhs::ray::INVALID_ID {
            return None;
        }
        let tri = &self.triangles[hit.primitive_id as usize];
        let n = tri.e1.as_dvec3().cross(tri.e2.as_dvec3()).normalize();
        let normal = if n.dot(d) > 0.0 { -n } else { n };
        Some(MeshHit {
            t: best as f32,
            point: (o + best * d).as_vec3(),
            normal: normal.as_vec3(),
            albedo: self.albedos[tri.mesh as usize],
        })
    }

    /// Whether a mesh blocks the ray before `t_max` (world units).
    pub fn occluded(&self, origin: Vec3, dir: Vec3, t_max: f32) -> bool {
        let Some(bvh) = &self.bvh else { return false };
        let (ray, o, d) = self.rays(origin, dir, t_max);
        !bvh.ray_traverse_miss(ray, |r, slot| match intersect(o, d, &self.triangles[slot], 0.0) {
            Some(t) if ((t * self.scale) as f32) < r.tmax => (t * self.scale) as f32,
            _ => f32::INFINITY,
        })
    }
}

/// Where rays leave a mesh hit: off the surface on the ray's side, by a margin above the f32
/// rounding of the hit point, so they cannot hit the same triangle again.
pub fn spawn_point(hit: &MeshHit) -> Vec3 {
    hit.point + hit.normal * (1e-5 * hit.point.abs().max_element().max(1e-3))
}

/// The triangles of a Wavefront OBJ file (polygons split into triangles; points and lines
/// ignored), in the file's units. Errors name the file and say what is wrong.
pub fn read_obj(path: &Path) -> Result<Vec<[Vec3; 3]>> {
    let bytes = std::fs::read(path).with_context(|| format!("{}: cannot read it", path.display()))?;
    parse_obj(&bytes, path)
}

/// [`read_obj`] of a file's bytes; `path` is what errors name. Materials are not read: a mesh
/// here has one albedo from the scene, and an `mtllib` line could name any file (`/dev/zero`
/// never ends).
pub fn parse_obj(bytes: &[u8], path: &Path) -> Result<Vec<[Vec3; 3]>> {
    let options = tobj::LoadOptions { triangulate: true, ignore_points: true, ignore_lines: true, single_index: false };
    let no_materials = |_: &Path| Ok(Default::default());
    let (models, _materials) =
        tobj::load_obj_buf(&mut { bytes }, &options, no_materials).map_err(|e| obj_error(path, e))?;
    let mut triangles = Vec::new();
    for model in &models {
        let mesh = &model.mesh;
        let vertex = |i: u32| -> Result<Vec3> {
            let at = 3 * i as usize;
            let Some(p) = mesh.positions.get(at..at + 3) else {
                bail!(
                    "{}: object `{}` has a face with vertex index {} but only {} vertices",
                    path.display(),
                    model.name,
                    i + 1,
                    mesh.positions.len() / 3
                );
            };
            let p = Vec3::new(p[0], p[1], p[2]);
            if !p.is_finite() {
                bail!("{}: object `{}`: vertex {} is not finite: {p}", path.display(), model.name, i + 1);
            }
            Ok(p)
        };
        for face in mesh.indices.chunks_exact(3) {
            let t = [vertex(face[0])?, vertex(face[1])?, vertex(face[2])?];
            if (t[1] - t[0]).cross(t[2] - t[0]).length_squared() > 0.0 {
                triangles.push(t);
            }
        }
    }
    if triangles.is_empty() {
        bail!("{}: holds no triangle (an OBJ mesh needs `v` vertices and `f` faces)", path.display());
    }
    Ok(triangles)
}

/// tobj's error, said in terms of the file.
fn obj_error(path: &Path, e: tobj::LoadError) -> crate::error::Error {
    use tobj::LoadError::*;
    let problem = match e {
        ReadError => "cannot read it (not a text file?)".into(),
        PositionParseError => "a `v` line does not hold three numbers".into(),
        NormalParseError => "a `vn` line does not hold three numbers".into(),
        TexcoordParseError => "a `vt` line does not hold two numbers".into(),
        FaceParseError => "an `f` line is malformed".into(),
        FaceVertexOutOfBounds => "a face refers to a vertex that does not exist".into(),
        FaceTexCoordOutOfBounds => "a face refers to a texture coordinate that does not exist".into(),
        FaceNormalOutOfBounds => "a face refers to a normal that does not exist".into(),
        other => format!("invalid OBJ: {other}"),
    };
    crate::error::invalid!("{}: {problem}", path.display())
}
