//! The shared resolve: how a pixel's fragments, in (depth, primitive) order, become a color.
//!
//! The GPU side is `shaders/shared/composite.wgsl`; this module holds its Rust twins and the
//! same compositing in f64 for the CPU reference:
//! - transparency: front to back, C += T·α·c, T *= 1 − α, then C += T·background;
//! - translucency: the same with Beer–Lambert attenuation exp(−σ·d) across each gap between
//!   consecutive fragments (d: view-space distance difference; σ of the object entered at the
//!   nearer fragment, else of the object left at the farther one) — Fresnel is already folded
//!   into each fragment's opacity by the shading;
//! - complexity: the fragment count (the heatmap is drawn from it);
//! - blend modes ([`Blend`], a material's `blend`): each fragment adds an emission and filters
//!   the RGB transmittance, over, add or multiply.

use bytemuck::{Pod, Zeroable};

use crate::keyword::keyword_enum;

keyword_enum! {
    /// How a fragment combines with what lies behind it, front to back, for linear color c and
    /// opacity α, with C the color so far and T an RGB transmittance starting at 1 (the picture is
    /// C + T·background):
    /// - over: C += T·α·c, then T ·= 1 − α;
    /// - add: C += T·α·c, T unchanged (glows, fire);
    /// - multiply: C unchanged, T ·= (1 − α) + α·c per channel (tinted glass, shadows).
    ///
    /// Every exact method honours all three (its resolve visits fragments in order); methods that
    /// cannot refuse a scene with add or multiply materials (see the method table).
    #[derive(Default, Hash)]
    #[cfg_attr(feature = "serde", derive(serde::Deserialize))]
    pub enum Blend ("blend") {
        /// The over operator.
        #[default]
        Over = "over",
        /// Additive: adds its light, hides nothing.
        Add = "add",
        /// Multiplicative: filters what lies behind by its color, adds no light.
        Multiply = "multiply",
    }
}

impl Blend {
    /// What a fragment of linear color `c` and opacity `a` in this mode adds (times the
    /// transmittance in front of it) and the factor its transmittance is multiplied by.
    pub fn emission_and_filter(self, c: [f64; 3], a: f64) -> ([f64; 3], [f64; 3]) {
        match self {
            Blend::Over => (c.map(|x| a * x), [1.0 - a; 3]),
            Blend::Add => (c.map(|x| a * x), [1.0; 3]),
            Blend::Multiply => ([0.0; 3], c.map(|x| 1.0 - a + a * x)),
        }
    }
}
/// The 16-byte fragment record. Keep in sync with `Fragment` in `shaders/shared/fragment.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq)]
pub struct Fragment {
    /// Window depth (0 near, 1 far).
    pub depth: f32,
    /// primitive index << 1 | front-facing bit
    pub tag: u32,
    /// f16 red, green
    pub rg: u32,
    /// f16 blue, alpha
    pub ba: u32,
}

/// Running front-to-back composite. Keep in sync with `Composite` in `composite.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct CompositeState {
    /// Premultiplied color composited so far.
    pub color: [f32; 3],
    /// Fragments composited so far.
    pub count: u32,
    /// What the fragments so far let through, per channel.
    pub transmittance: [f32; 3],
    /// Tag of the last fragment composited (translucency's entering and leaving surfaces).
    pub last_tag: u32,
    /// Depth of the last fragment composited.
    pub last_depth: f32,
    /// View distance of the last fragment composited (translucency's thickness).
    pub last_distance: f32,
    /// Padding to WGSL's 16-byte alignment.
    pub _pad: [u32; 2],
}

/// Bytes of one running composite in GPU storage (the peeling, convex and tiled methods keep
/// one or two per pixel).
pub const COMPOSITE_BYTES: u64 = std::mem::size_of::<CompositeState>() as u64;

/// One fragment as the CPU reference sees it, at full precision.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RefFragment {
    /// Window-space depth (0 near, 1 far).
    pub depth: f64,
    /// The scene's triangle index.
    pub prim: u32,
    /// Whether the triangle faces the camera.
    pub front_facing: bool,
    /// Linear RGB, not premultiplied.
    pub color: [f64; 3],
    /// Opacity.
    pub alpha: f64,
    /// Absorption σ of its material.
    pub absorption: f64,
    /// View-space distance along the view axis.
    pub distance: f64,
    /// The samples of its pixel it covers, bit i for sample i (`--msaa`; 1 single-sampled).
    /// One byte: 8 samples at most, and the record stays 64 bytes.
    pub coverage: u8,
    /// Its material's blend mode.
    pub blend: Blend,
}

