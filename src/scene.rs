//! Scene files: JSON describing the hair, the fiber, the camera, the lights and the render
//! settings. Every section but `hair` may be left out, and every field has a default (docs/usage.md, "Scene files").
//! Unknown fields are errors; bad values are errors that name the field.

use crate::camera::Camera;
use crate::error::{Context, Result, bail, ensure};
use crate::film::Film;
use crate::geometry::meshes::{Mesh, Meshes, read_obj};
use crate::geometry::strands::{BUILD_BYTES_PER_SEGMENT, Fibers};
use crate::geometry::world::World;
use crate::integrators::dual::options::{DualSpec, MAX_LIGHT_SAMPLES, ShadowMode};
use crate::integrators::dual::{DualModel, Transmittance};
use crate::integrators::{IntegratorKind, Sampling};
use crate::lights::{EnvMap, Environment, Lights, Sun};
use crate::memory;
use crate::render::SUM_CEILING;
use glam::{DMat4, DVec3, EulerRot};
use precompute::fiber::{FiberParams, ModelKind};
use precompute::spectrum::Rgb;
use precompute::strands::{Generator, HairFormat, Strands, read_strands};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

#[derive(Serialize, Deserialize, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct SceneFile {
    pub hair: HairSpec,
    #[serde(default)]
    pub fiber: FiberParams,
    #[serde(default)]
    pub camera: CameraSpec,
    #[serde(default)]
    pub lights: LightsSpec,
    #[serde(default)]
    pub render: RenderSpec,
    #[serde(default)]
    pub dual: DualSpec,
    /// Triangle meshes (a head): occluders and diffuse surfaces beside the hair.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub meshes: Vec<MeshSpec>,
}

/// A Wavefront OBJ mesh with a diffuse (Lambertian) surface of albedo `color` (each in [0, 1]),
/// scaled, rotated (XYZ Euler angles in degrees) and translated as `hair` is.
#[derive(Serialize, Deserialize, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct MeshSpec {
    pub file: PathBuf,
    #[serde(default = "mid_grey")]
    pub color: [f64; 3],
    #[serde(default = "one")]
    pub scale: f64,
    #[serde(default)]
    pub rotate: [f64; 3],
    #[serde(default)]
    pub translate: [f64; 3],
}

fn mid_grey() -> [f64; 3] {
    [0.5; 3]
}

/// The hair: a .hair file or a generator, then scaled, rotated (XYZ Euler angles in degrees) and
/// translated, in that order; `radius` replaces every fiber radius (after scaling).
#[derive(Serialize, Deserialize, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct HairSpec {
    #[serde(skip_serializing_if = "Option::is_none")]
    pub file: Option<PathBuf>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub generate: Option<Generator>,
    #[serde(default = "one")]
    pub scale: f64,
    #[serde(default)]
    pub rotate: [f64; 3],
    #[serde(default)]
    pub translate: [f64; 3],
    #[serde(skip_serializing_if = "Option::is_none")]
    pub radius: Option<f64>,
}

/// A pinhole camera. Without `position` the camera frames the hair's bounding box from the front
/// (-Y), looking along +Y with +Z up.
#[derive(Serialize, Deserialize, Debug, Clone)]
#[serde(default, deny_unknown_fields)]
pub struct CameraSpec {
    #[serde(skip_serializing_if = "Option::is_none")]
    pub position: Option<[f64; 3]>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub look_at: Option<[f64; 3]>,
    pub up: [f64; 3],
    /// Vertical field of view in degrees.
    pub fov: f64,
    pub width: usize,
    pub height: usize,
}

impl Default for CameraSpec {
    fn default() -> Self {
        CameraSpec { position: None, look_at: None, up: [0.0, 0.0, 1.0], fov: 30.0, width: 512, height: 512 }
    }
}

/// Lights. Without this section the hair sits in a uniform white environment of radiance 1.
#[derive(Serialize, Deserialize, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct LightsSpec {
    #[serde(skip_serializing_if = "Option::is_none")]
    pub environment: Option<EnvSpec>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sun: Option<SunSpec>,
}

impl Default for LightsSpec {
    fn default() -> Self {
        LightsSpec { environment: Some(EnvSpec::default()), sun: None }
    }
}

/// An environment: a lat-long map (`file`, .exr or .hdr) or a constant `color`; radiance times
/// `strength`; the map turned by `rotation` degrees about +Z.
#[derive(Serialize, Deserialize, Debug, Clone)]
#[serde(default, deny_unknown_fields)]
pub struct EnvSpec {
    #[serde(skip_serializing_if = "Option::is_none")]
    pub file: Option<PathBuf>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub color: Option<[f64; 3]>,
    pub strength: f64,
    pub rotation: f64,
}

