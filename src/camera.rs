//! A pinhole camera.

use glam::{DVec3, Vec3};

/// Perspective camera; pixel (0, 0) is the top-left corner of the image.
#[derive(Clone, Debug)]
pub struct Camera {
    pub width: usize,
    pub height: usize,
    position: DVec3,
    forward: DVec3,
    /// Image-plane axes at unit distance, each spanning half the image.
    right: DVec3,
    up: DVec3,
}

impl Camera {
    /// `fov_deg` is the vertical field of view; `up` need not be orthogonal to the view direction.
    pub fn new(position: DVec3, look_at: DVec3, up: DVec3, fov_deg: f64, width: usize, height: usize) -> Camera {
        let forward = (look_at - position).normalize();
        let right = forward.cross(up).normalize();
        let up = right.cross(forward);
        let half_h = (0.5 * fov_deg.to_radians()).tan();
        let half_w = half_h * width as f64 / height as f64;
        Camera { width, height, position, forward, right: right * half_w, up: up * half_h }
    }

    /// Frames a bounding box: looks at its center from the -Y side (the front of a Z-up head), far
    /// enough that the bounding sphere fits the narrower field of view with a 5% margin.
    pub fn framing(min: Vec3, max: Vec3, fov_deg: f64, width: usize, height: usize) -> Camera {
        let (min, max) = (min.as_dvec3(), max.as_dvec3());
        let center = 0.5 * (min + max);
        let radius = 0.5 * (max - min).length();
        let half_v = 0.5 * fov_deg.to_radians();
        let half_narrow = if width >= height { half_v } else { (half_v.tan() * width as f64 / height as f64).atan() };
        let distance = 1.05 * radius / half_narrow.sin();
        Camera::new(center - DVec3::Y * distance, center, DVec3::Z, fov_deg, width, height)
    }

    /// Where the camera is (its pinhole).
    pub fn position(&self) -> DVec3 {
        self.position
    }

    /// Position, a point it looks at (one unit ahead) and its up vector (unit, orthogonal to the
    /// view direction): what `camera.position`, `camera.look_at` and `camera.up` resolve to.
    pub fn orientation(&self) -> (DVec3, DVec3, DVec3) {
        (self.position, self.position + self.forward, self.up.normalize())
    }

    /// Width of a pixel at `distance` from the camera, in scene units.
    pub fn pixel_width(&self, distance: f64) -> f64 {
        2.0 * self.up.length() * distance / self.height as f64
    }

    /// Ray through the continuous pixel position (x right, y down): origin and unit direction.
    pub fn ray(&self, x: f64, y: f64) -> (Vec3, DVec3) {
        let sx = 2.0 * x / self.width as f64 - 1.0;
        let sy = 1.0 - 2.0 * y / self.height as f64;
        (self.position.as_vec3(), (self.forward + self.right * sx + self.up * sy).normalize())
    }
}
