//! Cubic and quadratic curves cut into the straight pieces strands are made of, for the readers of
//! curve formats (pbrt-v4, USD).
//!
//! Each Bezier segment is cut into as many straight pieces as keep the polyline within a tenth of
//! the fiber radius of the curve: linear interpolation at n even steps of a curve B(u) is off by
//! at most max|B''| / (8 n^2), and a degree-d Bezier's |B''| <= d (d - 1) max_i |P_i - 2 P_{i+1} +
//! P_{i+2}| (at most 64 pieces a segment).

use super::Strands;
use glam::DVec3;

/// The most straight pieces one curve segment is cut into.
const MAX_PIECES: usize = 64;

/// Appends one strand: Bezier segments (each its control points in world space, and the fiber
/// radius at its start and end), consecutive segments sharing their end points. Points and radii
/// beyond f32's range, and a strand whose points all coincide, are refused.
pub(crate) fn append_strand(s: &mut Strands, segments: &[(Vec<DVec3>, f64, f64)]) -> Result<(), String> {
    let (mut points, mut radii) = (Vec::new(), Vec::new());
    for (k, (bezier, r0, r1)) in segments.iter().enumerate() {
        let pieces = pieces(bezier, 0.1 * r0.min(*r1));
        let start = if k == 0 { 0 } else { 1 };
        for i in start..=pieces {
            let u = i as f64 / pieces as f64;
            let point = de_casteljau(bezier, u).as_vec3();
            // Coincident points (a degenerate segment) would make a zero-length capsule.
            if points.last() == Some(&point) {
                continue;
            }
            let radius = lerp(u, *r0, *r1) as f32;
            if !point.is_finite() {
                return Err(format!("a curve point is {point} after the transform, beyond f32's range"));
            }
            if !(radius > 0.0 && radius.is_finite()) {
                return Err(format!("a curve's radius is {radius} after the transform"));
            }
            points.push(point);
            radii.push(radius);
        }
    }
    if points.len() < 2 {
        return Err("a curve whose control points all coincide".into());
    }
    let end = u32::try_from(s.points.len() + points.len()).map_err(|_| "more than 2^32 points")?;
    s.points.extend(points);
    s.radii.extend(radii);
    s.offsets.push(end);
    Ok(())
}

pub(crate) fn lerp(t: f64, a: f64, b: f64) -> f64 {
    a + t * (b - a)
}

/// The Bezier control points of one segment of a uniform B-spline of degree 2 or 3 (its
/// `degree + 1` control points): the standard change of basis.
pub(crate) fn bspline_to_bezier(p: &[DVec3]) -> Vec<DVec3> {
    if p.len() == 3 {
        vec![0.5 * (p[0] + p[1]), p[1], 0.5 * (p[1] + p[2])]
    } else {
        vec![
            (p[0] + 4.0 * p[1] + p[2]) / 6.0,
            (2.0 * p[1] + p[2]) / 3.0,
            (p[1] + 2.0 * p[2]) / 3.0,
            (p[1] + 4.0 * p[2] + p[3]) / 6.0,
        ]
    }
}

/// The point at parameter `u` of the Bezier curve with control points `p` (de Casteljau).
fn de_casteljau(p: &[DVec3], u: f64) -> DVec3 {
    let mut q = p.to_vec();
    for k in (1..q.len()).rev() {
        for i in 0..k {
            q[i] = q[i].lerp(q[i + 1], u);
        }
    }
    q[0]
}

/// How many even steps in u keep the polyline of a Bezier segment within `tolerance` of it (module
/// documentation), from 1 to [`MAX_PIECES`].
fn pieces(p: &[DVec3], tolerance: f64) -> usize {
    let d = (p.len() - 1) as f64;
    let second = p.windows(3).map(|w| (w[0] - 2.0 * w[1] + w[2]).length()).fold(0.0, f64::max);
    let n = (d * (d - 1.0) * second / (8.0 * tolerance)).sqrt().ceil();
    if n.is_finite() { (n as usize).clamp(1, MAX_PIECES) } else { MAX_PIECES }
}