impl Default for EnvSpec {
    fn default() -> Self {
        EnvSpec { file: None, color: None, strength: 1.0, rotation: 0.0 }
    }
}

/// A distant sun: `direction` toward it, `irradiance` (one value or R,G,B) on a surface facing it,
/// `angular_diameter` in degrees (0 for a directional light; the real sun is 0.53).
#[derive(Serialize, Deserialize, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct SunSpec {
    pub direction: [f64; 3],
    pub irradiance: OneOrRgb,
    #[serde(default = "sun_diameter")]
    pub angular_diameter: f64,
}

#[derive(Serialize, Deserialize, Debug, Clone, Copy)]
#[serde(untagged)]
pub enum OneOrRgb {
    One(f64),
    Rgb([f64; 3]),
}

impl OneOrRgb {
    fn rgb(self) -> [f64; 3] {
        match self {
            OneOrRgb::One(v) => [v; 3],
            OneOrRgb::Rgb(c) => c,
        }
    }
}

#[derive(Serialize, Deserialize, Debug, Clone)]
#[serde(default, deny_unknown_fields)]
pub struct RenderSpec {
    pub integrator: IntegratorKind,
    pub spp: u32,
    pub seed: u64,
    /// Most fiber vertices on a path (`path` only); Russian roulette ends most paths long before.
    pub max_depth: u32,
    /// Direction sampling (see [`RenderSpec::sampling`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sampling: Option<Sampling>,
    /// PNG exposure in stops.
    pub exposure: f64,
    /// Also collect each pixel's light per dual-scattering term (`Term`; `render --aovs`,
    /// `calibrate`): 96 more bytes a pixel, so off unless asked for.
    #[serde(skip)]
    pub terms: bool,
}

impl RenderSpec {
    /// The direction sampling: the scene's, else `light` for `dual` (its F is smooth enough that
    /// light samples alone reach a given error in about 0.6 times the time of light samples MIS-
    /// combined with fiber samples: docs/dual_scattering.md, "Light samples per camera hit") and `importance` for the others.
    pub fn sampling(&self) -> Sampling {
        self.sampling.unwrap_or(if self.integrator == IntegratorKind::Dual {
            Sampling::Light
        } else {
            Sampling::Importance
        })
    }
}

impl Default for RenderSpec {
    fn default() -> Self {
        RenderSpec {
            integrator: IntegratorKind::Dual,
            spp: 16,
            seed: 0,
            max_depth: 512,
            sampling: None,
            exposure: 0.0,
            terms: false,
        }
    }
}

fn one() -> f64 {
    1.0
}

fn sun_diameter() -> f64 {
    0.53
}

fn finite3(field: &str, v: [f64; 3]) -> Result<DVec3> {
    ensure!(v.iter().all(|c| c.is_finite()), "{field} must be three finite numbers, got {v:?}");
    Ok(DVec3::from_array(v))
}

fn non_negative_rgb(field: &str, v: [f64; 3]) -> Result<Rgb> {
    ensure!(v.iter().all(|c| c.is_finite() && *c >= 0.0), "{field} must be finite and >= 0, got {v:?}");
    Ok(Rgb(v))
}

/// The matrix that scales by `scale`, rotates by XYZ Euler angles `rotate` (degrees), then
/// translates by `translate`: the transform of the hair and of each mesh (`what` names it).
fn transform(what: &str, scale: f64, rotate: [f64; 3], translate: [f64; 3]) -> Result<DMat4> {
    ensure!(scale.is_finite() && scale > 0.0, "{what}.scale must be finite and > 0, got {scale}");
    let rotate = finite3(&format!("{what}.rotate"), rotate)?;
    let translate = finite3(&format!("{what}.translate"), translate)?;
    Ok(DMat4::from_translation(translate)
        * DMat4::from_euler(EulerRot::XYZ, rotate.x.to_radians(), rotate.y.to_radians(), rotate.z.to_radians())
        * DMat4::from_scale(DVec3::splat(scale)))
}

/// A scene ready to render.
pub struct Scene {
    pub strands: Strands,
    pub fibers: Fibers,
    pub meshes: Meshes,
    pub fiber: FiberParams,
    pub camera: Camera,
    pub lights: Lights,
    pub render: RenderSpec,
    pub dual: DualSpec,
}

