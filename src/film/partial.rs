//! Partial renders: a render's exact per-pixel sums ([`Sums`]) stored in its EXR beside the
//! image, so an interrupted render can be resumed (`render --resume`) and the parts of a render
//! split across processes or machines (`render --part K/N`) merged (`dualhair merge`), with the
//! same bits as one uninterrupted render.
//!
//! The file is an ordinary image of the samples it holds (R, G, B, A, header `spp`), plus
//! unsigned 32-bit channels with each fixed-point sum as four little-endian words,
//! `exact.sum.R.0` to `exact.sum.R.3` (and G, B, `exact.sum_sq.*`, `exact.hits`, and with the
//! terms `exact.single.R.0`, ...), and header attributes naming the render they belong to:
//! `dualhair.samples` ("START..END", the sample indices held), `dualhair.spp` (the whole render's
//! spp), `dualhair.seed`, `dualhair.exposure` and `dualhair.fingerprint` (a hash of the scene and
//! settings, spp aside).

use crate::error::{Result, bail, ensure, invalid};
use crate::film::{ExrExtras, ExrLayer, Film, read_exr_layer};
use crate::integrators::Term;
use crate::render::{Exact, PixelSums, Sums, TermSums};
use exr::prelude::{AnyChannel, AttributeValue, FlatSamples, Text};
use std::path::Path;

/// The render a partial file belongs to: what must agree to resume it or to merge it with others.
#[derive(Clone, Debug, PartialEq)]
pub struct RenderId {
    /// Hash of the scene and every setting except the spp (see `render_cmd`).
    pub fingerprint: String,
    pub seed: u64,
    /// The whole render's samples per pixel.
    pub spp: u32,
    /// PNG exposure in stops, so a merge writes the same PNG.
    pub exposure: f64,
}

/// A render's sums and what render they belong to.
pub struct Partial {
    pub id: RenderId,
    pub sums: Sums,
}

const CHANNELS: [&str; 3] = ["R", "G", "B"];

/// The channels of one fixed-point sum per pixel: four 32-bit words per color channel.
fn exact_channels(prefix: &str, values: &[Exact], out: &mut Vec<AnyChannel<FlatSamples>>) {
    for (c, color) in CHANNELS.iter().enumerate() {
        for word in 0..4 {
            let data = values.iter().map(|v| (v.0[c] >> (32 * word)) as u32).collect();
            out.push(AnyChannel::new(format!("exact.{prefix}.{color}.{word}").as_str(), FlatSamples::U32(data)));
        }
    }
}

/// A channel's 32-bit words.
fn words<'a>(layer: &'a ExrLayer, path: &Path, name: &str) -> Result<&'a [u32]> {
    let channel = layer.channel_data.list.iter().find(|c| c.name.to_string() == name);
    match channel.map(|c| &c.sample_data) {
        Some(FlatSamples::U32(v)) if v.len() == layer.size.area() => Ok(v),
        Some(_) => bail!("{}: channel {name} is not one 32-bit integer per pixel", path.display()),
        None => bail!("{}: the partial render has no {name} channel", path.display()),
    }
}

/// Reads back what [`exact_channels`] wrote.
fn read_exact(layer: &ExrLayer, path: &Path, prefix: &str) -> Result<Vec<Exact>> {
    let mut out = vec![Exact::default(); layer.size.area()];
    for (c, color) in CHANNELS.iter().enumerate() {
        for word in 0..4 {
            for (v, &w) in out.iter_mut().zip(words(layer, path, &format!("exact.{prefix}.{color}.{word}"))?) {
                v.0[c] |= ((w as u128) << (32 * word)) as i128;
            }
        }
    }
    Ok(out)
}

