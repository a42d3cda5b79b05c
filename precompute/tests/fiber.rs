//! Physical and statistical checks of the Chiang 2016 fiber and its samplers.

use crate::common::sphere::{chi_square_p_value, sphere_integrals};
use glam::DVec3;
use precompute::conventions::{SPHERE, direction};
use precompute::fiber::{
    Absorption, Chiang, FiberHit, FiberModel, FiberParams, FiberSample, SpreadHit, UniformSampled, mp,
    scale_from_beta_n,
};
use precompute::quadrature::{composite, h_rule};
use precompute::special::i0e;
use precompute::spectrum::Rgb;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;
use rayon::prelude::*;
use std::f64::consts::{FRAC_PI_2, PI};

const BETAS: [f64; 5] = [0.1, 0.3, 0.5, 0.7, 0.9];
const ALPHAS: [f64; 3] = [0.0, 2.0, 4.0];

fn fiber(beta_m: f64, beta_n: f64, alpha: f64, sigma_a: f64) -> Chiang {
    Chiang::new(&FiberParams {
        absorption: Absorption::SigmaA([sigma_a; 3]),
        beta_m,
        beta_n,
        alpha,
        eta: 1.55,
        ..Default::default()
    })
    .unwrap()
}

/// The furnace grid of the issue: beta_m x beta_n x alpha x {random, grazing} light direction.
fn furnace_grid() -> Vec<(f64, f64, f64, DVec3)> {
    let mut rng = Pcg64::seed_from_u64(7);
    let random_wo = direction((2.0 * rng.random::<f64>() - 1.0).asin(), PI * (2.0 * rng.random::<f64>() - 1.0));
    let mut grid = Vec::new();
    for bm in BETAS {
        for bn in BETAS {
            for a in ALPHAS {
                for wo in [random_wo, direction(1.5, 0.3)] {
                    grid.push((bm, bn, a, wo));
                }
            }
        }
    }
    grid
}

/// Randomized quasi-Monte Carlo estimate of the albedo with uniformly sampled (h, wi): the R3
/// Kronecker sequence (Roberts 2018) over (h, u1, u2) (the uniform sampler's pair) under 8
/// independent random shifts. Doubles the count until the shifts' standard error is below 0.2%
/// (or 2^23 points per shift).
/// Returns (mean, standard error, points per shift).
fn uniform_furnace(model: &impl FiberModel, wo: DVec3, seed: u64) -> (f64, f64, usize) {
    let g = 1.220_744_084_605_759_5_f64; // the real root of x^4 = x + 1 (R3's generator)
    let step = [1.0 / g, 1.0 / (g * g), 1.0 / (g * g * g)];
    let mut rng = Pcg64::seed_from_u64(seed);
    let shifts: Vec<[f64; 3]> = (0..8).map(|_| rng.random()).collect();
    let mut sums = [0.0; 8];
    let (mut done, mut n) = (0usize, 1usize << 14);
    loop {
        for (shift, sum) in shifts.iter().zip(sums.iter_mut()) {
            for i in done..n {
                let x: [f64; 3] = std::array::from_fn(|d| (shift[d] + step[d] * i as f64).fract());
                *sum += model.at(wo, 2.0 * x[0] - 1.0).sample([0.0, x[1], x[2], 0.0]).unwrap().weight().0[1];
            }
        }
        done = n;
        let est = sums.map(|s| s / n as f64);
        let mean = est.iter().sum::<f64>() / 8.0;
        let se = (est.iter().map(|e| (e - mean).powi(2)).sum::<f64>() / 7.0 / 8.0).sqrt();
        if se < 0.002 || n >= 1 << 23 {
            return (mean, se, n);
        }
        n *= 2;
    }
}

