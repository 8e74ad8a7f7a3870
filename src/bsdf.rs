//! The four materials' scattering functions (DESIGN §4). All work in a local frame around the
//! geometric normal; opaque materials shade both sides, glass uses the normal's side to tell
//! entering from leaving. Values follow pbrt's convention: `f` without the cosine, and for delta
//! lobes `f·|cos|/pdf` is the path weight.

use crate::math::{Frame, INV_PI, PI, Rgb, Vec2, Vec3, cosine_hemisphere};

/// Whether a path carries radiance (from the camera) or importance (from a light). Refraction
/// scales radiance by 1/η² but not importance (Veach's thesis §5.2), so light and camera paths
/// must say which they are.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mode {
    Radiance,
    Importance,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Bsdf {
    Diffuse {
        albedo: Rgb,
    },
    Mirror {
        reflectance: Rgb,
    },
    /// Smooth dielectric; `eta` is the inside's index over the outside's (outside is vacuum).
    Glass {
        eta: f32,
        transmittance: Rgb,
    },
    /// GGX microfacet reflector with perfect (F = 1) Fresnel, like Mitsuba's `roughconductor`
    /// with `material=none`; `alpha` is GGX α.
    Glossy {
        reflectance: Rgb,
        alpha: f32,
    },
}

/// A sampled direction.
#[derive(Clone, Copy, Debug)]
pub struct BsdfSample {
    pub wi: Vec3,
    pub f: Rgb,
    pub pdf: f32,
    /// Density of sampling `wo` given `wi` (0 for delta lobes): the reverse density a
    /// bidirectional walk stores at each vertex.
    pub pdf_rev: f32,
    pub delta: bool,
    /// Relative index crossed (η_t/η_i of a refraction, 1 otherwise).
    pub eta: f32,
}

/// `Bsdf::evaluate`'s result.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Evaluated {
    pub f: Rgb,
    pub pdf: f32,
    pub pdf_rev: f32,
}

impl Evaluated {
    pub const ZERO: Evaluated = Evaluated {
        f: Rgb::ZERO,
        pdf: 0.0,
        pdf_rev: 0.0,
    };
}

impl BsdfSample {
    /// The throughput factor `f·|cos θi| / pdf`.
    pub fn weight(&self, ng: Vec3) -> Rgb {
        self.f * (self.wi.dot(ng).abs() / self.pdf)
    }
}

impl Bsdf {
    /// Delta lobes cannot be hit by connections or light sampling.
    pub fn is_delta(&self) -> bool {
        matches!(self, Bsdf::Mirror { .. } | Bsdf::Glass { .. })
    }

    /// Reflectance for the G-buffer's `albedo` AOV.
    pub fn albedo(&self) -> Rgb {
        match *self {
            Bsdf::Diffuse { albedo } => albedo,
            Bsdf::Mirror { reflectance } | Bsdf::Glossy { reflectance, .. } => reflectance,
            Bsdf::Glass { transmittance, .. } => transmittance,
        }
    }

    /// `f(wo, wi)` (no cosine) and the solid-angle densities of sampling `wi` given `wo`
    /// (`pdf`) and `wo` given `wi` (`pdf_rev`): a bidirectional connection needs all three at
    /// each of its ends, next-event estimation the first two. Zero for delta lobes. Every lobe
    /// here depends only on cosines with the normal and the half vector, which are the same in
    /// any frame, so no local frame is built: a connection evaluates two of these, and the frame
    /// (a division and four dot products) was most of a diffuse evaluation.
    pub fn evaluate(&self, ng: Vec3, wo: Vec3, wi: Vec3) -> Evaluated {
        // Two-sided: the side wo is on counts as the outside.
        let wo_n = wo.dot(ng);
        let side = if wo_n < 0.0 { -1.0 } else { 1.0 };
        let (cos_o, cos_i) = (side * wo_n, side * wi.dot(ng));
        if cos_o <= 0.0 || cos_i <= 0.0 {
            return Evaluated::ZERO;
        }
        match *self {
            Bsdf::Diffuse { albedo } => Evaluated {
                f: albedo * INV_PI,
                pdf: cos_i * INV_PI,
                pdf_rev: cos_o * INV_PI,
            },
            Bsdf::Glossy { reflectance, alpha } => {
                let h = (wo + wi).normalize();
                let d = ggx_d(side * h.dot(ng), alpha);
                let (g1o, g1i) = (
                    smith_g1(cos_o, wo.dot(h), alpha),
                    smith_g1(cos_i, wi.dot(h), alpha),
                );
                Evaluated {
                    f: reflectance * (d * g1o * g1i / (4.0 * cos_o * cos_i)),
                    pdf: g1o * d / (4.0 * cos_o),
                    pdf_rev: g1i * d / (4.0 * cos_i),
                }
            }
            Bsdf::Mirror { .. } | Bsdf::Glass { .. } => Evaluated::ZERO,
        }
    }

