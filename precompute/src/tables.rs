//! The precomputed dual-scattering tables (Zinke et al. 2008; Lemein 2020 ch. 3.3):
//! per color channel, as functions of the light's inclination theta, the forward and backward
//! attenuations a_f, a_b, their longitudinal shifts alpha_f, alpha_b and widths beta_f, beta_b, and
//! the local backscatter quantities A_b, Delta_b, sigma_b derived from them.
//!
//! Frame and units: the fiber frame of [`crate::conventions`]; every angle is in radians. The light
//! is the fixed direction `wo = direction(theta, 0)`, the direction our models are normalized in
//! (a model integrates to its albedo over wi for fixed wo; see [`crate::fiber`]), and wi ranges
//! over the sphere. "Backward" is |phi_i| < pi/2, the half facing the light, "forward" the rest.
//! For one channel,
//!
//! ```text
//! f_bar(wi) = (1/2) int_{-1}^{1} eval(wo, wi, h) dh                                  (1/sr)
//! a_f = int_forward f_bar cos(theta_i) dtheta_i dphi,  a_b the same over the backward half,
//! ```
//!
//! the measure of [`crate::lobe::LobeImage::albedo`], so a_f + a_b is the albedo (1 without
//! absorption). With theta_h = (theta + theta_i) / 2, alpha_f is the mean and beta_f^2 the variance
//! of theta_h under the forward energy f_bar cos(theta_i) dtheta_i dphi, and alpha_b, beta_b the
//! same over the backward half (a half without energy gets shift and width 0). These moments need
//! nothing from the model but `eval`. Widths therefore average as variances (beta^2), and by the
//! law of total variance beta_f^2 includes the spread of the lobe centers about alpha_f: it is the
//! width of the actual forward distribution. That is what the global term needs, sigma_f^2 =
//! n beta_f^2, since variances add under convolution.
//!
//! Everything is integrated deterministically in f64 with composite Gauss-Legendre rules, phi split
//! exactly at +-pi/2 so no panel straddles the forward/backward boundary, in parallel over theta.
//!
//! JSON export ([`Tables::to_json`]):
//!
//! ```text
//! {"theta": [radians over [-pi/2, pi/2], ends included, denser toward the ends: theta_grid],
//!  "a_f": {"r": [...], "g": [...], "b": [...]}, and the same for "a_b", "alpha_f", "beta_f",
//!  "alpha_b", "beta_b", "A_b", "delta_b", "sigma_b" (angles in radians),
//!  "d_b": 0.7, "fiber": FiberParams as serialized or null,
//!  "resolution": {"theta_count", "h_nodes", "theta_i_panels", "phi_panels", "order"}}
//! ```
//!
//! CSV export ([`Tables::write_csv`]): header `theta,a_f_r,a_f_g,a_f_b,...` in the same key order,
//! one row per theta.

use crate::conventions::direction;
use crate::fiber::{FiberModel, FiberParams};
use crate::quadrature::{composite, h_rule};
use crate::spectrum::Rgb;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::f64::consts::{FRAC_PI_2, PI};
use std::io::Write;

/// Zinke et al. 2008's backscatter density factor d_b (thesis eq. 3.21), the default.
pub const D_B: f64 = 0.7;

/// Gauss-Legendre points per panel of the theta_i and phi rules.
const ORDER: usize = 6;

/// Floor on 1 - a_f^2, where the series behind A_b and Delta_b diverge (a_f -> 1: unboundedly many
/// forward passes). Below it the closed forms are evaluated at the floor: large but finite.
const MIN_ONE_MINUS_AF2: f64 = 1e-12;

/// A tabulated quantity; the discriminant indexes [`Quantity::ALL`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Quantity {
    AF,
    AB,
    AlphaF,
    BetaF,
    AlphaB,
    BetaB,
    ABack,
    DeltaB,
    SigmaB,
}

impl Quantity {
    pub const ALL: [Quantity; 9] = [
        Quantity::AF,
        Quantity::AB,
        Quantity::AlphaF,
        Quantity::BetaF,
        Quantity::AlphaB,
        Quantity::BetaB,
        Quantity::ABack,
        Quantity::DeltaB,
        Quantity::SigmaB,
    ];

    /// The key in the JSON and CSV exports.
    pub fn key(self) -> &'static str {
        ["a_f", "a_b", "alpha_f", "beta_f", "alpha_b", "beta_b", "A_b", "delta_b", "sigma_b"][self as usize]
    }
}

