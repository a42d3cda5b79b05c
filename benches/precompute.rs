//! Precompute benchmark: the dual-scattering tables of the default fiber, and the density grid of a
//! groom (time and memory). `cargo bench --bench precompute -- [HAIR_FILE]`; without a file it uses
//! a generated scalp of 30,000 strands.

use precompute::density::DensityGrid;
use precompute::fiber::{Chiang, FiberParams};
use precompute::strands::{Generator, Scalp, read_hair};
use precompute::tables::{D_B, TableSettings, compute};
use std::path::Path;
use std::time::Instant;

/// Peak resident memory of this process so far (Linux), in MiB.
fn peak_rss_mib() -> Option<f64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let kb: f64 = status.lines().find(|l| l.starts_with("VmHWM:"))?.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb / 1024.0)
}

fn main() {
    let file = std::env::args().skip(1).find(|a| !a.starts_with("--"));
    let strands = match &file {
        Some(f) => read_hair(Path::new(f)).unwrap_or_else(|e| panic!("{e}")),
        None => Generator::Scalp(Scalp { strands: 30_000, ..Default::default() }).generate().unwrap(),
    };
    let before = peak_rss_mib();
    let size = DensityGrid::auto_voxel_size(&strands);
    let start = Instant::now();
    let grid = DensityGrid::voxelize(&strands, size);
    let seconds = start.elapsed().as_secs_f64();
    let voxels = grid.voxels().count();
    let bricks = grid.bricks().count();
    println!(
        "density grid of {} ({} segments): voxel size {size:.5}, {voxels} voxels in {bricks} bricks ({:.1} MiB of bricks), \
         voxelized in {seconds:.3} s; peak RSS {:.0} -> {:.0} MiB",
        file.as_deref().unwrap_or("generated scalp"),
        strands.segment_count(),
        bricks as f64 * 2048.0 / (1024.0 * 1024.0),
        before.unwrap_or(f64::NAN),
        peak_rss_mib().unwrap_or(f64::NAN),
    );

    let params = FiberParams::default();
    let settings = TableSettings::for_fiber(&params);
    let start = Instant::now();
    let tables = compute(&Chiang::new(&params).unwrap(), &settings, D_B);
    println!(
        "tables of the default fiber: {} inclinations in {:.2} s on {} threads",
        tables.theta.len(),
        start.elapsed().as_secs_f64(),
        rayon::current_num_threads()
    );
}
