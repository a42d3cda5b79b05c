//! `dualhair merge`: adds the parts of a split render (`render --part K/N`) into the image one
//! render would make, bit for bit, or gathers the folders of a split `converge` run
//! (`converge --part K/N`) and measures them as one run.

use crate::say;
use anyhow::{Result, bail, ensure};
use dualhair::analysis::converge;
use dualhair::film::Film;
use dualhair::film::partial::{self, add_parts};
use dualhair::output::ensure_writable;
use std::path::PathBuf;

/// Merges partial renders (.exr files from `render --part`) into one image, or the output
/// folders of `converge --part` runs into one converge folder.
#[derive(clap::Args, Debug)]
pub struct MergeArgs {
    /// The parts: EXR files written by `render --part K/N` (every K of one N, in any order), or
    /// folders written by `converge --part K/N`.
    #[arg(required = true)]
    pub parts: Vec<PathBuf>,
    /// Output: an image (.exr, with a .png beside it) for render parts, a folder for converge
    /// parts.
    #[arg(short, long, value_name = "OUT")]
    pub output: PathBuf,
    /// Keep the exact sums in the merged EXR, so `render --resume` can add samples to it.
    #[arg(long)]
    pub sums: bool,
}

pub fn run(args: &MergeArgs) -> Result<()> {
    if args.parts.iter().all(|p| p.is_dir()) {
        say!("{}", converge::merge(&args.parts, &args.output)?)?;
        return Ok(());
    }
    if let Some(dir) = args.parts.iter().find(|p| p.is_dir()) {
        bail!("{}: a folder among image parts: merge either render parts or converge folders", dir.display());
    }
    ensure_writable(&args.output)?;
    let exr = args.output.with_extension("exr");
    ensure!(exr == args.output, "{}: the merged image is an .exr (a .png is written beside it)", args.output.display());
    let mut parts = Vec::new();
    for path in &args.parts {
        match partial::read(path)? {
            Some(p) => parts.push((path.as_path(), p)),
            None => bail!("{}: not a partial render (write parts with `render --part K/N`)", path.display()),
        }
    }
    let (sums, first) = add_parts(parts)?;
    let film = Film::from_sums(&sums);
    let aovs = !sums.terms.is_empty();
    if args.sums {
        partial::write(&exr, &sums, &first.id, aovs)?;
    } else {
        film.write_exr(&exr, aovs)?;
    }
    let png = exr.with_extension("png");
    film.write_png(&png, first.id.exposure)?;
    say!(
        "merged {} parts into {} and {} ({}x{}, {} spp)",
        args.parts.len(),
        exr.display(),
        png.display(),
        film.width,
        film.height,
        film.spp
    )?;
    Ok(())
}
