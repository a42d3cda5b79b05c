//! Ray-fiber intersection against an independent reference (sphere tracing of the capsules'
//! signed distance field), and the hit-distance regime where CwBvh's built-in cut-off would bite.

use dualhair::geometry::strands::Fibers;
use glam::{DVec3, Vec3};
use precompute::strands::Strands;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;

/// Random short strands of hair-thin fibers (radius ~1e-3) in the unit cube.
fn random_strands(rng: &mut Pcg64, n: usize) -> Strands {
    let mut s = Strands { offsets: vec![0], ..Default::default() };
    for _ in 0..n {
        let mut p = Vec3::new(rng.random(), rng.random(), rng.random());
        for _ in 0..4 {
            s.points.push(p);
            s.radii.push(rng.random_range(0.0005..0.003));
            p += Vec3::new(rng.random_range(-0.2..0.2), rng.random_range(-0.2..0.2), rng.random_range(-0.2..0.2));
        }
        s.offsets.push(s.points.len() as u32);
    }
    s.validate().unwrap();
    s
}

fn segment_distance(p: DVec3, a: DVec3, b: DVec3) -> f64 {
    let ab = b - a;
    let s = ((p - a).dot(ab) / ab.length_squared()).clamp(0.0, 1.0);
    (p - (a + s * ab)).length()
}

/// First entry into the union of capsules not containing `o`, by sphere tracing in f64.
fn sphere_trace(strands: &Strands, o: DVec3, d: DVec3, t_max: f64) -> Option<f64> {
    let caps: Vec<(DVec3, DVec3, f64)> = strands
        .segments()
        .map(|s| (s.a.as_dvec3(), s.b.as_dvec3(), s.radius as f64))
        .filter(|&(a, b, r)| segment_distance(o, a, b) > r)
        .collect();
    let sdf = |p: DVec3| caps.iter().map(|&(a, b, r)| segment_distance(p, a, b) - r).fold(f64::INFINITY, f64::min);
    let mut t = 0.0;
    for _ in 0..1_000_000 {
        let dist = sdf(o + t * d);
        if dist < 1e-10 {
            return Some(t);
        }
        t += dist;
        if t > t_max {
            return None;
        }
    }
    panic!("sphere tracing did not converge");
}

#[test]
fn closest_hits_match_sphere_tracing() {
    let mut rng = Pcg64::seed_from_u64(1);
    let strands = random_strands(&mut rng, 60);
    let fibers = Fibers::new(&strands);
    let segments: Vec<_> = strands.segments().collect();
    let (mut hits, mut worst) = (0, 0.0f64);
    for _ in 0..3000 {
        let o = DVec3::new(rng.random(), rng.random(), rng.random()) * 1.4 - DVec3::splat(0.2);
        // Aim within a few radii of a random point on a random fiber, so that many rays graze.
        let s = segments[rng.random_range(0..segments.len())];
        let jitter = DVec3::new(rng.random(), rng.random(), rng.random()) * 2.0 - DVec3::ONE;
        let target = s.a.as_dvec3().lerp(s.b.as_dvec3(), rng.random()) + jitter * 2.0 * s.radius as f64;
        let d = (target - o).normalize();
        let want = sphere_trace(&strands, o, d, 3.0);
        let got = fibers.closest_hit(o.as_vec3(), d.as_vec3(), 3.0);
        match (want, got) {
            (None, None) => {}
            (Some(t), Some(h)) => {
                hits += 1;
                // f32 outputs: allow a few ulps of the distance, far below a fiber radius.
                let err = (h.t as f64 - t).abs();
                worst = worst.max(err);
                assert!(err < 2e-6, "t = {} vs reference {t}", h.t);
                let seg = strands.segments().nth(h.segment as usize).unwrap();
                let axis_dist = segment_distance(h.point.as_dvec3(), seg.a.as_dvec3(), seg.b.as_dvec3());
                assert!(
                    (axis_dist - seg.radius as f64).abs() < 1e-5 * seg.radius as f64 + 1e-6,
                    "hit not on its capsule"
                );
                assert!(
                    (h.normal.length() - 1.0).abs() < 1e-5 && h.normal.dot(d.as_vec3()) < 1e-4,
                    "normal must face the ray"
                );
                assert!(!fibers.occluded(o.as_vec3(), d.as_vec3(), h.t * 0.999), "occluded before the closest hit");
                assert!(fibers.occluded(o.as_vec3(), d.as_vec3(), h.t * 1.001 + 1e-6), "not occluded past the hit");
            }
            (w, g) => panic!("hit disagreement: reference {w:?}, bvh {g:?} for o={o} d={d}"),
        }
    }
    println!("{hits} hits, worst |t - t_ref| = {worst:.2e}");
    assert!(hits > 1000, "too few hits to be a test: {hits}");
}

