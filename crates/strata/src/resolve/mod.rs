//! The shared resolve: how a pixel's fragments, in (depth, primitive) order, become a color.
//!
//! The GPU side is `shaders/shared/composite.wgsl`; this module holds its Rust twins and the
//! same compositing in f64 for the CPU reference:
//! - transparency: front to back, C += T·α·c, T *= 1 − α, then C += T·background;
//! - translucency: the same with Beer–Lambert attenuation exp(−σ·d) across each gap between
//!   consecutive fragments (d: view-space distance difference; σ of the object entered at the
//!   nearer fragment, else of the object left at the farther one) — Fresnel is already folded
//!   into each fragment's opacity by the shading;
//! - complexity: the fragment count (the heatmap is drawn from it).

use bytemuck::{Pod, Zeroable};

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
    /// What the fragments so far let through.
    pub transmittance: f32,
    /// Fragments composited so far.
    pub count: u32,
    /// Depth of the last fragment composited.
    pub last_depth: f32,
    /// Tag of the last fragment composited (translucency's entering and leaving surfaces).
    pub last_tag: u32,
    /// View distance of the last fragment composited (translucency's thickness).
    pub last_distance: f32,
}

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

/// Composites depth-sorted fragments over a background: returns linear RGB.
pub fn composite(sorted: &[RefFragment], background: [f64; 3], translucency: bool) -> [f64; 3] {
    let mut color = [0.0f64; 3];
    let mut t = 1.0f64;
    for (i, f) in sorted.iter().enumerate() {
        if translucency && i > 0 {
            let prev = &sorted[i - 1];
            let sigma = gap_absorption(prev, f);
            if sigma != 0.0 {
                t *= (-sigma * (f.distance - prev.distance).max(0.0)).exp();
            }
        }
        for (c, fc) in color.iter_mut().zip(f.color) {
            *c += t * f.alpha * fc;
        }
        t *= 1.0 - f.alpha;
    }
    [0, 1, 2].map(|i| color[i] + t * background[i])
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::mem::{offset_of, size_of};

    #[test]
    fn fragment_and_composite_layout_match_wgsl() {
        assert_eq!(size_of::<Fragment>(), 16);
        assert_eq!(offset_of!(Fragment, rg), 8);
        assert_eq!(size_of::<CompositeState>(), 32);
        assert_eq!(offset_of!(CompositeState, count), 16);
        assert_eq!(offset_of!(CompositeState, last_distance), 28);
    }

    fn frag(depth: f64, alpha: f64, color: [f64; 3]) -> RefFragment {
        RefFragment {
            depth,
            prim: 0,
            front_facing: true,
            color,
            alpha,
            absorption: 0.0,
            distance: depth,
            coverage: 1,
        }
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
