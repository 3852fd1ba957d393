//! CPU twins of the G-buffer's normal encodings (`deferred_common.wgsl`) and of the tone map
//! (`tonemap.wgsl`), with the quantization the G-buffer's formats apply. The twins let tests bound
//! the encodings' error over every direction without a GPU, and let exact mode tone-map on the
//! CPU what it read back.

use glam::{DVec2, DVec3};

use super::{NormalEncoding, Tonemap};

/// Levels of a 10-bit unorm channel (RGB10A2).
pub const UNORM10_MAX: f64 = 1023.0;

/// Encodes a unit view-space normal into two values in [0, 1].
pub fn encode(encoding: NormalEncoding, n: DVec3) -> DVec2 {
    match encoding {
        // Seed 004's spheremap transform (Lambert azimuthal): singular only at n.z = −1, which
        // a normal turned towards the viewer does not reach.
        NormalEncoding::Spheremap => {
            let s = (8.0 * n.z + 8.0).max(1e-12).sqrt();
            n.truncate() / s + DVec2::splat(0.5)
        }
        NormalEncoding::Octahedral => {
            let p = n.truncate() / (n.x.abs() + n.y.abs() + n.z.abs());
            let folded = if n.z < 0.0 {
                (DVec2::ONE - DVec2::new(p.y.abs(), p.x.abs())) * sign_not_zero(p)
            } else {
                p
            };
            folded * 0.5 + DVec2::splat(0.5)
        }
    }
}

/// The inverse of [`encode`] (a unit vector for any input).
pub fn decode(encoding: NormalEncoding, e: DVec2) -> DVec3 {
    match encoding {
        NormalEncoding::Spheremap => {
            let fenc = e * 4.0 - DVec2::splat(2.0);
            let f = fenc.dot(fenc);
            let g = (1.0 - f / 4.0).max(0.0).sqrt();
            DVec3::new(fenc.x * g, fenc.y * g, 1.0 - f / 2.0).normalize()
        }
        NormalEncoding::Octahedral => {
            let f = e * 2.0 - DVec2::ONE;
            let z = 1.0 - f.x.abs() - f.y.abs();
            let xy = if z < 0.0 {
                (DVec2::ONE - DVec2::new(f.y.abs(), f.x.abs())) * sign_not_zero(f)
            } else {
                f
            };
            DVec3::new(xy.x, xy.y, z).normalize()
        }
    }
}

fn sign_not_zero(v: DVec2) -> DVec2 {
    DVec2::new(
        if v.x >= 0.0 { 1.0 } else { -1.0 },
        if v.y >= 0.0 { 1.0 } else { -1.0 },
    )
}

/// A value in [0, 1] stored in a 10-bit unorm channel and read back.
pub fn quantize10(x: f64) -> f64 {
    (x.clamp(0.0, 1.0) * UNORM10_MAX).round() / UNORM10_MAX
}

/// The normal the G-buffer gives back for `n`: encoded, stored in two 10-bit channels, decoded.
pub fn round_trip(encoding: NormalEncoding, n: DVec3) -> DVec3 {
    let e = encode(encoding, n);
    decode(encoding, DVec2::new(quantize10(e.x), quantize10(e.y)))
}

/// Angle between two unit vectors, in degrees.
pub fn angle_deg(a: DVec3, b: DVec3) -> f64 {
    a.dot(b).clamp(-1.0, 1.0).acos().to_degrees()
}

/// Channels below this pass the neutral tone map unchanged.
pub const NEUTRAL_KNEE: f64 = 0.8;
/// How far the neutral tone map blends compressed highlights towards white.
pub const NEUTRAL_DESATURATION: f64 = 0.15;

