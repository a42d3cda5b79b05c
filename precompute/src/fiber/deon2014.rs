//! d'Eon, Marschner and Hanika 2014's fiber model with non-separable lobes, sampled
//! exactly; the paper's iterative sampler (its section 3 and Appendix A) is kept to be measured.
//!
//! Notation. The paper calls the fixed (incident) direction theta_i and the scattered one theta_r
//! (theta_o in its text); here, as in the whole crate, `wo` = (theta_o, phi_o) is fixed and
//! `wi` = (theta_i, phi_i) is integrated or sampled: the paper's theta_i is our theta_o and its
//! theta_r our theta_i. phi = phi_i - phi_o, theta_d = (theta_o - theta_i) / 2, h = sin gamma.
//! Parameters (section 2.1, per wavelength): beta = `beta_m` (Beckmann roughness, radians),
//! alpha = `alpha` (degrees; sign below), eta = `eta`, mu_a = `sigma_a()` per unit radius.
//!
//! # The model
//!
//! Three lobes p = R, TT, TRT, each a mixture over the offset h at which light enters:
//!
//! ```text
//! f(wo, wi) |cos theta_i| = sum_p (1/2) int dh A_p(h) M(theta_i; c_p(h), v_p(h)) K_p(phi - Phi_p(h; theta_d))
//! ```
//!
//! - M(theta_i; c, v): d'Eon 2011's longitudinal lobe (seed eq. 5; [`Longitudinal`]) about the
//!   cone inclination c, a density of theta_i over cos theta_i dtheta_i. Eq. 5's 1/cos theta turns
//!   it into f; the projected value multiplies that by cos theta_i again.
//! - c_p(h) = asin x_p: the exit sine of the path through normals tilted by alpha at every
//!   interface, from section 2.2's compositions of the rotation Q in Nusselt coordinates
//!   (`trace`): R[a1], T'[a2] P T[a1], T'[a3] P R'[a2] P T[a1] applied to (sin theta_o, h cos
//!   theta_o). Total internal reflection on the way out (TT and TRT at grazing angles and tilt):
//!   the paper's rule (section 2.4): square-root inputs clamped to 0, and the pole
//!   c = -sign(theta_o) pi/2 where |x_p| > 1.
//! - v_p(h) = (beta^2 / 2) sum_k (dx_p / dalpha_k)^2 / cos^2 theta: the linearized variance of the
//!   exit inclination (section 2.2), each tilt alpha_k independent with variance beta^2 / 2, the
//!   per-axis slope variance of a Beckmann surface of roughness beta (what eq. 6 implies; see the
//!   errata), with the derivatives by the chain rule through Q's derivative matrix at
//!   alpha_k = 0, as the paper's widths are (eq. 6 for R, D_TT "estimated at alpha = 0", D_TRT at
//!   h = 0 and alpha = 0). At alpha_k = alpha they would collapse the lobe where a tilted cone
//!   passes the pole and diverge next to total internal reflection. Clamped to [`V_MIN`,
//!   `V_MAX`]: R's width vanishes at grazing offsets (eq. 6), TT's diverges at grazing light.
//! - R: h(phi) = -sin(phi / 2), the single root of Phi_R = -2 gamma, and no azimuthal roughness
//!   (section 2.3): the lobe is A_R M cos(phi/2) / 4 in closed form, exactly the paper's.
//! - TT: K a wrapped Gaussian of variance beta^2 / 2 (section 2.4). Each h carries its own cone
//!   and width: where the paper evaluates them at the root h(phi) of the (noisy) phi, we keep the h
//!   the light entered at. The two agree as the azimuthal width goes to 0; this one is a normalized
//!   density for every beta and is defined where Phi_TT has no root (|phi| < 2 asin(1/eta')).
//! - TRT: separable as the paper makes it (section 2.5): cone and width at h = 0; K a wrapped
//!   Gaussian of variance 2 beta^2.
//! - Phi_p(h; theta_d) = 2 p gamma_t - 2 gamma + p pi (eq. 3), sin gamma_t = h / eta', with the
//!   Bravais index eta' = sqrt(eta^2 - sin^2 theta_d) / cos theta_d at the theta_d of the
//!   integrated direction: the paper's coupling of N_p to theta_i, which curves the TRT caustic
//!   with theta (its Fig. 6b).
//! - A_p(h) = F, (1 - F)^2 T, (1 - F)^2 F T^2 (Pharr 2016 section 1.3.2; d'Eon 2011) at the fixed
//!   direction: F at cos theta_o cos gamma, T = exp(-mu_a 2 cos gamma_t / cos theta_t) with
//!   gamma_t at theta_o. Paths past TRT are not modeled (the paper's model has these three lobes):
//!   without absorption the albedo is the smooth cylinder's R + TT + TRT energy, below 1.
//!
//! With A_p and v_p taken at theta_o (the paper takes v_TT and v_TRT at theta_d "for reciprocity",
//! which its M breaks anyway), every M integrates to 1 over theta_i and every K to 1 over phi, so
//! lobe p integrates over the sphere to exactly (1/2) int A_p dh: no normalization is lost to the
//! non-separability. The model is normalized in wi for fixed wo, not reciprocal.
//!
//! Evaluation integrates over gamma with Gauss-Legendre panels: only where the kernel is not
//! negligible (within [`WINDOW`] standard deviations; the preimages found by bracketed Newton on
//! each interval where Phi_p is monotone), panels [`FINE`] kernel widths wide in phi and narrow
//! enough for the cone to move by at most half a lobe width across one.
//!
//! # Scale tilt
//!
//! The compositions as printed (R[a] = Q(a, -Q(-a, .))) put the R cone at -theta_o - 2 alpha_k:
//! our sign ([`FiberParams::alpha`]: positive alpha puts R toward the root, at -theta_o - 2
//! alpha), so alpha_k = alpha here. The paper's closed form for theta_cone_R (section 2.3) has the
//! opposite sign (its R peak is at -theta_o + 2 alpha at phi = 0), which is also the sign of
//! Marschner's alpha_R and of the paper's figures (alpha = -2 degrees for human hair in air, R toward
//! the root; its TIR remark, no TT below theta = -1.1 at a 2 degree tilt, holds for our +2): the
//! paper's alpha = -2 degrees is our alpha = +2 degrees.
//!
//! # Errata in the paper (1 to 5 checked in tests/deon2014.rs)
//!
//! 1. Eq. 3: eta' = sqrt(eta^2 - sin(theta_d)) / cos(theta_d) should read sin^2(theta_d) (the
//!    deflections then match a 3D vector-Snell trace through a smooth cylinder).
//! 2. Section 2.2: "each alpha_k ... variance beta^2" contradicts eq. 6 by sqrt(2): with it the
//!    compositions give sqrt(v_R) = 2 beta cos(phi/2). A Beckmann surface of roughness beta has
//!    slope variance beta^2 / 2 per axis, which gives eq. 6's beta sqrt(2) cos(phi/2).
//! 3. The compositions (section 2.2) and the closed form for theta_cone_R (section 2.3) disagree
//!    in alpha's sign (see above). In the compositions' sign, a = alpha_k:
//!    theta_cone_R = -asin(sin theta cos 2a + sin 2a cos theta cos(phi/2)); the printed form is
//!    this with a = -alpha.
//! 4. D_TT as printed, (-2z - eta z') / cos theta_d with eta z' = sqrt(eta^2 - x^2 - y^2), is not
//!    what the compositions give: dx_TT/dalpha_{1,2} = eta z' - z each, so
//!    D_TT = 2 (eta z' - z) / cos theta_d and sqrt(v_TT) = beta (eta z' - z) / cos theta_d.
//! 5. D_TRT = (4 eta z' - 2z) / cos theta_d is the sum of TRT's derivative vector [eta z' - z,
//!    2 eta z', eta z' - z] (one common tilt), not its norm as section 2.2 prescribes for
//!    independent tilts: v_TRT = beta^2 ((eta z' - z)^2 + 2 eta^2 z'^2) / cos^2 theta_d, 7.6%
//!    wider in standard deviation at normal incidence for eta = 1.55. We use the norm.
//! 6. Section 3's pseudo-code: sampleM(xi_M1, xi_M2, v_TT) drops theta_cone (computed one line
//!    above and unused) and passes the function v_TT instead of the variance v just computed.
//! 7. Appendix A's Jacobian prints dP_M/dphi in the lower right; it is dP_N/dphi = N.
//! 8. Section 3: "no more than 8 iterations worst case": the loop as printed leaves 3% of the
//!    draws on the paper's own grid unconverged after 8 (see [`Deon2014Hit::sample_iterated`]).
//!
//! The derivatives at alpha = 0 printed in section 2.2 ([-2z], [eta z' - z, eta z' - z],
//! [eta z' - z, 2 eta z', eta z' - z]) are right.
//!
//! # Sampling
//!
//! [`FiberHit::sample`] draws h uniformly, the lobe with probability proportional to the luminance
//! of A_p(h), theta_i from M(.; c_p(h), v_p(h)) exactly (d'Eon 2013) and then phi =
//! Phi_p(h; theta_d(theta_i)) + a Gaussian offset of the lobe's azimuthal width. That is the
//! paper's loop (choose every random number, then sample phi from theta and theta from phi) run to
//! its fixed point: with the cone and width taken at the drawn h and at theta_o, the theta update
//! no longer depends on phi, so the fixed point is reached after one pass, and the density drawn
//! is the model's (with the h-selection weights in place of A): `eval_pdf` integrates exactly
//! that, by the same quadrature as the value. The paper needs several passes only because it
//! re-derives the TT cone from the noisy phi and takes v_TT, v_TRT at theta_d; that literal loop
//! is [`Deon2014Hit::sample_iterated`], whose density has Appendix A's residual and is not known
//! in closed form.