/// A tables JSON document that does not follow the schema of [`Tables::to_json`].
#[derive(Debug, thiserror::Error)]
#[error("not a dual-scattering tables document: {0}")]
pub struct TablesFormatError(String);

/// How finely the tables are computed.
#[derive(Clone, Debug)]
pub struct TableSettings {
    /// Entries of the theta grid over [-pi/2, pi/2], both ends included (at least 2); see
    /// [`theta_grid`].
    pub theta_count: usize,
    /// `(h, weight)` nodes averaging over h in [-1, 1] (weights sum to 1), e.g. [`h_rule`].
    pub h_rule: Vec<(f64, f64)>,
    /// Gauss-Legendre panels over theta_i in [-pi/2, pi/2].
    pub theta_i_panels: usize,
    /// Gauss-Legendre panels over each half of phi_i (each pi wide).
    pub phi_panels: usize,
}

/// The resolution a table was computed at, recorded in its exports.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Resolution {
    pub theta_count: usize,
    pub h_nodes: usize,
    pub theta_i_panels: usize,
    pub phi_panels: usize,
    /// Gauss-Legendre points per theta_i and phi panel.
    pub order: usize,
}

impl TableSettings {
    /// Settings sized to a fiber's narrowest features: `scale` is the azimuthal logistic scale s
    /// and `variance` the longitudinal variance v (for the Chiang model,
    /// [`crate::fiber::scale_from_beta_n`] and [`crate::fiber::variance_from_beta_m`]; its
    /// narrowest longitudinal lobe, TT, has variance v/4).
    ///
    /// The integrands are logistic in phi and in gamma at scale s and about Gaussian in theta_i, so
    /// panels a few of those widths wide with 6-point rules suffice: theta_i panels 1.5 sqrt(v)
    /// wide (three standard deviations of the TT lobe), phi panels 6 s wide, and h panels 2 s wide
    /// in gamma ([`h_rule`]`(8 s, 1)`; the per-direction lobe image needs them four times finer).
    /// a_f and a_b then agree with rules twice as fine in every dimension to a few 1e-6 (tested to
    /// 1e-4) for beta_m, beta_n in 0.15..0.6. The cost grows as 1/(s^2 sqrt(v)); for beta_m =
    /// beta_n = 0.3 the default table takes about 4 s on 2 cores.
    ///
    /// The theta grid has 641 entries, denser toward grazing light ([`theta_grid`]): there the
    /// tables curve steeply (Fresnel reflection goes to 1; a_b of brown hair rises from 0.2 at 75
    /// degrees to 0.7 at 90), and linear interpolation then reaches 0.1% everywhere (tested).
    pub fn for_roughness(scale: f64, variance: f64) -> TableSettings {
        TableSettings {
            theta_count: 641,
            h_rule: h_rule(8.0 * scale, 1),
            theta_i_panels: panels(PI, 1.5 * variance.sqrt()),
            phi_panels: panels(PI, 6.0 * scale),
        }
    }

    /// [`TableSettings::for_roughness`] for a fiber: at the azimuthal scale and longitudinal
    /// variance of its model's narrowest features ([`crate::fiber::Model::table_features`], where
    /// each model says what they are), with the model's h rule ([`FiberParams::h_rule`]: one node
    /// for a far-field model, whose f is already integrated over h).
    pub fn for_fiber(params: &FiberParams) -> TableSettings {
        let features = params.model.table_features(params);
        let mut settings = TableSettings {
            h_rule: params.h_rule(8.0),
            ..TableSettings::for_roughness(features.scale, features.variance)
        };
        settings.theta_i_panels = settings.theta_i_panels.max(features.min_theta_i_panels);
        settings.phi_panels = settings.phi_panels.max(features.min_phi_panels);
        if features.even_phi_panels {
            settings.phi_panels += settings.phi_panels % 2;
        }
        settings
    }

    /// What the exports record of these settings.
    pub fn resolution(&self) -> Resolution {
        Resolution {
            theta_count: self.theta_count,
            h_nodes: self.h_rule.len(),
            theta_i_panels: self.theta_i_panels,
            phi_panels: self.phi_panels,
            order: ORDER,
        }
    }
}

/// Panels of at most `width` over an interval of length `span`, at least 4 and at most 4096.
fn panels(span: f64, width: f64) -> usize {
    ((span / width).ceil() as usize).clamp(4, 4096)
}

/// One channel's forward/backward statistics at one light inclination (angles in radians).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Scattering {
    pub a_f: f64,
    pub a_b: f64,
    pub alpha_f: f64,
    pub beta_f: f64,
    pub alpha_b: f64,
    pub beta_b: f64,
}