#[test]
fn white_furnace_uniform_sampling() {
    let results: Vec<_> = furnace_grid()
        .par_iter()
        .enumerate()
        .map(|(i, &(bm, bn, a, wo))| {
            let (mean, se, n) = uniform_furnace(&UniformSampled(fiber(bm, bn, a, 0.0)), wo, i as u64);
            (bm, bn, a, wo.x.asin(), mean, se, n)
        })
        .collect();
    let worst = results.iter().max_by(|x, y| (x.4 - 1.0).abs().total_cmp(&(y.4 - 1.0).abs())).unwrap();
    let most = results.iter().map(|r| r.6).max().unwrap();
    println!(
        "uniform furnace: worst (beta_m, beta_n, alpha, theta_o, albedo, se, n) = {worst:?}; most points per shift {most}"
    );
    for r in &results {
        assert!((r.4 - 1.0).abs() < 0.01, "uniform furnace off: {r:?}");
        assert!(r.5 < 0.003, "uniform furnace too noisy to judge: {r:?}");
    }
}

#[test]
fn white_furnace_importance_sampling() {
    let n = 20_000;
    let worst = furnace_grid()
        .par_iter()
        .map(|&(bm, bn, a, wo)| {
            let model = fiber(bm, bn, a, 0.0);
            let mut rng = Pcg64::seed_from_u64(11 + (bm * 1e3 + bn * 1e5 + a) as u64);
            let mut sum = 0.0;
            for _ in 0..n {
                let h = 2.0 * rng.random::<f64>() - 1.0;
                if let Some(s) = model.at(wo, h).sample(rng.random()) {
                    sum += s.weight().0[1];
                }
            }
            let albedo = sum / n as f64;
            ((albedo - 1.0).abs(), (bm, bn, a, wo.x.asin(), albedo))
        })
        .reduce(|| (0.0, (0.0, 0.0, 0.0, 0.0, 0.0)), |x, y| if x.0 >= y.0 { x } else { y });
    println!("importance furnace: worst |albedo - 1| = {:.2e} at {:?}", worst.0, worst.1);
    assert!(worst.0 < 0.005, "importance furnace off by {} at {:?}", worst.0, worst.1);
}

#[test]
fn h_average_shares_work_across_offsets_with_the_same_bits() {
    // Chiang's own h-average (M_p once per direction) against the plain per-offset sum, which
    // `UniformSampled` inherits (its hits evaluate as the model's): equal bit for bit, for
    // absorbing, tilted and grazing cases, one-node and empty rules included.
    let mut rng = Pcg64::seed_from_u64(17);
    for (bm, bn, a, sa, theta_o) in
        [(0.3, 0.3, 2.0, 0.0, 0.4), (0.1, 0.5, -4.0, 0.8, -1.2), (0.6, 0.2, 0.0, 3.0, FRAC_PI_2 - 1e-4)]
    {
        let model = fiber(bm, bn, a, sa);
        let wo = direction(theta_o, 0.7);
        let wis: Vec<DVec3> = (0..200)
            .map(|_| direction((2.0 * rng.random::<f64>() - 1.0).asin(), PI * (2.0 * rng.random::<f64>() - 1.0)))
            .collect();
        for rule in [h_rule(8.0 * scale_from_beta_n(bn), 1), vec![(0.3, 1.0)], vec![]] {
            let mut shared = vec![Rgb::splat(f64::NAN); wis.len()];
            let mut plain = vec![Rgb::splat(f64::NAN); wis.len()];
            model.eval_h_average(wo, &rule, &wis, &mut shared);
            UniformSampled(model.clone()).eval_h_average(wo, &rule, &wis, &mut plain);
            let same = shared.iter().zip(&plain).all(|(x, y)| x.0.map(f64::to_bits) == y.0.map(f64::to_bits));
            assert!(same, "{:?}: shared and per-offset sums differ", (bm, bn, a, rule.len()));
            assert!(rule.is_empty() || shared.iter().any(|f| f.luminance() > 0.0), "{:?}", (bm, bn, rule.len()));
        }
    }
}