use super::attenuation::{P_MAX, ap};
use super::azimuthal::phi_p;
use super::longitudinal::Longitudinal;
use super::model::{FlawedSampler, Model, TableFeatures};
use super::{FiberHit, FiberModel, FiberParams, FiberSample, ModelKind, ParamError, SamplerKind, SpreadHit};
use crate::conventions::{phi, pick, sin_cos_theta, wrap_angle};
use crate::quadrature::gauss_legendre;
use crate::spectrum::Rgb;
use glam::DVec3;
use statrs::function::erf::{erf_inv, erfc};
use std::f64::consts::{FRAC_1_PI, FRAC_1_SQRT_2, FRAC_PI_2, PI, SQRT_2, TAU};

const LOBES: usize = 3;

/// Bounds on a lobe's longitudinal variance (rad^2): below 1e-12 the lobe is narrower than any
/// direction grid; above (pi/2)^2 it is all but uniform in sin theta.
const V_MIN: f64 = 1e-12;
const V_MAX: f64 = FRAC_PI_2 * FRAC_PI_2;

/// Kernel standard deviations integrated on each side (the Gaussian's mass beyond: 4e-8).
const WINDOW: f64 = 5.5;
/// Panel width, in kernel standard deviations of phi, where the kernel varies.
const FINE: f64 = 3.0;
/// Widest panel in gamma (A_p and the Jacobian vary on this scale).
const MAX_STEP: f64 = PI / 8.0;
/// Most panels per integration interval; past it panels are this fraction of the interval.
const MAX_PANELS: usize = 256;
/// Gauss-Legendre points per panel.
const ORDER: usize = 6;

/// [`Deon2014Hit::sample_iterated`]: the change of theta, in standard deviations of the lobe
/// drawn from, below which it has converged (the draws are then indistinguishable from the fixed
/// point's).
const TOLERANCE: f64 = 1e-3;

