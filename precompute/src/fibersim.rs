//! Ground-truth Monte Carlo simulation of light scattered by one rough dielectric fiber, after
//! d'Eon, Marschner and Hanika 2014 (section 2.1): rays hit an infinite unit-radius
//! cylinder whose surface is Walter et al. 2007's rough dielectric BSDF (Beckmann, Smith), scale
//! tilt is a shading normal, the interior absorbs (Beer-Lambert), and the exit directions are
//! binned per lobe into lat-long images laid out exactly as [`crate::lobe`]'s.
//!
//! Frame and units ([`crate::conventions`]): x is the fiber axis (root to tip), the light arrives
//! from wo = direction(theta_i, 0), so rays travel along -wo; the offset h is uniform in [-1, 1]
//! across the projected width and a ray at offset h first meets the surface where the macro
//! normal n has azimuth -asin(h) (then `h_offset(wo, n) = h`). Lengths are in fiber radii, so
//! sigma_a is per unit radius; angles are radians except alpha (degrees).
//!
//! Design decisions:
//! - Roughness: `FiberParams::beta_m` is used directly as Walter's Beckmann width alpha_b. Beckmann
//!   slopes are Gaussian with variance alpha_b^2 / 2 per tangent axis, so the longitudinal tilt of
//!   the microfacet normal has standard deviation beta / sqrt(2), and d'Eon's dx_R/dalpha = -2z
//!   (d'Eon et al. 2014 section 2.2) then gives the R width beta sqrt(2 (1 - h^2)) of their eq. 6.
//!   (Section 2.2's "variance beta^2" would instead give 2 beta sqrt(1 - h^2), which disagrees
//!   with eq. 6; the tests check eq. 6.)
//! - Scale tilt: the shading normal is n cos(alpha) - x sin(alpha), the macro normal tilted toward
//!   the root for alpha > 0. Mirror reflection of wo about it puts the R peak at
//!   theta_r = -theta_i - 2 alpha, the project's sign (Blender Cycles' Offset; `fiber::chiang`).
//! - Energy accounting: every ray carries weight 1, and all of it ends up in the tallies of
//!   [`Tally`]: the lobes, absorbed, microfacet loss (the shortfall of Walter's weight
//!   |i.m| G / (|i.n| |m.n|) below 1, signed per event since the weight can exceed 1, and in
//!   expectation what Smith shadowing-masking removes), shading loss
//!   (the ray met a back-facing shading normal, or the sampled direction left on the wrong side of
//!   the macro surface: d'Eon et al. 2014 section 2.1's "energy loss" of tilted scales), or truncated (still
//!   inside after [`MAX_SEGMENTS`] internal segments).
//! - Determinism: rays are cut into chunks of [`CHUNK_RAYS`]; chunk k has its own PCG generator
//!   keyed by outputs 4k..4k+3 of a master generator seeded with the seed, and the exits are added
//!   to the images in ray order on one thread, so a result depends on the seed and never on the
//!   thread count.

use crate::conventions::{direction, phi, theta};
use crate::fiber::{FiberParams, ParamError};
use crate::lobe::LobeImage;
use crate::spectrum::Rgb;
use glam::DVec3;
use rand::{Rng, RngCore, SeedableRng};
use rand_pcg::Pcg64;
use rayon::prelude::*;
use statrs::function::erf::erf;
use std::f64::consts::{FRAC_PI_2, PI, TAU};

/// Lobes kept apart: R (p = 0), TT (p = 1), TRT (p = 2), and all p >= 3 together.
pub const LOBES: usize = 4;

/// Internal path segments after which a path still inside the fiber is cut (its energy is
/// counted in [`Tally::truncated`]).
pub const MAX_SEGMENTS: usize = 32;

/// Rays per chunk, the unit of parallel work and of random-number streams.
pub const CHUNK_RAYS: u64 = 1 << 14;

/// Largest ray count [`FiberSim::simulate`] accepts.
pub const MAX_RAYS: u64 = 1_000_000_000;

/// Largest image width and height [`FiberSim::simulate`] accepts (the images are f64 RGB).
pub const MAX_WIDTH: usize = 2048;
pub const MAX_HEIGHT: usize = 1024;