#[test]
fn sample_weights_are_one_without_absorption() {
    let worst = furnace_grid()
        .par_iter()
        .map(|&(bm, bn, a, wo)| {
            let model = fiber(bm, bn, a, 0.0);
            let mut rng = Pcg64::seed_from_u64(13);
            let mut worst: f64 = 0.0;
            for _ in 0..5_000 {
                let h = 2.0 * rng.random::<f64>() - 1.0;
                let s = model.at(wo, h).sample(rng.random()).expect("the sampler must always return a direction");
                for c in 0..3 {
                    worst = worst.max((s.weight().0[c] - 1.0).abs());
                }
            }
            worst
        })
        .reduce(|| 0.0, f64::max);
    println!("sample weights: worst |f cos / pdf - 1| = {worst:.2e}");
    assert!(worst < 1e-3, "worst sample weight deviates by {worst}");
}

#[test]
fn sampling_consistency_under_varying_radiance() {
    // Pharr 2016's SamplingConsistency: both estimators of the reflected radiance under
    // L(w) = w_z^2 must agree within their combined statistical error, which must be small.
    let li = |w: DVec3| w.z * w.z;
    let n = 400_000;
    let grid: Vec<(f64, f64)> = [0.2, 0.4, 0.6, 0.8].iter().flat_map(|&m| [0.4, 0.6, 0.8].map(|n| (m, n))).collect();
    grid.par_iter().enumerate().for_each(|(k, &(bm, bn))| {
        let mut rng = Pcg64::seed_from_u64(17 + k as u64);
        {
            let model = fiber(bm, bn, 2.0, 0.25);
            let uniform = UniformSampled(model.clone());
            let wo = direction((2.0 * rng.random::<f64>() - 1.0).asin(), 2.0 * PI * rng.random::<f64>());
            let mut stats = [(0.0, 0.0); 2];
            for _ in 0..n {
                let h = 2.0 * rng.random::<f64>() - 1.0;
                let u: [f64; 4] = rng.random();
                let samples = [model.at(wo, h).sample(u), uniform.at(wo, h).sample(u)];
                for (k, s) in samples.into_iter().enumerate() {
                    let x = s.map_or(0.0, |s| s.weight().luminance() * li(s.wi));
                    stats[k].0 += x;
                    stats[k].1 += x * x;
                }
            }
            let mean_se = stats.map(|(s, s2)| {
                let mean = s / n as f64;
                (mean, ((s2 / n as f64 - mean * mean) / n as f64).sqrt())
            });
            let (imp, uni) = (mean_se[0], mean_se[1]);
            let se = (imp.1 * imp.1 + uni.1 * uni.1).sqrt();
            println!(
                "beta_m={bm} beta_n={bn}: importance {:.5} +- {:.5}, uniform {:.5} +- {:.5}",
                imp.0, imp.1, uni.0, uni.1
            );
            assert!(se < 0.015 * uni.0, "test has too little power: se {se} vs {}", uni.0);
            assert!((imp.0 - uni.0).abs() < 4.0 * se, "estimates differ: {imp:?} vs {uni:?}");
        }
    });
}

#[test]
fn pdf_and_energy_integrate_to_one() {
    // (beta_m, beta_n, alpha, theta_o, h): low roughness, tilted, grazing and near-edge cases.
    let cases = [
        (0.3, 0.3, 2.0, 0.3, 0.4),
        (0.1, 0.3, 0.0, -0.8, -0.9),
        (0.7, 0.9, 4.0, 1.5, 0.0),
        (0.2, 0.2, -4.0, 1.2, 0.99),
        (0.5, 0.1, 2.0, -1.55, -0.3),
    ];
    for (bm, bn, a, theta_o, h) in cases {
        let model = fiber(bm, bn, a, 0.0);
        let wo = direction(theta_o, 0.4);
        let hit = model.at(wo, h);
        let [pdf, energy] = sphere_integrals(
            |wi| {
                let (f, pdf) = hit.eval_pdf(wi);
                [pdf, f.0[0]]
            },
            600,
            600,
        );
        println!("{:?}: int pdf = {pdf:.6}, int f cos = {energy:.6}", (bm, bn, a, theta_o, h));
        assert!((pdf - 1.0).abs() < 0.005, "pdf integrates to {pdf}");
        assert!((energy - 1.0).abs() < 0.005, "energy integrates to {energy}");
    }
}

