//! `dualhair convert`: hair from one format to another, with the transform flags of scene files.
//! Reads what scenes read (`.hair`, `.hair.gz`, the curves of `.pbrt`/`.pbrt.gz`), writes `.hair`
//! or gzipped `.hair.gz` (Cem Yuksel's format: points, and thickness as a diameter per point).

use crate::say;
use anyhow::{Context, Result, bail};
use dualhair::output::{ensure_writable, write_atomically};
use dualhair::scene::SceneFile;
use precompute::strands::{HairFormat, write_hair};
use std::io::Write;
use std::path::PathBuf;

/// Convert hair between formats: IN is .hair, .hair.gz, .pbrt or .pbrt.gz (every `Shape "curve"`,
/// includes followed, cut into straight pieces within a tenth of a fiber radius of the curve);
/// OUT is .hair or .hair.gz. The transform applies as in scene files: scale, then rotate, then
/// translate.
#[derive(clap::Args, Debug)]
pub struct ConvertArgs {
    /// Hair to read.
    #[arg(value_name = "IN")]
    pub input: PathBuf,
    /// Hair to write: .hair, or .hair.gz for a gzipped one.
    #[arg(value_name = "OUT")]
    pub output: PathBuf,
    /// Uniform scale (radii scale too).
    #[arg(long, default_value_t = 1.0)]
    pub scale: f64,
    /// XYZ Euler angles in degrees.
    #[arg(long, num_args = 3, value_names = ["X", "Y", "Z"], allow_negative_numbers = true)]
    pub rotate: Option<Vec<f64>>,
    /// Offset added last.
    #[arg(long, num_args = 3, value_names = ["X", "Y", "Z"], allow_negative_numbers = true)]
    pub translate: Option<Vec<f64>>,
    /// Replace every fiber radius (after scaling).
    #[arg(long)]
    pub radius: Option<f64>,
}

pub fn run(args: &ConvertArgs) -> Result<()> {
    let name = args.output.file_name().map(|n| n.to_string_lossy().to_ascii_lowercase()).unwrap_or_default();
    let gzip = match () {
        _ if name.ends_with(".hair.gz") => true,
        _ if name.ends_with(".hair") => false,
        _ => bail!("{}: convert writes .hair or .hair.gz", args.output.display()),
    };
    ensure_writable(&args.output)?;
    if HairFormat::of(&args.input).is_none() {
        bail!("{}: not a hair file (.hair, .hair.gz, .pbrt or .pbrt.gz)", args.input.display());
    }
    let mut file = SceneFile::load(&args.input)?;
    let three = |v: &Option<Vec<f64>>| v.as_deref().map_or([0.0; 3], |v| [v[0], v[1], v[2]]);
    (file.hair.scale, file.hair.rotate, file.hair.translate) =
        (args.scale, three(&args.rotate), three(&args.translate));
    file.hair.radius = args.radius;
    let strands = file.hair()?;
    let info = format!("dualhair convert of {}", args.input.display());
    write_atomically(&args.output, |tmp| {
        let out = std::io::BufWriter::new(std::fs::File::create(tmp)?);
        if gzip {
            let mut gz = flate2::write::GzEncoder::new(out, flate2::Compression::default());
            write_hair(&mut gz, &strands, &info)?;
            gz.finish()?.flush()?;
        } else {
            let mut out = out;
            write_hair(&mut out, &strands, &info)?;
            out.flush()?;
        }
        Ok(())
    })
    .with_context(|| format!("{}", args.output.display()))?;
    say!(
        "wrote {}: {} strands, {} points (from {})",
        args.output.display(),
        strands.strand_count(),
        strands.points.len(),
        args.input.display()
    )?;
    Ok(())
}
