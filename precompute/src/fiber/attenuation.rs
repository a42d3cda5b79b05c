//! Attenuation A_p: Fresnel at the cuticle and Beer-Lambert absorption inside the fiber
//! (Pharr 2016 section 1.3.2).

use crate::spectrum::Rgb;

/// Number of lobes evaluated explicitly (R, TT, TRT); index `P_MAX` holds all higher orders.
pub const P_MAX: usize = 3;

/// Unpolarized Fresnel reflectance from air into a dielectric of relative index `eta > 1`,
/// for the cosine of the angle of incidence.
pub fn fresnel_dielectric(cos_i: f64, eta: f64) -> f64 {
    let cos_i = cos_i.clamp(0.0, 1.0);
    let sin2_t = (1.0 - cos_i * cos_i) / (eta * eta);
    let cos_t = (1.0 - sin2_t).max(0.0).sqrt();
    let r_parl = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    let r_perp = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    0.5 * (r_parl * r_parl + r_perp * r_perp)
}

/// A_0..A_{P_MAX-1} and the closed-form residual A_{P_MAX}, for a path entering at inclination
/// theta_o (the fixed direction) and offset h, with `gamma_t` already refracted.
///
/// A_0 = f, A_p = (1 - f)^2 T^p f^(p-1) and the residual sum_{p >= P_MAX} A_p
/// = A_{P_MAX-1} f T / (1 - T f) (Pharr 2016 section 1.3.2), with the one-segment transmittance
/// T = exp(-sigma_a 2 cos(gamma_t) / cos(theta_t)) (sigma_a per unit radius, as in pbrt-v3 and Blender Cycles).
pub fn ap(cos_theta_o: f64, sin_theta_o: f64, eta: f64, h: f64, sigma_a: Rgb, cos_gamma_t: f64) -> [Rgb; P_MAX + 1] {
    let cos_gamma_o = (1.0 - h * h).max(0.0).sqrt();
    let f = fresnel_dielectric(cos_theta_o * cos_gamma_o, eta);
    let sin_theta_t = sin_theta_o / eta;
    let cos_theta_t = (1.0 - sin_theta_t * sin_theta_t).sqrt();
    let t = sigma_a.map(|s| (-s * 2.0 * cos_gamma_t / cos_theta_t).exp());

    let mut a = [Rgb::ZERO; P_MAX + 1];
    a[0] = Rgb::splat(f);
    a[1] = t * ((1.0 - f) * (1.0 - f));
    for p in 2..P_MAX {
        a[p] = a[p - 1] * t * f;
    }
    // Residual = (1 - f)^2 T^P f^(P-1) / (1 - T f) = (1 - f) T^P f^(P-1) * ratio with
    // ratio = (1 - f) / (1 - T f) in [0, 1]. The ratio is 0/0 only at f = T = 1 (grazing, no
    // absorption), where its limit is 1 and the residual is 0 anyway.
    let ratio = t.map(|t| if 1.0 - t * f > 0.0 { (1.0 - f) / (1.0 - t * f) } else { 1.0 });
    a[P_MAX] = t.map(|t| t.powi(P_MAX as i32)) * ratio * ((1.0 - f) * f.powi(P_MAX as i32 - 1));
    a
}
