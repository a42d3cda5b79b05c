//! `dualhair precompute`: the dual-scattering tables and the hair-density grid, as files other
//! tools read.

use crate::cli::fiber_args::FiberArgs;
use crate::say;
use anyhow::{Context, Result, bail, ensure};
use dualhair::analysis::tables_chart::draw_tables;
use dualhair::memory;
use dualhair::output::{ensure_writable, write_atomically};
use dualhair::scene::SceneFile;
use precompute::density::{DensityGrid, write_vdb};
use precompute::fiber::Fiber;
use precompute::strands::Strands;
use precompute::tables::{TableSettings, compute};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::Instant;

#[derive(clap::Subcommand, Debug)]
pub enum PrecomputeCommand {
    /// Dual-scattering tables (a_f, a_b, alpha/beta, A_b, Delta_b, sigma_b over the light's
    /// inclination, per channel) as .json, .csv, or a .png/.svg chart.
    Tables(TablesArgs),
    /// The voxelized hair-length density grid as an OpenVDB file (float grid `density`, fog
    /// volume), with a .json summary beside it.
    Density(DensityArgs),
}

#[derive(clap::Args, Debug)]
pub struct TablesArgs {
    #[command(flatten)]
    pub fiber: FiberArgs,
    /// Backscatter density factor d_b used in sigma_b (Zinke et al. 2008); scenes default to 1.
    #[arg(long, default_value_t = 1.0, allow_negative_numbers = true)]
    pub d_b: f64,
    /// Number of light inclinations (default: accurate to 0.1% under linear interpolation).
    #[arg(long)]
    pub theta_count: Option<usize>,
    /// Output: .json (documented schema), .csv (one row per inclination), .png or .svg (chart).
    #[arg(short, long, value_name = "FILE")]
    pub output: PathBuf,
}

#[derive(clap::Args, Debug)]
pub struct DensityArgs {
    /// A .hair file or a scene file (its hair, transformed as the scene says).
    pub input: PathBuf,
    /// Voxel edge length in scene units (default: 8 mean fiber diameters, within 1/512 and 1/16
    /// of the hair's longest extent).
    #[arg(long, allow_negative_numbers = true)]
    pub voxel_size: Option<f64>,
    /// Output .vdb file.
    #[arg(short, long, value_name = "FILE")]
    pub output: PathBuf,
}

pub fn run(command: &PrecomputeCommand) -> Result<()> {
    match command {
        PrecomputeCommand::Tables(args) => tables(args),
        PrecomputeCommand::Density(args) => density(args),
    }
}

fn extension(path: &Path) -> String {
    path.extension().and_then(|e| e.to_str()).unwrap_or("").to_ascii_lowercase()
}

fn tables(args: &TablesArgs) -> Result<()> {
    let ext = extension(&args.output);
    ensure!(
        ["json", "csv", "png", "svg"].contains(&ext.as_str()),
        "{}: use .json, .csv, .png or .svg",
        args.output.display()
    );
    ensure_writable(&args.output)?;
    ensure!(args.d_b.is_finite() && args.d_b >= 0.0, "--d-b must be finite and >= 0, got {}", args.d_b);
    let params = args.fiber.params()?;
    let mut settings = TableSettings::for_fiber(&params);
    if let Some(n) = args.theta_count {
        ensure!((2..=100_000).contains(&n), "--theta-count must be between 2 and 100000, got {n}");
        settings.theta_count = n;
    }
    eprintln!(
        "computing {} light inclinations ({} h nodes, {} threads; about 4 s for the default fiber on 2 cores)...",
        settings.theta_count,
        settings.h_rule.len(),
        rayon::current_num_threads()
    );
    let start = Instant::now();
    let mut tables = compute(&Fiber::exact(&params)?, &settings, args.d_b);
    tables.fiber = Some(params);
    match ext.as_str() {
        "json" => write_atomically(&args.output, |tmp| {
            Ok(std::fs::write(tmp, serde_json::to_string_pretty(&tables.to_json())?)?)
        })?,
        "csv" => write_atomically(&args.output, |tmp| {
            let mut w = std::io::BufWriter::new(std::fs::File::create(tmp)?);
            tables.write_csv(&mut w)?;
            Ok(w.flush()?)
        })?,
        _ => draw_tables(&tables, &args.output)?,
    }
    say!(
        "wrote {} ({} inclinations) in {:.2} s",
        args.output.display(),
        tables.theta.len(),
        start.elapsed().as_secs_f64()
    )?;
    Ok(())
}

/// The hair of a .hair file or of a scene file.
pub fn load_hair(path: &Path) -> Result<Strands> {
    Ok(SceneFile::load(path)?.hair()?)
}

fn density(args: &DensityArgs) -> Result<()> {
    if extension(&args.output) != "vdb" {
        bail!("{}: the density grid is written as OpenVDB (.vdb)", args.output.display());
    }
    ensure_writable(&args.output)?;
    let strands = load_hair(&args.input)?;
    let voxel_size = match args.voxel_size {
        Some(s) if s.is_finite() && s > 0.0 => s,
        Some(s) => bail!("--voxel-size must be finite and > 0, got {s}"),
        None => DensityGrid::auto_voxel_size(&strands),
    };
    memory::ensure_grid_fits(&strands, voxel_size, "--voxel-size")?;
    let start = Instant::now();
    let grid = DensityGrid::voxelize(&strands, voxel_size);
    let seconds = start.elapsed().as_secs_f64();
    write_atomically(&args.output, |tmp| {
        let mut w = std::io::BufWriter::new(std::fs::File::create(tmp)?);
        write_vdb(&mut w, &grid, "density")?;
        Ok(w.flush()?)
    })?;
    let voxels = grid.voxels().count();
    let summary = serde_json::json!({
        "grid": "density",
        "units": "hair length per unit volume (scene units^-2)",
        "voxel_size": voxel_size,
        "fiber_width": grid.fiber_width,
        "active_voxels": voxels,
        "total_length": grid.total_length(),
        "strand_length": strands.total_length(),
        "source": args.input.display().to_string(),
    });
    let json = args.output.with_extension("json");
    write_atomically(&json, |tmp| Ok(std::fs::write(tmp, serde_json::to_string_pretty(&summary)?)?))
        .with_context(|| format!("{}: cannot write the summary", json.display()))?;
    say!(
        "wrote {} and {}: voxel size {voxel_size:.5}, {voxels} voxels, voxelized in {seconds:.2} s",
        args.output.display(),
        json.display()
    )?;
    Ok(())
}
