//! Small geometric helpers on top of `glam`: the colour type, orthonormal frames and luminance.

pub use glam::{Vec2, Vec3};

/// Linear RGB radiance or throughput.
pub type Rgb = Vec3;

pub const PI: f32 = std::f32::consts::PI;
pub const INV_PI: f32 = std::f32::consts::FRAC_1_PI;

/// Rec. 709 luminance: the scalar the MCMC target and light selection use (DESIGN §3).
#[inline]
pub fn luminance(c: Rgb) -> f32 {
    0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z
}

/// An orthonormal basis around a normal, for working in the local shading frame where the
/// normal is +z.
#[derive(Clone, Copy, Debug)]
pub struct Frame {
    pub s: Vec3,
    pub t: Vec3,
    pub n: Vec3,
}

impl Frame {
    /// Duff et al. 2017, "Building an orthonormal basis, revisited": branchless and continuous
    /// except at one point, so neighbouring pixels get consistent frames.
    pub fn new(n: Vec3) -> Self {
        let sign = 1.0f32.copysign(n.z);
        let a = -1.0 / (sign + n.z);
        let b = n.x * n.y * a;
        let s = Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
        let t = Vec3::new(b, sign + n.y * n.y * a, -n.y);
        Frame { s, t, n }
    }

    #[inline]
    pub fn to_local(&self, v: Vec3) -> Vec3 {
        Vec3::new(v.dot(self.s), v.dot(self.t), v.dot(self.n))
    }

    #[inline]
    pub fn to_world(&self, v: Vec3) -> Vec3 {
        self.s * v.x + self.t * v.y + self.n * v.z
    }
}

/// Cosine-weighted hemisphere direction (local frame, +z up) from a uniform 2D sample,
/// via the concentric disk mapping (low distortion keeps stratification).
pub fn cosine_hemisphere(u: Vec2) -> Vec3 {
    let d = concentric_disk(u);
    let z = (1.0 - d.x * d.x - d.y * d.y).max(0.0).sqrt();
    Vec3::new(d.x, d.y, z)
}

/// Shirley–Chiu concentric mapping of the unit square onto the unit disk.
pub fn concentric_disk(u: Vec2) -> Vec2 {
    let o = 2.0 * u - Vec2::ONE;
    if o.x == 0.0 && o.y == 0.0 {
        return Vec2::ZERO;
    }
    // θ = (π/4)·(y/x), or π/2 − (π/4)·(x/y), whose cosine and sine are the sine and cosine of
    // (π/4)·(x/y): either way an angle within ±π/4. Chosen by selects, not a branch: which case
    // applies is a coin flip the branch predictor loses half the time.
    let x_major = o.x.abs() > o.y.abs();
    let (r, other) = if x_major { (o.x, o.y) } else { (o.y, o.x) };
    let (sin, cos) = sin_cos_quarter((PI / 4.0) * (other / r));
    let (cx, cy) = if x_major { (cos, sin) } else { (sin, cos) };
    r * Vec2::new(cx, cy)
}

/// sin a and cos a for |a| ≤ π/4, by their Taylor series to a⁹ and a¹⁰ (truncation below 2e-9,
/// under f32's rounding): no library call and no range reduction, which cost the path tracer
/// ~4% of its time in `sincosf`. Plain multiplies and adds, so every machine rounds alike.
fn sin_cos_quarter(a: f32) -> (f32, f32) {
    let a2 = a * a;
    let sin = a + a
        * a2
        * (-1.0 / 6.0 + a2 * (1.0 / 120.0 + a2 * (-1.0 / 5040.0 + a2 * (1.0 / 362_880.0))));
    let cos = 1.0
        + a2 * (-0.5
            + a2 * (1.0 / 24.0
                + a2 * (-1.0 / 720.0 + a2 * (1.0 / 40_320.0 + a2 * (-1.0 / 3_628_800.0)))));
    (sin, cos)
}

/// Uniform point on a triangle as barycentrics (b1, b2), Heitz 2019's low-distortion square
/// mapping would do too; the classic sqrt mapping is enough here.
pub fn uniform_triangle(u: Vec2) -> (f32, f32) {
    let su = u.x.sqrt();
    (1.0 - su, u.y * su)
}

/// True if every component is finite (rejects NaN and ±inf from scene files and AOVs).
pub fn is_finite3(v: Vec3) -> bool {
    v.x.is_finite() && v.y.is_finite() && v.z.is_finite()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frame_is_orthonormal() {
        for n in [
            Vec3::Z,
            -Vec3::Z,
            Vec3::X,
            Vec3::new(0.3, -0.5, 0.8).normalize(),
        ] {
            let f = Frame::new(n);
            assert!(f.s.dot(f.t).abs() < 1e-5 && f.s.dot(f.n).abs() < 1e-5);
            assert!((f.s.length() - 1.0).abs() < 1e-5 && (f.t.length() - 1.0).abs() < 1e-5);
            let v = Vec3::new(0.2, 0.7, -0.1);
            assert!((f.to_world(f.to_local(v)) - v).length() < 1e-5);
        }
    }

    #[test]
    fn quarter_sin_cos_match_the_library() {
        for i in 0..=1000 {
            let a = (i as f32 / 500.0 - 1.0) * PI / 4.0;
            let (s, c) = sin_cos_quarter(a);
            assert!(
                (s - a.sin()).abs() < 2e-7 && (c - a.cos()).abs() < 2e-7,
                "{a}: {s} {c}"
            );
        }
    }

    #[test]
    fn cosine_hemisphere_is_unit_and_upper() {
        for i in 0..100 {
            let u = Vec2::new((i as f32 + 0.5) / 100.0, ((i * 37) % 100) as f32 / 100.0);
            let w = cosine_hemisphere(u);
            assert!((w.length() - 1.0).abs() < 1e-4 && w.z >= 0.0);
        }
    }
}