/// The simulated fiber lit from one direction.
#[derive(Clone, Debug)]
pub struct FiberSim {
    /// Direction toward the light.
    wo: DVec3,
    /// Beckmann width alpha_b (Walter et al. 2007 eq. 25) = beta_m.
    alpha_b: f64,
    /// `(sin, cos)` of the scale tilt.
    tilt: (f64, f64),
    eta: f64,
    /// Absorption per unit radius.
    sigma_a: Rgb,
}

/// How a traced path ended.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum End {
    /// Left the fiber after `p` internal segments, along `direction`.
    Exit { p: usize, direction: DVec3 },
    /// Met a back-facing shading normal or scattered to the wrong side of the macro surface.
    ShadingLoss,
    /// A sampled microfacet passed nothing on (facing away from the ray, or Smith G = 0).
    Extinct,
    /// Still inside after [`MAX_SEGMENTS`] segments.
    Truncated,
}

/// One traced ray: how it ended, the weight it had then, and what it lost on the way. For every
/// channel `weight + absorbed + microfacet_loss = 1`.
#[derive(Clone, Copy, Debug)]
pub struct Path {
    pub end: End,
    pub weight: Rgb,
    pub absorbed: Rgb,
    pub microfacet_loss: Rgb,
}

/// Where the incident energy went, as fractions of it (per RGB channel): all fields but
/// `lobes_sq` sum to 1 up to rounding.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Tally {
    /// Energy leaving in each lobe (R, TT, TRT, rest).
    pub lobes: [Rgb; LOBES],
    /// Mean of the squared per-ray contribution to each lobe, for standard errors.
    pub lobes_sq: [Rgb; LOBES],
    /// Beer-Lambert absorption inside the fiber.
    pub absorbed: Rgb,
    /// Shortfall of Walter's weight below 1 (Smith shadowing-masking): signed per event, >= 0 in
    /// expectation.
    pub microfacet_loss: Rgb,
    /// Back-facing shading normals and directions on the wrong side of the macro surface.
    pub shading_loss: Rgb,
    /// Still inside after [`MAX_SEGMENTS`] segments.
    pub truncated: Rgb,
}

impl Tally {
    fn add(&mut self, o: &Tally) {
        for p in 0..LOBES {
            self.lobes[p] += o.lobes[p];
            self.lobes_sq[p] += o.lobes_sq[p];
        }
        self.absorbed += o.absorbed;
        self.microfacet_loss += o.microfacet_loss;
        self.shading_loss += o.shading_loss;
        self.truncated += o.truncated;
    }

    fn scale(&mut self, s: f64) {
        for p in 0..LOBES {
            self.lobes[p] = self.lobes[p] * s;
            self.lobes_sq[p] = self.lobes_sq[p] * s;
        }
        for v in [&mut self.absorbed, &mut self.microfacet_loss, &mut self.shading_loss, &mut self.truncated] {
            *v = *v * s;
        }
    }
}

/// The result of [`FiberSim::simulate`].
pub struct Simulation {
    pub rays: u64,
    /// One image per lobe (R, TT, TRT, rest) in [`crate::lobe`]'s layout and units: pixel = exiting
    /// energy per steradian per unit incident energy, so each image's `albedo()` is its lobe's
    /// share of [`Tally::lobes`].
    pub images: [LobeImage; LOBES],
    pub tally: Tally,
}

impl Simulation {
    /// Standard error of [`Tally::lobes`]`[p]` (sample standard deviation over sqrt(rays)).
    pub fn std_error(&self, p: usize) -> Rgb {
        let n = self.rays as f64;
        let (m, sq) = (self.tally.lobes[p], self.tally.lobes_sq[p]);
        (sq - m * m).map(|v| (v.max(0.0) / (n - 1.0).max(1.0)).sqrt())
    }

    /// Energy leaving the fiber in all lobes.
    pub fn albedo(&self) -> Rgb {
        self.tally.lobes.iter().copied().sum()
    }

    /// The sum of the four lobe images.
    pub fn total_image(&self) -> LobeImage {
        let [first, rest @ ..] = &self.images;
        let mut pixels = first.pixels.clone();
        for image in rest {
            pixels.iter_mut().zip(&image.pixels).for_each(|(a, b)| *a += *b);
        }
        LobeImage { width: first.width, height: first.height, pixels }
    }
}

