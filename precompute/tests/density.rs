//! The hair-length density grid: length conservation, the exact ray query, trilinear lookup.

use glam::{DVec3, Vec3};
use precompute::density::{DensityGrid, traverse};
use precompute::strands::{Curly, Generator, Straight, Strands, read_hair};

fn fixture() -> Strands {
    read_hair(&std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/wavy_short_200.hair")).unwrap()
}

fn assert_conserves(strands: &Strands, voxel_size: f64, what: &str) {
    let grid = DensityGrid::voxelize(strands, voxel_size);
    let (got, want) = (grid.total_length(), strands.total_length());
    println!("{what} at voxel size {voxel_size:.5}: {got:.6} vs {want:.6}");
    assert!(((got - want) / want).abs() < 1e-3, "{what} at voxel size {voxel_size}: {got} vs {want}");
}

#[test]
fn density_conserves_total_length() {
    let straight = Generator::Straight(Straight { strands: 300, ..Default::default() }).generate().unwrap();
    let curly = Generator::Curly(Curly { strands: 200, ..Default::default() }).generate().unwrap();
    let real = fixture();
    for (strands, what) in [(&straight, "straight"), (&curly, "curly"), (&real, "real groom subset")] {
        let auto = DensityGrid::auto_voxel_size(strands);
        // Voxels from 20x below to 8x above the automatic size: segments much longer than a voxel
        // at the small end, many segments per voxel at the large end.
        for size in [auto / 20.0, auto / 3.0, auto, 8.0 * auto] {
            assert_conserves(strands, size, what);
        }
    }
}

#[test]
fn brick_counts_before_voxelizing_match_the_grid() {
    let real = fixture();
    let auto = DensityGrid::auto_voxel_size(&real);
    for size in [auto / 20.0, auto, 8.0 * auto] {
        let made = DensityGrid::voxelize(&real, size).bricks().count() as u64;
        let (touched, bound) =
            (DensityGrid::bricks_touched(&real, size, u64::MAX), DensityGrid::bricks_bound(&real, size));
        // Walked at the brick's scale rather than the voxel's, a segment on a brick face may be
        // assigned to the other side: a few bricks either way.
        assert!(touched.abs_diff(made) * 100 <= made, "voxel size {size}: {touched} counted, {made} made");
        assert!(bound >= touched, "voxel size {size}: bound {bound} below {touched}");
        assert_eq!(DensityGrid::bricks_touched(&real, size, made / 2), made / 2 + 1, "stops at the limit");
    }
}

#[test]
fn segments_on_voxel_faces_and_edges_are_counted_once() {
    let s = 0.25;
    // Strands along x lying exactly on voxel faces (y = 2s) and edges (y = 2s, z = -3s), along z
    // on an edge, and a diagonal through voxel corners.
    let lines = [
        (Vec3::new(-1.0, 0.5, 0.1), Vec3::new(1.0, 0.5, 0.1)),
        (Vec3::new(-1.0, 0.5, -0.75), Vec3::new(1.0, 0.5, -0.75)),
        (Vec3::new(0.25, -0.5, -1.0), Vec3::new(0.25, -0.5, 1.0)),
        (Vec3::new(-0.5, -0.5, -0.5), Vec3::new(0.75, 0.75, 0.75)),
    ];
    let mut strands = Strands { offsets: vec![0], ..Default::default() };
    for (a, b) in lines {
        strands.points.extend([a, b]);
        strands.radii.extend([0.01, 0.01]);
        strands.offsets.push(strands.points.len() as u32);
    }
    strands.validate().unwrap();
    assert_conserves(&strands, s, "lines on faces");
    // The face line lies in the voxels above the face (y in [2s, 3s)), one voxel per step in x.
    let grid = DensityGrid::voxelize(&strands, s);
    assert!((grid.voxel([0, 2, 0]) as f64 - s / s.powi(3)).abs() < 1e-3);
    assert_eq!(grid.voxel([0, 1, 0]), 0.0);
}

#[test]
fn traversal_partitions_the_segment() {
    let cases = [
        (DVec3::new(0.1, 0.2, 0.3), DVec3::new(3.7, -2.2, 0.31)),
        (DVec3::new(1.0, 1.0, 1.0), DVec3::new(1.0, 1.0, 5.0)),
        (DVec3::new(-0.5, 2.0, 0.0), DVec3::new(-0.5, 2.0, 0.0) + DVec3::new(1e-9, 0.0, 0.0)),
    ];
    for (a, b) in cases {
        let mut covered = 0.0;
        let mut last = 0.0;
        traverse(a, b, 0.5, |_, t0, t1| {
            assert!((t0 - last).abs() < 1e-12 && t1 > t0, "intervals must be contiguous");
            covered += t1 - t0;
            last = t1;
        });
        assert!((covered - 1.0).abs() < 1e-12, "{covered}");
    }
}

#[test]
fn ray_query_is_exact_through_a_slab() {
    // Density rho in voxels with i in 4..12 (a slab of thickness 8 s perpendicular to x).
    let (s, rho, width) = (0.1, 250.0f32, 0.004);
    let voxels = (4..12).flat_map(|i| (-20..20).flat_map(move |j| (-20..20).map(move |k| ([i, j, k], rho))));
    let grid = DensityGrid::from_voxels(s, width, voxels);
    for dir in [DVec3::X, DVec3::new(1.0, 0.3, -0.2).normalize(), DVec3::new(-1.0, 0.5, 0.1).normalize()] {
        let origin = if dir.x > 0.0 { DVec3::new(0.0, 0.05, 0.07) } else { DVec3::new(2.0, 0.05, 0.07) };
        let want = rho as f64 * 0.8 / dir.x.abs() * width;
        let got = grid.fibers_crossed(origin, dir, f64::INFINITY);
        assert!((got - want).abs() < 1e-9 * want, "{dir}: {got} vs {want}");
        // Stopping halfway through the slab counts half of it.
        let t_mid = (0.8 - origin.x.min(2.0 - origin.x) + 0.4) / dir.x.abs();
        let half = grid.fibers_crossed(origin, dir, if dir.x > 0.0 { (0.8 - origin.x) / dir.x } else { t_mid });
        assert!((half - want / 2.0).abs() < 1e-9 * want, "{dir}: half {half} vs {}", want / 2.0);
    }
    // Rays that miss, start past the slab, or graze the grid's outer boundary count nothing.
    assert_eq!(grid.fibers_crossed(DVec3::new(0.0, 5.0, 0.0), DVec3::X, f64::INFINITY), 0.0);
    assert_eq!(grid.fibers_crossed(DVec3::new(1.3, 0.0, 0.0), DVec3::X, f64::INFINITY), 0.0);
    assert_eq!(grid.fibers_crossed(DVec3::new(0.0, 2.0, 0.0), DVec3::X, f64::INFINITY), 0.0);
    let empty = DensityGrid::from_voxels(s, width, std::iter::empty());
    assert_eq!(empty.fibers_crossed(DVec3::ZERO, DVec3::X, f64::INFINITY), 0.0);
    assert_eq!(empty.density(DVec3::ZERO), 0.0);
}

#[test]
fn ray_query_converges_on_a_cylinder_of_known_density() {
    // A cylinder of radius R along z with density rho: a ray through its axis crosses 2 R rho w
    // fibers. Voxelization error is bounded by the boundary voxels and shrinks with them.
    let (radius, rho, width) = (1.0, 100.0f32, 0.002);
    let want = 2.0 * radius * rho as f64 * width;
    let mut last_err = f64::INFINITY;
    for s in [0.2, 0.1, 0.05, 0.025] {
        let n = (radius / s).ceil() as i32 + 1;
        let voxels: Vec<([i32; 3], f32)> = (-n..n)
            .flat_map(|i| (-n..n).map(move |j| (i, j)))
            .filter(|&(i, j)| (((i as f64 + 0.5) * s).powi(2) + ((j as f64 + 0.5) * s).powi(2)).sqrt() < radius)
            .flat_map(|(i, j)| (-2..2).map(move |k| ([i, j, k], rho)))
            .collect();
        let grid = DensityGrid::from_voxels(s, width, voxels);
        let got = grid.fibers_crossed(DVec3::new(-3.0, 0.3 * s, 0.01), DVec3::X, f64::INFINITY);
        let err = (got - want).abs();
        println!("voxel {s}: {got:.5} vs {want:.5}");
        assert!(err <= 2.0 * s * rho as f64 * width + 1e-12, "voxel {s}: {got} vs {want}");
        assert!(err <= last_err + 1e-12, "error must not grow as voxels shrink");
        last_err = err;
    }
}

#[test]
fn trilinear_lookup_reproduces_linear_fields() {
    // Voxel values sampled from f(p) = 3 + 2x - y + 0.5z at voxel centers: trilinear interpolation
    // is exact for such a field between centers.
    let s = 0.5;
    let f = |p: DVec3| 3.0 + 2.0 * p.x - p.y + 0.5 * p.z;
    let voxels = (-6..6).flat_map(|i| (-6..6).flat_map(move |j| (-6..6).map(move |k| ([i, j, k], 0.0f32))));
    let voxels: Vec<_> = voxels
        .map(|(v, _)| (v, f((DVec3::new(v[0] as f64, v[1] as f64, v[2] as f64) + DVec3::splat(0.5)) * s) as f32))
        .collect();
    let grid = DensityGrid::from_voxels(s, 0.001, voxels);
    for p in [DVec3::new(0.1, -0.3, 0.7), DVec3::new(-1.9, 1.2, 0.25), DVec3::new(0.25, 0.25, 0.25)] {
        assert!((grid.density(p) - f(p)).abs() < 1e-5, "{p}: {} vs {}", grid.density(p), f(p));
    }
}

#[test]
fn automatic_voxel_size_follows_the_fibers() {
    for (strands, what) in [(fixture(), "real"), (Generator::Curly(Curly::default()).generate().unwrap(), "curly")] {
        let s = DensityGrid::auto_voxel_size(&strands);
        let (lo, hi) = strands.bounds();
        let longest = (hi - lo).max_element() as f64;
        let diameter = 2.0 * strands.radii.iter().map(|&r| r as f64).sum::<f64>() / strands.radii.len() as f64;
        println!(
            "{what}: voxel size {s:.5} ({:.1} fiber diameters, {:.0} voxels along the longest edge)",
            s / diameter,
            longest / s
        );
        assert!(s >= longest / 512.0 - 1e-12 && s <= longest / 16.0 + 1e-12);
    }
}

#[test]
fn ray_query_matches_voxel_chords_on_real_hair() {
    // The brick-cached march against an independent exact sum: the ray's chord through every
    // stored voxel (slab test) times its density, along random rays from the hair, every fourth
    // nearly parallel to the voxel faces.
    use rand::{Rng, SeedableRng};
    let strands = fixture();
    let grid = DensityGrid::voxelize(&strands, DensityGrid::auto_voxel_size(&strands));
    let s = grid.voxel_size;
    let voxels: Vec<([i32; 3], f32)> = grid.voxels().collect();
    let mut rng = rand_pcg::Pcg64::seed_from_u64(3);
    let mut nonzero = 0;
    for _ in 0..100 {
        let origin = strands.points[rng.random_range(0..strands.points.len())].as_dvec3();
        let z = if rng.random::<f64>() < 0.25 { 1e-3 } else { 2.0 * rng.random::<f64>() - 1.0 };
        let a = std::f64::consts::TAU * rng.random::<f64>();
        let r = (1.0 - z * z).sqrt();
        let dir = DVec3::new(r * a.cos(), r * a.sin(), z);
        let want: f64 = voxels
            .iter()
            .map(|&(v, d)| {
                let lo = DVec3::from_array(v.map(|c| c as f64)) * s;
                let (mut t0, mut t1) = (0.0f64, f64::INFINITY);
                for k in 0..3 {
                    let (a, b) = ((lo[k] - origin[k]) / dir[k], (lo[k] + s - origin[k]) / dir[k]);
                    t0 = t0.max(a.min(b));
                    t1 = t1.min(a.max(b));
                }
                (t1 - t0).max(0.0) * d as f64
            })
            .sum::<f64>()
            * grid.fiber_width;
        let got = grid.fibers_crossed(origin, dir, f64::INFINITY);
        assert!(got.is_finite() && got >= 0.0);
        assert!((got - want).abs() <= 1e-9 * want + 1e-15, "{origin} {dir}: {got} vs {want}");
        nonzero += (want > 0.0) as usize;
    }
    assert!(nonzero > 90, "too few rays crossed hair: {nonzero}");
}

/// `n` straight fibers of radius `r` along `axis` (unit), from -1 to 1 along it, through random
/// points of the unit square across it, each in 16 segments.
fn parallel_fibers(n: usize, r: f32, axis: DVec3, seed: u64) -> Strands {
    use rand::{Rng, SeedableRng};
    let mut rng = rand_pcg::Pcg64::seed_from_u64(seed);
    let (u, v) = axis.any_orthonormal_pair();
    let mut s = Strands::default();
    for _ in 0..n {
        s.offsets.push(s.points.len() as u32);
        let c = u * (2.0 * rng.random::<f64>() - 1.0) + v * (2.0 * rng.random::<f64>() - 1.0);
        for k in 0..=16 {
            s.points.push((c + axis * (k as f64 / 8.0 - 1.0)).as_vec3());
            s.radii.push(r);
        }
    }
    s.offsets.push(s.points.len() as u32);
    s
}

#[test]
fn oriented_count_matches_the_real_crossings_of_parallel_fibers() {
    // A fiber of width w at angle a to a ray presents a cross-section w |sin a| per unit length
    // (the projected width of a cylinder), so through parallel fibers the count falls by
    // sin a from the count of fibers across the ray. Checked two ways: the grid's count against
    // the plain grid's times sin a (all fibers share one orientation: exact), and against the
    // real number of fibers a ray passes within r of, averaged over many rays (Monte Carlo).
    use rand::{Rng, SeedableRng};
    let (r, axis) = (0.004f32, DVec3::new(1.0, 0.3, -0.2).normalize());
    let strands = parallel_fibers(400, r, axis, 1);
    let plain = DensityGrid::voxelize(&strands, 0.05);
    let grid = plain.clone().with_orientation(&strands);
    let (u, v) = axis.any_orthonormal_pair();
    let mut rng = rand_pcg::Pcg64::seed_from_u64(2);
    for angle in [90.0f64, 50.0, 25.0] {
        let a = angle.to_radians();
        let dir = (axis * a.cos() + u * a.sin()).normalize();
        let (mut real, mut oriented, rays) = (0.0, 0.0, 3000);
        for _ in 0..rays {
            // A ray piece of length 0.8 centred inside the bundle, away from its ends and sides.
            let centre =
                axis * (0.4 * (2.0 * rng.random::<f64>() - 1.0)) + v * (0.6 * (2.0 * rng.random::<f64>() - 1.0));
            let origin = centre - dir * 0.4;
            let (got, want) = (grid.fibers_crossed(origin, dir, 0.8), plain.fibers_crossed(origin, dir, 0.8));
            // The tangents come from f32 points: about 1e-6 of relative error.
            assert!((got - want * a.sin()).abs() <= 1e-5 * want, "{angle} deg: {got} vs {want} sin a");
            // The thesis's count, which Zinke's formulas read literally keep, ignores it.
            assert_eq!(grid.fibers_across(origin, dir, 0.8), want);
            oriented += got;
            // Fibers whose axis passes within r of the ray piece.
            real += strands
                .offsets
                .windows(2)
                .filter(|w| {
                    let c = strands.points[w[0] as usize].as_dvec3();
                    let n = dir.cross(axis);
                    let gap = ((c - origin).dot(n) / n.length()).abs();
                    // Where along the ray the fiber comes closest (skew lines).
                    let t = (c - origin).cross(axis).dot(n) / n.length_squared();
                    gap < r as f64 && (0.0..0.8).contains(&t)
                })
                .count() as f64;
        }
        let (real, oriented) = (real / rays as f64, oriented / rays as f64);
        // Poisson-like counts: the standard error of the mean is about sqrt(count / rays).
        let tolerance = 4.0 * (real / rays as f64).sqrt() + 0.02 * real;
        println!("{angle} deg: real {real:.3}, oriented grid {oriented:.3}");
        assert!((real - oriented).abs() < tolerance, "{angle} deg: real {real} vs grid {oriented}");
    }
}

#[test]
fn oriented_count_of_random_orientations_is_sqrt_two_thirds() {
    // For fibers of every orientation alike mean sin^2 = 2/3 (mean cos^2 = 1/3), so the grid
    // counts sqrt(2/3) of the plain count: 4% above the true mean |sin| = pi/4 (documented on
    // `DensityGrid::fibers_crossed`), against 27% above it without the orientation.
    use rand::{Rng, SeedableRng};
    let mut rng = rand_pcg::Pcg64::seed_from_u64(5);
    let mut s = Strands::default();
    for _ in 0..60_000 {
        let z: f64 = 2.0 * rng.random::<f64>() - 1.0;
        let a = std::f64::consts::TAU * rng.random::<f64>();
        let t = DVec3::new((1.0 - z * z).sqrt() * a.cos(), (1.0 - z * z).sqrt() * a.sin(), z);
        let c = DVec3::new(rng.random(), rng.random(), rng.random());
        s.offsets.push(s.points.len() as u32);
        s.points.extend([(c - 0.01 * t).as_vec3(), (c + 0.01 * t).as_vec3()]);
        s.radii.extend([0.001, 0.001]);
    }
    s.offsets.push(s.points.len() as u32);
    // One brick (8 voxels of 1/8) holds most of the unit cube: many segments per brick.
    let plain = DensityGrid::voxelize(&s, 0.125);
    let grid = plain.clone().with_orientation(&s);
    for dir in [DVec3::X, DVec3::Z, DVec3::new(1.0, -2.0, 0.5).normalize()] {
        let origin = DVec3::splat(0.5) - 0.3 * dir;
        let ratio = grid.fibers_crossed(origin, dir, 0.6) / plain.fibers_crossed(origin, dir, 0.6);
        println!("{dir}: oriented / plain {ratio:.4}, sqrt(2/3) = {:.4}", (2.0f64 / 3.0).sqrt());
        assert!((ratio - (2.0f64 / 3.0).sqrt()).abs() < 0.01, "{dir}: {ratio}");
    }
}