#[test]
fn longitudinal_normalization_down_to_tiny_variance() {
    // int M_p cos(theta_i) dtheta_i = 1 (Pharr 2016 eq. 1.3), including v where the naive formula
    // overflows (sinh(1/v) = inf for v < 1.4e-3).
    for v in [1e-4, 1e-3, 0.02, 0.3, 5.0, 100.0] {
        for theta_o in [0.0, 0.7, -1.3, 1.55] {
            let (so, co) = f64::sin_cos(theta_o);
            let total: f64 = composite(-FRAC_PI_2, FRAC_PI_2, 20_000, 4)
                .iter()
                .map(|&(t, w)| w * t.cos() * mp(t.cos(), t.sin(), co, so, v))
                .sum();
            assert!((total - 1.0).abs() < 1e-6, "v={v} theta_o={theta_o}: {total}");
        }
    }
}

#[test]
#[allow(clippy::excessive_precision)] // reference values pasted as printed
fn bessel_and_mp_match_independent_values() {
    // e^-x I0(x) and M_p computed with mpmath 1.3 at 50 significant digits:
    //   mp.besseli(0, x) * mp.exp(-x)
    //   mp.exp(-sin(to) sin(ti)/v) * mp.besseli(0, cos(to) cos(ti)/v) / (2 v mp.sinh(1/v))
    let i0e_ref = [
        (0.0, 1.0),
        (0.5, 0.64503527044915007),
        (3.0, 0.2430003541618254),
        (12.0, 0.11642622121344044),
        (19.9, 0.090008588864389594),
        (20.1, 0.089553763620613447),
        (100.0, 0.039944379299096683),
        (1e4, 0.0039894726746047321),
    ];
    for (x, want) in i0e_ref {
        let got = i0e(x);
        assert!(((got - want) / want).abs() < 1e-13, "i0e({x}) = {got}, want {want}");
    }
    // (theta_o, theta_i, v, M_p)
    let mp_ref = [
        (-0.5, 0.5, 1e-4, 45.459968470625305),
        (-0.5, 0.51, 1e-4, 27.649301746702152),
        (0.3, -0.29, 1e-3, 12.544075145906104),
        (0.3, -0.25, 1e-3, 3.7583159444218631),
        (1.2, -1.18, 1e-2, 10.62487054407767),
        (1.2, -0.9, 1e-2, 0.097126324269873793),
        (0.0, 0.0, 0.1, 1.2783333742691275),
        (0.7, 0.2, 0.1, 0.033727331485824813),
        (-1.0, 0.4, 0.5, 0.67087165746840472),
        (1.5, -1.5, 2e-4, 400.83194837079315),
        (1.5, 1.2, 0.3, 0.0053788683067210547),
        (0.2, 0.1, 2.0, 0.50367975487255035),
        (1.55, -1.55, 1e-4, 1984.1868036955902),
    ];
    for (to, ti, v, want) in mp_ref {
        let got = mp(f64::cos(ti), f64::sin(ti), f64::cos(to), f64::sin(to), v);
        // The peak cases at v = 1e-4 amplify the f64 rounding of cos(theta_o + theta_i) by 1/v.
        assert!(((got - want) / want).abs() < 1e-9, "M_p({to}, {ti}, v={v}) = {got}, want {want}");
    }
}

