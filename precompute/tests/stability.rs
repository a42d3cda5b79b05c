//! Checks of the measures `dualhair stability` takes, against facts known without them: the
//! Chiang model conserves energy and samples exactly (Pharr 2016), the Marschner thesis density's
//! integral by plain quadrature, and a lobe image evaluated pixel by pixel.

use crate::common::sphere::sphere_quadrature;
use precompute::fiber::{Fiber, FiberHit, FiberModel, ModelKind, SamplerKind, scale_from_beta_n};
use precompute::lobe::{LobeImage, h_rule, lobe_image};
use precompute::quadrature::composite;
use precompute::spectrum::Rgb;
use precompute::stability::{GridPoint, Method, estimates, health, lobe_distance, lobe_histogram, params_for};

fn point(theta: f64, beta: f64) -> GridPoint {
    GridPoint { theta, beta, alpha: 2.0, mu_a: 0.0, eta: 1.55 }
}

#[test]
fn chiang_furnace_and_pdf_integrals_are_one() {
    // Without absorption Chiang's albedo is exactly 1 (Pharr 2016's white furnace) and its density
    // integrates to 1, at every roughness, including where uniform sampling cannot see the lobe.
    let method = Method { model: ModelKind::Chiang, sampler: SamplerKind::Exact };
    for (theta, beta) in [(0.0, 0.0025), (1.0, 0.04), (std::f64::consts::FRAC_PI_2 - 1e-4, 0.3), (0.5, 0.01)] {
        let (fiber, exact) = method.fibers(&point(theta, beta)).unwrap();
        let e = estimates(&fiber, &exact, theta, 40_000, 7);
        println!("theta {theta} beta {beta}: {e:?}");
        for (name, x) in [("albedo", e.albedo), ("pdf integral", e.pdf_integral), ("importance", e.importance)] {
            assert!((x.mean - 1.0).abs() <= 4.0 * x.se + 1e-9, "{name}: {x:?}");
            assert!(x.se < 0.02, "{name}: the defensive mixture should converge fast: {x:?}");
        }
        // Uniform sampling cannot see a lobe this narrow (its standard error is then no guide).
        if beta >= 0.04 {
            assert!((e.uniform.mean - 1.0).abs() <= 4.0 * e.uniform.se, "uniform {:?}", e.uniform);
        }
        let h = health(&fiber, theta, 16, 8, 3);
        assert_eq!((h.non_finite, h.negative, h.inconsistent, h.no_direction), (0, 0, 0, 0), "{h:?}");
        assert_eq!(h.values, 16 * 8 * 2);
    }
}

#[test]
fn pdf_integral_of_a_wrong_density_matches_quadrature() {
    // The thesis's stated Marschner density is not normalized; the defensive estimate of its
    // integral (averaged over h) must equal a plain quadrature over h and the sphere.
    // The thesis's defaults (beta_R = -alpha_R = 7.5 degrees), light at theta 1.2 (integral 1.06).
    let p = GridPoint { theta: 1.2, beta: 7.5f64.to_radians() / 2f64.sqrt(), alpha: 3.75, mu_a: 0.0, eta: 1.55 };
    let method = Method { model: ModelKind::Marschner, sampler: SamplerKind::Flawed(ModelKind::Marschner) };
    let (fiber, exact) = method.fibers(&p).unwrap();
    let e = estimates(&fiber, &exact, p.theta, 60_000, 11);
    let wo = precompute::conventions::direction(p.theta, 0.0);
    let quad: f64 = composite(-1.0, 1.0, 8, 4)
        .iter()
        .map(|&(h, w)| {
            let hit = fiber.at(wo, h);
            0.5 * w * sphere_quadrature(|wi| hit.pdf(wi), 96, 192)
        })
        .sum();
    println!("stated density's integral: estimate {:?}, quadrature {quad}", e.pdf_integral);
    assert!((quad - 1.0).abs() > 0.01, "this test needs a density that is not normalized: {quad}");
    assert!(
        (e.pdf_integral.mean - quad).abs() <= 4.0 * e.pdf_integral.se + 1e-3 * quad,
        "{:?} vs {quad}",
        e.pdf_integral
    );
}

