//! On-disk cache of what the dual-scattering integrator precomputes: the tables (keyed by the
//! fiber, d_b and the table resolution) and the density grid (keyed by the strands' exact geometry
//! and the voxel size). A render reuses them while their inputs are unchanged and recomputes them
//! otherwise. Location: `$DUALHAIR_CACHE`, else `$XDG_CACHE_HOME/dualhair`, else
//! `$HOME/.cache/dualhair`. Entries are named by a 64-bit FNV-1a hash of their inputs and of the
//! code that makes them ([`CODE_ID`]), and a cached table also records its inputs, which are
//! compared on load.

use crate::error::{Context, Result};
use crate::fingerprint::{CODE_ID, Fnv};
use crate::integrators::dual::transmittance::{ForwardLookup, LookupSettings};
use crate::lights::Lights;
use crate::memory;
use crate::output::write_atomically;
use crate::progress::Progress;
use precompute::density::{DensityGrid, read_vdb, write_vdb};
use precompute::fiber::{Fiber, FiberParams};
use precompute::strands::Strands;
use precompute::tables::{TableSettings, Tables, compute};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::Instant;

pub struct Cache {
    dir: PathBuf,
    /// The code identity that keys the entries ([`CODE_ID`]).
    code: String,
}

impl Cache {
    pub fn at(dir: impl Into<PathBuf>) -> Cache {
        Cache::for_code(dir, CODE_ID)
    }

    /// A cache whose entries are those of the code identified by `code` (tests: entries of
    /// another build).
    pub fn for_code(dir: impl Into<PathBuf>, code: &str) -> Cache {
        Cache { dir: dir.into(), code: code.into() }
    }