/// One interface event of the paper's section 2.2, in Nusselt coordinates (x along the fiber axis).
#[derive(Clone, Copy, Debug)]
enum Event {
    /// Q(sign alpha_k, .): rotation about the y axis into or out of the frame of tilted normal k.
    Rotate(f64, usize),
    /// (x, y) -> -(x, y): reflection, and propagation P to the next interface.
    Negate,
    /// (x, y) -> s (x, y): refraction in (s = -1/eta) and out (s = -eta).
    Refract(f64),
}

/// The three paths as sequences of events, in order of application (section 2.2):
/// R[a] = Q(a, -Q(-a, .)), R'[a] = Q(-a, -Q(a, .)), T[a] = Q(-a, -Q(-a, .) / eta),
/// T'[a] = Q(a, -eta Q(a, .)), P = -1; R = R[a1], TT = T'[a2] P T[a1],
/// TRT = T'[a3] P R'[a2] P T[a1].
fn paths(eta: f64) -> [Vec<Event>; LOBES] {
    use Event::{Negate, Refract, Rotate};
    let reflect = |k| [Rotate(-1.0, k), Negate, Rotate(1.0, k)];
    let reflect_inside = |k| [Rotate(1.0, k), Negate, Rotate(-1.0, k)];
    let enter = |k| [Rotate(-1.0, k), Refract(-1.0 / eta), Rotate(-1.0, k)];
    let leave = |k| [Rotate(1.0, k), Refract(-eta), Rotate(1.0, k)];
    let cross = [Negate];
    [
        reflect(0).to_vec(),
        [&enter(0)[..], &cross, &leave(1)].concat(),
        [&enter(0)[..], &cross, &reflect_inside(1), &cross, &leave(2)].concat(),
    ]
}

/// Where a path leaves the fiber, with derivatives with respect to (alpha_1, alpha_2, alpha_3,
/// gamma) at alpha_k = alpha.
struct Exit {
    /// Exit sine x_p.
    x: f64,
    /// Exit cosine sqrt(y^2 + z^2) (of a unit vector unless `tir`).
    cos: f64,
    dx: [f64; 4],
    /// A refraction out of the fiber met total internal reflection (clamped as the paper does).
    tir: bool,
}

/// Follows a path's events from the incident direction (sin theta, h cos theta) at h = sin gamma
/// through normals tilted by the angle with sine and cosine `tilt`, in forward-mode derivatives:
/// section 2.2's chain rule through Q's derivative matrix
/// [-z cos a - x sin a, cos a + (x/z) sin a, (y/z) sin a], written with the normal component z
/// carried along (dz = -(x dx + y dy) / z) instead of recomputed as +sqrt(1 - x^2 - y^2). That
/// keeps its precision where the path grazes the axis, and its sign where light meets a tilted
/// facet from behind (grazing light, |theta| > pi/2 - |alpha| about): there the paper's positive
/// root folds the reflected path back onto the pole (x_R = -1 however the light comes in), the
/// signed z is the exact reflection about the tilted normal. Elsewhere the two are the same.
fn trace(path: &[Event], tilt: (f64, f64), sin_t: f64, cos_t: f64, gamma: f64) -> Exit {
    let (sin_g, cos_g) = gamma.sin_cos();
    let (mut x, mut y, mut z) = (sin_t, cos_t * sin_g, cos_t * cos_g);
    let mut dx = [0.0; 4];
    let mut dy = [0.0, 0.0, 0.0, cos_t * cos_g];
    let mut dz = [0.0, 0.0, 0.0, -cos_t * sin_g];
    let mut tir = false;
    for &event in path {
        match event {
            Event::Rotate(sign, k) => {
                // Q(a, x, y) = (x cos a - z sin a, y), z the normal component: the rotation of the
                // unit vector, carried with its sign.
                let (s, c) = (sign * tilt.0, tilt.1);
                for i in 0..4 {
                    (dx[i], dz[i]) = (c * dx[i] - s * dz[i], s * dx[i] + c * dz[i]);
                }
                // d/dalpha_k through a = sign alpha_k.
                dx[k] += sign * (-x * s - z * c);
                dz[k] += sign * (x * c - z * s);
                (x, z) = (x * c - z * s, x * s + z * c);
            }
            Event::Negate => {
                // z kept.
                (x, y) = (-x, -y);
                for i in 0..4 {
                    (dx[i], dy[i]) = (-dx[i], -dy[i]);
                }
            }
            Event::Refract(f) => {
                // z^2 = 1 - f^2 (x^2 + y^2) = 1 - f^2 + f^2 z^2 for a unit vector;
                // negative is total internal reflection (only f = -eta), clamped to 0 (seed
                // section 2.4).
                let r = 1.0 - f * f + f * f * z * z;
                tir |= r < 0.0;
                let nz = r.max(0.0).sqrt();
                for i in 0..4 {
                    dx[i] *= f;
                    dy[i] *= f;
                    dz[i] = if nz > 0.0 { f * f * z * dz[i] / nz } else { 0.0 };
                }
                (x, y, z) = (x * f, y * f, nz);
            }
        }
    }
    Exit { x, cos: (y * y + z * z).sqrt(), dx, tir }
}

/// A longitudinal lobe: the cone inclination's sine and cosine, the variance, and dc/dgamma.
#[derive(Clone, Copy, Debug)]
struct Cone {
    sin: f64,
    cos: f64,
    v: f64,
    slope: f64,
}

impl Cone {
    fn lobe(&self, extra: f64) -> Longitudinal {
        Longitudinal::new(self.v + extra)
    }

