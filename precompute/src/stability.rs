//! What `dualhair stability` measures of one fiber model and sampler at one point of a parameter
//! grid: where each method fails, as numbers. The grid is d'Eon, Marschner and Hanika
//! 2014's (section 2.1: theta_i, alpha, mu_a, beta, eta), on which their rough-cylinder simulation
//! was run.
//!
//! Every estimate draws h uniformly in [-1, 1] with each direction, so albedos are h-averaged as
//! in [`crate::lobe`] and [`crate::fibersim`], and uses its own seeded generator, so results do
//! not depend on thread counts.

use crate::conventions::{SPHERE, direction, uniform_sphere};
use crate::fiber::{Absorption, Fiber, FiberHit, FiberModel, FiberParams, ModelKind, ParamError, SamplerKind};
use crate::fibersim::pixel_of;
use crate::lobe::LobeImage;
use crate::spectrum::Rgb;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;
use std::f64::consts::{PI, TAU};

/// The width each model's R lobe is given at a grid point (it lives with the models).
pub use crate::fiber::r_width;

/// One point of the grid, in d'Eon et al. 2014's physical parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GridPoint {
    /// Inclination of the light direction wo (radians).
    pub theta: f64,
    /// Surface roughness beta (radians): the Beckmann roughness of [`crate::fibersim`].
    pub beta: f64,
    /// Scale tilt in degrees, in [`FiberParams::alpha`]'s sign.
    pub alpha: f64,
    /// Absorption per unit radius (all channels).
    pub mu_a: f64,
    pub eta: f64,
}

/// The parameters of `model` that stand for `point`: the same eta, absorption and tilt for every
/// model, and roughness set so that each model's R lobe is [`r_width`] wide (each model says how
/// in its [`crate::fiber::Model::set_grid_roughness`]).
pub fn params_for(model: ModelKind, point: &GridPoint) -> FiberParams {
    let mut p = FiberParams {
        model,
        absorption: Absorption::SigmaA([point.mu_a; 3]),
        alpha: point.alpha,
        eta: point.eta,
        ..FiberParams::default()
    };
    model.set_grid_roughness(&mut p, point.beta);
    p
}

/// A fiber model with one of its samplers: a row of the stability report.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Method {
    pub model: ModelKind,
    pub sampler: SamplerKind,
}

/// Rows of the stability report: each model, and each flawed sampler once more.
const METHODS: usize = {
    let (mut n, mut i) = (0, 0);
    while i < ModelKind::ALL.len() {
        n += if ModelKind::ALL[i].flawed().is_some() { 2 } else { 1 };
        i += 1;
    }
    n
};

impl Method {
    /// Every model with every sampler it has, in the order of [`ModelKind::ALL`]: its exact
    /// sampler, then its flawed one.
    pub const ALL: [Method; METHODS] = {
        let mut all = [Method { model: ModelKind::ALL[0], sampler: SamplerKind::Exact }; METHODS];
        let (mut i, mut k) = (0, 0);
        while i < ModelKind::ALL.len() {
            let model = ModelKind::ALL[i];
            all[k] = Method { model, sampler: SamplerKind::Exact };
            k += 1;
            if model.flawed().is_some() {
                all[k] = Method { model, sampler: SamplerKind::Flawed(model) };
                k += 1;
            }
            i += 1;
        }
        all
    };

    /// A short name, MODEL-SAMPLER ([`crate::fiber::Model::EXACT_LABEL`] and
    /// [`crate::fiber::FlawedSampler::label`]): `chiang-dEon2013`, `marschner-exact`,
    /// `marschner-thesis`, `sadeghi-cauchy`, `sadeghi-box_muller`, `deon2014-exact`,
    /// `deon2014-iterative`.
    pub fn name(&self) -> &'static str {
        match self.model.flawed() {
            Some(flawed) if self.sampler == SamplerKind::Flawed(self.model) => flawed.label,
            _ => self.model.exact_label(),
        }
    }

    /// The method's fiber at `point`, and the same model with its exact sampler.
    pub fn fibers(&self, point: &GridPoint) -> Result<(Fiber, Fiber), ParamError> {
        let params = params_for(self.model, point);
        Ok((Fiber::new(&params, self.sampler)?, Fiber::exact(&params)?))
    }
}

