//! The dual-scattering tables: energy conservation, the closed forms against the series and
//! formulas they stand for, degenerate inputs, theta interpolation, quadrature convergence and the
//! direction of the physical trends.

use precompute::fiber::{Absorption, Chiang, FiberParams, scale_from_beta_n};
use precompute::lobe::h_rule;
use precompute::tables::{D_B, Quantity, Scattering, TableSettings, Tables, compute};
use std::f64::consts::FRAC_PI_2;

fn fiber(absorption: Absorption, beta_m: f64, beta_n: f64, alpha: f64) -> FiberParams {
    FiberParams { absorption, beta_m, beta_n, alpha, eta: 1.55, ..Default::default() }
}

fn melanin(eumelanin: f64) -> Absorption {
    Absorption::Melanin { eumelanin, pheomelanin: 0.0 }
}

/// The default settings for `params` with `theta_count` entries.
fn tables(params: &FiberParams, theta_count: usize) -> Tables {
    let settings = TableSettings { theta_count, ..TableSettings::for_fiber(params) };
    compute(&Chiang::new(params).unwrap(), &settings, D_B)
}

/// A quickly computed table of the default fiber with 5 entries, for the interface tests.
fn small_table() -> Tables {
    let settings = TableSettings { theta_count: 5, h_rule: h_rule(1.0, 1), theta_i_panels: 4, phi_panels: 4 };
    compute(&Chiang::new(&FiberParams::default()).unwrap(), &settings, D_B)
}

/// The statistics of entry `k`, channel `c`.
fn scattering(t: &Tables, k: usize, c: usize) -> Scattering {
    let v = |q| t.values(q)[k].0[c];
    Scattering {
        a_f: v(Quantity::AF),
        a_b: v(Quantity::AB),
        alpha_f: v(Quantity::AlphaF),
        beta_f: v(Quantity::BetaF),
        alpha_b: v(Quantity::AlphaB),
        beta_b: v(Quantity::BetaB),
    }
}

#[test]
fn forward_and_backward_add_up_to_one_without_absorption() {
    for (bm, bn, alpha, n) in [(0.3, 0.3, 2.0, 9), (0.2, 0.5, -4.0, 9), (0.6, 0.2, 4.0, 9), (0.15, 0.15, 1.0, 5)] {
        let t = tables(&fiber(Absorption::SigmaA([0.0; 3]), bm, bn, alpha), n);
        let (af, ab) = (t.values(Quantity::AF), t.values(Quantity::AB));
        let worst = (0..n).flat_map(|k| (af[k] + ab[k]).0).map(|s| (s - 1.0).abs()).fold(0.0, f64::max);
        println!("beta_m {bm} beta_n {bn} alpha {alpha}: worst |a_f + a_b - 1| = {worst:.1e}");
        assert!(worst < 2e-3, "beta_m {bm} beta_n {bn} alpha {alpha}: {worst}");
    }
}

#[test]
fn backscatter_matches_the_series_and_formulas_of_zinke() {
    // Over real table entries (blond hair, every theta and channel) and a grid of made-up ones.
    let t = tables(&fiber(melanin(0.3), 0.3, 0.3, 2.0), 9);
    let mut cases: Vec<Scattering> =
        (0..9).flat_map(|k| (0..3).map(move |c| (k, c))).map(|(k, c)| scattering(&t, k, c)).collect();
    for a_f in [0.05, 0.5, 0.8, 0.9] {
        for a_b in [0.01, 0.1, 1.0 - a_f] {
            cases.push(Scattering { a_f, a_b, alpha_f: 0.03, beta_f: 0.12, alpha_b: -0.05, beta_b: 0.2 });
        }
    }
    for s in cases {
        let Scattering { a_f, a_b, alpha_f, beta_f, alpha_b, beta_b } = s;
        let x = a_f * a_f;
        // Enough terms that the first one left out is below e^-40 of the first.
        let terms = (-40.0 / x.ln()).ceil() as usize + 2;
        let pow: Vec<f64> = (0..3 * terms).map(|e| x.powi(e as i32)).collect();
        // A_1 = a_b sum_{i>=1} a_f^(2i); A_3 = a_b^3 sum_{i>=1} sum_{j<i} sum_{k>j} a_f^(2(i-j-1+k)).
        let a1 = a_b * (1..terms).map(|i| pow[i]).sum::<f64>();
        let mut a3 = 0.0;
        for i in 1..terms {
            for j in 0..i {
                a3 += (j + 1..j + terms).map(|k| pow[i - j - 1 + k]).sum::<f64>();
            }
        }
        a3 *= a_b.powi(3);
        // Delta_b and sigma_b as Zinke et al. 2008 print them.
        let g = 1.0 - x;
        let delta =
            alpha_b * (1.0 - 2.0 * a_b * a_b / (g * g)) + alpha_f * (2.0 * g * g + 4.0 * x * a_b * a_b) / g.powi(3);
        let sigma = (1.0 + D_B * x)
            * (a_b * (2.0 * beta_f.powi(2) + beta_b.powi(2)).sqrt()
                + a_b.powi(3) * (2.0 * beta_f.powi(2) + 3.0 * beta_b.powi(2)).sqrt())
            / (a_b + a_b.powi(3) * (2.0 * beta_f + 3.0 * beta_b));
        let b = s.backscatter(D_B);
        for (name, got, want) in [("A_b", b.a, a1 + a3), ("Delta_b", b.delta, delta), ("sigma_b", b.sigma, sigma)] {
            assert!((got - want).abs() <= 1e-10 * want.abs().max(1.0), "{name} for {s:?}: {got} vs {want}");
        }
    }
}