    /// M at (sin theta_i, cos theta_i), widened by `extra`: [`Longitudinal`]'s lobe about the
    /// mirror of its fixed inclination, given the mirror of the cone.
    fn m(&self, sin_i: f64, cos_i: f64, extra: f64) -> f64 {
        self.lobe(extra).eval(cos_i, sin_i, self.cos, -self.sin)
    }
}

/// The azimuthal kernel of a lobe: a Gaussian of standard deviation sigma about the deflection
/// (one copy; the wrapped kernel is the sum over copies 2 pi apart), or, for f_s^G, its average
/// over the half circle within pi/2 (sigma = 0: the half circle's indicator).
#[derive(Clone, Copy, Debug)]
enum Kernel {
    Gauss(f64),
    HalfCircle(f64),
}

/// A stretch of kernel offsets x = phi - u with whether the kernel varies across it.
type Zone = (f64, f64, bool);

impl Kernel {
    fn sigma(self) -> f64 {
        match self {
            Kernel::Gauss(s) | Kernel::HalfCircle(s) => s,
        }
    }

    fn at(self, x: f64) -> f64 {
        match self {
            Kernel::Gauss(s) => (-0.5 * (x / s).powi(2)).exp() / (s * TAU.sqrt()),
            Kernel::HalfCircle(s) if s > 0.0 => {
                let cdf = |t: f64| 0.5 * erfc(-t * FRAC_1_SQRT_2 / s);
                FRAC_1_PI * (cdf(x + FRAC_PI_2) - cdf(x - FRAC_PI_2))
            }
            Kernel::HalfCircle(_) => {
                if x.abs() < FRAC_PI_2 {
                    FRAC_1_PI
                } else {
                    0.0
                }
            }
        }
    }

    /// The offsets where the kernel is not negligible: fine zones where it varies, a flat one
    /// where it is constant.
    fn zones(self) -> ([Zone; 3], usize) {
        let w = WINDOW * self.sigma();
        let none = (0.0, 0.0, false);
        match self {
            Kernel::Gauss(_) => ([(-w, w, true), none, none], 1),
            // The indicator (R's): one flat zone with exact edges.
            Kernel::HalfCircle(_) if w == 0.0 => ([(-FRAC_PI_2, FRAC_PI_2, false), none, none], 1),
            Kernel::HalfCircle(_) if 2.0 * w < PI => (
                [
                    (-FRAC_PI_2 - w, -FRAC_PI_2 + w, true),
                    (-FRAC_PI_2 + w, FRAC_PI_2 - w, false),
                    (FRAC_PI_2 - w, FRAC_PI_2 + w, true),
                ],
                3,
            ),
            Kernel::HalfCircle(_) => ([(-FRAC_PI_2 - w, FRAC_PI_2 + w, true), none, none], 1),
        }
    }
}

/// Deflection Phi_p at gamma (seed eq. 3), for 1/eta' = `inv`.
fn deflection(p: usize, gamma: f64, inv: f64) -> f64 {
    phi_p(p, gamma, (gamma.sin() * inv).asin())
}

/// dPhi_p / dgamma = 2 p cos gamma / sqrt(eta'^2 - sin^2 gamma) - 2.
fn deflection_slope(p: usize, gamma: f64, inv: f64) -> f64 {
    let s = gamma.sin() * inv;
    2.0 * p as f64 * gamma.cos() * inv / (1.0 - s * s).max(1e-300).sqrt() - 2.0
}

/// The intervals of gamma on which Phi_p is monotone: dPhi/dgamma = 0 where
/// sin^2 gamma = (4 - eta'^2) / 3, only for TRT below eta' = 2 (its caustic).
fn monotone_intervals(p: usize, inv: f64) -> ([f64; 4], usize) {
    if p == 2 && inv > 0.5 {
        let g = ((4.0 * inv * inv - 1.0) / (3.0 * inv * inv)).sqrt().min(1.0).asin();
        ([-FRAC_PI_2, -g, g, FRAC_PI_2], 3)
    } else {
        ([-FRAC_PI_2, FRAC_PI_2, 0.0, 0.0], 1)
    }
}

/// The gamma in [a, b] where Phi_p = target, Phi_p monotone on [a, b]: Newton steps kept inside a
/// shrinking bracket (bisection when a step leaves it). `target` must lie between Phi_p(a) and
/// Phi_p(b).
fn solve(p: usize, inv: f64, target: f64, mut a: f64, mut b: f64) -> f64 {
    let rising = deflection(p, b, inv) > deflection(p, a, inv);
    let mut g = 0.5 * (a + b);
    for _ in 0..100 {
        let f = deflection(p, g, inv) - target;
        if (f > 0.0) == rising {
            b = g;
        } else {
            a = g;
        }
        let next = g - f / deflection_slope(p, g, inv);
        let next = if next > a && next < b { next } else { 0.5 * (a + b) };
        if (next - g).abs() < 1e-14 || b - a < 1e-14 {
            return next;
        }
        g = next;
    }
    g
}

/// A standard normal number from u in [0, 1), clamped to +-5.2 standard deviations (the tail
/// beyond, 2e-7, lands on the clamp, inside the evaluation window).
fn std_normal(u: f64) -> f64 {
    SQRT_2 * erf_inv(2.0 * u.clamp(1e-7, 1.0 - 1e-7) - 1.0)
}

/// The d'Eon 2014 fiber with its per-material constants.
#[derive(Debug)]
pub struct Deon2014 {
    sigma_a: Rgb,
    eta: f64,
    /// Variance of each normal's longitudinal tilt about alpha: beta^2 / 2.
    slope_var: f64,
    /// (sin, cos) of the tilt alpha_k = alpha.
    tilt: (f64, f64),
    /// Azimuthal standard deviation per lobe: 0 for R, beta / sqrt(2) for TT, sqrt(2) beta for
    /// TRT (seed sections 2.3-2.5).
    kernel_sigma: [f64; LOBES],
    paths: [Vec<Event>; LOBES],
    rule: Vec<(f64, f64)>,
    /// Whether [`FiberHit::sample`] runs the paper's literal loop ([`Deon2014Hit::sample_iterated`]).
    iterated: bool,
}