#[test]
fn hits_closer_than_cwbvh_cutoff_are_found() {
    // Two parallel fibers of radius 5e-4 with a 5e-5 gap: a ray leaving the first one's surface
    // toward the second hits it 5e-5 world units later, below CwBvh's built-in 1e-4.
    let r = 5e-4;
    let strands = Strands {
        points: vec![
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(0.0, 0.0, 1.0),
            Vec3::new(2.0 * r + 5e-5, 0.0, 0.0),
            Vec3::new(2.0 * r + 5e-5, 0.0, 1.0),
        ],
        radii: vec![r; 4],
        offsets: vec![0, 2, 4],
    };
    let fibers = Fibers::new(&strands);
    let origin = Vec3::new(r, 0.0, 0.5);
    let hit = fibers.closest_hit(origin, Vec3::X, 1.0).expect("the neighbour fiber must be hit");
    assert_eq!(hit.segment, 1);
    assert!((hit.t - 5e-5).abs() < 1e-8, "t = {}", hit.t);
    // Leaving the first fiber through itself (into it) must not hit it: rays only enter from outside.
    let through = fibers.closest_hit(origin, -Vec3::X, 1.0);
    assert!(through.is_none(), "{through:?}");
    assert!(fibers.occluded(origin, Vec3::X, 1.0));
}

#[test]
fn a_ray_inside_a_fiber_crosses_no_joint() {
    // A straight strand of three points is a convex tube: a ray from inside it (as rays leaving a
    // scattering event start, 1% of the radius below the surface) leaves it once and hits
    // nothing, even where it passes the joint, inside the next segment's end sphere. A second
    // strand crossing through the first one is a real hit, as in Blender Cycles.
    let r = 0.05f32;
    let strands = Strands { points: vec![Vec3::ZERO, Vec3::Z, 2.0 * Vec3::Z], radii: vec![r; 3], offsets: vec![0, 3] };
    let fibers = Fibers::new(&strands);
    let mut rng = Pcg64::seed_from_u64(7);
    let mut near_joint = 0;
    for _ in 0..20_000 {
        let (phi, z) = (std::f32::consts::TAU * rng.random::<f32>(), 1.0 - 0.2 * rng.random::<f32>());
        let origin = Vec3::new(0.99 * r * phi.cos(), 0.99 * r * phi.sin(), z);
        let d = Vec3::new(rng.random::<f32>() - 0.5, rng.random::<f32>() - 0.5, 2.0 * rng.random::<f32>()).normalize();
        near_joint += (z > 1.0 - 0.14 * r) as u32;
        let hit = fibers.closest_hit(origin, d, 10.0);
        assert!(hit.is_none(), "a ray from {origin} along {d} hit {hit:?}");
        assert!(!fibers.occluded(origin, d, 10.0));
        assert_eq!(fibers.crossings(origin, d, f32::INFINITY), 0);
    }
    assert!(near_joint > 100, "too few origins inside the next segment's end sphere: {near_joint}");

    let crossing = Strands {
        points: vec![Vec3::ZERO, Vec3::Z, 2.0 * Vec3::Z, Vec3::new(-1.0, 0.03, 1.0), Vec3::new(1.0, 0.03, 1.0)],
        radii: vec![r; 5],
        offsets: vec![0, 3, 5],
    };
    let fibers = Fibers::new(&crossing);
    let hit = fibers.closest_hit(Vec3::new(-0.99 * r, 0.0, 0.9), Vec3::Z, 1.0).expect("the crossing strand");
    assert_eq!(hit.segment, 2);
}