/// What one chunk of rays produced: exits `(lobe, pixel, weight)` in ray order, and its tally sums.
struct Chunk {
    exits: Vec<(u8, u32, Rgb)>,
    tally: Tally,
}

/// The outcome of one surface interaction.
enum Scatter {
    /// Scattered into `o` with Walter's weight `factor`; `transmitted` if it crossed the shading
    /// surface (`o` may still be on the wrong side of the macro surface).
    Into { o: DVec3, factor: f64, transmitted: bool },
    /// The weight is zero (microfacet facing away or shadowed).
    Extinct,
    /// The shading or the macro normal faces away from the ray.
    BackFacing,
}

impl FiberSim {
    /// A fiber with `params`' beta_m (as the Beckmann width), alpha, eta and sigma_a, lit from
    /// inclination `theta_i` (radians, in [-pi/2, pi/2]).
    pub fn new(params: &FiberParams, theta_i: f64) -> Result<FiberSim, ParamError> {
        params.validate()?;
        check("theta_i", theta_i, (-FRAC_PI_2..=FRAC_PI_2).contains(&theta_i), "must be in [-pi/2, pi/2] radians")?;
        Ok(FiberSim {
            wo: direction(theta_i, 0.0),
            alpha_b: params.beta_m,
            tilt: params.alpha.to_radians().sin_cos(),
            eta: params.eta,
            sigma_a: params.sigma_a(),
        })
    }

    /// Traces `rays` rays with offsets uniform in [-1, 1] and bins their exits into
    /// `width` x `height` lat-long images. `progress` is called on the calling thread with the
    /// number of rays finished so far.
    pub fn simulate(
        &self,
        rays: u64,
        seed: u64,
        width: usize,
        height: usize,
        progress: &mut dyn FnMut(u64),
    ) -> Result<Simulation, ParamError> {
        check("rays", rays as f64, (1..=MAX_RAYS).contains(&rays), "must be in 1..=1e9")?;
        check("width", width as f64, (1..=MAX_WIDTH).contains(&width), "must be in 1..=2048")?;
        check("height", height as f64, (1..=MAX_HEIGHT).contains(&height), "must be in 1..=1024")?;
        let blank = || LobeImage { width, height, pixels: vec![Rgb::ZERO; width * height] };
        let mut images = [blank(), blank(), blank(), blank()];
        let mut tally = Tally::default();
        let chunks = rays.div_ceil(CHUNK_RAYS);
        // Batches only bound memory; results do not depend on their size.
        let batch = 8 * rayon::current_num_threads() as u64;
        let mut start = 0;
        while start < chunks {
            let end = (start + batch).min(chunks);
            let done: Vec<Chunk> = (start..end)
                .into_par_iter()
                .map(|k| {
                    let n = CHUNK_RAYS.min(rays - k * CHUNK_RAYS);
                    self.chunk(k, n, seed, width, height)
                })
                .collect();
            for c in &done {
                for &(lobe, pixel, w) in &c.exits {
                    images[lobe as usize].pixels[pixel as usize] += w;
                }
                tally.add(&c.tally);
            }
            progress((end * CHUNK_RAYS).min(rays));
            start = end;
        }
        // Pixel = energy / (rays * solid angle), the solid angle taken as cos(theta) dtheta dphi
        // at the pixel center so that LobeImage::albedo returns exactly the binned energy.
        let cell = (PI / height as f64) * (TAU / width as f64);
        for image in &mut images {
            for y in 0..height {
                let norm = 1.0 / (rays as f64 * image.theta(y).cos() * cell);
                image.pixels[y * width..(y + 1) * width].iter_mut().for_each(|p| *p = *p * norm);
            }
        }
        tally.scale(1.0 / rays as f64);
        Ok(Simulation { rays, images, tally })
    }