    /// Sample `wi` given `wo` with a 2D sample `u` and a lobe-choice sample `uc`.
    pub fn sample(&self, ng: Vec3, wo: Vec3, u: Vec2, uc: f32, mode: Mode) -> Option<BsdfSample> {
        let frame = Frame::new(ng);
        let lo = frame.to_local(wo);
        if lo.z == 0.0 {
            return None;
        }
        // Opaque materials: work on wo's side (two-sided shading), flip back at the end.
        let side = lo.z.signum();
        let o = Vec3::new(lo.x, lo.y, lo.z * side);
        let to_world = |v: Vec3| frame.to_world(Vec3::new(v.x, v.y, v.z * side));
        match *self {
            Bsdf::Diffuse { albedo } => {
                let i = cosine_hemisphere(u);
                if i.z <= 0.0 {
                    return None;
                }
                Some(BsdfSample {
                    wi: to_world(i),
                    f: albedo * INV_PI,
                    pdf: i.z * INV_PI,
                    pdf_rev: o.z * INV_PI,
                    delta: false,
                    eta: 1.0,
                })
            }
            Bsdf::Mirror { reflectance } => {
                let i = Vec3::new(-o.x, -o.y, o.z);
                Some(BsdfSample {
                    wi: to_world(i),
                    f: reflectance / i.z,
                    pdf: 1.0,
                    pdf_rev: 0.0,
                    delta: true,
                    eta: 1.0,
                })
            }
            Bsdf::Glossy { reflectance, alpha } => {
                let h = sample_ggx_vndf(o, alpha, u);
                let i = 2.0 * o.dot(h) * h - o;
                if i.z <= 0.0 {
                    return None;
                }
                let d = ggx_d(h.z, alpha);
                let (g1o, g1i) = (
                    smith_g1(o.z, o.dot(h), alpha),
                    smith_g1(i.z, i.dot(h), alpha),
                );
                let pdf = g1o * d / (4.0 * o.z);
                let f = reflectance * (d * g1o * g1i / (4.0 * o.z * i.z));
                if pdf <= 0.0 || !pdf.is_finite() {
                    return None;
                }
                Some(BsdfSample {
                    wi: to_world(i),
                    f,
                    pdf,
                    pdf_rev: g1i * d / (4.0 * i.z),
                    delta: false,
                    eta: 1.0,
                })
            }
            Bsdf::Glass { eta, transmittance } => {
                // Relative index across the interface in the direction of travel of `wo`'s side.
                let etap = if lo.z > 0.0 { eta } else { 1.0 / eta };
                let cos_o = lo.z.abs();
                let (fr, cos_t) = fresnel_dielectric(cos_o, etap);
                if uc < fr {
                    let i = Vec3::new(-lo.x, -lo.y, lo.z);
                    Some(BsdfSample {
                        wi: frame.to_world(i),
                        f: Rgb::splat(fr / cos_o),
                        pdf: fr,
                        pdf_rev: 0.0,
                        delta: true,
                        eta: 1.0,
                    })
                } else {
                    let i = Vec3::new(-lo.x / etap, -lo.y / etap, -side * cos_t);
                    let scale = if mode == Mode::Radiance {
                        1.0 / (etap * etap)
                    } else {
                        1.0
                    };
                    let f = transmittance * ((1.0 - fr) * scale / cos_t);
                    Some(BsdfSample {
                        wi: frame.to_world(i).normalize(),
                        f,
                        pdf: 1.0 - fr,
                        pdf_rev: 0.0,
                        delta: true,
                        eta: etap,
                    })
                }
            }
        }
    }
}