/// Counts over values a method returned at one grid point.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Health {
    /// Values computed: eval and pdf at random directions, and samples.
    pub values: usize,
    /// NaN or infinite values among them.
    pub non_finite: usize,
    /// Negative values (a channel of f, or a pdf).
    pub negative: usize,
    /// Samples whose reported value or density differs from `eval_pdf` at their direction by more
    /// than 1e-6 relative.
    pub inconsistent: usize,
    /// Draws for which the sampler returned no direction.
    pub no_direction: usize,
}

impl Health {
    fn value(&mut self, f: Rgb, pdf: f64) {
        self.values += 1;
        if !f.is_finite() || !pdf.is_finite() {
            self.non_finite += 1;
        } else if f.0.iter().any(|&c| c < 0.0) || pdf < 0.0 {
            self.negative += 1;
        }
    }
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-6 * a.abs().max(b.abs()) + 1e-300
}

/// Evaluates and samples `fiber` at `hits` random offsets h (with wo at `theta`), `per_hit` random
/// directions and samples each, and counts what went wrong.
pub fn health(fiber: &Fiber, theta: f64, hits: usize, per_hit: usize, seed: u64) -> Health {
    let mut rng = Pcg64::seed_from_u64(seed);
    let wo = direction(theta, 0.0);
    let mut out = Health::default();
    for _ in 0..hits {
        let hit = fiber.at(wo, rng.random_range(-1.0..=1.0));
        for _ in 0..per_hit {
            let (f, pdf) = hit.eval_pdf(uniform_sphere(rng.random()));
            out.value(f, pdf);
            match hit.sample(rng.random()) {
                None => out.no_direction += 1,
                Some(s) => {
                    out.value(s.value, s.pdf);
                    let (f, pdf) = hit.eval_pdf(s.wi);
                    let same = close(pdf, s.pdf) && (0..3).all(|c| close(f.0[c], s.value.0[c]));
                    if !same && s.pdf.is_finite() && pdf.is_finite() {
                        out.inconsistent += 1;
                    }
                }
            }
        }
    }
    out
}

/// A Monte Carlo mean and its standard error.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Estimate {
    pub mean: f64,
    pub se: f64,
}

/// Accumulates the mean and standard error of non-negative finite terms; a non-finite term makes
/// the estimate non-finite (what the report must show).
#[derive(Default)]
struct Mean {
    n: f64,
    sum: f64,
    sum_sq: f64,
}

impl Mean {
    fn add(&mut self, x: f64) {
        self.n += 1.0;
        self.sum += x;
        self.sum_sq += x * x;
    }

    fn estimate(&self) -> Estimate {
        let mean = self.sum / self.n;
        let var = (self.sum_sq / self.n - mean * mean).max(0.0) / (self.n - 1.0).max(1.0);
        Estimate { mean, se: var.sqrt() }
    }
}

/// The h-averaged integrals a method is judged by, at one grid point (luminance of f).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Estimates {
    /// The model's albedo: the integral of f |cos theta_i| over wi (a white furnace when mu_a = 0),
    /// estimated with the defensive mixture below.
    pub albedo: Estimate,
    /// The integral of the density the method reports, same estimator.
    pub pdf_integral: Estimate,
    /// The albedo as the method estimates it: the mean of value / pdf over its own samples.
    pub importance: Estimate,
    /// The albedo with uniform sphere sampling.
    pub uniform: Estimate,
}

/// The share of uniform directions in the reference integrals' defensive mixture: enough to
/// bound every ratio, small enough to leave the exact sampler's low variance.
const UNIFORM_SHARE: f64 = 0.1;

