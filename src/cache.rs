//! On-disk cache of what the dual-scattering integrator precomputes: the tables (keyed by the
//! fiber, d_b and the table resolution) and the density grid (keyed by the strands' exact geometry
//! and the voxel size). A render reuses them while their inputs are unchanged and recomputes them
//! otherwise. Location: `$DUALHAIR_CACHE`, else `$XDG_CACHE_HOME/dualhair`, else
//! `$HOME/.cache/dualhair`. Entries are named by a 64-bit FNV-1a hash of their inputs, and a
//! cached table also records its inputs, which are compared on load.

use crate::output::write_atomically;
use crate::scene::Scene;
use crate::transmittance::ForwardLookup;
use anyhow::{Context, Result};
use indicatif::ProgressBar;
use precompute::density::{DensityGrid, read_vdb, write_vdb};
use precompute::fiber::{Fiber, FiberParams};
use precompute::strands::Strands;
use precompute::tables::{TableSettings, Tables, compute};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// A spinner with `message` for work of unknown length (hidden unless `show`); clear it when done.
pub(crate) fn spinner(show: bool, message: String) -> ProgressBar {
    if !show {
        return ProgressBar::hidden();
    }
    let spinner = ProgressBar::new_spinner().with_message(message);
    spinner.enable_steady_tick(Duration::from_millis(120));
    spinner
}

/// Bumped whenever the cached formats or the computations change meaning.
const VERSION: u64 = 1;

/// 64-bit FNV-1a (Fowler, Noll, Vo): stable across platforms and compiler versions.
pub(crate) struct Fnv(pub(crate) u64);

impl Fnv {
    pub(crate) fn new() -> Fnv {
        Fnv(0xcbf2_9ce4_8422_2325 ^ VERSION)
    }

    pub(crate) fn bytes(mut self, bytes: &[u8]) -> Fnv {
        for &b in bytes {
            self.0 = (self.0 ^ b as u64).wrapping_mul(0x0000_0100_0000_01b3);
        }
        self
    }
}

pub struct Cache {
    dir: PathBuf,
}

impl Cache {
    pub fn at(dir: impl Into<PathBuf>) -> Cache {
        Cache { dir: dir.into() }
    }

    /// The default location (see the module documentation).
    pub fn default_location() -> Cache {
        let env = |k: &str| std::env::var_os(k).filter(|v| !v.is_empty()).map(PathBuf::from);
        let dir = env("DUALHAIR_CACHE")
            .or_else(|| env("XDG_CACHE_HOME").map(|d| d.join("dualhair")))
            .or_else(|| env("HOME").map(|d| d.join(".cache/dualhair")))
            .unwrap_or_else(|| std::env::temp_dir().join("dualhair-cache"));
        Cache::at(dir)
    }

    fn entry(&self, name: String) -> Result<PathBuf> {
        std::fs::create_dir_all(&self.dir)
            .with_context(|| format!("{}: cannot create the cache folder", self.dir.display()))?;
        Ok(self.dir.join(name))
    }

    /// The dual-scattering tables of a fiber at its default resolution; `progress` shows a
    /// spinner while they are computed.
    pub fn tables(&self, fiber: &FiberParams, d_b: f64, progress: bool) -> Result<Tables> {
        let settings = TableSettings::for_fiber(fiber);
        let inputs = serde_json::to_vec(&(fiber, d_b, settings.resolution()))?;
        let path = self.entry(format!("tables-{:016x}.json", Fnv::new().bytes(&inputs).0))?;
        if let Some(tables) = load_tables(&path, fiber, d_b) {
            return Ok(tables);
        }
        let spinner = spinner(
            progress,
            format!("computing the dual-scattering tables once for this fiber (cached in {})", path.display()),
        );
        let mut tables = compute(&Fiber::exact(fiber)?, &settings, d_b);
        spinner.finish_and_clear();
        tables.fiber = Some(*fiber);
        write_atomically(&path, |tmp| Ok(std::fs::write(tmp, serde_json::to_vec(&tables.to_json())?)?))?;
        Ok(tables)
    }