#[test]
fn degenerate_inputs_stay_finite() {
    let (beta_f, beta_b) = (0.1, 0.2);
    for a_f in [0.0, 0.5, 1.0 - 1e-12, 1.0, 1.001] {
        for a_b in [0.0, 1e-300, 1e-8, 0.5, 1.0] {
            let s = Scattering { a_f, a_b, alpha_f: 0.02, beta_f, alpha_b: -0.04, beta_b };
            let b = s.backscatter(D_B);
            assert!(b.a.is_finite() && b.delta.is_finite() && b.sigma.is_finite(), "{s:?}: {b:?}");
            assert!(b.a >= 0.0 && b.sigma > 0.0, "{s:?}: {b:?}");
            if a_b == 0.0 {
                // No backward scattering: nothing comes back, and sigma_b is the formula's limit.
                let limit = (1.0 + D_B * a_f * a_f) * (2.0 * beta_f * beta_f + beta_b * beta_b).sqrt();
                assert_eq!(b.a, 0.0);
                assert!((b.sigma - limit).abs() < 1e-12, "{s:?}: {b:?}");
            }
        }
    }
    // Opaque fibers, at every inclination including grazing (theta = +-pi/2 are table entries).
    let t = tables(&fiber(Absorption::SigmaA([1e3; 3]), 0.3, 0.3, 2.0), 9);
    assert_eq!((t.theta[0], t.theta[8]), (-FRAC_PI_2, FRAC_PI_2));
    for q in Quantity::ALL {
        assert!(t.values(q).iter().all(|v| v.is_finite()), "{}: {:?}", q.key(), t.values(q));
    }
}

#[test]
fn quadrature_converges() {
    // The default rules against rules with twice their panels in theta_i, phi and h (the default h
    // rule is h_rule(8 s, 1)).
    for (params, label) in
        [(fiber(melanin(1.3), 0.3, 0.3, 2.0), "brown"), (fiber(Absorption::SigmaA([0.0; 3]), 0.2, 0.5, -4.0), "clear")]
    {
        let coarse = TableSettings { theta_count: 5, ..TableSettings::for_fiber(&params) };
        let fine = TableSettings {
            h_rule: h_rule(8.0 * scale_from_beta_n(params.beta_n), 2),
            theta_i_panels: 2 * coarse.theta_i_panels,
            phi_panels: 2 * coarse.phi_panels,
            ..coarse.clone()
        };
        let model = Chiang::new(&params).unwrap();
        let (a, b) = (compute(&model, &coarse, D_B), compute(&model, &fine, D_B));
        for q in [Quantity::AF, Quantity::AB] {
            let worst =
                a.values(q).iter().zip(b.values(q)).flat_map(|(x, y)| (*x - *y).0).map(f64::abs).fold(0.0, f64::max);
            println!("{label} {}: default vs finer {worst:.1e}", q.key());
            assert!(worst < 1e-4, "{label} {}: {worst}", q.key());
        }
    }
}

#[test]
fn linear_interpolation_between_default_entries_is_accurate() {
    // The default grid's entries are the even entries of the (2N - 1)-entry grid (the same theta
    // bit for bit), so one table holds both; the odd entries are checked against linear
    // interpolation between their neighbours at their own theta. Coarse theta_i and phi
    // rules suffice: their error varies smoothly with theta and cancels in the comparison.
    // Brown (the default) and blond hair, whose tables curve most near grazing light.
    for params in [FiberParams::default(), FiberParams { absorption: melanin(0.3), ..Default::default() }] {
        let default = TableSettings::for_fiber(&params);
        let n = default.theta_count;
        let settings = TableSettings { theta_count: 2 * n - 1, theta_i_panels: 4, phi_panels: 4, ..default };
        let fine = compute(&Chiang::new(&params).unwrap(), &settings, D_B);
        let grazing = 80f64.to_radians();
        println!("N = {n}: worst error at the midpoints (inside |theta| <= 80 degrees / beyond)");
        for q in Quantity::ALL {
            let v = fine.values(q);
            let relative = matches!(q, Quantity::AF | Quantity::AB | Quantity::ABack);
            let mut worst = [0.0f64; 2];
            for c in 0..3 {
                let (lo, hi) =
                    v.iter().map(|x| x.0[c]).fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), x| (l.min(x), h.max(x)));
                for k in (1..2 * n - 1).step_by(2) {
                    let t = &fine.theta;
                    let w = (t[k] - t[k - 1]) / (t[k + 1] - t[k - 1]);
                    let (got, want) = ((1.0 - w) * v[k - 1].0[c] + w * v[k + 1].0[c], v[k].0[c]);
                    let err = if relative { (got / want - 1.0).abs() } else { (got - want).abs() / (hi - lo) };
                    let region = usize::from(fine.theta[k].abs() > grazing);
                    worst[region] = worst[region].max(err);
                }
            }
            println!(
                "  {:8} {:.1e} / {:.1e}{}",
                q.key(),
                worst[0],
                worst[1],
                if relative { " relative" } else { " of its range" }
            );
            // Relative 0.1% for the attenuations, 0.1% of the range for shifts and widths, everywhere.
            assert!(worst[0] < 1e-3 && worst[1] < 1e-3, "{}: {worst:?}", q.key());
        }
    }
}