/// The local backscatter quantities of one channel.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Backscatter {
    /// A_b: average backscattering attenuation (one and three backward events).
    pub a: f64,
    /// Delta_b: average longitudinal shift of the backscattered light in theta_h (radians).
    pub delta: f64,
    /// sigma_b: its average longitudinal standard deviation in theta_h (radians).
    pub sigma: f64,
}

impl Scattering {
    /// A_b, Delta_b and sigma_b (Zinke et al. 2008), finite for every
    /// a_f, a_b in [0, 1] and beyond: with a_b = 0, A_b = 0, Delta_b = alpha_b + 2 alpha_f/(1 - a_f^2)
    /// and sigma_b is its limit (1 + d_b a_f^2) sqrt(2 beta_f^2 + beta_b^2); where 1 - a_f^2 falls
    /// below 1e-12 (a_f -> 1) it is taken as 1e-12.
    pub fn backscatter(&self, d_b: f64) -> Backscatter {
        let Scattering { a_f, a_b, alpha_f, beta_f, alpha_b, beta_b } = *self;
        let af2 = a_f * a_f;
        let g = (1.0 - af2).max(MIN_ONE_MINUS_AF2);
        let ab2 = a_b * a_b;
        // A_b = A_1 + A_3 (Zinke et al. 2008; thesis eqs. 3.23-3.25). Light enters the
        // stack of fiber layers below x (layer 0 is x's own) and each layer passes it on forward
        // (a_f) or turns it around (a_b). One turn at depth i >= 1 crosses i layers down and i up:
        // A_1 = a_b sum_{i>=1} a_f^(2i). Three turns, at depths i >= 1 (down to up), j < i (up to
        // down) and k > j (down to up), cross i + (i-j-1) + (k-j-1) + k layers:
        // A_3 = a_b^3 sum_{i>=1} sum_{j=0}^{i-1} sum_{k>=j+1} a_f^(2(i-j-1+k)) = a_b^3 a_f^2/(1-a_f^2)^3
        // (with x = a_f^2 and l = k-j-1 the exponent is i + l, and each i has i choices of j: the sum
        // is sum_{i>=1} i x^i sum_{l>=0} x^l = x/(1-x)^3). The cube is the one public code gets wrong.
        let a = a_b * af2 / g + a_b * ab2 * af2 / (g * g * g);
        // Delta_b (Zinke et al. 2008).
        let delta = alpha_b * (1.0 - 2.0 * ab2 / (g * g)) + alpha_f * (2.0 * g * g + 4.0 * af2 * ab2) / (g * g * g);
        // sigma_b (Zinke et al. 2008), numerator and denominator divided
        // by a_b so that a_b = 0 gives the limit instead of 0/0.
        let (bf2, bb2) = (beta_f * beta_f, beta_b * beta_b);
        let sigma = (1.0 + d_b * af2) * ((2.0 * bf2 + bb2).sqrt() + ab2 * (2.0 * bf2 + 3.0 * bb2).sqrt())
            / (1.0 + ab2 * (2.0 * beta_f + 3.0 * beta_b));
        Backscatter { a, delta, sigma }
    }
}

/// The dual-scattering tables of one fiber.
#[derive(Clone, Debug)]
pub struct Tables {
    /// Light inclinations (radians), increasing.
    pub theta: Vec<f64>,
    /// `values[q as usize][k]`: quantity q at theta[k].
    values: [Vec<Rgb>; 9],
    /// The backscatter density factor used for sigma_b.
    pub d_b: f64,
    /// The fiber the tables describe, when known (the caller sets it; models do not expose it).
    pub fiber: Option<FiberParams>,
    pub resolution: Resolution,
}

/// Energy-weighted moments of theta_h over one half of the sphere, per channel.
#[derive(Clone, Copy, Default)]
struct Moments {
    m0: Rgb,
    m1: Rgb,
    m2: Rgb,
}

impl Moments {
    /// (energy, mean, standard deviation) of channel c; an empty half has mean and width 0.
    fn stats(&self, c: usize) -> (f64, f64, f64) {
        let m0 = self.m0.0[c];
        if m0 <= 0.0 {
            return (m0.max(0.0), 0.0, 0.0);
        }
        let mean = self.m1.0[c] / m0;
        (m0, mean, (self.m2.0[c] / m0 - mean * mean).max(0.0).sqrt())
    }
}