impl Deon2014 {
    /// The paper's bound on its sampler's iterations (section 3), [`Deon2014Hit::sample_iterated`]'s.
    pub const MAX_ITERATIONS: usize = 8;

    /// The model with its exact sampler.
    pub fn new(params: &FiberParams) -> Result<Deon2014, ParamError> {
        Deon2014::with_sampler(params, false)
    }

    /// The model drawing with the paper's literal loop when `iterated` (biased: it reports the
    /// model's density, which is not quite the loop's), else exactly.
    pub fn with_sampler(params: &FiberParams, iterated: bool) -> Result<Deon2014, ParamError> {
        params.validate()?;
        let beta = params.beta_m;
        Ok(Deon2014 {
            sigma_a: params.sigma_a(),
            eta: params.eta,
            slope_var: 0.5 * beta * beta,
            tilt: params.alpha.to_radians().sin_cos(),
            kernel_sigma: [0.0, beta * FRAC_1_SQRT_2, beta * SQRT_2],
            paths: paths(params.eta),
            rule: gauss_legendre(ORDER),
            iterated,
        })
    }

    /// The exit sine x_p of lobe `p` (0 R, 1 TT, else TRT) for light at inclination `theta` and
    /// offset `h`, its derivatives with respect to (alpha_1, alpha_2, alpha_3, gamma = asin h) at
    /// alpha_k = alpha, and whether it met total internal reflection.
    pub fn exit_sine(&self, p: usize, theta: f64, h: f64) -> (f64, [f64; 4], bool) {
        let e = trace(&self.paths[p.min(2)], self.tilt, theta.sin(), theta.cos(), h.clamp(-1.0, 1.0).asin());
        (e.x, e.dx, e.tir)
    }

    /// The azimuthal deflection Phi_p (seed eq. 3) of lobe `p` at offset `h` from light at
    /// inclination `theta_o` to inclination `theta_i`, with the Bravais index of their theta_d.
    pub fn deflection(&self, p: usize, theta_o: f64, theta_i: f64, h: f64) -> f64 {
        let (sin_d, cos_d) = (0.5 * (theta_o - theta_i)).sin_cos();
        deflection(p.min(2), h.clamp(-1.0, 1.0).asin(), self.inv_bravais(sin_d, cos_d))
    }

    /// The cone inclination theta_cone_p and variance v_p (rad^2) of lobe `p` for light at
    /// inclination `theta` and offset `h`, as the model uses them (TRT at h = 0).
    pub fn cone(&self, p: usize, theta: f64, h: f64) -> (f64, f64) {
        let gamma = if p < 2 { h.clamp(-1.0, 1.0).asin() } else { 0.0 };
        let c = self.cone_at(p.min(2), theta.sin(), theta.cos(), gamma);
        (c.sin.atan2(c.cos), c.v)
    }

    fn cone_at(&self, p: usize, sin_t: f64, cos_t: f64, gamma: f64) -> Cone {
        let e = trace(&self.paths[p], self.tilt, sin_t, cos_t, gamma);
        let v = self.variance(p, sin_t, cos_t, gamma);
        let (sin, cos) = match (e.tir, e.x.abs() < 1.0) {
            (false, _) => (e.x, e.cos),
            // Section 2.4: asin x_p while |x_p| <= 1, the pole -sign(theta) pi/2 beyond.
            (true, true) => (e.x, (1.0 - e.x * e.x).sqrt()),
            (true, false) => (-sin_t.signum(), 0.0),
        };
        let slope = if cos > 0.0 { e.dx[3] / cos } else { 0.0 };
        Cone { sin, cos, v, slope }
    }

    /// v_p = (beta^2 / 2) sum_k (dx_p/dalpha_k)^2 / cos^2 theta for light at inclination theta
    /// (sine, cosine) and offset sin gamma, within [`V_MIN`, `V_MAX`]. The derivatives are taken
    /// about the untilted path, as the paper's eq. 6, D_TT and D_TRT are: about the tilted one the
    /// inclination's derivative vanishes where the cone passes the pole (the exit moves in azimuth
    /// there, collapsing the lobe to a spike) and diverges at the onset of total internal
    /// reflection; the untilted path meets neither. There [`trace`]'s chain rule reduces to the
    /// paper's printed derivatives (section 2.2, tested): dx_R = [-2z],
    /// dx_TT = [eta z' - z, eta z' - z], dx_TRT = [eta z' - z, 2 eta z', eta z' - z], with
    /// z = cos theta cos gamma, eta z' = sqrt(eta^2 - sin^2 theta - sin^2 gamma cos^2 theta), and
    /// the exit at -theta.
    fn variance(&self, p: usize, sin_t: f64, cos_t: f64, gamma: f64) -> f64 {
        let (sin_g, cos_g) = gamma.sin_cos();
        let v = if p == 0 {
            // 4 z^2 / cos^2 theta = 4 cos^2 gamma: eq. 6, with no division at theta = pi/2.
            self.slope_var * 4.0 * cos_g * cos_g
        } else {
            let z = cos_t * cos_g;
            let ez = (self.eta * self.eta - sin_t * sin_t - (sin_g * cos_t).powi(2)).max(0.0).sqrt();
            let g2 = 2.0 * (ez - z).powi(2) + if p == 1 { 0.0 } else { 4.0 * ez * ez };
            self.slope_var * g2 / (cos_t * cos_t)
        };
        if v.is_nan() { V_MAX } else { v.clamp(V_MIN, V_MAX) }
    }

