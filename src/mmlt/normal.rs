//! Standard normal numbers from random bits by Marsaglia and Tsang's ziggurat (2000): MMLT's
//! small steps. Box–Muller took two more hashes, a logarithm and a cosine per dimension read, a
//! fifth of MMLT's time on the bathroom; here 99% of the numbers cost a table lookup and a
//! multiply, and the distribution is still exactly the normal one (BENCHMARKS.md, "MMLT's small
//! step").
//!
//! The area under e^(−x²/2), x ≥ 0, is cut into `LAYERS` horizontal layers of equal area: layer
//! i ≥ 1 is the box [0, x_i] × [f(x_i), f(x_(i+1))], layer 0 the box under f(r) out to r plus
//! the tail beyond r. A uniform point of a random layer is accepted at once when it lies left of
//! the next layer's edge, which is under the curve; otherwise the curve is tested, or, in layer
//! 0, a tail number drawn (Marsaglia's tail method).

use crate::rng::{mix64, to_unit_f32};
use std::sync::LazyLock;

const LAYERS: usize = 128;
/// Where the tail starts, and each layer's area, for 128 layers (Marsaglia and Tsang).
const R: f64 = 3.442_619_855_899;
const AREA: f64 = 9.912_563_035_262_17e-3;

/// Layer i's right edge `x[i]` (layer 0's as if it were a box of the layers' area) and the
/// curve there, `f[i]`; `x[LAYERS]` = 0.
struct Table {
    x: [f32; LAYERS + 1],
    f: [f32; LAYERS + 1],
}

fn curve(x: f64) -> f64 {
    (-0.5 * x * x).exp()
}

static TABLE: LazyLock<Table> = LazyLock::new(|| {
    let mut x = [0.0f64; LAYERS + 1];
    x[0] = AREA / curve(R);
    x[1] = R;
    for i in 1..LAYERS - 1 {
        // Layer i's area x_i·(f(x_(i+1)) − f(x_i)) is AREA.
        x[i + 1] = (-2.0 * (AREA / x[i] + curve(x[i])).ln()).sqrt();
    }
    Table {
        x: x.map(|v| v as f32),
        f: x.map(|v| curve(v) as f32),
    }
});

/// A standard normal number from 64 random bits. The first try takes 32 of them (layer, sign,
/// position) and is accepted 99% of the time, so it is inlined into MMLT's primary-sample read;
/// only where it fails does `ziggurat` run, which makes that try again and the rare further
/// ones, drawn from hashes of `bits`.
#[inline(always)]
pub fn normal(bits: u64) -> f32 {
    match one_try(bits) {
        Ok(z) => z,
        Err(_) => ziggurat(bits),
    }
}

/// One try from bits `b`: the signed number where the point lies left of the next layer's
/// edge, else its layer, sign and position for the test beyond it.
#[inline(always)]
fn one_try(b: u64) -> Result<f32, (usize, f32, f32)> {
    let t = &*TABLE;
    let layer = (b & (LAYERS as u64 - 1)) as usize;
    let sign = if b & 128 == 0 { 1.0 } else { -1.0 };
    let z = to_unit_f32(b << 32) * t.x[layer];
    if z < t.x[layer + 1] {
        Ok(sign * z)
    } else {
        Err((layer, sign, z))
    }
}

/// The whole method: tries until one is accepted, each past the layer's edge tested against
/// the curve, or in layer 0 answered by a tail number (Marsaglia's tail method).
#[cold]
fn ziggurat(bits: u64) -> f32 {
    let t = &*TABLE;
    let (mut b, mut attempt) = (bits, 0u64);
    loop {
        attempt += 1;
        let (layer, sign, z) = match one_try(b) {
            Ok(z) => return z,
            Err(rest) => rest,
        };
        let more = mix64(bits ^ attempt.wrapping_mul(0x9e37_79b9_7f4a_7c15));
        let (u1, u2) = (to_unit_f32(more), to_unit_f32(more << 24));
        if layer == 0 {
            // The tail beyond R: R + a with a exponential of rate R, kept with probability
            // e^(−a²/2).
            let a = -(1.0 - u1).ln() / R as f32;
            if -2.0 * (1.0 - u2).ln() > a * a {
                return sign * (R as f32 + a);
            }
        } else {
            let y = t.f[layer] + u1 * (t.f[layer + 1] - t.f[layer]);
            if y < (-0.5 * z * z).exp() {
                return sign * z;
            }
        }
        b = mix64(more);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Rng;

    #[test]
    fn the_layers_close_at_zero_with_equal_areas() {
        let t = &*TABLE;
        // Layer 0, the box under f(R) and the tail beyond it (√(2π)·Q(R), Q(R) = 2.8805e-4 for
        // the normal distribution), holds AREA: R and AREA belong together.
        let base = R * curve(R) + (2.0 * std::f64::consts::PI).sqrt() * 2.8805e-4;
        assert!((base / AREA - 1.0).abs() < 1e-3, "{base}");
        // The recurrence ends where the curve is 1: the top layer, out to x[LAYERS − 1] from
        // 0, holds AREA too.
        assert!(
            t.x[LAYERS - 1] > 0.0 && t.x[LAYERS - 1] < 0.3,
            "{}",
            t.x[LAYERS - 1]
        );
        let top = t.x[LAYERS - 1] as f64 * (1.0 - t.f[LAYERS - 1] as f64);
        assert!((top / AREA - 1.0).abs() < 1e-3, "{top}");
    }

    #[test]
    fn numbers_follow_the_normal_distribution() {
        let mut r = Rng::new(8, 0, 0);
        let n = 4_000_000;
        let v: Vec<f64> = (0..n).map(|_| normal(r.next_u64()) as f64).collect();
        let mean = v.iter().sum::<f64>() / n as f64;
        let var = v.iter().map(|x| x * x).sum::<f64>() / n as f64;
        let kurt = v.iter().map(|x| x.powi(4)).sum::<f64>() / n as f64;
        assert!(
            mean.abs() < 0.003 && (var - 1.0).abs() < 0.005,
            "{mean} {var}"
        );
        assert!((kurt - 3.0).abs() < 0.03, "{kurt}");
        // Φ at a few points (tables), the tail and the wedges included.
        for (z, phi) in [
            (-3.0, 0.001_350),
            (-1.0, 0.158_655),
            (0.5, 0.691_462),
            (2.0, 0.977_250),
            (3.5, 0.999_767),
        ] {
            let p = v.iter().filter(|&&x| x < z).count() as f64 / n as f64;
            let se = (phi * (1.0 - phi) / n as f64).sqrt();
            assert!((p - phi).abs() < 5.0 * se, "Φ({z}) {p} against {phi}");
        }
        // The tail beyond R: its mass, and its mean excess over R, 0.2547 (σ 0.2415) for the
        // normal distribution (0.29 = 1/R for an exponential tail without the rejection).
        let tail: Vec<f64> = v
            .iter()
            .filter(|x| x.abs() > R)
            .map(|x| x.abs() - R)
            .collect();
        let (mass, k) = (2.0 * 2.8805e-4, tail.len() as f64);
        assert!(
            (k / n as f64 - mass).abs() < 5.0 * (mass / n as f64).sqrt(),
            "{k}"
        );
        let excess = tail.iter().sum::<f64>() / k;
        assert!(
            (excess - 0.2547).abs() < 4.0 * 0.2415 / k.sqrt(),
            "{excess}"
        );
    }
}