    /// The density grid of some strands at a voxel size (automatic when `None`).
    pub fn density(&self, strands: &Strands, voxel_size: Option<f64>) -> Result<DensityGrid> {
        let size = voxel_size.unwrap_or_else(|| DensityGrid::auto_voxel_size(strands));
        let h = hash_strands(Fnv::new().bytes(&size.to_le_bytes()), strands);
        let path = self.entry(format!("density-{:016x}.vdb", h.0))?;
        if let Ok(grid) = read_vdb(&path, "density")
            && grid.voxel_size == size
        {
            return Ok(grid);
        }
        let grid = DensityGrid::voxelize(strands, size);
        write_atomically(&path, |tmp| {
            let mut w = std::io::BufWriter::new(std::fs::File::create(tmp)?);
            write_vdb(&mut w, &grid, "density")?;
            Ok(w.flush()?)
        })?;
        Ok(grid)
    }

    /// The forward-transmittance lookup of a scene's hair, seen by its camera, toward its lights;
    /// `progress` shows a bar while it is built. Keyed by the strands, the camera, the density
    /// grid's contents, the sun's direction and disc, whether there is an environment (its
    /// directions are fixed, so its image does not matter), the lookup's resolutions and the
    /// build's version.
    pub fn lookup(&self, scene: &Scene, grid: &DensityGrid, progress: bool) -> Result<ForwardLookup> {
        let (strands, lights, settings, camera) = (&scene.strands, &scene.lights, &scene.dual.lookup, &scene.camera);
        let mut h = hash_strands(Fnv::new(), strands).bytes(format!("{camera:?}").as_bytes());
        h = h.bytes(&grid.voxel_size.to_le_bytes()).bytes(&grid.fiber_width.to_le_bytes());
        let mut bricks: Vec<_> = grid.bricks().collect();
        bricks.sort_unstable_by_key(|(k, _)| *k);
        for (k, values) in bricks {
            h = h.bytes(&k.map(i32::to_le_bytes).concat()).bytes(&values.map(f32::to_le_bytes).concat());
        }
        if let Some(sun) = &lights.sun {
            h = h.bytes(&[1]).bytes(&sun.direction.to_array().map(f64::to_le_bytes).concat());
            h = h.bytes(&sun.half_angle.to_le_bytes());
        }
        h = h.bytes(&[lights.environment.is_some() as u8]);
        h = h.bytes(&[settings.sun_rays, settings.env_theta, settings.env_phi].map(u32::to_le_bytes).concat());
        // Meshes occlude (hashed only when there are any, so hair-only keys stay as they were).
        for (triangle, _) in scene.meshes.triangles() {
            h = h.bytes(&triangle.map(|p| p.to_array().map(f32::to_le_bytes).concat()).concat());
        }
        h = h.bytes(&ForwardLookup::VERSION.to_le_bytes());
        let path = self.entry(format!("lookup-{:016x}.bin", h.0))?;
        let segments = strands.segment_count();
        if let Some(lookup) = std::fs::read(&path).ok().and_then(|b| ForwardLookup::read(&b, segments)) {
            return Ok(lookup);
        }
        let start = Instant::now();
        let lookup = ForwardLookup::build(strands, scene.world(), camera, grid, lights, settings, progress);
        if progress {
            let (seen, all) = lookup.coverage();
            eprintln!(
                "built the forward-transmittance lookup for the {seen} of {all} segments in view in {:.1} s ({:.1} MB, cached in {})",
                start.elapsed().as_secs_f64(),
                lookup.bytes() as f64 / 1e6,
                path.display()
            );
        }
        write_atomically(&path, |tmp| {
            let mut w = std::io::BufWriter::new(std::fs::File::create(tmp)?);
            lookup.write(&mut w)?;
            Ok(w.flush()?)
        })?;
        Ok(lookup)
    }
}

/// Feeds the strands' exact geometry to a hash.
fn hash_strands(mut h: Fnv, strands: &Strands) -> Fnv {
    for p in &strands.points {
        h = h.bytes(&p.to_array().map(f32::to_le_bytes).concat());
    }
    for r in &strands.radii {
        h = h.bytes(&r.to_le_bytes());
    }
    for o in &strands.offsets {
        h = h.bytes(&o.to_le_bytes());
    }
    h
}

/// A cached table, if the file is readable and was made from these inputs.
fn load_tables(path: &Path, fiber: &FiberParams, d_b: f64) -> Option<Tables> {
    let json: serde_json::Value = serde_json::from_slice(&std::fs::read(path).ok()?).ok()?;
    let tables = Tables::from_json(&json).ok()?;
    (tables.fiber.as_ref() == Some(fiber) && tables.d_b == d_b).then_some(tables)
}