    /// 1/eta' at difference angle theta_d (its sine and cosine): cos / sqrt(eta^2 - sin^2), which
    /// goes to 0 rather than dividing by cos theta_d = 0.
    fn inv_bravais(&self, sin_d: f64, cos_d: f64) -> f64 {
        cos_d / (self.eta * self.eta - sin_d * sin_d).sqrt()
    }
}

impl Model for Deon2014 {
    const NAME: &'static str = "deon2014";
    const HELP: &'static str = "d'Eon et al. 2014; --beta-m as its roughness beta, --alpha";
    const TITLE: &'static str = "d'Eon 2014";
    const CAPTION: &'static str = "d'Eon 2014 fiber";
    const FAR_FIELD: bool = true;
    const EXACT_LABEL: &'static str = "deon2014-exact";
    const FLAWED: Option<FlawedSampler> = Some(FlawedSampler {
        name: "iterative",
        label: "deon2014-iterative",
        help: "d'Eon et al. 2014's iterative sampler as its Appendix A prints it, with the model's density: \
               slightly biased at grazing angles",
    });

    /// With the paper's literal loop when `flawed` ([`Deon2014::with_sampler`]).
    fn build(params: &FiberParams, flawed: bool) -> Result<Deon2014, ParamError> {
        Deon2014::with_sampler(params, flawed)
    }

    /// The narrowest azimuthal kernel is TT's Gaussian of standard deviation beta / sqrt(2),
    /// passed as the logistic scale with that standard deviation (s pi / sqrt(3)). The narrowest
    /// longitudinal lobes are TT's at normal incidence, standard deviation (eta - 1) beta, and R's
    /// toward grazing offsets, beta sqrt(2) cos(phi / 2) (eq. 6), resolved down to
    /// cos(phi / 2) = 1/4.
    fn table_features(params: &FiberParams) -> TableFeatures {
        let beta = params.beta_m;
        let scale = beta * FRAC_1_SQRT_2 * 3f64.sqrt() / PI;
        let sd = beta * (params.eta - 1.0).min(SQRT_2 / 4.0);
        TableFeatures::new(scale, sd * sd)
    }

    /// beta itself: `beta_m` is the model's Beckmann roughness.
    fn set_grid_roughness(params: &mut FiberParams, beta: f64) {
        params.beta_m = beta;
    }

    fn describe(params: &FiberParams) -> String {
        format!("beta {}, alpha {} deg, eta {}", params.beta_m, params.alpha, params.eta)
    }
}

impl SamplerKind {
    /// The d'Eon 2014 model's flawed sampler (a name kept for the renderer).
    #[allow(non_upper_case_globals)]
    pub const Iterative: SamplerKind = SamplerKind::Flawed(ModelKind::Deon2014);
}

/// A [`Deon2014`] fiber at one hit: what depends on the fixed direction wo.
pub struct Deon2014Hit<'a> {
    fiber: &'a Deon2014,
    sin_o: f64,
    cos_o: f64,
    theta_o: f64,
    phi_o: f64,
    /// sin gamma_t / h at theta_o (for A_p).
    inv_eta_o: f64,
    /// TRT's separable cone, at h = 0 (seed eq. 8).
    trt: Cone,
}

impl FiberModel for Deon2014 {
    type Hit<'a> = Deon2014Hit<'a>;

    /// The model is far-field: `h` is integrated over, not fixed.
    fn at(&self, wo: DVec3, _h: f64) -> Deon2014Hit<'_> {
        let (sin_o, cos_o) = sin_cos_theta(wo);
        Deon2014Hit {
            fiber: self,
            sin_o,
            cos_o,
            theta_o: sin_o.atan2(cos_o),
            phi_o: phi(wo),
            inv_eta_o: cos_o / (self.eta * self.eta - sin_o * sin_o).sqrt(),
            trt: self.cone_at(2, sin_o, cos_o, 0.0),
        }
    }
}

/// What every lobe needs of a direction wi.
struct Incoming {
    sin_i: f64,
    cos_i: f64,
    /// phi_i - phi_o in [-pi, pi].
    dphi: f64,
    /// 1/eta' at theta_d = (theta_o - theta_i) / 2.
    inv: f64,
}