#[test]
fn sampled_directions_follow_the_pdf() {
    // (beta_m, beta_n, alpha, sigma_a, theta_o, h)
    let cases = [
        (0.3, 0.3, 2.0, 0.0, 0.4, 0.3),
        (0.1, 0.3, 0.0, 0.0, -0.6, -0.5),
        (0.3, 0.5, 4.0, 0.0, 1.2, 0.8),
        (0.6, 0.8, -4.0, 0.0, 1.5, -0.95),
        (0.25, 0.3, 2.0, 0.8, 0.1, 0.0),
    ];
    // Sidak-corrected significance 1% over all cases.
    let alpha = 1.0 - 0.99f64.powf(1.0 / cases.len() as f64);
    for (i, (bm, bn, a, sa, theta_o, h)) in cases.into_iter().enumerate() {
        let model = fiber(bm, bn, a, sa);
        let (p, dof) = chi_square_p_value(&model, direction(theta_o, 0.0), h, 400_000, 100 + i as u64);
        assert!(dof > 50, "too few bins to be a test: {dof}");
        assert!(p > alpha, "case {i} {:?}: p = {p}", (bm, bn, a, sa, theta_o, h));
    }
}

#[test]
fn chi_square_test_rejects_a_wrong_pdf() {
    // The test above must have power: the same sampler checked against a slightly wider M_p
    // (beta_m 0.3 vs 0.32) must fail.
    struct Mismatched(Chiang, Chiang);
    struct MismatchedHit<'a>(<Chiang as FiberModel>::Hit<'a>, <Chiang as FiberModel>::Hit<'a>);
    impl FiberModel for Mismatched {
        type Hit<'a> = MismatchedHit<'a>;
        fn at(&self, wo: DVec3, h: f64) -> MismatchedHit<'_> {
            MismatchedHit(self.0.at(wo, h), self.1.at(wo, h))
        }
    }
    impl FiberHit for MismatchedHit<'_> {
        fn eval(&self, wi: DVec3) -> Rgb {
            self.0.eval(wi)
        }
        fn sample(&self, u: [f64; 4]) -> Option<FiberSample> {
            self.0.sample(u)
        }
        fn eval_pdf(&self, wi: DVec3) -> (Rgb, f64) {
            (self.0.eval(wi), self.1.pdf(wi))
        }
    }
    let model = Mismatched(fiber(0.3, 0.3, 2.0, 0.0), fiber(0.32, 0.3, 2.0, 0.0));
    let (p, _) = chi_square_p_value(&model, direction(0.4, 0.0), 0.3, 400_000, 5);
    assert!(p < 1e-6, "a wrong pdf passed with p = {p}");
}

#[test]
fn stable_over_the_parameter_grid_of_deon_marschner_and_hanika() {
    let mut thetas = vec![0.0, 0.25, 0.5, 0.75, 1.0, 1.1, 1.2, 1.3, 1.4, 1.5, 1.55, FRAC_PI_2 - 1e-6, FRAC_PI_2];
    thetas.extend(thetas.clone().iter().map(|t| -t));
    let alphas = [0.0, 2.0, -2.0, 4.0, -4.0];
    let mu_a = [0.0, 0.003, 0.006, 0.015, 0.03, 0.06, 0.12, 0.25, 0.5, 1.0, 2.0, 4.0, 8.0, 16.0];
    let betas = [0.0025, 0.005, 0.01, 0.02, 0.03, 0.04, 0.06, 0.08, 0.15, 0.3];
    let etas = [1.55, 1.55 / 1.33];
    let hs = [-1.0, -0.999, 0.0, 0.999, 1.0];
    let below_one = 1.0 - f64::EPSILON / 2.0;
    let us =
        [[0.0; 4], [below_one; 4], [0.0, below_one, 0.0, below_one], [below_one, 0.0, 0.5, 0.0], [0.3, 0.7, 0.1, 0.9]];
    let mut cases = Vec::new();
    for &a in &alphas {
        for &m in &mu_a {
            for &b in &betas {
                for &eta in &etas {
                    cases.push((a, m, b, eta));
                }
            }
        }
    }
    let failures: Vec<String> = cases
        .par_iter()
        .flat_map_iter(|&(alpha, m, beta, eta)| {
            let params = FiberParams {
                absorption: Absorption::SigmaA([m; 3]),
                beta_m: beta,
                beta_n: beta,
                alpha,
                eta,
                ..Default::default()
            };
            let model = Chiang::new(&params).unwrap();
            let mut bad = Vec::new();
            for &t in &thetas {
                let wo = direction(t, 0.1);
                for &h in &hs {
                    let hit = model.at(wo, h);
                    for &u in &us {
                        let ok = match hit.sample(u) {
                            Some(s) => {
                                s.value.is_finite()
                                    && s.pdf.is_finite()
                                    && s.pdf > 0.0
                                    && s.wi.is_finite()
                                    && (s.wi.length() - 1.0).abs() < 1e-9
                            }
                            // u1 = 0 draws the exact antipode of the specular cone, where M_p is
                            // e^(-2/v)-small and underflows to 0 for tiny v: a measure-zero sample
                            // the sampler must decline rather than weight by 0/0.
                            None => u[1] == 0.0,
                        };
                        if !ok {
                            bad.push(format!("sample {params:?} theta={t} h={h} u={u:?}"));
                        }
                    }
                    for &ti in &thetas {
                        let wi = direction(ti, 2.0);
                        let (f, pdf) = hit.eval_pdf(wi);
                        if !(f.is_finite() && f.0.iter().all(|&c| c >= 0.0) && pdf.is_finite() && pdf >= 0.0) {
                            bad.push(format!("eval/pdf {params:?} theta_o={t} theta_i={ti} h={h}: {f:?} {pdf}"));
                        }
                    }
                }
            }
            bad
        })
        .collect();
    assert!(failures.is_empty(), "{} failures, first: {:?}", failures.len(), &failures[..failures.len().min(5)]);
}

