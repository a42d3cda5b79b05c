//! Azimuthal scattering N_p: the trimmed logistic about the specular deflection Phi(p, h)
//! (Pharr 2016 section 1.3.3) and its exact sampler.

use std::f64::consts::{FRAC_PI_2, PI, TAU};

/// Logistic scale `s` from the user roughness `beta_n` in [0, 1] (Pharr 2016 section 1.3.3):
/// s = sqrt(pi/8) (0.265 beta + 1.194 beta^2 + 5.372 beta^22).
pub fn scale_from_beta_n(beta_n: f64) -> f64 {
    (PI / 8.0).sqrt() * (0.265 * beta_n + 1.194 * beta_n * beta_n + 5.372 * beta_n.powi(22))
}

/// Net azimuthal deflection of the specular path p: Phi = 2 p gamma_t - 2 gamma_o + p pi.
pub fn phi_p(p: usize, gamma_o: f64, gamma_t: f64) -> f64 {
    let p = p as f64;
    2.0 * p * gamma_t - 2.0 * gamma_o + p * PI
}

fn logistic_cdf(x: f64, s: f64) -> f64 {
    1.0 / (1.0 + (-x / s).exp())
}

/// The logistic distribution of scale `s` trimmed to [-pi, pi] and renormalized.
#[derive(Clone, Copy, Debug)]
pub struct TrimmedLogistic {
    s: f64,
    /// CDF of the untrimmed logistic at -pi.
    cdf_lo: f64,
    /// Its mass inside [-pi, pi].
    mass: f64,
}

impl TrimmedLogistic {
    pub fn new(s: f64) -> TrimmedLogistic {
        let cdf_lo = logistic_cdf(-PI, s);
        TrimmedLogistic { s, cdf_lo, mass: logistic_cdf(PI, s) - cdf_lo }
    }

    /// Density at x in [-pi, pi]: e^(-|x|/s) / (s (1 + e^(-|x|/s))^2) / mass.
    pub fn pdf(&self, x: f64) -> f64 {
        let e = (-x.abs() / self.s).exp();
        e / (self.s * (1.0 + e) * (1.0 + e) * self.mass)
    }

    /// Inverse-CDF sample from u in [0, 1).
    pub fn sample(&self, u: f64) -> f64 {
        let x = -self.s * (1.0 / (u * self.mass + self.cdf_lo) - 1.0).ln();
        // u -> 0 gives -inf and u -> 1 can round past pi; both belong at the interval's ends.
        if x.is_nan() { 0.0 } else { x.clamp(-PI, PI) }
    }

    /// CDF at x in [-pi, pi].
    fn cdf(&self, x: f64) -> f64 {
        ((logistic_cdf(x, self.s) - self.cdf_lo) / self.mass).clamp(0.0, 1.0)
    }

    /// Probability of the circular interval [c - pi/2, c + pi/2] for c in [-pi, pi], the parts
    /// past +-pi wrapped around (the distribution lives on the circle).
    pub fn half_circle_mass(&self, c: f64) -> f64 {
        let (a, b) = (c - FRAC_PI_2, c + FRAC_PI_2);
        let mut m = self.cdf(b.min(PI)) - self.cdf(a.max(-PI));
        if b > PI {
            m += self.cdf(b - TAU);
        }
        if a < -PI {
            m += 1.0 - self.cdf(a + TAU);
        }
        m.clamp(0.0, 1.0)
    }
}