impl Deon2014Hit<'_> {
    fn incoming(&self, wi: DVec3) -> Incoming {
        let (sin_i, cos_i) = sin_cos_theta(wi);
        let (sin_d, cos_d) = (0.5 * (self.theta_o - sin_i.atan2(cos_i))).sin_cos();
        Incoming { sin_i, cos_i, dphi: wrap_angle(phi(wi) - self.phi_o), inv: self.fiber.inv_bravais(sin_d, cos_d) }
    }

    /// A_R, A_TT, A_TRT at offset sin gamma, and the lobe-selection weights: their luminances,
    /// normalized.
    fn attenuation(&self, gamma: f64) -> ([Rgb; LOBES], [f64; LOBES]) {
        let h = gamma.sin();
        let sin_t = h * self.inv_eta_o;
        let cos_gamma_t = (1.0 - sin_t * sin_t).max(0.0).sqrt();
        let a: [Rgb; P_MAX + 1] = ap(self.cos_o, self.sin_o, self.fiber.eta, h, self.fiber.sigma_a, cos_gamma_t);
        let a = [a[0], a[1], a[2]];
        let y = a.map(Rgb::luminance);
        let total: f64 = y.iter().sum();
        (a, if total > 0.0 { y.map(|y| y / total) } else { [1.0, 0.0, 0.0] })
    }

    fn cone(&self, p: usize, gamma: f64) -> Cone {
        if p == 2 { self.trt } else { self.fiber.cone_at(p, self.sin_o, self.cos_o, gamma) }
    }

    /// Calls `node(gamma, weight)` for the nodes of a quadrature of
    /// int dgamma (cos gamma / 2) K(phi - Phi_p(gamma)) g(gamma) over [-pi/2, pi/2], g smooth on
    /// the scale `scale(gamma)`: each copy of each kernel zone, mapped to gamma on each interval
    /// where Phi_p is monotone, in panels that resolve the kernel and g.
    fn integrate(
        &self,
        p: usize,
        d: &Incoming,
        kernel: Kernel,
        scale: impl Fn(f64) -> f64,
        mut node: impl FnMut(f64, f64),
    ) {
        let (ends, n) = monotone_intervals(p, d.inv);
        let (zones, nz) = kernel.zones();
        let sigma = kernel.sigma();
        for k in 0..n {
            let (a, b) = (ends[k], ends[k + 1]);
            let (ua, ub) = (deflection(p, a, d.inv), deflection(p, b, d.inv));
            let (lo, hi) = (ua.min(ub), ua.max(ub));
            let gamma_of = |u: f64| {
                if u <= lo {
                    if ua <= ub { a } else { b }
                } else if u >= hi {
                    if ua <= ub { b } else { a }
                } else {
                    solve(p, d.inv, u, a, b)
                }
            };
            for &(x_lo, x_hi, fine) in &zones[..nz] {
                // Copy j of the zone covers u in [dphi + 2 pi j - x_hi, dphi + 2 pi j - x_lo].
                let j_lo = ((lo - d.dphi + x_lo) / TAU).ceil() as i64;
                let j_hi = ((hi - d.dphi + x_hi) / TAU).floor() as i64;
                for j in j_lo..=j_hi {
                    let centre = d.dphi + TAU * j as f64;
                    let (u0, u1) = ((centre - x_hi).max(lo), (centre - x_lo).min(hi));
                    if u1 <= u0 {
                        continue;
                    }
                    let (g0, g1) = (gamma_of(u0), gamma_of(u1));
                    let step = |g: f64| {
                        let s = MAX_STEP.min(scale(g));
                        if fine { s.min(FINE * sigma / deflection_slope(p, g, d.inv).abs()) } else { s }
                    };
                    self.panels(g0.min(g1), g0.max(g1), step, |g, w| {
                        node(g, w * 0.5 * g.cos() * kernel.at(centre - deflection(p, g, d.inv)));
                    });
                }
            }
        }
    }

    /// Gauss-Legendre panels over [a, b], each `step` (at its start) wide or the rest of the
    /// interval, at most [`MAX_PANELS`]: calls `f(node, weight)`.
    fn panels(&self, a: f64, b: f64, step: impl Fn(f64) -> f64, mut f: impl FnMut(f64, f64)) {
        let min_step = (b - a) / MAX_PANELS as f64;
        let mut g = a;
        while g < b {
            let s = step(g).max(min_step);
            let e = if b - g <= 1.5 * s || g + s <= g { b } else { g + s };
            let (mid, half) = (0.5 * (g + e), 0.5 * (e - g));
            for &(x, w) in &self.fiber.rule {
                f(mid + half * x, w * half);
            }
            g = e;
        }
    }

    /// The gamma scale on which lobe p's M moves at theta_i by half its width (`extra` widening
    /// it): sqrt(v + extra) / (2 |dc/dgamma|).
    fn m_scale(&self, p: usize, gamma: f64, extra: f64) -> f64 {
        let c = self.cone(p, gamma);
        let s = 0.5 * (c.v + extra).sqrt() / c.slope.abs();
        if s.is_nan() { 0.0 } else { s }
    }

    /// The projected value and the sampler's density at `d`.
    fn value_pdf(&self, d: &Incoming) -> (Rgb, f64) {
        // R (section 2.3): the root gamma = -phi / 2, density cos(gamma) / 4 in phi.
        let gamma = -0.5 * d.dphi;
        let (a, w) = self.attenuation(gamma);
        let m = self.cone(0, gamma).m(d.sin_i, d.cos_i, 0.0) * 0.25 * gamma.cos();
        let (mut value, mut pdf) = (a[0] * m, w[0] * m);
        // TT: the mixture over gamma, each with its own cone.
        self.integrate(
            1,
            d,
            Kernel::Gauss(self.fiber.kernel_sigma[1]),
            |g| self.m_scale(1, g, 0.0),
            |g, wt| {
                let (a, w) = self.attenuation(g);
                let m = self.cone(1, g).m(d.sin_i, d.cos_i, 0.0) * wt;
                value += a[1] * m;
                pdf += w[1] * m;
            },
        );
        // TRT: separable, M times the integral over gamma.
        let m = self.trt.m(d.sin_i, d.cos_i, 0.0);
        if m > 0.0 {
            let (mut n, mut nw) = (Rgb::ZERO, 0.0);
            self.integrate(
                2,
                d,
                Kernel::Gauss(self.fiber.kernel_sigma[2]),
                |_| f64::INFINITY,
                |g, wt| {
                    let (a, w) = self.attenuation(g);
                    n += a[2] * wt;
                    nw += w[2] * wt;
                },
            );
            value += n * m;
            pdf += nw * m;
        }
        (value, pdf)
    }

    /// f_s^G at `d`: every lobe's K replaced by its half-circle average, every M widened by the
    /// channel's spread.
    fn spread_value(&self, d: &Incoming, spread: Rgb) -> Rgb {
        let least = spread.0.iter().fold(f64::INFINITY, |m, &s| m.min(s)).max(0.0);
        let widened = |c: &Cone| Rgb(spread.0.map(|s| c.m(d.sin_i, d.cos_i, s.max(0.0))));
        let mut out = Rgb::ZERO;
        for p in 0..2 {
            let kernel = Kernel::HalfCircle(self.fiber.kernel_sigma[p]);
            self.integrate(
                p,
                d,
                kernel,
                |g| self.m_scale(p, g, least),
                |g, wt| {
                    let (a, _) = self.attenuation(g);
                    out += a[p] * widened(&self.cone(p, g)) * wt;
                },
            );
        }
        let mut n = Rgb::ZERO;
        self.integrate(
            2,
            d,
            Kernel::HalfCircle(self.fiber.kernel_sigma[2]),
            |_| f64::INFINITY,
            |g, wt| {
                n += self.attenuation(g).0[2] * wt;
            },
        );
        out + n * widened(&self.trt)
    }

    /// Direction from inclination (sine, cosine) and azimuth relative to wo's.
    fn direction(&self, sin_i: f64, cos_i: f64, dphi: f64) -> DVec3 {
        let (sin_p, cos_p) = (self.phi_o + dphi).sin_cos();
        DVec3::new(sin_i, cos_i * cos_p, cos_i * sin_p)
    }

    fn finish(&self, wi: DVec3) -> Option<FiberSample> {
        let (value, pdf) = self.eval_pdf(wi);
        (pdf > 0.0 && pdf.is_finite()).then_some(FiberSample { wi, value, pdf })
    }

    /// The paper's iterative sampler as section 3 prints it (with theta_cone passed to sampleM),
    /// for measurement: the same random numbers as [`FiberHit::sample`], theta started at
    /// -theta_o, then phi from theta and theta from phi until theta moves by less than a
    /// thousandth of the lobe's standard deviation, at most [`Deon2014::MAX_ITERATIONS`] times.
    /// Unlike the model it takes TT's cone at the root h of the noisy phi (the nearer end of
    /// [-1, 1] where there is none) and the TT and TRT widths at theta_d. Returns the sample with
    /// the model's density, which is what the paper claims it draws (Appendix A: "the fiber
    /// function plus a very small residual"), and the number of iterations after which theta had
    /// stopped moving (`MAX_ITERATIONS + 1`: not within the bound). On the paper's grid that takes
    /// 1.9 iterations on average, but 3% of draws (tails of wide lobes at grazing light, where the
    /// widths at theta_d change fastest) oscillate instead of converging, and at grazing light its
    /// estimates are biased by about 1% (tests/deon2014.rs).
    pub fn sample_iterated(&self, u: [f64; 4]) -> Option<(FiberSample, usize)> {
        let f = self.fiber;
        let gamma = (2.0 * u[0] - 1.0).clamp(-1.0, 1.0).asin();
        let (p, u3) = pick(&self.attenuation(gamma).1, u[3]);
        let offset = f.kernel_sigma[p] * std_normal(u3);
        let (mut theta, mut sin_cos_i, mut dphi) = (-self.theta_o, (0.0, 1.0), 0.0);
        let mut iterations = Deon2014::MAX_ITERATIONS + 1;
        for k in 0..=Deon2014::MAX_ITERATIONS {
            let (sin_d, cos_d) = (0.5 * (self.theta_o - theta)).sin_cos();
            let inv = f.inv_bravais(sin_d, cos_d);
            dphi = deflection(p, gamma, inv) + offset;
            let g = match p {
                0 => gamma,
                1 => {
                    let (u_hi, u_lo) = (deflection(1, -FRAC_PI_2, inv), deflection(1, FRAC_PI_2, inv));
                    // Phi_TT falls from u_hi to u_lo; the copy of phi nearest its range.
                    let target = u_lo + (dphi - u_lo).rem_euclid(TAU);
                    let target =
                        if target > u_hi && target - u_hi > TAU - (target - u_lo) { target - TAU } else { target };
                    solve(1, inv, target.clamp(u_lo, u_hi), -FRAC_PI_2, FRAC_PI_2)
                }
                _ => 0.0,
            };
            let mut cone = f.cone_at(p, self.sin_o, self.cos_o, g);
            if p > 0 {
                cone.v = f.variance(p, sin_d, cos_d, g);
            }
            sin_cos_i = cone.lobe(0.0).sample(cone.cos, -cone.sin, u[1], u[2]);
            let next = sin_cos_i.0.atan2(sin_cos_i.1);
            let moved = (next - theta).abs();
            theta = next;
            if k > 0 && moved < TOLERANCE * cone.v.sqrt() {
                iterations = k;
                break;
            }
        }
        let s = self.finish(self.direction(sin_cos_i.0, sin_cos_i.1, dphi))?;
        Some((s, iterations))
    }
}