/// Unpolarised Fresnel reflectance of a smooth dielectric for incident cosine `cos_i` ≥ 0 and
/// relative index `eta` (transmitted over incident). Returns (F, cos θt); F = 1 on total
/// internal reflection.
pub fn fresnel_dielectric(cos_i: f32, eta: f32) -> (f32, f32) {
    let sin2_t = (1.0 - cos_i * cos_i).max(0.0) / (eta * eta);
    if sin2_t >= 1.0 {
        return (1.0, 0.0);
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    let rs = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    let rp = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    (0.5 * (rs * rs + rp * rp), cos_t)
}

/// GGX normal distribution D(h) of a half vector whose cosine with the normal is `cos_h`.
fn ggx_d(cos_h: f32, alpha: f32) -> f32 {
    if cos_h <= 0.0 {
        return 0.0;
    }
    let a2 = alpha * alpha;
    let t = cos_h * cos_h * (a2 - 1.0) + 1.0;
    a2 / (PI * t * t)
}

/// Smith's masking for GGX of a direction v, from its cosines with the normal (`cos_v`) and the
/// half vector (`v_dot_h`); separable G = G1(wo)·G1(wi) as in Mitsuba 3.
fn smith_g1(cos_v: f32, v_dot_h: f32, alpha: f32) -> f32 {
    if v_dot_h * cos_v <= 0.0 {
        return 0.0;
    }
    let tan2 = (1.0 - cos_v * cos_v).max(0.0) / (cos_v * cos_v);
    2.0 / (1.0 + (1.0 + alpha * alpha * tan2).sqrt())
}

/// Heitz 2018, "Sampling the GGX distribution of visible normals": samples h with density
/// G1(wo)·max(0, wo·h)·D(h)/wo.z.
fn sample_ggx_vndf(wo: Vec3, alpha: f32, u: Vec2) -> Vec3 {
    let vh = Vec3::new(alpha * wo.x, alpha * wo.y, wo.z).normalize();
    let lensq = vh.x * vh.x + vh.y * vh.y;
    let t1 = if lensq > 0.0 {
        Vec3::new(-vh.y, vh.x, 0.0) / lensq.sqrt()
    } else {
        Vec3::X
    };
    let t2 = vh.cross(t1);
    let r = u.x.sqrt();
    let phi = 2.0 * PI * u.y;
    let p1 = r * phi.cos();
    let s = 0.5 * (1.0 + vh.z);
    let p2 = (1.0 - s) * (1.0 - p1 * p1).max(0.0).sqrt() + s * r * phi.sin();
    let nh = p1 * t1 + p2 * t2 + (1.0 - p1 * p1 - p2 * p2).max(0.0).sqrt() * vh;
    Vec3::new(alpha * nh.x, alpha * nh.y, nh.z.max(1e-6)).normalize()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::{Rng, Sampler};

    /// Monte Carlo estimate of the directional albedo ∫ f cos dωi by importance sampling, and of
    /// ∫ pdf dωi by uniform sphere sampling (must be ≤ 1, = 1 for lossless lobes).
    fn albedo_and_pdf_mass(b: &Bsdf, wo: Vec3, n: u32) -> (Rgb, f32) {
        let ng = Vec3::Z;
        let mut rng = Rng::new(1, 2, 3);
        let mut alb = Rgb::ZERO;
        let mut mass = 0.0;
        for _ in 0..n {
            if let Some(s) = b.sample(ng, wo, rng.next_2d(), rng.next_1d(), Mode::Radiance) {
                alb += s.weight(ng);
                if !s.delta {
                    // evaluate must agree with what sample returned, both ways.
                    let e = b.evaluate(ng, wo, s.wi);
                    assert!(
                        (e.f - s.f).abs().max_element() <= 1e-3 * e.f.max_element().max(1.0),
                        "{} vs {}",
                        e.f,
                        s.f
                    );
                    assert!((e.pdf - s.pdf).abs() <= 1e-3 * s.pdf.max(1.0));
                    assert!((e.pdf_rev - s.pdf_rev).abs() <= 1e-3 * s.pdf_rev.max(1.0));
                    // Reciprocity: swapping the directions swaps the densities.
                    let r = b.evaluate(ng, s.wi, wo);
                    assert!((r.pdf - e.pdf_rev).abs() <= 1e-4 * e.pdf_rev.max(1.0));
                    assert!((r.f - e.f).abs().max_element() <= 1e-4 * e.f.max_element().max(1.0));
                }
            }
            let u = rng.next_2d();
            let z = 1.0 - 2.0 * u.x;
            let r = (1.0 - z * z).max(0.0).sqrt();
            let w = Vec3::new(r * (2.0 * PI * u.y).cos(), r * (2.0 * PI * u.y).sin(), z);
            mass += b.evaluate(ng, wo, w).pdf * 4.0 * PI;
        }
        (alb / n as f32, mass / n as f32)
    }

    #[test]
    fn diffuse_albedo_and_pdf() {
        let b = Bsdf::Diffuse {
            albedo: Rgb::splat(0.5),
        };
        let (a, m) = albedo_and_pdf_mass(&b, Vec3::new(0.3, 0.1, 0.9).normalize(), 200_000);
        assert!(
            (a.x - 0.5).abs() < 1e-3 && (m - 1.0).abs() < 0.02,
            "{a} {m}"
        );
        // Two-sided: from below it reflects below.
        let (a, _) = albedo_and_pdf_mass(&b, Vec3::new(0.3, 0.1, -0.9).normalize(), 10_000);
        assert!((a.x - 0.5).abs() < 1e-3);
    }

    /// ∫ f(wo, wi) cos θi dωi by midpoint quadrature over the upper hemisphere.
    fn albedo_quadrature(b: &Bsdf, wo: Vec3) -> f32 {
        let n = 400;
        let mut sum = 0.0f64;
        for i in 0..n {
            let th = (i as f32 + 0.5) / n as f32 * PI / 2.0;
            for j in 0..2 * n {
                let ph = (j as f32 + 0.5) / (2 * n) as f32 * 2.0 * PI;
                let wi = Vec3::new(th.sin() * ph.cos(), th.sin() * ph.sin(), th.cos());
                let d_omega = th.sin() * (PI / 2.0 / n as f32) * (PI / n as f32);
                sum += (b.evaluate(Vec3::Z, wo, wi).f.x * wi.z * d_omega) as f64;
            }
        }
        sum as f32
    }

    #[test]
    fn glossy_sampling_matches_its_integral() {
        for alpha in [0.1, 0.3, 0.6] {
            let b = Bsdf::Glossy {
                reflectance: Rgb::ONE,
                alpha,
            };
            let wo = Vec3::new(0.5, 0.0, 0.8).normalize();
            let (a, m) = albedo_and_pdf_mass(&b, wo, 200_000);
            let q = albedo_quadrature(&b, wo);
            assert!(
                a.x <= 1.0 + 1e-3 && (a.x - q).abs() < 0.01 * q,
                "alpha {alpha}: sampled {a}, quadrature {q}"
            );
            assert!(m <= 1.02 && m > 0.7, "alpha {alpha}: pdf mass {m}");
        }
    }

    /// The other tests evaluate around +z only. `evaluate` works in world space, so a lobe must
    /// give the same values around any normal, and from either side of it (two-sided).
    #[test]
    fn evaluation_is_the_same_around_any_normal_and_from_either_side() {
        let lobes = [
            Bsdf::Diffuse {
                albedo: Rgb::splat(0.5),
            },
            Bsdf::Glossy {
                reflectance: Rgb::new(0.9, 0.6, 0.3),
                alpha: 0.3,
            },
        ];
        let mut rng = Rng::new(4, 5, 6);
        let mut compared = 0;
        for b in &lobes {
            for _ in 0..2000 {
                let uniform = |rng: &mut Rng| {
                    let z = 1.0 - 2.0 * rng.next_1d();
                    let (r, phi) = ((1.0 - z * z).max(0.0).sqrt(), 2.0 * PI * rng.next_1d());
                    Vec3::new(r * phi.cos(), r * phi.sin(), z)
                };
                let (wo, wi, n) = (uniform(&mut rng), uniform(&mut rng), uniform(&mut rng));
                // Directions this close to the surface can change side by rounding.
                if wo.z.abs() < 1e-2 || wi.z.abs() < 1e-2 {
                    continue;
                }
                let want = b.evaluate(Vec3::Z, wo, wi);
                let frame = Frame::new(n);
                let (wo_n, wi_n) = (frame.to_world(wo), frame.to_world(wi));
                for ng in [n, -n] {
                    let got = b.evaluate(ng, wo_n, wi_n);
                    let close = |a: f32, b: f32| (a - b).abs() <= 1e-4 * a.abs().max(b.abs());
                    assert!(
                        (0..3).all(|c| close(got.f[c], want.f[c]))
                            && close(got.pdf, want.pdf)
                            && close(got.pdf_rev, want.pdf_rev),
                        "{b:?} n {ng}: {got:?} against {want:?}"
                    );
                }
                compared += (want.pdf > 0.0) as usize;
            }
        }
        assert!(compared > 1500, "only {compared} non-zero evaluations");
    }

    #[test]
    fn glass_reflects_and_refracts_by_fresnel() {
        let b = Bsdf::Glass {
            eta: 1.5,
            transmittance: Rgb::ONE,
        };
        // Normal incidence: F = ((1.5-1)/(1.5+1))^2 = 0.04; importance is conserved exactly.
        let (f, _) = fresnel_dielectric(1.0, 1.5);
        assert!((f - 0.04).abs() < 1e-6);
        let mut rng = Rng::new(0, 0, 0);
        let mut refl = 0;
        let n = 100_000;
        for _ in 0..n {
            let s = b
                .sample(
                    Vec3::Z,
                    Vec3::Z,
                    rng.next_2d(),
                    rng.next_1d(),
                    Mode::Importance,
                )
                .unwrap();
            if s.wi.z > 0.0 {
                refl += 1;
                assert!((s.weight(Vec3::Z).x - 1.0).abs() < 1e-5);
            } else {
                assert!(
                    (s.wi + Vec3::Z).length() < 1e-5 && (s.weight(Vec3::Z).x - 1.0).abs() < 1e-5
                );
            }
        }
        assert!((refl as f32 / n as f32 - 0.04).abs() < 0.003);
        // Radiance entering glass is divided by η².
        let s = b
            .sample(Vec3::Z, Vec3::Z, Vec2::ZERO, 0.99, Mode::Radiance)
            .unwrap();
        assert!((s.weight(Vec3::Z).x - 1.0 / 2.25).abs() < 1e-5);
        // Total internal reflection from inside at grazing angles.
        let wo = Vec3::new(0.9, 0.0, -0.2).normalize();
        let s = b
            .sample(Vec3::Z, wo, Vec2::ZERO, 0.999, Mode::Radiance)
            .unwrap();
        assert!(s.wi.z < 0.0 && (s.weight(Vec3::Z).x - 1.0).abs() < 1e-5);
    }

    #[test]
    fn refraction_obeys_snell() {
        let b = Bsdf::Glass {
            eta: 1.33,
            transmittance: Rgb::ONE,
        };
        let wo = Vec3::new(0.6, 0.0, 0.8);
        let s = b
            .sample(Vec3::Z, wo, Vec2::ZERO, 0.9999, Mode::Radiance)
            .unwrap();
        let sin_o = wo.x;
        let sin_i = (s.wi.x * s.wi.x + s.wi.y * s.wi.y).sqrt();
        assert!((sin_o - 1.33 * sin_i).abs() < 1e-5 && s.wi.z < 0.0 && s.wi.x < 0.0);
    }
}