#[test]
fn lookup_interpolates_linearly_and_clamps() {
    let t = small_table();
    for q in Quantity::ALL {
        let v = t.values(q);
        for (&theta, &value) in t.theta.iter().zip(v) {
            assert_eq!(t.lookup(q, theta), value);
        }
        let third = t.lookup(q, t.theta[1] + (t.theta[2] - t.theta[1]) / 3.0);
        let want = v[1] * (2.0 / 3.0) + v[2] * (1.0 / 3.0);
        assert!((third - want).0.iter().all(|d| d.abs() < 1e-12), "{}: {third:?} vs {want:?}", q.key());
        assert_eq!(t.lookup(q, -2.0), v[0]);
        assert_eq!(t.lookup(q, 2.0), v[4]);
    }
}

#[test]
fn exports_follow_the_documented_schema() {
    let params = FiberParams::default();
    let mut t = small_table();
    t.fiber = Some(params);
    let json = t.to_json();
    assert_eq!(json["theta"].as_array().unwrap().len(), 5);
    for q in Quantity::ALL {
        for (c, channel) in ["r", "g", "b"].into_iter().enumerate() {
            let values: Vec<f64> =
                json[q.key()][channel].as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect();
            assert_eq!(values, t.values(q).iter().map(|v| v.0[c]).collect::<Vec<_>>(), "{}", q.key());
        }
    }
    assert_eq!(json["d_b"], 0.7);
    assert_eq!(serde_json::from_value::<FiberParams>(json["fiber"].clone()).unwrap(), params);
    assert_eq!(json["resolution"]["theta_count"], 5);
    assert_eq!(json["resolution"]["order"], 6);

    let mut csv = Vec::new();
    t.write_csv(&mut csv).unwrap();
    let csv = String::from_utf8(csv).unwrap();
    let lines: Vec<&str> = csv.lines().collect();
    assert_eq!(lines.len(), 6);
    assert!(lines[0].starts_with("theta,a_f_r,a_f_g,a_f_b,a_b_r,"), "{}", lines[0]);
    assert!(lines[0].ends_with(",sigma_b_r,sigma_b_g,sigma_b_b"), "{}", lines[0]);
    let row: Vec<f64> = lines[3].split(',').map(|x| x.parse().unwrap()).collect();
    assert_eq!(row.len(), 1 + 9 * 3);
    assert_eq!(row[0], t.theta[2]);
    assert_eq!(row[1 + 3 * 6 + 1], t.values(Quantity::ABack)[2].0[1]);
}

#[test]
fn trends_follow_the_physics() {
    // Blond, brown and black hair (eumelanin 0.3, 1.3, 8) at every inclination short of grazing,
    // where Fresnel reflection goes to 1 and every fiber reflects everything.
    let albedo = [0.3, 1.3, 8.0].map(|e| {
        let t = tables(&fiber(melanin(e), 0.3, 0.3, 2.0), 7);
        let (af, ab) = (t.values(Quantity::AF), t.values(Quantity::AB));
        if e == 0.3 {
            // Light colored hair scatters mostly forward.
            assert!((0..3).all(|c| af[3].0[c] > ab[3].0[c]), "blond at theta = 0: {:?} {:?}", af[3], ab[3]);
        }
        (1..6).map(|k| af[k] + ab[k]).collect::<Vec<_>>()
    });
    for (k, ((blond, brown), black)) in (1..6).zip(albedo[0].iter().zip(&albedo[1]).zip(&albedo[2])) {
        for a in [blond, brown, black] {
            // Melanin absorbs blue most: less than 1 is scattered, least of it in blue.
            assert!(a.0[0] < 1.0 && a.0[0] > a.0[1] && a.0[1] > a.0[2], "entry {k}: {a:?}");
        }
        for c in 0..3 {
            assert!(blond.0[c] > brown.0[c] && brown.0[c] > black.0[c], "entry {k}: {blond:?} {brown:?} {black:?}");
        }
    }
}