impl Scene {
    /// What rays meet: the hair and the meshes.
    pub fn world(&self) -> World<'_> {
        World { fibers: &self.fibers, meshes: &self.meshes }
    }
}

/// Values that replace a scene file's (the command line's flags); `None` keeps the file's.
#[derive(Clone, Debug, Default)]
pub struct Overrides {
    pub spp: Option<u32>,
    pub integrator: Option<IntegratorKind>,
    pub sampling: Option<Sampling>,
    pub seed: Option<u64>,
    pub max_depth: Option<u32>,
    pub d_f: Option<f64>,
    pub d_b: Option<f64>,
    pub model: Option<ModelKind>,
    pub dual_model: Option<DualModel>,
    pub shadows: Option<ShadowMode>,
    pub light_samples: Option<u32>,
    pub width: Option<usize>,
    pub height: Option<usize>,
}

impl SceneFile {
    /// The scene file at `path` (default: `scenes/default.json`, which must then exist here)
    /// with `overrides` applied.
    pub fn load_with(path: Option<&Path>, overrides: &Overrides) -> Result<SceneFile> {
        let default = Path::new("scenes/default.json");
        if path.is_none() && !default.exists() {
            bail!(
                "no scene given and {} does not exist here (run from the repository root or name a scene)",
                default.display()
            );
        }
        let (mut file, o) = (SceneFile::load(path.unwrap_or(default))?, overrides);
        let r = &mut file.render;
        r.spp = o.spp.unwrap_or(r.spp);
        r.integrator = o.integrator.unwrap_or(r.integrator);
        r.sampling = o.sampling.or(r.sampling);
        r.seed = o.seed.unwrap_or(r.seed);
        r.max_depth = o.max_depth.unwrap_or(r.max_depth);
        file.dual.d_f = o.d_f.unwrap_or(file.dual.d_f);
        file.dual.d_b = o.d_b.unwrap_or(file.dual.d_b);
        file.fiber.model = o.model.unwrap_or(file.fiber.model);
        file.dual.model = o.dual_model.unwrap_or(file.dual.model);
        file.dual.shadows = o.shadows.unwrap_or(file.dual.shadows);
        file.dual.light_samples = o.light_samples.or(file.dual.light_samples);
        file.camera.width = o.width.unwrap_or(file.camera.width);
        file.camera.height = o.height.unwrap_or(file.camera.height);
        Ok(file)
    }

    /// Reads a scene file; a hair file (`.hair`, `.hair.gz`, `.pbrt`, `.pbrt.gz`) stands for a scene with that hair and every default.
    pub fn load(path: &Path) -> Result<SceneFile> {
        if HairFormat::of(path).is_some() {
            return Ok(SceneFile {
                hair: HairSpec {
                    file: Some(path.to_path_buf()),
                    generate: None,
                    scale: 1.0,
                    rotate: [0.0; 3],
                    translate: [0.0; 3],
                    radius: None,
                },
                fiber: FiberParams::default(),
                camera: CameraSpec::default(),
                lights: LightsSpec::default(),
                render: RenderSpec::default(),
                dual: DualSpec::default(),
                meshes: Vec::new(),
            });
        }
        let text =
            std::fs::read_to_string(path).with_context(|| format!("{}: cannot read the scene file", path.display()))?;
        SceneFile::parse(&text, path)
    }

    /// Parses the JSON text of the scene file at `path`, which errors name and relative file
    /// names in the scene are resolved against (its directory).
    pub fn parse(text: &str, path: &Path) -> Result<SceneFile> {
        let mut scene: SceneFile =
            serde_json::from_str(text).with_context(|| format!("{}: invalid scene", path.display()))?;
        let dir = path.parent().unwrap_or(Path::new(""));
        scene.hair.file = scene.hair.file.map(|f| dir.join(f));
        if let Some(env) = &mut scene.lights.environment {
            env.file = env.file.take().map(|f| dir.join(f));
        }
        scene.dual.density_grid = scene.dual.density_grid.map(|f| dir.join(f));
        for mesh in &mut scene.meshes {
            mesh.file = dir.join(&mesh.file);
        }
        Ok(scene)
    }

