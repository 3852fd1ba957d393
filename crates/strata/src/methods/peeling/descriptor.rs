//! The peeling methods' entries in the method table (kpeel's is in `kbuffer`, with its code).

use crate::methods::options::K;
use crate::methods::table::{Descriptor, Family, Setup, Support};

use super::options::{BUCKETS, LAYERS};
use crate::methods::traffic::TrafficModel;
use crate::methods::{Method, MethodId};

type Made = crate::error::Result<Box<dyn Method>>;

// Each entry's builder makes its own method.
fn f2b(_: MethodId, made: &Setup<'_>) -> Made {
    let (gpu, scene, options) = (made.gpu, made.scene, made.options);
    let triangles = scene.triangle_count as u64;
    if options.build.msaa > 1 && triangles > super::F2B_MSAA_MAX_TRIANGLES {
        return Err(crate::error::Error::unsupported(format!(
            "f2b --msaa {} takes at most {} triangles (its layer's tag travels as an exact float, as 32-bit integer targets cannot be multisampled); the scene has {triangles}",
            options.build.msaa,
            super::F2B_MSAA_MAX_TRIANGLES
        )));
    }
    Ok(Box::new(super::FrontToBack::new(gpu, scene)?))
}

fn dual(_: MethodId, made: &Setup<'_>) -> Made {
    Ok(Box::new(super::Dual::new(made.gpu, made.scene)?))
}

fn bucket(_: MethodId, made: &Setup<'_>) -> Made {
    Ok(Box::new(super::bucket::Bucket::new(made.gpu, made.scene)?))
}

/// `f2b`.
pub const F2B: Descriptor = Descriptor {
    exact: true,
    geometry_passes: "N (the last frame's depth complexity, or --layers)",
    memory: "72·W·H",
    summary: "front-to-back depth peeling, one layer per geometry pass",
    reads: &[LAYERS],
    // Ties peel in draw order.
    takes_order: false,
    downlevel: true,
    app_shaders: Support::Yes,
    ..Descriptor::new(MethodId::F2b, "f2b", Family::Peeling, f2b)
};

/// `dual`.
pub const DUAL: Descriptor = Descriptor {
    exact: true,
    geometry_passes: "ceil(N/2)+1 (N: the last frame's depth complexity, or --layers)",
    memory: "172·W·H with 64-bit atomics, else 156·W·H",
    summary: "dual depth peeling: nearest and farthest layer per pass; exact with ties given 64-bit atomic min/max (else fragments at exactly equal depth in one pixel collapse and are counted as dropped)",
    reads: &[LAYERS],
    compute_raster: Support::Yes,
    app_shaders: Support::Yes,
    traffic: TrafficModel::PerPixelState {
        atomic_per_fragment: true,
    },
    ..Descriptor::new(MethodId::Dual, "dual", Family::Peeling, dual)
};

/// `bucket`.
pub const BUCKET: Descriptor = Descriptor {
    needs: wgpu::Features::FLOAT32_BLENDABLE,
    exact_without_drops: true,
    geometry_passes: "3 (4 with --buckets adaptive)",
    memory: "(16·k + 16·ceil(k/4) + 16)·W·H + 16, +128·W·H with --buckets adaptive; with --msaa S: (S·(16·k + 16·ceil(k/4) + 4) + 8·S + 16)·W·H + 16; k even, at most 32 and 4 × the color targets the device blends at once",
    summary: "bucket depth peeling (Liu et al. 2009): each pixel's depth range split into k/2 buckets (uniform, or adaptive: shared among the occupied parts of a 1024-part histogram), every bucket's nearest and farthest depth kept by MAX blending into ceil(k/4) RGBA32F targets in one geometry pass, colors claimed in a second; a third fragment in a bucket collides and is counted as dropped",
    reads: &[K, BUCKETS],
    past_k: Some("collided in buckets that already held two and were dropped; a larger even --k splits each pixel's depth range finer"),
    max_k: super::bucket::MAX_SLOTS,
    traffic: TrafficModel::Bucket,
    app_shaders: Support::Yes,
    ..Descriptor::new(MethodId::Bucket, "bucket", Family::Peeling, bucket)
};