#[test]
fn sigma_a_from_color_matches_the_published_example() {
    // Pharr 2016 figure 1.20: color (0.2, 0.8, 0.3) at beta_n = 0.8 gives sigma_a = (0.141, 0.003, 0.079).
    let params = FiberParams { absorption: Absorption::Color([0.2, 0.8, 0.3]), beta_n: 0.8, ..Default::default() };
    let s = params.sigma_a();
    for (got, want) in s.0.iter().zip([0.141, 0.003, 0.079]) {
        assert!((got - want).abs() < 6e-4, "{s:?}");
    }
    // Concentrations: black (8) absorbs more than brown (1.3), more than blond (0.3), in every channel,
    // and pheomelanin reddens (absorbs blue more than red).
    let melanin = |e: f64, p: f64| {
        FiberParams { absorption: Absorption::Melanin { eumelanin: e, pheomelanin: p }, ..Default::default() }.sigma_a()
    };
    for c in 0..3 {
        assert!(melanin(8.0, 0.0).0[c] > melanin(1.3, 0.0).0[c] && melanin(1.3, 0.0).0[c] > melanin(0.3, 0.0).0[c]);
    }
    let red = melanin(0.0, 1.0);
    assert!(red.0[2] > 4.0 * red.0[0]);
}

#[test]
fn bad_parameters_are_named() {
    let cases = [
        (FiberParams { beta_m: 0.0, ..Default::default() }, "beta_m"),
        (FiberParams { beta_n: f64::NAN, ..Default::default() }, "beta_n"),
        (FiberParams { eta: 0.9, ..Default::default() }, "eta"),
        (FiberParams { alpha: f64::INFINITY, ..Default::default() }, "alpha"),
        (FiberParams { absorption: Absorption::SigmaA([0.1, -1.0, 0.0]), ..Default::default() }, "sigma_a"),
        (FiberParams { absorption: Absorption::Color([0.0, 0.5, 0.5]), ..Default::default() }, "color"),
        (
            FiberParams { absorption: Absorption::Melanin { eumelanin: -1.0, pheomelanin: 0.0 }, ..Default::default() },
            "eumelanin",
        ),
    ];
    for (params, field) in cases {
        let err = Chiang::new(&params).unwrap_err();
        assert_eq!(err.field, field);
        assert!(err.to_string().contains(field), "{err}");
    }
    assert!(Chiang::new(&FiberParams::default()).is_ok());
}