    /// Traces chunk `k` (`n` rays) with its own random stream.
    fn chunk(&self, k: u64, n: u64, seed: u64, width: usize, height: usize) -> Chunk {
        // The chunk's generator is seeded (state and stream) with four consecutive outputs of a
        // master stream: independent-looking streams, unlike jump-ahead substreams of one PCG,
        // whose states differ only in their high bits.
        let mut master = Pcg64::seed_from_u64(seed);
        master.advance(4 * u128::from(k));
        let mut key = [0u8; 32];
        master.fill_bytes(&mut key);
        let mut rng = Pcg64::from_seed(key);
        let mut out = Chunk { exits: Vec::with_capacity(n as usize), tally: Tally::default() };
        let t = &mut out.tally;
        for _ in 0..n {
            let h = 2.0 * rng.random::<f64>() - 1.0;
            let path = self.trace(h, &mut rng);
            t.absorbed += path.absorbed;
            t.microfacet_loss += path.microfacet_loss;
            match path.end {
                End::Exit { p, direction } => {
                    let lobe = p.min(LOBES - 1);
                    t.lobes[lobe] += path.weight;
                    t.lobes_sq[lobe] += path.weight * path.weight;
                    out.exits.push((lobe as u8, pixel_of(direction, width, height), path.weight));
                }
                End::ShadingLoss => t.shading_loss += path.weight,
                End::Truncated => t.truncated += path.weight,
                End::Extinct => {}
            }
        }
        out
    }

    /// Traces one ray entering at offset `h` in [-1, 1].
    pub fn trace(&self, h: f64, rng: &mut impl Rng) -> Path {
        let gamma = h.clamp(-1.0, 1.0).asin();
        // Point on the unit circle in the normal plane (x is irrelevant on an infinite cylinder).
        let mut pos = DVec3::new(0.0, gamma.cos(), -gamma.sin());
        let mut d = -self.wo;
        let mut path = Path { end: End::Truncated, weight: Rgb::ONE, absorbed: Rgb::ZERO, microfacet_loss: Rgb::ZERO };
        let mut inside = false;
        // Internal segments traversed so far: the lobe index p on exit.
        let mut p = 0;
        loop {
            let n_out = DVec3::new(0.0, pos.y, pos.z);
            let (sin_a, cos_a) = self.tilt;
            let s_out = n_out * cos_a - DVec3::X * sin_a;
            // Normals on the side the ray comes from, and the relative index across the surface.
            let (n, s, eta) = if inside { (-n_out, -s_out, 1.0 / self.eta) } else { (n_out, s_out, self.eta) };
            let (o, transmitted) = match self.scatter(-d, n, s, eta, rng) {
                Scatter::Into { o, factor, transmitted } => {
                    path.microfacet_loss += path.weight * (1.0 - factor);
                    path.weight = path.weight * factor;
                    // Leaving on the wrong side of the macro surface (possible only with tilt):
                    // lost after the weight, so that the expected microfacet loss stays Walter's
                    // shortfall whatever the direction.
                    if (o.dot(n) < 0.0) != transmitted {
                        path.end = End::ShadingLoss;
                        return path;
                    }
                    (o, transmitted)
                }
                Scatter::Extinct => {
                    path.microfacet_loss += path.weight;
                    path.weight = Rgb::ZERO;
                    path.end = End::Extinct;
                    return path;
                }
                Scatter::BackFacing => {
                    path.end = End::ShadingLoss;
                    return path;
                }
            };
            inside ^= transmitted;
            if !inside {
                path.end = End::Exit { p, direction: o };
                return path;
            }
            if p == MAX_SEGMENTS {
                path.end = End::Truncated;
                return path;
            }
            // Next hit on the unit circle: |pos + t o_yz| = 1 with |pos| = 1 gives
            // t = -2 pos.o / |o_yz|^2 (o.x moves along the axis, which changes nothing).
            let o_yz = DVec3::new(0.0, o.y, o.z);
            let t = -2.0 * pos.dot(o_yz) / o_yz.length_squared();
            if !t.is_finite() {
                // Running along the axis: the path never returns to the surface.
                path.end = End::Truncated;
                return path;
            }
            // Beer-Lambert along the whole 3D segment of length t (d'Eon et al. 2014 section 2.1).
            let transmittance = self.sigma_a.map(|s| (-s * t).exp());
            path.absorbed += path.weight * (Rgb::ONE - transmittance);
            path.weight = path.weight * transmittance;
            pos = (pos + o_yz * t).normalize();
            d = o;
            p += 1;
        }
    }