    /// Checks every value and builds the scene: loads or generates the hair, builds the BVH,
    /// reads the meshes, loads the environment map and frames the camera.
    pub fn build(&self) -> Result<Scene> {
        self.check_settings()?;
        let strands = self.hair()?;
        let camera = self.camera(&strands)?;
        let lights = self.lights()?;
        let segments = strands.segment_count() as u64;
        memory::ensure_fits(
            format_args!("the BVH over the hair's {segments} segments ({BUILD_BYTES_PER_SEGMENT} bytes each)"),
            segments * BUILD_BYTES_PER_SEGMENT,
        )
        .context("hair")?;
        let fibers = Fibers::new(&strands);
        let meshes = self.meshes(fibers.scale())?;
        Ok(Scene {
            strands,
            fibers,
            meshes,
            fiber: self.fiber,
            camera,
            lights,
            render: self.render.clone(),
            dual: self.dual.clone(),
        })
    }

    /// Checks the render, fiber and dual settings (the hair, camera and lights are checked as
    /// they are built).
    pub fn check_settings(&self) -> Result<()> {
        let r = &self.render;
        ensure!(r.spp >= 1, "render.spp must be at least 1, got {}", r.spp);
        ensure!(r.max_depth >= 1, "render.max_depth must be at least 1, got {}", r.max_depth);
        ensure!(r.exposure.is_finite(), "render.exposure must be finite");
        self.fiber.validate().context("fiber")?;
        if r.sampling == Some(Sampling::Light) && r.integrator != IntegratorKind::Dual {
            bail!("render.sampling `light` needs the dual integrator (path tracing must sample fiber directions)");
        }
        if let Some(s) = r.sampling {
            s.check_model(self.fiber.model).map_err(|e| crate::error::invalid!("render.sampling {e}"))?;
        }
        let d = &self.dual;
        for (name, v) in [("dual.d_f", d.d_f), ("dual.d_b", d.d_b)] {
            ensure!((0.0..=1.0).contains(&v), "{name} must be in [0, 1], got {v}");
        }
        d.lookup.validate()?;
        if let Some(k) = d.light_samples {
            ensure!(
                (1..=MAX_LIGHT_SAMPLES).contains(&k),
                "dual.light_samples must be in 1..={MAX_LIGHT_SAMPLES}, got {k}"
            );
        }
        // Sub-sample j of sample i reads point i k + j (k <= MAX_LIGHT_SAMPLES) of 32-bit
        // sequences (sampler.rs).
        let max_spp = (1u64 << 32) / MAX_LIGHT_SAMPLES as u64;
        ensure!(r.spp as u64 <= max_spp, "render.spp must be at most {max_spp}, got {}", r.spp);
        if d.shadows == ShadowMode::Lookup && d.model.transmittance_kind() == Transmittance::Fibers {
            bail!("dual.model `fibers` counts the fibers along each shadow ray, so it needs dual.shadows \"rays\"");
        }
        if let Some(s) = d.voxel_size {
            ensure!(s.is_finite() && s > 0.0, "dual.voxel_size must be finite and > 0, got {s}");
        }
        Ok(())
    }

    /// Loads or generates the hair and applies its transform.
    pub fn hair(&self) -> Result<Strands> {
        let h = &self.hair;
        let mut strands = match (&h.file, &h.generate) {
            (Some(file), None) => read_strands(file)?,
            (None, Some(g)) => g.generate().context("hair.generate")?,
            _ => bail!("hair needs exactly one of `file` and `generate`"),
        };
        let m = transform("hair", h.scale, h.rotate, h.translate)?;
        for p in &mut strands.points {
            *p = m.transform_point3(p.as_dvec3()).as_vec3();
        }
        for r in &mut strands.radii {
            *r = (*r as f64 * h.scale) as f32;
        }
        if let Some(radius) = h.radius {
            ensure!(radius.is_finite() && radius > 0.0, "hair.radius must be finite and > 0, got {radius}");
            strands.radii.fill(radius as f32);
        }
        strands.validate().context("hair after its transform")?;
        Ok(strands)
    }

    /// The meshes, read and transformed; `scale` turns world units into the BVH's (the hair's).
    pub fn meshes(&self, scale: f64) -> Result<Meshes> {
        let meshes = self
            .meshes
            .iter()
            .enumerate()
            .map(|(i, spec)| {
                let what = format!("meshes[{i}]");
                let m = transform(&what, spec.scale, spec.rotate, spec.translate)?;
                let albedo = non_negative_rgb(&format!("{what}.color"), spec.color)?;
                ensure!(albedo.0.iter().all(|&c| c <= 1.0), "{what}.color must be in [0, 1] (an albedo)");
                let mut triangles = read_obj(&spec.file)?;
                for p in triangles.iter_mut().flatten() {
                    *p = m.transform_point3(p.as_dvec3()).as_vec3();
                    ensure!(p.is_finite(), "{what}: {} leaves f32 range after its transform", spec.file.display());
                }
                Ok(Mesh { triangles, albedo })
            })
            .collect::<Result<Vec<_>>>()?;
        Ok(Meshes::new(&meshes, scale))
    }

