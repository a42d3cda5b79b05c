//! The lobe image integrates to the fiber's albedo, with an h quadrature accurate to 0.1%.

use precompute::conventions::direction;
use precompute::fiber::{Absorption, Chiang, FiberHit, FiberModel, FiberParams, scale_from_beta_n};
use precompute::lobe::{h_rule, lobe_image};
use precompute::spectrum::Rgb;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;

fn params(sigma_a: [f64; 3], beta_m: f64, beta_n: f64, alpha: f64) -> FiberParams {
    FiberParams { absorption: Absorption::SigmaA(sigma_a), beta_m, beta_n, alpha, eta: 1.55, ..Default::default() }
}

#[test]
fn albedo_without_absorption_is_one() {
    for (theta, bm, bn, alpha) in
        [(0.5, 0.3, 0.3, 2.0), (-1.0, 0.3, 0.3, -2.0), (1.3, 0.5, 0.7, 4.0), (0.0, 0.2, 0.3, 0.0)]
    {
        let p = params([0.0; 3], bm, bn, alpha);
        let image = lobe_image(&Chiang::new(&p).unwrap(), theta, 256, 128, &h_rule(scale_from_beta_n(bn), 1));
        let a = image.albedo();
        println!("theta {theta}: albedo {a:?}");
        for c in a.0 {
            assert!((c - 1.0).abs() < 0.005, "theta={theta}: albedo {a:?}");
        }
    }
}

#[test]
fn albedo_with_absorption_matches_the_sampled_furnace() {
    // The furnace value of an absorbing fiber, estimated independently by importance sampling.
    let p = params([0.25, 0.5, 1.0], 0.3, 0.3, 2.0);
    let model = Chiang::new(&p).unwrap();
    let theta = 0.4;
    let image = lobe_image(&model, theta, 256, 128, &h_rule(scale_from_beta_n(0.3), 1));
    let mut rng = Pcg64::seed_from_u64(1);
    let n = 400_000;
    let mut sum = Rgb::ZERO;
    for _ in 0..n {
        let h = 2.0 * rng.random::<f64>() - 1.0;
        sum += model.at(direction(theta, 0.0), h).sample(rng.random()).unwrap().weight();
    }
    let (furnace, albedo) = (sum / n as f64, image.albedo());
    println!("furnace {furnace:?}, lobe albedo {albedo:?}");
    for c in 0..3 {
        assert!((albedo.0[c] - furnace.0[c]).abs() < 0.005 * furnace.0[c], "{albedo:?} vs {furnace:?}");
    }
}

#[test]
fn h_quadrature_is_accurate_to_a_tenth_of_a_percent() {
    // Against a rule four times finer, at every pixel carrying at least 1% of the peak.
    for (bm, bn) in [(0.3, 0.3), (0.2, 0.1), (0.5, 0.8)] {
        let p = params([0.1, 0.3, 0.9], bm, bn, 2.0);
        let model = Chiang::new(&p).unwrap();
        let s = scale_from_beta_n(bn);
        let coarse = lobe_image(&model, 0.3, 96, 48, &h_rule(s, 1));
        let fine = lobe_image(&model, 0.3, 96, 48, &h_rule(s, 4));
        let peak = fine.pixels.iter().map(|p| p.luminance()).fold(0.0, f64::max);
        let mut worst: f64 = 0.0;
        for (c, f) in coarse.pixels.iter().zip(&fine.pixels) {
            if f.luminance() >= 0.01 * peak {
                for k in 0..3 {
                    worst = worst.max(((c.0[k] - f.0[k]) / f.0[k]).abs());
                }
            }
        }
        println!("beta_m {bm} beta_n {bn}: worst relative h-quadrature error {worst:.2e}");
        assert!(worst < 1e-3, "beta_n={bn}: {worst}");
    }
}