/// The backward and forward moments for a light at inclination `theta`.
fn half_moments(
    model: &impl FiberModel,
    theta: f64,
    theta_i: &[(f64, f64)],
    halves: &[Vec<(f64, f64)>; 2],
    h_rule: &[(f64, f64)],
) -> [Moments; 2] {
    let wo = direction(theta, 0.0);
    let mut out = [Moments::default(); 2];
    let (mut wis, mut averages) = (Vec::new(), Vec::new());
    for &(t, wt) in theta_i {
        let th = 0.5 * (theta + t);
        let cos_t = t.cos();
        // The row's directions, both halves, and f averaged over h at each.
        wis.clear();
        wis.extend(halves.iter().flatten().map(|&(p, _)| direction(t, p)));
        averages.resize(wis.len(), Rgb::ZERO);
        model.eval_h_average(wo, h_rule, &wis, &mut averages);
        let mut row = averages.iter();
        for (half, rule) in out.iter_mut().zip(halves) {
            for (&(_, wp), &f_bar) in rule.iter().zip(&mut row) {
                let e = f_bar * (wt * wp * cos_t);
                half.m0 += e;
                half.m1 += e * th;
                half.m2 += e * (th * th);
            }
        }
    }
    out
}

/// Share of the sine term in [`theta_grid`].
const GRID_BEND: f64 = 0.6;

/// The light inclinations of an `n`-entry table: theta = (pi/2) ((1 - b) u + b sin(pi u / 2)) for
/// u uniform over [-1, 1] and b = 0.6. Entries are 2.5 times closer than a uniform grid's at +-pi/2,
/// where the tables curve most, and 1.34 times farther apart at theta = 0. The entries of the
/// (2n - 1)-entry grid with even index are exactly those of the n-entry grid.
pub fn theta_grid(n: usize) -> Vec<f64> {
    (0..n)
        .map(|k| {
            let u = 2.0 * k as f64 / (n - 1) as f64 - 1.0;
            FRAC_PI_2 * ((1.0 - GRID_BEND) * u + GRID_BEND * (FRAC_PI_2 * u).sin())
        })
        .collect()
}

/// Computes the tables of `model` for the light inclinations of `settings`, with backscatter
/// density factor `d_b` (Zinke et al. 2008 use 0.7, [`D_B`]). `fiber` is left `None`.
pub fn compute(model: &impl FiberModel, settings: &TableSettings, d_b: f64) -> Tables {
    let n = settings.theta_count;
    assert!(n >= 2, "a theta grid needs at least 2 entries");
    let theta = theta_grid(n);
    let theta_i = composite(-FRAC_PI_2, FRAC_PI_2, settings.theta_i_panels, ORDER);
    // Backward half |phi| < pi/2, then forward half pi/2 <= phi <= 3 pi/2.
    let halves = [FRAC_PI_2, 3.0 * FRAC_PI_2].map(|hi| composite(hi - PI, hi, settings.phi_panels, ORDER));
    let moments: Vec<[Moments; 2]> =
        theta.par_iter().map(|&t| half_moments(model, t, &theta_i, &halves, &settings.h_rule)).collect();

    let mut values: [Vec<Rgb>; 9] = std::array::from_fn(|_| vec![Rgb::ZERO; n]);
    for (k, [back, fwd]) in moments.iter().enumerate() {
        for c in 0..3 {
            let (a_f, alpha_f, beta_f) = fwd.stats(c);
            let (a_b, alpha_b, beta_b) = back.stats(c);
            let s = Scattering { a_f, a_b, alpha_f, beta_f, alpha_b, beta_b };
            let b = s.backscatter(d_b);
            for (q, v) in
                Quantity::ALL.into_iter().zip([a_f, a_b, alpha_f, beta_f, alpha_b, beta_b, b.a, b.delta, b.sigma])
            {
                values[q as usize][k].0[c] = v;
            }
        }
    }
    Tables { theta, values, d_b, fiber: None, resolution: settings.resolution() }
}

impl Tables {
    /// Quantity `q` at every theta entry.
    pub fn values(&self, q: Quantity) -> &[Rgb] {
        &self.values[q as usize]
    }

    /// Quantity `q` at light inclination `theta` (radians), linearly interpolated between entries
    /// and clamped to the first and last.
    pub fn lookup(&self, q: Quantity, theta: f64) -> Rgb {
        let (k, w) = self.bracket(theta);
        let v = self.values(q);
        v[k - 1] * (1.0 - w) + v[k] * w
    }

    /// The entry k >= 1 with theta[k - 1] <= theta < theta[k] (clamped to the ends) and the
    /// interpolation weight of entry k.
    fn bracket(&self, theta: f64) -> (usize, f64) {
        let t = &self.theta;
        let k = t.partition_point(|&x| x <= theta).clamp(1, t.len() - 1);
        (k, ((theta - t[k - 1]) / (t[k] - t[k - 1])).clamp(0.0, 1.0))
    }

