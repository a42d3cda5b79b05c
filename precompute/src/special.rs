//! Special functions the fiber models need, accurate in f64 over their whole range.

use std::f64::consts::TAU;

/// Terms of the power series kept below the switch to the asymptotic expansion.
const SERIES_TERMS: usize = 64;

/// 1 / k^2 for the power series, so that its hot loop multiplies instead of divides.
const INV_K2: [f64; SERIES_TERMS] = {
    let mut t = [0.0; SERIES_TERMS];
    let mut k = 1;
    while k < SERIES_TERMS {
        t[k] = 1.0 / (k * k) as f64;
        k += 1;
    }
    t
};

/// Exponentially scaled modified Bessel function of the first kind, `e^-|x| I0(x)`.
///
/// Power series `sum (x^2/4)^k / (k!)^2` below 20 (all terms positive, no cancellation) and the
/// asymptotic expansion `e^x / sqrt(2 pi x) sum_k ((2k-1)!!)^2 / (k! (8x)^k)` from 20 on
/// (Abramowitz & Stegun 9.7.1), summed until its terms fall below 1e-17 (before they start to grow
/// near k = 2x). Both are accurate to ~1e-15 relative.
pub fn i0e(x: f64) -> f64 {
    let (m, e) = i0e_parts(x);
    m * e.exp()
}

/// `e^-|x| I0(x)` as `m e^e`: the scale e^e kept apart, so that a caller who multiplies by
/// another exponential pays for one `exp` instead of two. Same series and expansion as [`i0e`].
pub fn i0e_parts(x: f64) -> (f64, f64) {
    let x = x.abs();
    if x < 20.0 {
        let q = 0.25 * x * x;
        let (mut term, mut sum) = (1.0, 1.0);
        for inv_k2 in &INV_K2[1..] {
            term *= q * inv_k2;
            sum += term;
            if term < 1e-17 * sum {
                break;
            }
        }
        (sum, -x)
    } else {
        let (mut term, mut sum) = (1.0, 1.0);
        for k in 1..40 {
            let odd = (2 * k - 1) as f64;
            term *= odd * odd / (8.0 * k as f64 * x);
            sum += term;
            if term < 1e-17 {
                break;
            }
        }
        (sum / (TAU * x).sqrt(), 0.0)
    }
}