#[test]
fn furnace_value_with_absorption_matches_between_estimators() {
    // Uniform-sphere estimate of the h-averaged albedo agrees with the importance estimate.
    let model =
        Chiang::new(&FiberParams { absorption: Absorption::SigmaA([0.2, 0.5, 1.0]), ..Default::default() }).unwrap();
    let wo = direction(0.2, 0.0);
    let mut rng = Pcg64::seed_from_u64(3);
    let n = 400_000;
    let (mut imp, mut uni) = (Rgb::ZERO, Rgb::ZERO);
    let uniform = UniformSampled(model.clone());
    for _ in 0..n {
        let h = 2.0 * rng.random::<f64>() - 1.0;
        let u: [f64; 4] = rng.random();
        imp += model.at(wo, h).sample(u).unwrap().weight();
        uni += uniform.at(wo, h).sample(u).unwrap().value * SPHERE;
    }
    let (imp, uni) = (imp / n as f64, uni / n as f64);
    for c in 0..3 {
        assert!((imp.0[c] - uni.0[c]).abs() < 0.01 * uni.0[c], "{imp:?} vs {uni:?}");
    }
    assert!(imp.0[0] < 1.0 && imp.0[2] < imp.0[0], "absorption must remove energy, most in blue: {imp:?}");
}

#[test]
fn spread_response_is_the_half_circle_average_of_the_fiber() {
    // Without extra longitudinal spread, f_s^G at azimuth phi is (1/pi) times the integral of f_s
    // over [phi - pi/2, phi + pi/2]: checked against quadrature of `eval`, an independent path
    // (no logistic CDF involved).
    let model = fiber(0.3, 0.25, 2.0, 0.4);
    let rule = composite(-FRAC_PI_2, FRAC_PI_2, 400, 6);
    for (theta_o, h, theta_i, phi_i) in [(0.3, 0.2, -0.4, 0.1), (-1.0, -0.8, 0.9, 2.9), (1.4, 0.95, -1.2, -2.0)] {
        let wo = direction(theta_o, 0.0);
        let hit = model.at(wo, h);
        let got = hit.eval_spread(direction(theta_i, phi_i), Rgb::ZERO);
        let want: Rgb = rule.iter().map(|&(x, w)| hit.eval(direction(theta_i, phi_i + x)) * (w / PI)).sum();
        for c in 0..3 {
            let rel = (got.0[c] - want.0[c]).abs() / want.0[c];
            assert!(rel < 1e-6, "{:?} channel {c}: {} vs {}", (theta_o, h, theta_i, phi_i), got.0[c], want.0[c]);
        }
    }
}

#[test]
fn spread_response_keeps_the_albedo() {
    // f_s^G integrates over wi to the same albedo as f_s, channel by channel: the spread moves
    // light, never adds or removes it.
    let cases = [
        (0.3, 0.3, 2.0, 0.5, 0.4, 0.3, 0.05),
        (0.2, 0.4, -3.0, 0.0, -1.2, -0.9, 0.6),
        (0.5, 0.2, 2.0, 0.2, 1.5, 0.0, 2.0),
    ];
    for (i, (bm, bn, a, sa, theta_o, h, spread)) in cases.into_iter().enumerate() {
        let wo = direction(theta_o, 0.3);
        let model = fiber(bm, bn, a, sa);
        let hit = model.at(wo, h);
        // Both responses, all three channels, in one pass over the sphere.
        let energies = sphere_integrals(
            |wi| {
                let (plain, spread) = hit.eval_both(wi, Rgb([spread; 3]));
                [plain.0[0], plain.0[1], plain.0[2], spread.0[0], spread.0[1], spread.0[2]]
            },
            600,
            600,
        );
        for c in 0..3 {
            let (plain, spread_energy) = (energies[c], energies[3 + c]);
            assert!((spread_energy / plain - 1.0).abs() < 2e-3, "case {i} channel {c}: {spread_energy} vs {plain}");
        }
    }
}
