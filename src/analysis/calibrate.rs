//! Calibration (`dualhair calibrate`): fits the density factors d_f and d_b of `dual` to a path-traced
//! reference of the user's own groom and fiber.
//!
//! `dual`'s image depends on the factors through its terms (see [`Term`]): with d_f applied
//! k times (k = 2 for `zinke2008`, else 1) a pixel is
//!
//! ```text
//! L(d_f, d_b) = S + d_f^k F + d_b B_lit + d_f^k d_b B_shadow
//! ```
//!
//! (single scattering, forward scattering, backscatter where lit and where in shadow). Two `dual`
//! renders with the same seed, at (1, 1) and (1/2, 1), give the four images, and least squares
//! over hair pixels and channels against the reference gives (d_f, d_b) in [0, 1]^2. Only the
//! backscatter lobe's width depends on d_b otherwise (sigma_b, Zinke et al. 2008 eq. 16), so
//! the error after the fit is measured on a fresh render at the fitted values.

use crate::analysis::compare::{block_relative_rmse, hair_pixels, mean_luminance};
use crate::error::{Context, Result, ensure};
use crate::film::Film;
use crate::integrators::IntegratorKind;
use crate::integrators::Term;
use crate::integrators::dual::cache::Cache;
use crate::job::render_scene;
use crate::output::write_atomically;
use crate::progress::Progress;
use crate::scene::SceneFile;

/// The result of a fit: the factors and the error of `dual` before (the scene's own factors)
/// and after, as (mean luminance ratio dual/reference, 4x4-block relative RMSE).
#[derive(Debug)]
pub struct Calibration {
    pub d_f: f64,
    pub d_b: f64,
    pub before: (f64, f64),
    pub after: (f64, f64),
}

/// Least-squares (d_f, d_b) in [0, 1]^2 for the reference `target` from two `dual` renders with the
/// same seed: `full` at (1, 1) and `half` at (1/2, 1); `k` is how often d_f is applied.
pub fn fit(target: &Film, full: &Film, half: &Film, k: i32) -> (f64, f64) {
    let pixels = hair_pixels(target);
    // Per pixel and channel: target, S, F, B_lit, B_shadow.
    let mut rows: Vec<[f64; 5]> = Vec::with_capacity(3 * pixels.len());
    let term = |f: &Film, i: usize, t: Term, c: usize| f.terms[i][t as usize].0[c];
    let half_k = 0.5f64.powi(k);
    for &i in &pixels {
        for c in 0..3 {
            let (back_1, back_half) = (term(full, i, Term::Back, c), term(half, i, Term::Back, c));
            // back_1 = B_lit + B_shadow, back_half = B_lit + (1/2)^k B_shadow.
            let shadow = (back_1 - back_half) / (1.0 - half_k);
            let f = term(full, i, Term::Forward, c);
            rows.push([target.mean[i].0[c], term(full, i, Term::Single, c), f, back_1 - shadow, shadow]);
        }
    }
    // For a given d_b the image is linear in x = d_f^k: solve for x, clamp, keep the best d_b.
    let error = |x: f64, d_b: f64| {
        rows.iter().map(|r| (r[0] - r[1] - d_b * r[3] - x * (r[2] + d_b * r[4])).powi(2)).sum::<f64>()
    };
    let mut best = (f64::INFINITY, 1.0, 1.0);
    for step in 0..=1000 {
        let d_b = step as f64 / 1000.0;
        let (num, den) = rows.iter().fold((0.0, 0.0), |(n, d), r| {
            let g = r[2] + d_b * r[4];
            (n + (r[0] - r[1] - d_b * r[3]) * g, d + g * g)
        });
        let x = if den > 0.0 { (num / den).clamp(0.0, 1.0) } else { 1.0 };
        let e = error(x, d_b);
        if e < best.0 {
            best = (e, x, d_b);
        }
    }
    (best.1.powf(1.0 / k as f64), best.2)
}

