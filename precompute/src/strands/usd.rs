//! Hair from USD: every `BasisCurves` prim of a `.usda`, `.usdc`, `.usd` or `.usdz` stage becomes
//! strands, in world space (Pixar's UsdGeomBasisCurves schema, openusd.org/dev/api/class_usd_geom_basis_curves.html).
//!
//! Read at the stage's start time code: `points`, `curveVertexCounts`, `widths` (with their
//! interpolation: `constant`, `uniform` (per curve), `varying` (per segment end) or `vertex`; 1
//! where unauthored, as Hydra does), `type`, `basis` and `wrap`, and the prim's local-to-world
//! transform composed through its ancestors' xformOps. Linear curves are polylines as they are;
//! cubic ones (`bezier`, `bspline`, `catmullRom`; `nonperiodic` or `pinned`, whose phantom end
//! points 2 P_0 - P_1 make the curve reach its end points) are turned into Bezier segments and
//! cut as pbrt's are (`curves.rs`). Widths scale by the cube root of the transform's determinant.
//! Periodic curves and other prim types (`NurbsCurves`, `HermiteCurves`) are not read. Units and
//! the up axis are the file's: scene files scale and rotate hair (Blender writes Z up, meters).

use super::Strands;
use super::curves::{append_strand, bspline_to_bezier};
use glam::{DMat4, DVec3};
use openusd::schemas::geom::{self, Curves, Imageable, PointBased, Xformable};
use openusd::usd::{self, Prim, SchemaBase, SchemaKind, Stage, TimeCode};
use openusd::{ar, gf, sdf, tf};
use std::path::{Path, PathBuf};

/// A USD file that cannot be read as hair; the message names the file and, where it is one
/// prim's problem, the prim.
#[derive(Debug, thiserror::Error)]
pub enum UsdError {
    #[error("cannot read {}: {problem}", path.display())]
    Stage { path: PathBuf, problem: String },
    #[error("{}: {prim}: {problem}", path.display())]
    Prim { path: PathBuf, prim: String, problem: String },
    #[error("{}: holds no BasisCurves prim", path.display())]
    NoCurves { path: PathBuf },
}

/// Reads every `BasisCurves` prim of a USD stage (and the layers it composes) as strands.
pub fn read_usd_curves(path: &Path) -> Result<Strands, UsdError> {
    let stage = Stage::open(&path.to_string_lossy())
        .map_err(|e| UsdError::Stage { path: path.to_owned(), problem: text(e) })?;
    curves(&stage, path)
}

/// [`read_usd_curves`] of a file held in memory as `name` (its extension gives the format): the
/// only file there is, so every layer it refers to is missing (the fuzz target's confinement).
pub fn parse_usd_curves(name: &str, bytes: &[u8]) -> Result<Strands, UsdError> {
    let resolver = OneFile { name: name.to_owned(), bytes: bytes.to_vec() };
    let stage = Stage::builder()
        .resolver(resolver)
        .open(name)
        .map_err(|e| UsdError::Stage { path: name.into(), problem: text(e) })?;
    curves(&stage, Path::new(name))
}

/// A resolver that knows one file, held in memory.
struct OneFile {
    name: String,
    bytes: Vec<u8>,
}

impl ar::Resolver for OneFile {
    fn create_identifier(&self, asset_path: &str, _anchor: Option<&ar::ResolvedPath>) -> String {
        asset_path.to_owned()
    }

    fn resolve(&self, asset_path: &str) -> Option<ar::ResolvedPath> {
        (asset_path == self.name).then(|| ar::ResolvedPath::new(asset_path))
    }

    fn resolve_for_new_asset(&self, _asset_path: &str) -> Option<ar::ResolvedPath> {
        None
    }

    fn open_asset(&self, resolved: &ar::ResolvedPath) -> std::io::Result<Box<dyn ar::Asset>> {
        match resolved.to_str() == Some(self.name.as_str()) {
            true => Ok(Box::new(std::io::Cursor::new(self.bytes.clone()))),
            false => Err(std::io::ErrorKind::NotFound.into()),
        }
    }
}

/// An error of the USD crate with its causes.
fn text(e: impl std::fmt::Display) -> String {
    format!("{e:#}")
}