    /// One interaction with the rough dielectric surface (Walter et al. 2007 section 5.3): `i`
    /// points back along the ray, `n` is the macro normal and `s` the shading normal on `i`'s
    /// side, `eta` the index of the far side over the near side.
    fn scatter(&self, i: DVec3, n: DVec3, s: DVec3, eta: f64, rng: &mut impl Rng) -> Scatter {
        let (i_n, i_s) = (i.dot(n), i.dot(s));
        if i_n <= 0.0 || i_s <= 0.0 {
            return Scatter::BackFacing;
        }
        let m = self.sample_microfacet(s, [rng.random(), rng.random()]);
        let c = i.dot(m);
        if c <= 0.0 {
            return Scatter::Extinct;
        }
        // Reflect with probability F (Walter eq. 22), else refract (eqs. 39, 40).
        let transmitted = rng.random::<f64>() >= fresnel(c, eta);
        let o = if transmitted {
            let r = 1.0 / eta;
            let k = (1.0 + r * r * (c * c - 1.0)).max(0.0);
            m * (r * c - k.sqrt()) - i * r
        } else {
            m * (2.0 * c) - i
        };
        // Walter eq. 41 with G = G1(i) G1(o) (eq. 23); the Fresnel choice cancels F.
        let factor = c * self.smith_g1(i, m, s) * self.smith_g1(o, m, s) / (i_s * m.dot(s));
        if factor <= 0.0 {
            return Scatter::Extinct;
        }
        Scatter::Into { o, factor, transmitted }
    }

    /// A microfacet normal with density D(m) |m.s| about `s` (Walter eqs. 25, 28):
    /// tan^2 theta_m = -alpha_b^2 ln(1 - u0), phi_m = 2 pi u1. The first tangent is the fiber
    /// axis projected onto the tangent plane, so its slope is the longitudinal tilt.
    fn sample_microfacet(&self, s: DVec3, u: [f64; 2]) -> DVec3 {
        let along = (DVec3::X - s * s.x).normalize();
        let across = s.cross(along);
        let tan2 = -self.alpha_b * self.alpha_b * (1.0 - u[0]).ln();
        let cos_m = 1.0 / (1.0 + tan2).sqrt();
        let sin_m = tan2.sqrt() * cos_m;
        let (sin_p, cos_p) = (TAU * u[1]).sin_cos();
        s * cos_m + (along * cos_p + across * sin_p) * sin_m
    }

    /// Smith shadowing-masking of the Beckmann distribution about normal `s` (Walter eq. 26):
    /// chi+(v.m / v.s) 2 / (1 + erf(a) + exp(-a^2) / (a sqrt(pi))), a = 1 / (alpha_b tan theta_v).
    fn smith_g1(&self, v: DVec3, m: DVec3, s: DVec3) -> f64 {
        let v_s = v.dot(s);
        if v.dot(m) * v_s <= 0.0 {
            return 0.0;
        }
        let cos = v_s.abs().min(1.0);
        let a = cos / (self.alpha_b * (1.0 - cos * cos).sqrt());
        2.0 / (1.0 + erf(a) + (-a * a).exp() / (a * PI.sqrt()))
    }
}

/// `Ok` if `value` is finite and `ok`, else the error naming `field`.
fn check(field: &'static str, value: f64, ok: bool, problem: &'static str) -> Result<(), ParamError> {
    if value.is_finite() && ok { Ok(()) } else { Err(ParamError { field, problem, value }) }
}

/// Unpolarized dielectric Fresnel reflectance for cos(angle to the microfacet normal) `c > 0` and
/// relative index `eta` = far side over near side; 1 under total internal reflection
/// (Walter et al. 2007 eq. 22).
fn fresnel(c: f64, eta: f64) -> f64 {
    let g2 = eta * eta - 1.0 + c * c;
    if g2 <= 0.0 {
        return 1.0;
    }
    let g = g2.sqrt();
    let a = (g - c) / (g + c);
    let b = (c * (g + c) - 1.0) / (c * (g - c) + 1.0);
    0.5 * a * a * (1.0 + b * b)
}

/// Index into a `width` x `height` lat-long image ([`crate::lobe`]'s layout) of a direction.
pub(crate) fn pixel_of(w: DVec3, width: usize, height: usize) -> u32 {
    let x = ((phi(w) + PI) / TAU * width as f64) as usize;
    let y = ((FRAC_PI_2 - theta(w)) / PI * height as f64) as usize;
    (y.min(height - 1) * width + x.min(width - 1)) as u32
}