    /// Checks the image size, and that its film (with the terms' split when `aovs`) fits in memory.
    pub fn check_film(&self, aovs: bool) -> Result<()> {
        let c = &self.camera;
        ensure!((1..=16384).contains(&c.width), "camera.width must be in 1..=16384, got {}", c.width);
        ensure!((1..=16384).contains(&c.height), "camera.height must be in 1..=16384, got {}", c.height);
        let per_pixel = Film::bytes_per_pixel(aovs);
        memory::ensure_fits(
            format_args!("camera.width x camera.height = {} x {} pixels ({per_pixel} bytes each)", c.width, c.height),
            (c.width * c.height) as u64 * per_pixel,
        )
    }

    /// The camera: as given, or framing `strands`.
    pub fn camera(&self, strands: &Strands) -> Result<Camera> {
        let c = &self.camera;
        ensure!(c.fov > 0.0 && c.fov < 180.0, "camera.fov must be in (0, 180) degrees, got {}", c.fov);
        self.check_film(false)?;
        match (c.position, c.look_at) {
            (None, None) => {
                let (lo, hi) = strands.bounds();
                Ok(Camera::framing(lo, hi, c.fov, c.width, c.height))
            }
            (Some(p), Some(l)) => {
                let (p, l, up) =
                    (finite3("camera.position", p)?, finite3("camera.look_at", l)?, finite3("camera.up", c.up)?);
                ensure!((l - p).length() > 0.0, "camera.look_at must differ from camera.position");
                ensure!(
                    (l - p).cross(up).length() > 1e-9 * (l - p).length() * up.length(),
                    "camera.up must not be parallel to the view direction"
                );
                Ok(Camera::new(p, l, up, c.fov, c.width, c.height))
            }
            _ => bail!("camera needs both `position` and `look_at`, or neither (to frame the hair)"),
        }
    }

    /// The lights, with the environment map loaded.
    pub fn lights(&self) -> Result<Lights> {
        let environment = match &self.lights.environment {
            None => None,
            Some(e) => {
                ensure!(
                    e.strength.is_finite() && e.strength >= 0.0,
                    "lights.environment.strength must be finite and >= 0"
                );
                ensure!(e.rotation.is_finite(), "lights.environment.rotation must be finite");
                Some(match (&e.file, e.color) {
                    (Some(f), None) => Environment::Map(EnvMap::load(f, e.strength, e.rotation)?),
                    (None, c) => Environment::Constant(
                        non_negative_rgb("lights.environment.color", c.unwrap_or([1.0; 3]))? * e.strength,
                    ),
                    _ => bail!("lights.environment takes `file` or `color`, not both"),
                })
            }
        };
        let sun = match &self.lights.sun {
            None => None,
            Some(s) => {
                let d = finite3("lights.sun.direction", s.direction)?;
                ensure!(d.length() > 0.0, "lights.sun.direction must not be zero");
                ensure!(
                    s.angular_diameter.is_finite() && (0.0..90.0).contains(&s.angular_diameter),
                    "lights.sun.angular_diameter must be in [0, 90) degrees, got {}",
                    s.angular_diameter
                );
                Some(Sun {
                    direction: d.normalize(),
                    irradiance: non_negative_rgb("lights.sun.irradiance", s.irradiance.rgb())?,
                    half_angle: 0.5 * s.angular_diameter.to_radians(),
                })
            }
        };
        // Every pixel sums spp samples in fixed point (render.rs): a light whose radiance alone
        // fills the sums would be clipped in silence.
        let brightest = [
            (
                "lights.environment.strength",
                match &environment {
                    Some(Environment::Map(m)) => m.brightest(),
                    Some(Environment::Constant(c)) => c.0.into_iter().fold(0.0, f64::max),
                    None => 0.0,
                },
            ),
            ("lights.sun.irradiance", sun.map_or(0.0, |s| s.irradiance.0.into_iter().fold(0.0, f64::max))),
        ];
        let spp = self.render.spp as f64;
        for (field, value) in brightest {
            ensure!(value.is_finite(), "{field}: takes the radiance beyond f32's range (3.4e38)");
            ensure!(
                value * spp <= SUM_CEILING,
                "{field}: radiance up to {value:.1e} over {spp} samples a pixel is beyond the {SUM_CEILING:.1e} a pixel's sums hold"
            );
        }
        Ok(Lights::new(environment, sun))
    }
}