/// Any prim as an `Xformable`, so that ancestors of every type (Xform, Scope, ...) compose.
struct AnyXformable(Prim);

impl SchemaBase for AnyXformable {
    const KIND: SchemaKind = SchemaKind::AbstractTyped;
    fn prim(&self) -> &Prim {
        &self.0
    }
}
impl Imageable for AnyXformable {}
impl Xformable for AnyXformable {}

/// Local-to-world of the prim at `path`: its xformOps, then its parents' up to the root or to a
/// prim that resets the transform stack. USD's matrices act on row vectors (p M, translation in
/// the last row), which is glam's column-major layout for column vectors.
fn local_to_world(stage: &Stage, path: &sdf::Path, t: TimeCode) -> Result<DMat4, String> {
    let mut m = gf::Matrix4d::IDENTITY;
    let mut at = Some(path.clone());
    while let Some(p) = at.filter(|p| !p.is_abs_root()) {
        let x = AnyXformable(stage.prim(p.clone()));
        // openusd 0.6 loops forever on an op that is not an attribute name ("xformOp:scale}").
        for op in x.xform_op_order().map_err(text)?.unwrap_or_default() {
            if !is_op_name(&op) {
                return Err(format!("{}: xformOpOrder holds {op:?}, which names no transform op", p.as_str()));
            }
        }
        m = m * x.local_to_parent_transform(t).map_err(text)?;
        if x.resets_xform_stack().map_err(text)? {
            break;
        }
        at = p.parent();
    }
    Ok(DMat4::from_cols_array(&m.0))
}

/// Whether `s` is a USD identifier: a letter or underscore, then letters, digits and underscores.
fn identifier(s: &str) -> bool {
    s.chars().next().is_some_and(|c| c.is_ascii_alphabetic() || c == '_')
        && s.chars().all(|c| c.is_ascii_alphanumeric() || c == '_')
}

/// Whether an entry of `xformOpOrder` is `!resetXformStack!` or names an op attribute: an
/// optional `!invert!`, then `xformOp:` and identifiers joined by colons.
fn is_op_name(op: &str) -> bool {
    op == "!resetXformStack!"
        || op
            .strip_prefix("!invert!")
            .unwrap_or(op)
            .strip_prefix("xformOp:")
            .is_some_and(|rest| rest.split(':').all(identifier))
}

/// Whether a path names its prims by identifiers (`/A/B`, relative `../A`, with variant
/// selections `{set=variant}`; what follows a `.` or `[` is left to openusd): openusd 0.6 loops
/// or recurses without end composing a prim named `Ze}a` or a reference to `</C}x>`.
fn is_prim_path(path: &str) -> bool {
    let mut rest = path.strip_prefix('/').unwrap_or(path);
    while let Some(up) = rest.strip_prefix("..") {
        rest = up.strip_prefix('/').unwrap_or(up);
    }
    let prims = rest.split(['.', '[']).next().unwrap_or_default();
    prims.is_empty()
        || prims.split('/').all(|element| {
            let mut parts = element.split('{');
            identifier(parts.next().unwrap_or_default())
                && parts.all(|v| {
                    v.strip_suffix('}')
                        .and_then(|v| v.split_once('='))
                        .is_some_and(|(set, variant)| identifier(set) && (variant.is_empty() || identifier(variant)))
                })
        })
}

/// The first path in `layer`, among its specs and the targets of their composition arcs and
/// relationships, that [`is_prim_path`] refuses.
fn bad_path(layer: &sdf::Layer) -> Option<String> {
    let data = layer.data();
    let mut specs = data.spec_paths();
    specs.sort_by(|a, b| a.as_str().cmp(b.as_str()));
    for spec in specs {
        // A prim named "" collapses into the root: its properties are the root's ("/.points").
        if !is_prim_path(spec.as_str()) || spec.as_str().starts_with("/.") {
            return Some(format!("{:?}", spec.as_str()));
        }
        for field in data.list_fields(&spec).unwrap_or_default() {
            let Ok(Some(value)) = data.try_field(&spec, &field) else { continue };
            if let sdf::Value::TokenVec(children) = value.as_ref()
                && field == "primChildren"
                && let Some(bad) = children.iter().find(|c| !identifier(c.as_str()))
            {
                return Some(format!("{}'s child {:?}", spec.as_str(), bad.as_str()));
            }
            let targets: Vec<sdf::Path> = match value.as_ref() {
                sdf::Value::PathListOp(op) => op.flatten(),
                sdf::Value::PathVec(v) => v.clone(),
                sdf::Value::ReferenceListOp(op) => op.flatten().into_iter().map(|r| r.prim_path).collect(),
                sdf::Value::PayloadListOp(op) => op.flatten().into_iter().map(|p| p.prim_path).collect(),
                sdf::Value::Payload(p) => vec![p.prim_path.clone()],
                _ => continue,
            };
            if let Some(bad) = targets.iter().find(|t| !is_prim_path(t.as_str())) {
                return Some(format!("{}'s {field} {:?}", spec.as_str(), bad.as_str()));
            }
        }
    }
    None
}

