//! The h-averaged scattering lobe of a fiber as a lat-long image, for users to see what a fiber
//! does (the `dualhair lobe` command).
//!
//! With the fixed direction wo at inclination `theta` and azimuth 0, pixel (x, y) holds
//! (1/2) int_{-1}^{1} f(wo, wi) |cos theta_i| dh at wi = (theta_y, phi_x), where
//! phi_x runs from -pi (left) to pi (right) and theta_y from +pi/2 (top row) to -pi/2 (bottom row),
//! sampled at pixel centers. Then sum(pixel cos(theta) dtheta dphi) is the fiber's albedo.

use crate::conventions::direction;
use crate::fiber::FiberModel;
use crate::spectrum::Rgb;
use rayon::prelude::*;
use std::f64::consts::{FRAC_PI_2, PI, TAU};

/// The h quadrature rule lives with the other rules; named here too, where lobes are averaged.
pub use crate::quadrature::h_rule;

/// A lat-long image of linear RGB values, rows top to bottom.
pub struct LobeImage {
    pub width: usize,
    pub height: usize,
    pub pixels: Vec<Rgb>,
}

impl LobeImage {
    /// Inclination of row `y`'s pixel centers.
    pub fn theta(&self, y: usize) -> f64 {
        FRAC_PI_2 - (y as f64 + 0.5) * PI / self.height as f64
    }

    /// Azimuth of column `x`'s pixel centers.
    pub fn phi(&self, x: usize) -> f64 {
        -PI + (x as f64 + 0.5) * TAU / self.width as f64
    }

    /// The midpoint-rule integral of the image over the sphere: sum pixel cos(theta) dtheta dphi.
    pub fn albedo(&self) -> Rgb {
        let cell = (PI / self.height as f64) * (TAU / self.width as f64);
        (0..self.height)
            .map(|y| {
                let row: Rgb = self.pixels[y * self.width..(y + 1) * self.width].iter().copied().sum();
                row * (self.theta(y).cos() * cell)
            })
            .sum()
    }
}

/// Renders the h-averaged lobe for a light (fixed direction) at inclination `theta`.
pub fn lobe_image(
    model: &impl FiberModel,
    theta: f64,
    width: usize,
    height: usize,
    h_rule: &[(f64, f64)],
) -> LobeImage {
    let mut image = LobeImage { width, height, pixels: vec![Rgb::ZERO; width * height] };
    let wo = direction(theta, 0.0);
    let (thetas, phis): (Vec<f64>, Vec<f64>) =
        ((0..height).map(|y| image.theta(y)).collect(), (0..width).map(|x| image.phi(x)).collect());
    image.pixels.par_chunks_mut(width).enumerate().for_each(|(y, row)| {
        let wis: Vec<_> = phis.iter().map(|&phi| direction(thetas[y], phi)).collect();
        model.eval_h_average(wo, h_rule, &wis, row);
    });
    image
}
