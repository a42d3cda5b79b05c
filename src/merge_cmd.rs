//! `dualhair merge`: adds the parts of a split render (`render --part K/N`) into the image one
//! render would make, bit for bit, or gathers the folders of a split `converge` run
//! (`converge --part K/N`) and measures them as one run.

use crate::converge_cmd;
use crate::film::Film;
use crate::output::ensure_writable;
use crate::partial::{self, Partial};
use crate::render::Sums;
use crate::say;
use anyhow::{Result, bail, ensure};
use std::path::{Path, PathBuf};

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
        return converge_cmd::merge(&args.parts, &args.output);
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

/// Adds parts in sample order, after checking that they belong to one render and hold each of
/// its samples exactly once. Returns the sums and the first part (for its render's identity).
fn add_parts(mut parts: Vec<(&Path, Partial)>) -> Result<(Sums, Partial)> {
    parts.sort_by_key(|(_, p)| p.sums.samples.start);
    let mut iter = parts.into_iter();
    let (first_path, first) = iter.next().expect("clap requires a part");
    ensure!(
        first.sums.samples.start == 0,
        "no part holds the first samples (the earliest part, {}, starts at sample {})",
        first_path.display(),
        first.sums.samples.start
    );
    let mut sums = first.sums.clone();
    for (path, part) in iter {
        let (a, b) = (&first, &part);
        ensure!(
            a.id.fingerprint == b.id.fingerprint && a.id.seed == b.id.seed && a.id.spp == b.id.spp,
            "{} and {} are parts of different renders (scene, settings, seed or spp differ)",
            first_path.display(),
            path.display()
        );
        ensure!(
            (a.sums.width, a.sums.height, a.sums.terms.is_empty())
                == (b.sums.width, b.sums.height, b.sums.terms.is_empty()),
            "{}: its image size or terms differ from {}'s",
            path.display(),
            first_path.display()
        );
        let s = &b.sums.samples;
        ensure!(
            s.start == sums.samples.end,
            "{}: holds samples {}..{}, but the parts before it end at sample {} ({})",
            path.display(),
            s.start,
            s.end,
            sums.samples.end,
            if s.start < sums.samples.end { "an overlap" } else { "a gap: a part is missing or unfinished" }
        );
        sums.append(&part.sums);
    }
    ensure!(
        sums.samples.end == first.id.spp,
        "the parts hold samples 0..{} of the render's {} spp: a part is missing or unfinished",
        sums.samples.end,
        first.id.spp
    );
    Ok((sums, first))
}
