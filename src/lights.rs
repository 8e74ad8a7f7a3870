//! Area lights: every emissive triangle, chosen in proportion to its power (luminance of the
//! emitted radiance × area) and then uniformly by area.

use crate::math::{Rgb, Vec2, Vec3, luminance, uniform_triangle};

#[derive(Clone, Debug)]
pub struct Lights {
    /// Triangle index of each light.
    pub tris: Vec<u32>,
    /// Selection probability of each light.
    pub pmf: Vec<f32>,
    cdf: Vec<f32>,
    /// Light index of each scene triangle, or `u32::MAX`.
    light_of_tri: Vec<u32>,
    pub total_power: f32,
}

/// A point sampled on a light.
#[derive(Clone, Copy, Debug)]
pub struct LightSample {
    pub p: Vec3,
    pub n: Vec3,
    pub le: Rgb,
    /// Density with respect to area, selection included.
    pub pdf_area: f32,
    pub tri: u32,
}

/// What the light sampler needs to know about one triangle.
pub struct EmitterTri {
    pub p: [Vec3; 3],
    pub n: Vec3,
    pub area: f32,
    pub le: Rgb,
}

impl Lights {
    /// `emission(i)` gives triangle i's emitted radiance (zero if it does not emit).
    pub fn new(n_tris: usize, emitter: impl Fn(usize) -> Option<(f32, Rgb)>) -> Lights {
        let mut tris = Vec::new();
        let mut power = Vec::new();
        let mut light_of_tri = vec![u32::MAX; n_tris];
        for (i, slot) in light_of_tri.iter_mut().enumerate() {
            if let Some((area, le)) = emitter(i) {
                let p = luminance(le) * area;
                if p > 0.0 {
                    *slot = tris.len() as u32;
                    tris.push(i as u32);
                    power.push(p);
                }
            }
        }
        let total: f32 = power.iter().sum();
        let pmf: Vec<f32> = power.iter().map(|p| p / total).collect();
        let mut acc = 0.0;
        let cdf = pmf
            .iter()
            .map(|p| {
                acc += p;
                acc
            })
            .collect();
        Lights {
            tris,
            pmf,
            cdf,
            light_of_tri,
            total_power: total * std::f32::consts::PI,
        }
    }

    pub fn is_empty(&self) -> bool {
        self.tris.is_empty()
    }

    /// Choose a light by power; returns its index and probability.
    pub fn choose(&self, u: f32) -> (usize, f32) {
        let i = self
            .cdf
            .partition_point(|&c| c <= u)
            .min(self.tris.len() - 1);
        (i, self.pmf[i])
    }

    /// Area density (selection included) of sampling a point on triangle `tri`, or 0 if it
    /// is not a light.
    pub fn pdf_area(&self, tri: u32, area: f32) -> f32 {
        match self.light_of_tri.get(tri as usize) {
            Some(&l) if l != u32::MAX => self.pmf[l as usize] / area,
            _ => 0.0,
        }
    }

    /// Sample a point on the lights; `emitter` describes the chosen triangle.
    pub fn sample(
        &self,
        u_select: f32,
        u: Vec2,
        emitter: impl Fn(u32) -> EmitterTri,
    ) -> LightSample {
        let (i, prob) = self.choose(u_select);
        let tri = self.tris[i];
        let e = emitter(tri);
        let (b1, b2) = uniform_triangle(u);
        let p = e.p[0] * (1.0 - b1 - b2) + e.p[1] * b1 + e.p[2] * b2;
        LightSample {
            p,
            n: e.n,
            le: e.le,
            pdf_area: prob / e.area,
            tri,
        }
    }
}