    /// The hash every entry's key starts from.
    fn key(&self) -> Fnv {
        Fnv::START.bytes(self.code.as_bytes())
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

    /// The dual-scattering tables of a fiber at its default resolution; `progress` is told while
    /// they are computed.
    pub fn tables(&self, fiber: &FiberParams, d_b: f64, progress: &dyn Progress) -> Result<Tables> {
        let settings = TableSettings::for_fiber(fiber);
        let inputs = serde_json::to_vec(&(fiber, d_b, settings.resolution()))?;
        let path = self.entry(format!("tables-{:016x}.json", self.key().bytes(&inputs).0))?;
        let build = || {
            let task = progress.task("computing the dual-scattering tables once for this fiber", None);
            let mut tables = compute(&Fiber::exact(fiber)?, &settings, d_b);
            drop(task);
            tables.fiber = Some(*fiber);
            write_atomically(&path, |tmp| Ok(std::fs::write(tmp, serde_json::to_vec(&tables.to_json())?)?))?;
            Ok(tables)
        };
        cached(&path, "the dual-scattering tables", progress, |p| load_tables(p, fiber, d_b), build)
    }

    /// The density grid of some strands at a voxel size (automatic when `None`), with their
    /// orientation ([`DensityGrid::with_orientation`]).
    pub fn density(&self, strands: &Strands, voxel_size: Option<f64>, progress: &dyn Progress) -> Result<DensityGrid> {
        let size = voxel_size.unwrap_or_else(|| DensityGrid::auto_voxel_size(strands));
        let h = hash_strands(self.key().bytes(&size.to_le_bytes()), strands);
        let path = self.entry(format!("density-{:016x}.vdb", h.0))?;
        let read = |p: &Path| read_vdb(p, "density").ok().filter(|g| g.voxel_size == size);
        let build = || {
            memory::ensure_grid_fits(strands, size, "dual.voxel_size")?;
            let grid = DensityGrid::voxelize(strands, size);
            write_atomically(&path, |tmp| {
                let mut w = std::io::BufWriter::new(std::fs::File::create(tmp)?);
                write_vdb(&mut w, &grid, "density")?;
                Ok(w.flush()?)
            })?;
            Ok(grid)
        };
        Ok(cached(&path, "the density grid", progress, read, build)?.with_orientation(strands))
    }

    /// The forward-transmittance lookup of the strands toward the lights, reported to `progress`
    /// while it is built. The sun's map and the environment's maps are two entries, each
    /// keyed by the strands, its resolution, its directions (the sun's direction and disc; the
    /// environment's are fixed, so its image does not matter) and the code: never by
    /// the camera or the meshes.
    pub fn lookup(
        &self,
        strands: &Strands,
        lights: &Lights,
        settings: &LookupSettings,
        progress: &dyn Progress,
    ) -> Result<ForwardLookup> {
        let hair = hash_strands(self.key(), strands);
        let sun = match &lights.sun {
            Some(sun) => {
                let key = [sun.direction.x, sun.direction.y, sun.direction.z, sun.half_angle, settings.sun_texel];
                let h = hair.bytes(b"sun").bytes(&key.map(f64::to_le_bytes).concat());
                let path = self.entry(format!("lookup-sun-{:016x}.bin", h.0))?;
                let build = || {
                    let _task = progress.task("building the forward-transmittance map of the sun", None);
                    ForwardLookup::sun(strands, sun.direction, sun.half_angle, settings)
                };
                Some(self.lookup_entry(&path, "the sun", progress, build)?)
            }
            None => None,
        };
        let env = match &lights.environment {
            Some(_) => {
                let h =
                    hair.bytes(b"env").bytes(&settings.env_texel.to_le_bytes()).bytes(&settings.env_grid.to_le_bytes());
                let path = self.entry(format!("lookup-sky-{:016x}.bin", h.0))?;
                let build = || ForwardLookup::environment(strands, settings, progress);
                Some(self.lookup_entry(&path, "the sky", progress, build)?)
            }
            None => None,
        };
        Ok(ForwardLookup::join(sun, env))
    }

    /// One cached part of the lookup: read from `path`, else built and written there.
    fn lookup_entry(
        &self,
        path: &Path,
        what: &str,
        progress: &dyn Progress,
        build: impl FnOnce() -> ForwardLookup,
    ) -> Result<ForwardLookup> {
        let read = |p: &Path| std::fs::read(p).ok().and_then(|b| ForwardLookup::read(&b));
        let build = || {
            let lookup = build();
            write_atomically(path, |tmp| {
                let mut w = std::io::BufWriter::new(std::fs::File::create(tmp)?);
                lookup.write(&mut w)?;
                Ok(w.flush()?)
            })?;
            Ok(lookup)
        };
        let maps = format!("the forward-transmittance maps of {what}");
        cached(path, &maps, progress, read, build)
    }
}

/// The entry at `path`: read it, or else build (and write) it under a lock beside it, so that
/// processes sharing a cache (a render split over a cluster's nodes) build each entry once: the
/// others wait for the lock, then read what it built. Tells `progress` what it built or waits for,
/// and how long it took.
fn cached<T>(
    path: &Path,
    what: &str,
    progress: &dyn Progress,
    read: impl Fn(&Path) -> Option<T>,
    build: impl FnOnce() -> Result<T>,
) -> Result<T> {
    if let Some(entry) = read(path) {
        return Ok(entry);
    }
    let _lock = lock_beside(path, what, progress)?;
    if let Some(entry) = read(path) {
        return Ok(entry);
    }
    let start = Instant::now();
    let entry = build()?;
    progress.note(&format!("built {what} in {:.1} s (cached in {})", start.elapsed().as_secs_f64(), path.display()));
    Ok(entry)
}

/// An exclusive lock on `path` + ".lock", held until dropped (or the process ends, however it
/// ends). `None` where the file system cannot lock: the build goes ahead, and the entry is
/// still written whole ([`write_atomically`]), only perhaps twice.
fn lock_beside(path: &Path, what: &str, progress: &dyn Progress) -> Result<Option<std::fs::File>> {
    let lock = PathBuf::from(format!("{}.lock", path.display()));
    let file = std::fs::OpenOptions::new()
        .create(true)
        .truncate(false)
        .write(true)
        .open(&lock)
        .with_context(|| format!("{}: cannot create the cache's lock file", lock.display()))?;
    match file.try_lock() {
        Ok(()) => return Ok(Some(file)),
        Err(std::fs::TryLockError::WouldBlock) => {}
        Err(std::fs::TryLockError::Error(_)) => return Ok(None),
    }
    progress.note(&format!("waiting for another dualhair process building {what} ({})", path.display()));
    Ok(file.lock().ok().map(|()| file))
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::progress::Silent;
    use precompute::strands::{Generator, Straight};

    /// An entry written under one code identity is read under it and never under another.
    #[test]
    fn entries_are_keyed_by_the_code_that_made_them() {
        let dir = tempfile::tempdir().unwrap();
        let hair = |strands| Generator::Straight(Straight { strands, ..Default::default() }).generate().unwrap();
        let (strands, other) = (hair(40), hair(7));
        let voxel = DensityGrid::auto_voxel_size(&strands);
        let size = Some(voxel);
        let old = Cache::for_code(dir.path(), "older build");
        let fresh = old.density(&strands, size, &Silent).unwrap();
        let entries = || {
            let paths = std::fs::read_dir(dir.path()).unwrap().map(|e| e.unwrap().path());
            paths.filter(|p| p.extension().is_none_or(|e| e != "lock")).collect::<Vec<_>>()
        };
        let [entry] = entries().try_into().unwrap();
        // Replace the entry with another hair's grid at the same voxel size: what the older build
        // reads back is that grid, so reads do come from the entry.
        let planted = DensityGrid::voxelize(&other, voxel);
        let mut bytes = Vec::new();
        write_vdb(&mut bytes, &planted, "density").unwrap();
        std::fs::write(&entry, bytes).unwrap();
        assert_eq!(old.density(&strands, size, &Silent).unwrap().total_length(), planted.total_length());
        // Another build computes its own entry beside it.
        let new = Cache::for_code(dir.path(), "newer build").density(&strands, size, &Silent).unwrap();
        assert_eq!(new.total_length(), fresh.total_length());
        assert_ne!(new.total_length(), planted.total_length());
        assert_eq!(entries().len(), 2);
        assert_eq!(CODE_ID.len(), 16, "build.rs sets a 64-bit hash: {CODE_ID}");
    }
}