impl FiberHit for Deon2014Hit<'_> {
    fn eval(&self, wi: DVec3) -> Rgb {
        self.value_pdf(&self.incoming(wi)).0
    }

    fn sample(&self, u: [f64; 4]) -> Option<FiberSample> {
        if self.fiber.iterated {
            return self.sample_iterated(u).map(|(s, _)| s);
        }
        let gamma = (2.0 * u[0] - 1.0).clamp(-1.0, 1.0).asin();
        let (p, u3) = pick(&self.attenuation(gamma).1, u[3]);
        let cone = self.cone(p, gamma);
        let (sin_i, cos_i) = cone.lobe(0.0).sample(cone.cos, -cone.sin, u[1], u[2]);
        let (sin_d, cos_d) = (0.5 * (self.theta_o - sin_i.atan2(cos_i))).sin_cos();
        let inv = self.fiber.inv_bravais(sin_d, cos_d);
        let dphi = deflection(p, gamma, inv) + self.fiber.kernel_sigma[p] * std_normal(u3);
        self.finish(self.direction(sin_i, cos_i, dphi))
    }

    fn eval_pdf(&self, wi: DVec3) -> (Rgb, f64) {
        self.value_pdf(&self.incoming(wi))
    }
}

impl SpreadHit for Deon2014Hit<'_> {
    fn eval_spread(&self, wi: DVec3, spread: Rgb) -> Rgb {
        self.spread_value(&self.incoming(wi), spread)
    }

    fn eval_both(&self, wi: DVec3, spread: Rgb) -> (Rgb, Rgb) {
        let d = self.incoming(wi);
        (self.value_pdf(&d).0, self.spread_value(&d, spread))
    }
}