impl RefFragment {
    /// The order every exact method follows: depth, then primitive index.
    pub fn order(a: &RefFragment, b: &RefFragment) -> std::cmp::Ordering {
        a.depth.total_cmp(&b.depth).then(a.prim.cmp(&b.prim))
    }
}

/// σ of the gap between two consecutive fragments (see the module docs).
pub fn gap_absorption(nearer: &RefFragment, farther: &RefFragment) -> f64 {
    if nearer.front_facing {
        nearer.absorption
    } else if !farther.front_facing {
        farther.absorption
    } else {
        0.0
    }
}

/// Composites depth-sorted fragments over a background, each by its blend mode: returns
/// linear RGB.
pub fn composite(sorted: &[RefFragment], background: [f64; 3], translucency: bool) -> [f64; 3] {
    let (color, t) = composite_parts(sorted, translucency);
    [0, 1, 2].map(|i| color[i] + t[i] * background[i])
}

/// The premultiplied color and RGB transmittance of depth-sorted fragments (front to back:
/// C += T·e, T ·= m, with each fragment's emission e and filter m of
/// [`Blend::emission_and_filter`]).
pub fn composite_parts(sorted: &[RefFragment], translucency: bool) -> ([f64; 3], [f64; 3]) {
    let mut color = [0.0f64; 3];
    let mut t = [1.0f64; 3];
    for (i, f) in sorted.iter().enumerate() {
        if translucency && i > 0 {
            let prev = &sorted[i - 1];
            let sigma = gap_absorption(prev, f);
            if sigma != 0.0 {
                let g = (-sigma * (f.distance - prev.distance).max(0.0)).exp();
                t = t.map(|x| x * g);
            }
        }
        let (emission, filter) = f.blend.emission_and_filter(f.color, f.alpha);
        for i in 0..3 {
            color[i] += t[i] * emission[i];
            t[i] *= filter[i];
        }
    }
    (color, t)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::assert_layout;

    #[test]
    fn fragment_and_composite_layout_match_wgsl() {
        assert_layout!(Fragment, 16, rg: 8);
        assert_layout!(CompositeState, 48, count: 12, transmittance: 16, last_tag: 28,
            last_distance: 36);
    }

    fn frag(depth: f64, alpha: f64, color: [f64; 3]) -> RefFragment {
        crate::testing::fragment(0, depth, alpha, color)
    }

    #[test]
    fn two_layers_composite_in_closed_form() {
        let a = frag(0.1, 0.5, [1.0, 0.0, 0.0]);
        let b = frag(0.2, 0.25, [0.0, 1.0, 0.0]);
        let c = composite(&[a, b], [0.0, 0.0, 1.0], false);
        assert!((c[0] - 0.5).abs() < 1e-12);
        assert!((c[1] - 0.5 * 0.25).abs() < 1e-12);
        assert!((c[2] - 0.5 * 0.75).abs() < 1e-12);
    }

    #[test]
    fn blend_modes_composite_as_defined() {
        let red = frag(0.1, 0.5, [1.0, 0.0, 0.0]);
        let green = frag(0.2, 0.25, [0.0, 1.0, 0.0]);
        let bg = [0.0, 0.0, 1.0];
        let with = |mut f: RefFragment, blend| {
            f.blend = blend;
            f
        };
        // add over nothing: the light adds and hides nothing.
        let c = composite(&[with(red, Blend::Add)], bg, false);
        assert_eq!(c, [0.5, 0.0, 1.0]);
        // multiply filters per channel by (1 − α) + α·c and adds no light.
        let c = composite(&[with(red, Blend::Multiply)], [1.0; 3], false);
        assert_eq!(c, [1.0, 0.5, 0.5]);
        // a multiply in front tints the over layer behind it; add behind it is seen through it.
        let c = composite(
            &[with(red, Blend::Multiply), green, with(red, Blend::Add)],
            bg,
            false,
        );
        let t = [1.0, 0.5, 0.5];
        let expect = [t[0] * 0.75 * 0.5, t[1] * 0.25, t[2] * 0.75 * 1.0];
        for i in 0..3 {
            assert!((c[i] - expect[i]).abs() < 1e-12, "{c:?} {expect:?}");
        }
    }

    #[test]
    fn absorption_applies_inside_entered_objects() {
        let mut enter = frag(0.1, 0.0, [0.0; 3]);
        enter.absorption = 2.0;
        enter.distance = 1.0;
        let mut leave = enter;
        leave.front_facing = false;
        leave.distance = 1.5;
        leave.depth = 0.2;
        let c = composite(&[enter, leave], [1.0; 3], true);
        assert!((c[0] - (-1.0f64).exp()).abs() < 1e-12);
        let c = composite(&[enter, leave], [1.0; 3], false);
        assert!((c[0] - 1.0).abs() < 1e-12);
    }
}
