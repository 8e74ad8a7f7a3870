//! The pinhole camera: rays through raster positions, and for light tracing the inverse map and
//! the importance function.

use crate::math::Vec3;

#[derive(Clone, Debug)]
pub struct Camera {
    pub position: Vec3,
    pub forward: Vec3,
    pub right: Vec3,
    pub up: Vec3,
    /// tan of half the vertical and horizontal field of view.
    pub tan_half_y: f32,
    pub tan_half_x: f32,
    pub width: u32,
    pub height: u32,
    /// The look-at point, up vector and vertical field of view (degrees) it was made from, so
    /// that an exporter hands on the numbers it was given: recomputing them from the frame above
    /// changes their last bits, and a re-imported scene would no longer be the same scene.
    pub look_at: Vec3,
    pub up_given: Vec3,
    pub fov_y_given: f32,
}

impl Camera {
    pub fn new(
        position: Vec3,
        look_at: Vec3,
        up: Vec3,
        fov_y_deg: f32,
        width: u32,
        height: u32,
    ) -> Camera {
        let up_in = up;
        let forward = (look_at - position).normalize();
        // Right-handed, y up: with the camera looking down +z, screen right is −x.
        let right = forward.cross(up).normalize();
        let up = right.cross(forward);
        let tan_half_y = (fov_y_deg.to_radians() * 0.5).tan();
        let tan_half_x = tan_half_y * width as f32 / height as f32;
        Camera {
            position,
            forward,
            right,
            up,
            tan_half_y,
            tan_half_x,
            width,
            height,
            look_at,
            up_given: up_in,
            fov_y_given: fov_y_deg,
        }
    }

    /// The vertical field of view in degrees, as the OMC header records it for the mask's
    /// depth rule.
    pub fn fov_y_deg(&self) -> f64 {
        2.0 * (self.tan_half_y as f64).atan().to_degrees()
    }

    /// Unit direction through continuous raster position (x right, y down, pixels of size 1).
    pub fn ray_dir(&self, x: f32, y: f32) -> Vec3 {
        let sx = (2.0 * x / self.width as f32 - 1.0) * self.tan_half_x;
        let sy = (1.0 - 2.0 * y / self.height as f32) * self.tan_half_y;
        (self.forward + self.right * sx + self.up * sy).normalize()
    }

    /// Raster position of a world direction from the camera, if it falls on the film.
    pub fn raster(&self, dir: Vec3) -> Option<(f32, f32)> {
        let z = dir.dot(self.forward);
        if z <= 0.0 {
            return None;
        }
        let sx = dir.dot(self.right) / z / self.tan_half_x;
        let sy = dir.dot(self.up) / z / self.tan_half_y;
        let x = (sx + 1.0) * 0.5 * self.width as f32;
        let y = (1.0 - sy) * 0.5 * self.height as f32;
        (x >= 0.0 && x < self.width as f32 && y >= 0.0 && y < self.height as f32).then_some((x, y))
    }

    /// Area of the film rectangle on the plane at distance 1.
    pub fn film_area(&self) -> f32 {
        4.0 * self.tan_half_x * self.tan_half_y
    }

    /// Importance W_e for a direction with cosine `cos` to the view axis, normalised so that one
    /// pixel's importance integrates to 1 (pbrt's PerspectiveCamera::We, pinhole, summed over
    /// the film: per-pixel splats multiply by the pixel count).
    pub fn importance(&self, cos: f32) -> f32 {
        if cos <= 0.0 {
            return 0.0;
        }
        1.0 / (self.film_area() * cos * cos * cos * cos)
    }

    /// Solid-angle density of the camera's ray directions (uniform over the film).
    pub fn pdf_dir(&self, cos: f32) -> f32 {
        if cos <= 0.0 {
            return 0.0;
        }
        1.0 / (self.film_area() * cos * cos * cos)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn raster_inverts_ray_dir() {
        let c = Camera::new(
            Vec3::new(1.0, 2.0, -5.0),
            Vec3::new(1.0, 2.0, 0.0),
            Vec3::Y,
            40.0,
            64,
            48,
        );
        for (x, y) in [(0.5, 0.5), (10.25, 30.75), (63.9, 47.9), (32.0, 24.0)] {
            let (rx, ry) = c.raster(c.ray_dir(x, y)).unwrap();
            assert!((rx - x).abs() < 1e-3 && (ry - y).abs() < 1e-3);
        }
        // Looking down +z with y up, the image's right is −x; its top is +y.
        assert!(c.ray_dir(63.0, 24.0).x < 0.0 && c.ray_dir(32.0, 0.0).y > 0.0);
    }
}
