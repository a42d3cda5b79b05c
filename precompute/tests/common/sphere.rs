//! Shared by the fiber-model tests: integrals over the sphere of directions, the chi-square test
//! of a sampler against its density, Monte Carlo means, and an independent Fresnel reflectance.

use glam::DVec3;
use precompute::conventions::direction;
use precompute::fiber::{FiberHit, FiberModel};
use precompute::quadrature::composite;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;
use rayon::prelude::*;
use statrs::distribution::{ChiSquared, ContinuousCDF};
use std::f64::consts::{FRAC_PI_2, PI};

/// Integral over the sphere of `g(wi)` by composite Gauss-Legendre in (theta, phi).
pub fn sphere_quadrature(g: impl Fn(DVec3) -> f64 + Sync, theta_panels: usize, phi_panels: usize) -> f64 {
    let [total] = sphere_integrals(|wi| [g(wi)], theta_panels, phi_panels);
    total
}

/// Integrals over the sphere of several integrands in one pass, as [`sphere_quadrature`]: for
/// models that are costly to evaluate, or several channels of one evaluation.
pub fn sphere_integrals<const N: usize>(
    g: impl Fn(DVec3) -> [f64; N] + Sync,
    theta_panels: usize,
    phi_panels: usize,
) -> [f64; N] {
    let thetas = composite(-FRAC_PI_2, FRAC_PI_2, theta_panels, 4);
    let phis = composite(-PI, PI, phi_panels, 4);
    // Rows in parallel, summed in order: rayon's parallel sum adds in whatever order the threads
    // finish, which changes the last bits from run to run.
    let rows: Vec<[f64; N]> = thetas
        .par_iter()
        .map(|&(t, wt)| {
            let mut row = [0.0; N];
            for &(p, wp) in &phis {
                for (r, v) in row.iter_mut().zip(g(direction(t, p))) {
                    *r += v * wp;
                }
            }
            row.map(|r| r * wt * t.cos())
        })
        .collect();
    rows.iter().fold([0.0; N], |a, b| std::array::from_fn(|k| a[k] + b[k]))
}

/// Chi-square test of `model.sample` against `model.pdf` on an equal-area (sin theta, phi) grid.
pub fn chi_square_p_value(model: &impl FiberModel, wo: DVec3, h: f64, samples: usize, seed: u64) -> (f64, usize) {
    let hit = model.at(wo, h);
    let (nx, np) = (40, 80);
    let mut observed = vec![0.0; nx * np];
    let mut rng = Pcg64::seed_from_u64(seed);
    for _ in 0..samples {
        let s = hit.sample(rng.random()).unwrap();
        let x = (((s.wi.x + 1.0) * 0.5 * nx as f64) as usize).min(nx - 1);
        let p = (((precompute::conventions::phi(s.wi) + PI) / (2.0 * PI) * np as f64) as usize).min(np - 1);
        observed[x * np + p] += 1.0;
    }
    // Expected counts: the pdf integrated over each bin (dw = d(sin theta) dphi), 7x7 Gauss-Legendre.
    let expected: Vec<f64> = (0..nx * np)
        .into_par_iter()
        .map(|b| {
            let (ix, ip) = (b / np, b % np);
            let x0 = -1.0 + 2.0 * ix as f64 / nx as f64;
            let p0 = -PI + 2.0 * PI * ip as f64 / np as f64;
            let mut sum = 0.0;
            for &(x, wx) in &composite(x0, x0 + 2.0 / nx as f64, 1, 7) {
                for &(p, wp) in &composite(p0, p0 + 2.0 * PI / np as f64, 1, 7) {
                    sum += wx * wp * hit.pdf(direction(x.asin(), p));
                }
            }
            sum * samples as f64
        })
        .collect();
    // Pool bins expected to hold fewer than 5 samples (Mitsuba's chi2 test does the same).
    let (mut stat, mut dof, mut pool_o, mut pool_e) = (0.0, 0usize, 0.0, 0.0);
    for (o, e) in observed.iter().zip(&expected) {
        if *e < 5.0 {
            pool_o += o;
            pool_e += e;
        } else {
            stat += (o - e) * (o - e) / e;
            dof += 1;
        }
    }
    if pool_e > 0.0 {
        stat += (pool_o - pool_e) * (pool_o - pool_e) / pool_e;
        dof += 1;
    }
    let p = ChiSquared::new((dof - 1) as f64).unwrap().sf(stat);
    println!("chi2 = {stat:.1} with {} dof, p = {p:.4}", dof - 1);
    (p, dof)
}

/// Mean and standard error of `n` draws of `draw` from seeded uniform numbers (a failed draw
/// counts 0), e.g. the green sample weight f cos / pdf.
pub fn mean_and_error(n: usize, seed: u64, draw: impl Fn([f64; 4]) -> Option<f64>) -> (f64, f64) {
    let mut rng = Pcg64::seed_from_u64(seed);
    let (mut s, mut s2) = (0.0, 0.0);
    for _ in 0..n {
        let w = draw(rng.random()).unwrap_or(0.0);
        s += w;
        s2 += w * w;
    }
    let mean = s / n as f64;
    (mean, ((s2 / n as f64 - mean * mean) / n as f64).sqrt())
}

/// [`mean_and_error`] of the green sample weight of `hit`'s sampler: its estimate of the albedo.
pub fn weight_mean(hit: &impl FiberHit, n: usize, seed: u64) -> (f64, f64) {
    mean_and_error(n, seed, |u| hit.sample(u).map(|s| s.weight().0[1]))
}

/// Unpolarized Fresnel reflectance of a dielectric of index `eta` at incidence cosine `c`, written
/// out from the two polarizations (Hecht), independently of the crate's.
pub fn fresnel(c: f64, eta: f64) -> f64 {
    let s = (1.0 - c * c).sqrt() / eta;
    let ct = (1.0 - s * s).sqrt();
    let rs = (c - eta * ct) / (c + eta * ct);
    let rp = (eta * c - ct) / (eta * c + ct);
    0.5 * (rs * rs + rp * rp)
}