fn curves(stage: &Stage, path: &Path) -> Result<Strands, UsdError> {
    let t = TimeCode::new(stage.start_time_code());
    let stage_error = |e| UsdError::Stage { path: path.to_owned(), problem: text(e) };
    for id in stage.layer_identifiers() {
        let Some(layer) = stage.layer(&id) else { continue };
        if let Some(bad) = bad_path(&layer) {
            let layer = if Path::new(&id) == path { String::new() } else { format!(" (in {id})") };
            let problem = format!("{bad} is not a prim path{layer}");
            return Err(UsdError::Stage { path: path.to_owned(), problem });
        }
    }
    let mut prims = Vec::new();
    stage.traverse(usd::PrimPredicate::DEFAULT, |p| prims.push(p.clone())).map_err(stage_error)?;
    let mut strands = Strands { offsets: vec![0], ..Strands::default() };
    let mut found = false;
    for prim in prims {
        let Some(c) = geom::BasisCurves::get(stage, prim.clone()).map_err(stage_error)? else { continue };
        found = true;
        let error = |problem: String| UsdError::Prim { path: path.to_owned(), prim: prim.as_str().to_owned(), problem };
        prim_strands(stage, &c, &prim, t, &mut strands).map_err(error)?;
    }
    if !found {
        return Err(UsdError::NoCurves { path: path.to_owned() });
    }
    Ok(strands)
}