    /// Every quantity at light inclination `theta`, indexed by `Quantity as usize` (one search
    /// for all nine; see [`Tables::lookup`]).
    pub fn at(&self, theta: f64) -> [Rgb; 9] {
        let (k, w) = self.bracket(theta);
        std::array::from_fn(|q| self.values[q][k - 1] * (1.0 - w) + self.values[q][k] * w)
    }

    /// Reads the JSON export back, checking it: every key present, every array as long as
    /// `theta`, every number finite, `theta` increasing within [-pi/2, pi/2].
    pub fn from_json(doc: &serde_json::Value) -> Result<Tables, TablesFormatError> {
        let bad = |m: String| TablesFormatError(m);
        let numbers = |v: &serde_json::Value, what: &str| -> Result<Vec<f64>, TablesFormatError> {
            let a = v.as_array().ok_or_else(|| bad(format!("`{what}` is not an array")))?;
            a.iter()
                .map(|x| x.as_f64().filter(|x| x.is_finite()))
                .collect::<Option<Vec<f64>>>()
                .ok_or_else(|| bad(format!("`{what}` holds a value that is not a finite number")))
        };
        let field = |k: &str| doc.get(k).ok_or_else(|| bad(format!("missing `{k}`")));
        let theta = numbers(field("theta")?, "theta")?;
        if theta.len() < 2 || theta.windows(2).any(|w| w[0] >= w[1]) || theta.iter().any(|t| t.abs() > FRAC_PI_2 + 1e-9)
        {
            return Err(bad("`theta` must be at least 2 increasing angles within [-pi/2, pi/2]".into()));
        }
        let mut values: [Vec<Rgb>; 9] = std::array::from_fn(|_| vec![Rgb::ZERO; theta.len()]);
        for q in Quantity::ALL {
            let entry = field(q.key())?;
            for (c, name) in ["r", "g", "b"].into_iter().enumerate() {
                let what = format!("{}.{name}", q.key());
                let v = numbers(entry.get(name).ok_or_else(|| bad(format!("missing `{what}`")))?, &what)?;
                if v.len() != theta.len() {
                    return Err(bad(format!("`{what}` has {} entries, `theta` {}", v.len(), theta.len())));
                }
                for (k, x) in v.into_iter().enumerate() {
                    values[q as usize][k].0[c] = x;
                }
            }
        }
        let d_b =
            field("d_b")?.as_f64().filter(|d| d.is_finite()).ok_or_else(|| bad("`d_b` is not a number".into()))?;
        let fiber = serde_json::from_value(field("fiber")?.clone()).map_err(|e| bad(format!("`fiber`: {e}")))?;
        let resolution =
            serde_json::from_value(field("resolution")?.clone()).map_err(|e| bad(format!("`resolution`: {e}")))?;
        Ok(Tables { theta, values, d_b, fiber, resolution })
    }

    /// The JSON export described in the module documentation.
    pub fn to_json(&self) -> serde_json::Value {
        let mut doc = serde_json::Map::new();
        doc.insert("theta".into(), self.theta.clone().into());
        for q in Quantity::ALL {
            let channel = |c: usize| self.values(q).iter().map(|v| v.0[c]).collect::<Vec<f64>>();
            doc.insert(q.key().into(), serde_json::json!({"r": channel(0), "g": channel(1), "b": channel(2)}));
        }
        doc.insert("d_b".into(), self.d_b.into());
        doc.insert("fiber".into(), serde_json::to_value(self.fiber).expect("fiber parameters serialize"));
        doc.insert("resolution".into(), serde_json::to_value(self.resolution).expect("resolution serializes"));
        doc.into()
    }

    /// The CSV export: header `theta,a_f_r,a_f_g,a_f_b,...`, one row per theta (radians).
    pub fn write_csv<W: Write>(&self, mut w: W) -> std::io::Result<()> {
        let header: Vec<String> =
            Quantity::ALL.iter().flat_map(|q| ["r", "g", "b"].map(|c| format!("{}_{c}", q.key()))).collect();
        writeln!(w, "theta,{}", header.join(","))?;
        for (k, t) in self.theta.iter().enumerate() {
            let row: Vec<String> =
                Quantity::ALL.iter().flat_map(|&q| self.values(q)[k].0.map(|v| v.to_string())).collect();
            writeln!(w, "{t},{}", row.join(","))?;
        }
        Ok(())
    }
}