#[test]
fn lobe_histogram_matches_the_evaluated_lobe() {
    // Sampling and binning (the stability command's model side) against evaluating f at pixel
    // centers and averaging over h by quadrature (`lobe`), for lobes several pixels wide.
    let p = GridPoint { theta: 0.6, beta: 0.3, alpha: 2.0, mu_a: 0.5, eta: 1.55 };
    let params = params_for(ModelKind::Chiang, &p);
    let fiber = Fiber::exact(&params).unwrap();
    let (w, h) = (120, 60);
    let evaluated = lobe_image(&fiber, p.theta, w, h, &h_rule(scale_from_beta_n(params.beta_n), 1));
    let binned = lobe_histogram(&fiber, p.theta, 2_000_000, 5, w, h);
    let d = lobe_distance(&binned, &evaluated);
    let albedo = (binned.albedo().luminance(), evaluated.albedo().luminance());
    println!("distance {d}, albedo {albedo:?}");
    assert!((albedo.0 / albedo.1 - 1.0).abs() < 0.01, "{albedo:?}");
    // Binning averages over a pixel where evaluation takes its center: a few percent at this size.
    assert!(d < 0.06, "{d}");
    // A lobe seen from another inclination is far away.
    let other = lobe_image(&fiber, -p.theta, w, h, &h_rule(scale_from_beta_n(params.beta_n), 1));
    assert!(lobe_distance(&other, &evaluated) > 0.5);
}

#[test]
fn lobe_distance_is_zero_for_equal_and_two_for_disjoint_images() {
    let image = |lit: usize| LobeImage {
        width: 4,
        height: 2,
        pixels: (0..8).map(|i| if i == lit { Rgb::splat(3.0) } else { Rgb::ZERO }).collect(),
    };
    assert_eq!(lobe_distance(&image(1), &image(1)), 0.0);
    assert!((lobe_distance(&image(1), &image(2)) - 2.0).abs() < 1e-12);
}

#[test]
fn every_model_gets_the_grids_r_width() {
    // Each model's roughness is set so that its R lobe has the width sqrt(2) beta of d'Eon et al. 2014
    // eq. 6 at h = 0: measured here as the standard deviation of theta_i + theta_o over the
    // R-only lobe of a nearly opaque fiber at normal incidence, by quadrature over azimuths near
    // the mirror direction (phi = 0 is h = 0 for the far-field models, whose R narrows with h).
    for &model in ModelKind::ALL {
        let p = GridPoint { theta: 0.0, beta: 0.04, alpha: 0.0, mu_a: 1e4, eta: 1.55 };
        let fiber = Fiber::exact(&params_for(model, &p)).unwrap();
        let hit = fiber.at(precompute::conventions::direction(0.0, 0.0), 0.0);
        let (mut m0, mut m2) = (0.0, 0.0);
        for &(t, w) in &composite(-0.5, 0.5, 400, 4) {
            let row: f64 = composite(-0.2, 0.2, 16, 4)
                .iter()
                .map(|&(ph, wp)| wp * hit.eval(precompute::conventions::direction(t, ph)).luminance())
                .sum();
            m0 += w * row;
            m2 += w * row * t * t;
        }
        let sd = (m2 / m0).sqrt();
        println!("{model:?}: R width {sd:.5} rad (target {:.5})", 0.04 * std::f64::consts::SQRT_2);
        assert!((sd / (0.04 * std::f64::consts::SQRT_2) - 1.0).abs() < 0.1, "{model:?}: {sd}");
    }
}

#[test]
fn methods_are_every_model_with_each_of_its_samplers() {
    // Today's models first (a model added later comes after them).
    let names: Vec<&str> = Method::ALL.iter().map(Method::name).take(7).collect();
    assert_eq!(
        names,
        [
            "chiang-dEon2013",
            "marschner-exact",
            "marschner-thesis",
            "sadeghi-cauchy",
            "sadeghi-box_muller",
            "deon2014-exact",
            "deon2014-iterative"
        ]
    );
    for &model in ModelKind::ALL {
        let samplers: Vec<SamplerKind> = Method::ALL.iter().filter(|m| m.model == model).map(|m| m.sampler).collect();
        let flawed = model.flawed().map(|_| SamplerKind::Flawed(model));
        assert_eq!(samplers, [Some(SamplerKind::Exact), flawed].into_iter().flatten().collect::<Vec<_>>());
    }
    // Another model's flawed sampler is the model's exact one.
    let odd = Method { model: ModelKind::Marschner, sampler: SamplerKind::Flawed(ModelKind::Sadeghi) };
    assert_eq!(odd.name(), "marschner-exact");
}