/// (mean luminance ratio, 4x4-block relative RMSE) of `test` against `reference`, which
/// [`calibrate`] has checked covers a block fully.
fn errors(test: &Film, reference: &Film) -> (f64, f64) {
    let pixels = hair_pixels(reference);
    let blocks = block_relative_rmse(test, reference, 4).expect("calibrate checked the reference's blocks");
    (mean_luminance(test, &pixels) / mean_luminance(reference, &pixels), blocks.0)
}

/// Renders `file` with `dual` at the given factors.
fn dual(file: &SceneFile, d_f: f64, d_b: f64, cache: &Cache, progress: &dyn Progress) -> Result<Film> {
    let mut f = file.clone();
    f.render.integrator = IntegratorKind::Dual;
    f.render.terms = true;
    (f.dual.d_f, f.dual.d_b) = (d_f, d_b);
    render_scene(&f.build()?, cache, progress)
}

/// Fits the factors of `file` (its camera, spp and seed as given) to `reference`, or to a path
/// traced one rendered at `reference_spp`.
pub fn calibrate(
    file: &SceneFile,
    reference: Option<Film>,
    reference_spp: u32,
    cache: &Cache,
    progress: &dyn Progress,
) -> Result<Calibration> {
    let reference = match reference {
        Some(r) => r,
        None => {
            let mut path = file.clone();
            path.render.integrator = IntegratorKind::Path;
            path.render.spp = reference_spp;
            path.render.seed = file.render.seed.wrapping_add(0x5eed);
            render_scene(&path.build()?, cache, progress)?
        }
    };
    ensure!(
        (reference.width, reference.height) == (file.camera.width, file.camera.height),
        "the reference is {}x{} pixels, the renders {}x{}",
        reference.width,
        reference.height,
        file.camera.width,
        file.camera.height
    );
    ensure!(
        block_relative_rmse(&reference, &reference, 4).is_some(),
        "hair covers no 4x4-pixel block of the reference fully: use a larger --size or frame the hair closer"
    );
    let k = if file.dual.model.d_f_twice() { 2 } else { 1 };
    let full = dual(file, 1.0, 1.0, cache, progress)?;
    let half = dual(file, 0.5, 1.0, cache, progress)?;
    let (d_f, d_b) = fit(&reference, &full, &half, k);
    // The scene's own factors are often the defaults, (1, 1): that render is `full` already.
    let before = if (file.dual.d_f, file.dual.d_b) == (1.0, 1.0) {
        errors(&full, &reference)
    } else {
        errors(&dual(file, file.dual.d_f, file.dual.d_b, cache, progress)?, &reference)
    };
    let after = errors(&dual(file, d_f, d_b, cache, progress)?, &reference);
    Ok(Calibration { d_f, d_b, before, after })
}

/// Sets `dual.d_f` and `dual.d_b` in the scene file, keeping everything else.
pub fn write_factors(path: &std::path::Path, d_f: f64, d_b: f64) -> Result<()> {
    let text = std::fs::read_to_string(path).with_context(|| format!("{}: cannot read", path.display()))?;
    let mut doc: serde_json::Value =
        serde_json::from_str(&text).with_context(|| format!("{}: invalid scene", path.display()))?;
    let root = doc.as_object_mut().with_context(|| format!("{}: not a JSON object", path.display()))?;
    let dual = root.entry("dual").or_insert_with(|| serde_json::json!({}));
    let dual = dual.as_object_mut().with_context(|| format!("{}: `dual` is not an object", path.display()))?;
    // Three decimals: the fit's own precision (d_b is searched in steps of 0.001).
    dual.insert("d_f".into(), ((d_f * 1e3).round() / 1e3).into());
    dual.insert("d_b".into(), ((d_b * 1e3).round() / 1e3).into());
    let out = serde_json::to_string_pretty(&doc)? + "\n";
    write_atomically(path, |tmp| Ok(std::fs::write(tmp, out)?))
}