/// The curves of one prim, appended to `strands`.
fn prim_strands(
    stage: &Stage,
    c: &geom::BasisCurves,
    prim: &sdf::Path,
    t: TimeCode,
    strands: &mut Strands,
) -> Result<(), String> {
    let counts: Vec<i32> = match c.curve_vertex_counts_attr().get_at::<sdf::Value>(t).map_err(text)? {
        Some(sdf::Value::IntVec(v)) => v,
        None => return Err("no curveVertexCounts".into()),
        Some(other) => return Err(format!("curveVertexCounts is not an int[]: {other:?}")),
    };
    let points: Vec<gf::Vec3f> = c.points_attr().get_at(t).map_err(text)?.unwrap_or_default();
    let widths: Vec<f32> = c.widths_attr().get_at(t).map_err(text)?.unwrap_or_default();
    let token = |a: Option<tf::Token>, default: &str| a.map_or(default.to_owned(), |t| t.as_str().to_owned());
    let interpolation = token(c.widths_attr().get_metadata("interpolation").map_err(text)?, "vertex");
    let kind = token(c.type_attr().get().map_err(text)?, "cubic");
    let basis = token(c.basis_attr().get().map_err(text)?, "bezier");
    let wrap = token(c.wrap_attr().get().map_err(text)?, "nonperiodic");
    let total: u64 = counts.iter().map(|&n| n.max(0) as u64).sum();
    if counts.iter().any(|&n| n < 0) || total != points.len() as u64 {
        return Err(format!("curveVertexCounts add up to {total}, but there are {} points", points.len()));
    }
    if wrap == "periodic" {
        return Err("periodic (closed) curves are not hair".into());
    }
    if !["nonperiodic", "pinned"].contains(&wrap.as_str()) {
        return Err(format!("unknown wrap \"{wrap}\""));
    }
    let m = local_to_world(stage, prim, t)?;
    let scale = m.determinant().abs().cbrt();
    let world: Vec<DVec3> =
        points.iter().map(|p| m.transform_point3(DVec3::new(p.x as f64, p.y as f64, p.z as f64))).collect();
    // Per curve: its Bezier segments as (control points, index of the width at its start and end
    // among the curve's vertices, and among its segment ends).
    let mut first = 0;
    let mut segment_ends = 0; // varying widths seen so far
    let widths_of = |n: usize, total: usize, curves: usize| match interpolation.as_str() {
        "constant" => 1,
        "uniform" => curves,
        "varying" | "faceVarying" => total,
        _ => n,
    };
    let varying_total: usize =
        counts.iter().map(|&n| segments(&kind, &basis, &wrap, n as usize).map_or(0, |s| s + 1)).sum();
    let expected = widths_of(points.len(), varying_total, counts.len());
    if !widths.is_empty() && widths.len() != expected {
        return Err(format!("{} widths, where {interpolation} interpolation takes {expected}", widths.len()));
    }
    for (curve, &n) in counts.iter().enumerate() {
        let n = n as usize;
        let p = &world[first..first + n];
        let count = segments(&kind, &basis, &wrap, n).map_err(|e| format!("curve {curve}: {e}"))?;
        // The width at vertex v of this curve, or at segment end e.
        let width = |v: usize, e: usize| -> f64 {
            let w = match interpolation.as_str() {
                _ if widths.is_empty() => 1.0,
                "constant" => widths[0],
                "uniform" => widths[curve],
                "varying" | "faceVarying" => widths[segment_ends + e],
                _ => widths[first + v],
            };
            0.5 * w as f64 * scale
        };
        let pinned = wrap == "pinned";
        let mut list = Vec::with_capacity(count);
        for s in 0..count {
            let (bezier, v0, v1) = match (kind.as_str(), basis.as_str()) {
                ("linear", _) => (vec![p[s], p[s + 1]], s, s + 1),
                (_, "bezier") => (p[3 * s..=3 * s + 3].to_vec(), 3 * s, 3 * s + 3),
                (_, b) => {
                    // Four consecutive points, with phantoms beyond the ends where pinned.
                    let at = |i: isize| -> DVec3 {
                        match i {
                            -1 => 2.0 * p[0] - p[1],
                            i if i as usize == n => 2.0 * p[n - 1] - p[n - 2],
                            i => p[i as usize],
                        }
                    };
                    let o = if pinned { s as isize - 1 } else { s as isize };
                    let q = [at(o), at(o + 1), at(o + 2), at(o + 3)];
                    let bezier = match b {
                        "bspline" => bspline_to_bezier(&q),
                        // Uniform Catmull-Rom from q1 to q2, in Bezier form.
                        _ => vec![q[1], q[1] + (q[2] - q[0]) / 6.0, q[2] - (q[3] - q[1]) / 6.0, q[2]],
                    };
                    (bezier, (o + 1) as usize, (o + 2) as usize)
                }
            };
            list.push((bezier, width(v0, s), width(v1, s + 1)));
        }
        append_strand(strands, &list).map_err(|e| format!("curve {curve}: {e}"))?;
        first += n;
        segment_ends += count + 1;
    }
    Ok(())
}

/// How many segments a curve of `n` vertices has.
fn segments(kind: &str, basis: &str, wrap: &str, n: usize) -> Result<usize, String> {
    match (kind, basis) {
        ("linear", _) if n >= 2 => Ok(n - 1),
        ("linear", _) => Err(format!("{n} vertices: a linear curve takes at least 2")),
        ("cubic", "bezier") if n >= 4 && (n - 4).is_multiple_of(3) => Ok((n - 1) / 3),
        ("cubic", "bezier") => Err(format!("{n} vertices: a cubic Bezier curve takes 4 + 3 k")),
        ("cubic", "bspline" | "catmullRom") if wrap == "pinned" && n >= 2 => Ok(n - 1),
        ("cubic", "bspline" | "catmullRom") if n >= 4 => Ok(n - 3),
        ("cubic", "bspline" | "catmullRom") => Err(format!("{n} vertices: a cubic {basis} curve takes at least 4")),
        ("cubic", other) => Err(format!("unknown basis \"{other}\" (bezier, bspline or catmullRom)")),
        (other, _) => Err(format!("unknown type \"{other}\" (linear or cubic)")),
    }
}
