//! What a render will hold in memory, checked before the work: a size that cannot fit is refused
//! with the field that asked for it, not met by an allocation failure half-way.

use crate::error::{Result, bail};
use precompute::density::DensityGrid;
use precompute::strands::Strands;

/// Bytes this process may still allocate: the kernel's estimate of available memory
/// (`MemAvailable`), lowered by a cgroup's limit (containers, Slurm jobs), or
/// `DUALHAIR_MEMORY` (bytes) where set. `None` where neither can be read (then nothing is refused).
pub fn available() -> Option<u64> {
    if let Some(v) = std::env::var_os("DUALHAIR_MEMORY") {
        return v.to_str().and_then(|s| s.trim().parse().ok());
    }
    let meminfo = std::fs::read_to_string("/proc/meminfo").ok()?;
    let kib = meminfo.lines().find_map(|l| l.strip_prefix("MemAvailable:"))?;
    let mut bytes = kib.trim().trim_end_matches("kB").trim().parse::<u64>().ok()? * 1024;
    let read = |f: &str| std::fs::read_to_string(f).ok().and_then(|s| s.trim().parse::<u64>().ok());
    if let (Some(max), Some(used)) = (read("/sys/fs/cgroup/memory.max"), read("/sys/fs/cgroup/memory.current")) {
        bytes = bytes.min(max.saturating_sub(used));
    }
    Some(bytes)
}

/// Refuses `bytes` of memory for `what` (which names the field that asked for it) where more than
/// is available.
pub fn ensure_fits(what: impl std::fmt::Display, bytes: u64) -> Result<()> {
    match available() {
        Some(free) if bytes > free => {
            bail!("{what} would need {} of memory; {} is available", show(bytes), show(free))
        }
        _ => Ok(()),
    }
}

/// Refuses a density grid of `strands` at `voxel_size` (asked for by `field`) that cannot fit;
/// bricks are counted only where the hair's bounds could hold too many.
pub fn ensure_grid_fits(strands: &Strands, voxel_size: f64, field: &str) -> Result<()> {
    let per_brick = DensityGrid::VOXELIZE_BYTES_PER_BRICK;
    let Some(free) = available() else { return Ok(()) };
    if DensityGrid::bricks_bound(strands, voxel_size).saturating_mul(per_brick) <= free {
        return Ok(());
    }
    let limit = free / per_brick;
    let bricks = DensityGrid::bricks_touched(strands, voxel_size, limit);
    let what = format!("the density grid at {field} {voxel_size} ({per_brick} bytes a brick of 8^3 voxels)");
    if bricks > limit {
        bail!("{what} would need over {limit} bricks, more than the {} of memory available", show(free));
    }
    ensure_fits(what, bricks * per_brick)
}

/// Bytes in the units people read (decimal: GB = 1e9).
pub fn show(bytes: u64) -> String {
    let b = bytes as f64;
    match b {
        b if b >= 1e12 => format!("{:.1} TB", b / 1e12),
        b if b >= 1e9 => format!("{:.1} GB", b / 1e9),
        b if b >= 1e6 => format!("{:.1} MB", b / 1e6),
        _ => format!("{bytes} bytes"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_read_in_decimal_units() {
        assert_eq!(show(4_480_000_000_000), "4.5 TB");
        assert_eq!(show(2_750_000_000), "2.8 GB");
        assert_eq!(show(999), "999 bytes");
    }

    #[test]
    fn this_machine_reports_some_memory() {
        // Linux always has MemAvailable (since 3.14); the figure is positive and below 2^50.
        if std::env::var_os("DUALHAIR_MEMORY").is_none() && cfg!(target_os = "linux") {
            let free = available().expect("MemAvailable");
            assert!(free > 0 && free < 1 << 50, "{free}");
        }
    }
}