/// Estimates at `theta` from `n` draws of each estimator.
///
/// The reference integrals sample q = (uniform + 9 x the model's exact sampler) / 10 and weigh by
/// 1/q:
/// unbiased for any integrand, and f / q and pdf / q stay bounded wherever the exact sampler
/// follows f, so they converge fast even where uniform sampling cannot see a narrow lobe
/// (Hesterberg's defensive importance sampling). The exact samplers' densities are checked
/// against their samples (chi-square) in the tests.
pub fn estimates(fiber: &Fiber, exact: &Fiber, theta: f64, n: usize, seed: u64) -> Estimates {
    let mut rng = Pcg64::seed_from_u64(seed);
    let wo = direction(theta, 0.0);
    let (mut albedo, mut pdf_integral, mut importance, mut uniform) =
        (Mean::default(), Mean::default(), Mean::default(), Mean::default());
    let fixed = fiber.far_field().then(|| (fiber.at(wo, 0.0), exact.at(wo, 0.0)));
    for _ in 0..n {
        let h = rng.random_range(-1.0..=1.0);
        let own;
        let (tested, reference) = match &fixed {
            Some((t, r)) => (t, r),
            None => {
                own = (fiber.at(wo, h), exact.at(wo, h));
                (&own.0, &own.1)
            }
        };
        let u: [f64; 4] = rng.random();
        let wi = if rng.random::<f64>() < UNIFORM_SHARE {
            Some(uniform_sphere([u[1], u[2]]))
        } else {
            reference.sample(u).map(|s| s.wi)
        };
        match wi {
            Some(wi) => {
                let (f, p_exact) = reference.eval_pdf(wi);
                let q = UNIFORM_SHARE / SPHERE + (1.0 - UNIFORM_SHARE) * p_exact;
                albedo.add(f.luminance() / q);
                pdf_integral.add(tested.pdf(wi) / q);
            }
            None => {
                albedo.add(0.0);
                pdf_integral.add(0.0);
            }
        }
        importance.add(tested.sample(rng.random()).map_or(0.0, |s| s.value.luminance() / s.pdf));
        uniform.add(tested.eval(uniform_sphere(rng.random())).luminance() * SPHERE);
    }
    Estimates {
        albedo: albedo.estimate(),
        pdf_integral: pdf_integral.estimate(),
        importance: importance.estimate(),
        uniform: uniform.estimate(),
    }
}

/// The model's h-averaged lobe as a histogram in [`crate::lobe`]'s layout and units, binned like
/// [`crate::fibersim`]'s images: `n` directions from the model's exact sampler (h uniform), each
/// adding its weight value / pdf to its pixel. Pixels are averages over their solid angle, as the
/// simulation's are, so the two compare at any roughness (evaluating at pixel centers would not
/// see lobes narrower than a pixel).
pub fn lobe_histogram(exact: &Fiber, theta: f64, n: usize, seed: u64, width: usize, height: usize) -> LobeImage {
    let mut rng = Pcg64::seed_from_u64(seed);
    let wo = direction(theta, 0.0);
    let mut image = LobeImage { width, height, pixels: vec![Rgb::ZERO; width * height] };
    let fixed = exact.far_field().then(|| exact.at(wo, 0.0));
    for _ in 0..n {
        let h = rng.random_range(-1.0..=1.0);
        let own;
        let hit = match &fixed {
            Some(hit) => hit,
            None => {
                own = exact.at(wo, h);
                &own
            }
        };
        if let Some(s) = hit.sample(rng.random()) {
            image.pixels[pixel_of(s.wi, width, height) as usize] += s.weight();
        }
    }
    let cell = (PI / height as f64) * (TAU / width as f64);
    for y in 0..height {
        let norm = 1.0 / (n as f64 * image.theta(y).cos() * cell);
        image.pixels[y * width..(y + 1) * width].iter_mut().for_each(|p| *p = *p * norm);
    }
    image
}

/// Relative L1 distance of two lobe images of the same size, by luminance: the integral over the
/// sphere of |a - b| divided by the integral of b, so 0 is identical and 2 is disjoint.
pub fn lobe_distance(a: &LobeImage, b: &LobeImage) -> f64 {
    let (mut diff, mut total) = (0.0, 0.0);
    for y in 0..b.height {
        let w = b.theta(y).cos();
        for x in 0..b.width {
            let i = y * b.width + x;
            diff += w * (a.pixels[i].luminance() - b.pixels[i].luminance()).abs();
            total += w * b.pixels[i].luminance();
        }
    }
    diff / total
}