/// The tone map of the lit pipelines; the twin of `tone_map` in tonemap.wgsl.
pub fn tone_map(tonemap: Tonemap, c: [f64; 3]) -> [f64; 3] {
    match tonemap {
        Tonemap::None => c,
        Tonemap::Reinhard => c.map(|x| x / (1.0 + x)),
        // Khronos PBR Neutral's highlight compression without its toe: colors whose largest
        // channel is below the knee pass unchanged (unlit materials and the background keep
        // their values); above it the peak rolls off towards 1 and blends towards white.
        Tonemap::Neutral => {
            let peak = c[0].max(c[1]).max(c[2]);
            if peak < NEUTRAL_KNEE {
                return c;
            }
            let d = 1.0 - NEUTRAL_KNEE;
            let new_peak = 1.0 - d * d / (peak + d - NEUTRAL_KNEE);
            let g = 1.0 - 1.0 / (NEUTRAL_DESATURATION * (peak - new_peak) + 1.0);
            c.map(|x| {
                let scaled = x * new_peak / peak;
                scaled + (new_peak - scaled) * g
            })
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// Directions on a Fibonacci sphere: `count` points spread evenly over every direction.
    fn sphere(count: usize) -> impl Iterator<Item = DVec3> {
        let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
        (0..count).map(move |i| {
            let z = 1.0 - 2.0 * (i as f64 + 0.5) / count as f64;
            let r = (1.0 - z * z).sqrt();
            let phi = golden * i as f64;
            DVec3::new(r * phi.cos(), r * phi.sin(), z)
        })
    }

    fn max_error(encoding: NormalEncoding, min_z: f64) -> f64 {
        sphere(200_000)
            .filter(|n| n.z >= min_z)
            .map(|n| angle_deg(n, round_trip(encoding, n)))
            .fold(0.0, f64::max)
    }

    // Bounds: the maxima measured over 200 000 directions, rounded up. A normal the G-buffer
    // stores faces the viewer, so in view space z ≥ −sin θ for θ the half-diagonal field of view:
    // −0.5 for a square 45° view, −0.75 for a 97° diagonal. The spheremap's step grows towards
    // z = −1, where it is singular: 0.217° over z ≥ 0, 0.299° over z ≥ −0.5, 0.419° over
    // z ≥ −0.75. Octahedral: 0.235° over the whole sphere.
    #[test]
    fn spheremap_error_is_below_its_bound_on_the_directions_the_gbuffer_stores() {
        let front = max_error(NormalEncoding::Spheremap, 0.0);
        let wide = max_error(NormalEncoding::Spheremap, -0.75);
        let square_45 = max_error(NormalEncoding::Spheremap, -0.5);
        assert!(front < 0.22, "spheremap, z ≥ 0: {front}°");
        assert!(square_45 < 0.30, "spheremap, z ≥ −0.5: {square_45}°");
        assert!(wide < 0.42, "spheremap, z ≥ −0.75: {wide}°");
    }

    #[test]
    fn octahedral_error_is_below_its_bound_on_the_whole_sphere() {
        let all = max_error(NormalEncoding::Octahedral, -1.0);
        assert!(all < 0.24, "octahedral: {all}°");
    }

    #[test]
    fn encodings_are_exact_before_quantization() {
        for encoding in [NormalEncoding::Spheremap, NormalEncoding::Octahedral] {
            for n in sphere(5000).filter(|n| n.z > -0.99) {
                let back = decode(encoding, encode(encoding, n));
                assert!(angle_deg(n, back) < 1e-5, "{encoding:?} {n}");
                let e = encode(encoding, n);
                assert!((0.0..=1.0).contains(&e.x) && (0.0..=1.0).contains(&e.y));
            }
        }
    }

    proptest! {
        #[test]
        fn neutral_tone_map_keeps_low_colors_and_stays_below_one(
            r in 0.0f64..50.0, g in 0.0f64..50.0, b in 0.0f64..50.0
        ) {
            let out = tone_map(Tonemap::Neutral, [r, g, b]);
            let peak = r.max(g).max(b);
            if peak < NEUTRAL_KNEE {
                prop_assert_eq!(out, [r, g, b]);
            }
            for x in out {
                prop_assert!((0.0..1.0).contains(&x), "{:?} -> {:?}", [r, g, b], out);
            }
            // Brighter in, brighter out.
            let brighter = tone_map(Tonemap::Neutral, [r * 1.5, g * 1.5, b * 1.5]);
            prop_assert!(brighter.iter().sum::<f64>() >= out.iter().sum::<f64>() - 1e-12);
        }
    }

    #[test]
    fn neutral_tone_map_is_continuous_at_the_knee() {
        let below = tone_map(Tonemap::Neutral, [NEUTRAL_KNEE - 1e-9, 0.2, 0.1]);
        let above = tone_map(Tonemap::Neutral, [NEUTRAL_KNEE + 1e-9, 0.2, 0.1]);
        for (a, b) in below.iter().zip(above) {
            assert!((a - b).abs() < 1e-6);
        }
    }
}