/// Writes `sums` with their render's identity to `path` (atomically): the image of these samples
/// plus everything needed to resume or merge them. `aovs` as for [`Film::write_exr`].
pub fn write(path: &Path, sums: &Sums, id: &RenderId, aovs: bool) -> Result<()> {
    let mut channels = Vec::new();
    exact_channels("sum", &sums.pixels.iter().map(|p| p.sum).collect::<Vec<_>>(), &mut channels);
    exact_channels("sum_sq", &sums.pixels.iter().map(|p| p.sum_sq).collect::<Vec<_>>(), &mut channels);
    channels.push(AnyChannel::new("exact.hits", FlatSamples::U32(sums.pixels.iter().map(|p| p.hits).collect())));
    for term in Term::ALL.iter().filter(|_| !sums.terms.is_empty()) {
        let values: Vec<Exact> = sums.terms.iter().map(|t| t[*term as usize]).collect();
        exact_channels(term.name(), &values, &mut channels);
    }
    let text = |s: String| AttributeValue::Text(Text::from(s.as_str()));
    let attributes = vec![
        ("dualhair.samples", text(format!("{}..{}", sums.samples.start, sums.samples.end))),
        ("dualhair.spp", AttributeValue::I32(id.spp.min(i32::MAX as u32) as i32)),
        ("dualhair.seed", text(id.seed.to_string())),
        ("dualhair.exposure", AttributeValue::F64(id.exposure)),
        ("dualhair.fingerprint", text(id.fingerprint.clone())),
    ];
    Film::from_sums(sums).write_exr_with(path, aovs, ExrExtras { channels, attributes })
}

/// Reads a partial render; `None` for an EXR without sums (an ordinary finished render).
pub fn read(path: &Path) -> Result<Option<Partial>> {
    let layer = read_exr_layer(path)?;
    let attribute = |name: &str| layer.attributes.other.get(&Text::from(name));
    let Some(samples) = attribute("dualhair.samples") else {
        return Ok(None);
    };
    let text = |name: &str| match attribute(name) {
        Some(AttributeValue::Text(t)) => Ok(t.to_string()),
        _ => Err(invalid!("{}: the partial render has no text attribute {name}", path.display())),
    };
    let AttributeValue::Text(samples) = samples else {
        bail!("{}: dualhair.samples is not text", path.display());
    };
    let range = samples.to_string();
    let (start, end) = range
        .split_once("..")
        .and_then(|(a, b)| Some((a.parse::<u32>().ok()?, b.parse::<u32>().ok()?)))
        .filter(|(a, b)| a <= b)
        .ok_or_else(|| invalid!("{}: dualhair.samples `{range}` is not START..END", path.display()))?;
    let spp = match attribute("dualhair.spp") {
        Some(AttributeValue::I32(n)) if *n >= 0 && end <= *n as u32 => *n as u32,
        _ => bail!("{}: dualhair.spp is missing or below the samples held ({range})", path.display()),
    };
    let exposure = match attribute("dualhair.exposure") {
        Some(AttributeValue::F64(e)) if e.is_finite() => *e,
        _ => bail!("{}: dualhair.exposure is missing or not finite", path.display()),
    };
    let seed = text("dualhair.seed")?.parse().map_err(|e| invalid!("{}: dualhair.seed: {e}", path.display()))?;
    let id = RenderId { fingerprint: text("dualhair.fingerprint")?, seed, spp, exposure };

    let (sum, sum_sq) = (read_exact(&layer, path, "sum")?, read_exact(&layer, path, "sum_sq")?);
    let hits = words(&layer, path, "exact.hits")?;
    ensure!(hits.iter().all(|&h| h <= end - start), "{}: a pixel has more hits than samples", path.display());
    let pixels = (0..layer.size.area()).map(|i| PixelSums { sum: sum[i], sum_sq: sum_sq[i], hits: hits[i] }).collect();
    let has_terms = layer.channel_data.list.iter().any(|c| c.name.to_string().starts_with("exact.single."));
    let mut terms = vec![TermSums::default(); if has_terms { layer.size.area() } else { 0 }];
    for term in Term::ALL.iter().filter(|_| has_terms) {
        for (t, v) in terms.iter_mut().zip(read_exact(&layer, path, term.name())?) {
            t[*term as usize] = v;
        }
    }
    let (width, height) = (layer.size.width(), layer.size.height());
    Ok(Some(Partial { id, sums: Sums { width, height, samples: start..end, pixels, terms } }))
}

/// Adds parts in sample order, after checking that they belong to one render and hold each of
/// its samples exactly once. Returns the sums and the first part (for its render's identity).
pub fn add_parts(mut parts: Vec<(&Path, Partial)>) -> Result<(Sums, Partial)> {
    parts.sort_by_key(|(_, p)| p.sums.samples.start);
    let mut iter = parts.into_iter();
    let (first_path, first) = iter.next().ok_or_else(|| crate::error::invalid!("no parts to add"))?;
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
