//! `bucket` against its CPU twin and the reference, on lavapipe; the twin's properties.

use crate::methods::peeling::PeelingOptions;
use proptest::prelude::*;

use super::*;
use crate::frame::{Effect, RenderOptions};
use crate::methods::peeling::BucketSplit;
use crate::render::LinearImage;
use crate::scene::{loaders, Scene};
use crate::testing::{
    assert_close, assert_exact, render_gpu, render_reference, EXACT_MAX_DIFF, EXACT_MAX_FRACTION,
};

/// The tolerance of the exact methods' tests (methods/tests.rs): lavapipe's f32 edge and depth
/// equations against the reference's exact ones.
use crate::methods::kbuffer::tests::{options, reference_fragments_at_device_depths};

/// The reference's fragments at the depths and samples the device's rasterizer gave them (read
/// back through `abuffer-ll`: the twin must route what the GPU routes, and a depth on a bucket
/// boundary rounds differently on every rasterizer), cut by the twin: each pixel keeps what
/// [`select_samples`] keeps (visited in depth-then-primitive order), each sample composites what
/// it kept over the background, and the samples are averaged. Returns the picture, the
/// fragments some sample kept, and the fragments only one of the reference and the device has
/// (coverage at pixel centres on an edge).
fn twin_picture(scene: &Scene, opts: &RenderOptions, slots: u32) -> (LinearImage, u64, u64) {
    let at = reference_fragments_at_device_depths(scene, opts);
    let (lists, unmatched) = (at.lists, at.unmatched);
    let translucency = opts.frame.effect == Effect::Translucency;
    let samples = opts.build.msaa.max(1);
    let mut kept_total = 0;
    let pixels = lists
        .iter()
        .enumerate()
        .map(|(i, list)| {
            let (x, y) = (i as u32 % opts.frame.width, i as u32 / opts.frame.width);
            let depths: Vec<f32> = list.iter().map(|f| f.depth as f32).collect();
            let coverage: Vec<u32> = list.iter().map(|f| f.coverage as u32).collect();
            let kept = select_samples(
                &depths,
                &coverage,
                samples,
                slots,
                opts.frame.family::<PeelingOptions>().buckets,
            );
            let bg = opts.frame.background.at(x, y).map(|c| c as f64);
            let mut sum = [0.0f64; 3];
            for s in 0..samples {
                let own: Vec<_> = list
                    .iter()
                    .zip(&kept)
                    .filter(|(_, k)| *k >> s & 1 == 1)
                    .map(|(f, _)| *f)
                    .collect();
                let c = crate::resolve::composite(&own, bg, translucency);
                sum = std::array::from_fn(|j| sum[j] + c[j] / samples as f64);
            }
            let count = kept.iter().filter(|k| **k != 0).count();
            kept_total += count as u64;
            [sum[0] as f32, sum[1] as f32, sum[2] as f32, count as f32]
        })
        .collect();
    let image = LinearImage {
        width: opts.frame.width,
        height: opts.frame.height,
        pixels,
    };
    (image, kept_total, unmatched)
}

/// Renders `bucket` and checks its picture and kept count against the twin's (at the device's
/// own fragment depths, so exactly: a difference is a fault of `bucket`, not rounding); its
/// statistics.
fn bucket_against_its_twin(name: &str, s: &Scene, opts: &RenderOptions) -> crate::FrameStats {
    let k = opts.frame.k.expect("bucket tests give k");
    let (expected, kept, unmatched) = twin_picture(s, opts, k);
    let (actual, stats) = render_gpu(s, opts, "bucket");
    let generated = stats.fragments_generated.unwrap();
    // Coverage at pixel centres on an edge may differ between a rasterizer and the reference's
    // exact rules (module docs of methods/tests.rs): within the exact tests' 0.1%.
    assert!(
        unmatched as f64 <= generated as f64 * EXACT_MAX_FRACTION,
        "{name}: {unmatched} fragments only the reference or only the device has"
    );
    assert_close(
        name,
        &actual,
        &expected,
        opts.frame.effect,
        EXACT_MAX_DIFF,
        if unmatched == 0 {
            0.0
        } else {
            EXACT_MAX_FRACTION
        },
    );
    let stored = stats.fragments_stored.unwrap();
    let off = stored.abs_diff(kept) as f64 / generated as f64;
    assert!(
        off <= if unmatched == 0 {
            0.0
        } else {
            EXACT_MAX_FRACTION
        },
        "{name}: kept {stored}, twin {kept}"
    );
    stats
}

/// Renders `bucket` and checks it against the full reference; its statistics.
fn bucket_against_the_reference(name: &str, s: &Scene, opts: &RenderOptions) -> crate::FrameStats {
    let (actual, stats) = render_gpu(s, opts, "bucket");
    let expected = render_reference(s, opts);
    assert_exact(name, &actual, &expected, opts.frame.effect);
    stats
}

fn scene(spec: &str) -> Scene {
    loaders::load_scene(spec).unwrap()
}

#[test]
fn stages_and_the_uniforms_validate() {
    crate::gpu::twin::assert_twin::<BucketParams>();
    for samples in [1, 4] {
        for stage in stages(samples) {
            crate::gpu::shader::validate(&stage);
        }
    }
    for layers in 1..=8 {
        crate::gpu::shader::validate(&sort_stage(layers));
    }
}

/// Fragments clustered in depth collide, fewer with the adaptive split: the GPU keeps what the
/// twin keeps, with both splits.
#[test]
fn bucket_keeps_what_its_cpu_twin_keeps() {
    for (spec, size, k, split) in [
        (
            "builtin:layers?n=16&coverage=0.75&order=random&seed=3",
            64,
            8,
            BucketSplit::Uniform,
        ),
        ("builtin:spheres?layers=8", 64, 4, BucketSplit::Uniform),
        ("builtin:spheres?layers=8", 64, 4, BucketSplit::Adaptive),
        (
            "builtin:nvpro?objects=48&subdiv=10&seed=4",
            48,
            6,
            BucketSplit::Uniform,
        ),
        (
            "builtin:nvpro?objects=48&subdiv=10&seed=4",
            48,
            6,
            BucketSplit::Adaptive,
        ),
    ] {
        let s = scene(spec);
        let mut opts = options(size, k);
        opts.frame.family_mut::<PeelingOptions>().buckets = split;
        let stats = bucket_against_its_twin(&format!("bucket-twin-k{k}"), &s, &opts);
        assert!(
            stats.fragments_dropped.unwrap() > 0,
            "{spec}: the test wants collisions"
        );
        let passes = if split == BucketSplit::Adaptive { 4 } else { 3 };
        assert_eq!(stats.geometry_passes, passes);
    }
}

/// --msaa 4: each sample keeps its own two fragments per bucket (the routing is the pixel's);
/// the GPU keeps what the twin keeps, counted once per fragment, with both splits, and a
/// half-covered edge pixel gets half its layer.
#[test]
fn multisampled_bucket_keeps_what_its_cpu_twin_keeps() {
    for (spec, k, split) in [
        ("builtin:spheres?layers=8", 4, BucketSplit::Uniform),
        ("builtin:spheres?layers=8", 8, BucketSplit::Adaptive),
        (
            "builtin:nvpro?objects=48&subdiv=10&seed=4",
            6,
            BucketSplit::Uniform,
        ),
    ] {
        let s = scene(spec);
        let mut opts = options(48, k);
        opts.build.msaa = 4;
        opts.frame.family_mut::<PeelingOptions>().buckets = split;
        let name = format!("bucket-msaa-{}-k{k}", split.name());
        let stats = bucket_against_its_twin(&name, &s, &opts);
        assert_eq!(stats.bytes_allocated, frame_bytes(48 * 48, k, split, 4));
    }
}

/// With enough buckets nothing collides, and the frame is the reference's exactly, translucency
/// included.
#[test]
fn without_collisions_bucket_equals_the_reference() {
    let s = scene("builtin:spheres?layers=8");
    let mut opts = options(64, 32);
    opts.frame.effect = Effect::Translucency;
    let stats = bucket_against_the_reference("bucket-exact", &s, &opts);
    assert_eq!(stats.fragments_dropped, Some(0));
}

/// Nested shells crowd a pixel's fragments into part of its depth range: at k = 8 uniform
/// buckets collide, while the adaptive split gives every occupied part a bucket and keeps all
/// eight layers, equal to the reference.
#[test]
fn the_adaptive_split_keeps_what_uniform_buckets_lose() {
    let s = scene("builtin:spheres?layers=8");
    let mut opts = options(64, 8);
    let (_, uniform) = render_gpu(&s, &opts, "bucket");
    assert!(uniform.fragments_dropped.unwrap() > 0);
    opts.frame.family_mut::<PeelingOptions>().buckets = BucketSplit::Adaptive;
    let adaptive = bucket_against_the_reference("bucket-adaptive", &s, &opts);
    assert_eq!(adaptive.fragments_dropped, Some(0));
    assert_eq!(adaptive.geometry_passes, 4);
    assert_eq!(
        adaptive.bytes_allocated,
        frame_bytes(64 * 64, 8, BucketSplit::Adaptive, 1)
    );
}

/// The histogram, claims and counts are cleared before anything reads them.
#[test]
fn poisoned_storage_changes_nothing_with_the_adaptive_split() {
    let mut opts = crate::methods::tests::options(40, Effect::Translucency);
    opts.frame.k = Some(6);
    opts.frame.family_mut::<PeelingOptions>().buckets = BucketSplit::Adaptive;
    crate::methods::tests::check_poisoned(&opts, [crate::MethodId::Bucket].into_iter());
}

/// Coincident faces: two fragments at exactly one depth are a bucket's nearest and farthest at
/// once and keep both slots, composited in primitive order like the reference; a third at that
/// depth collides and is counted.
#[test]
fn coincident_faces_keep_two_slots_and_drop_the_third() {
    let mut s = scene("builtin:layers?n=4&coverage=1&order=front");
    s.objects[1].mesh.positions = s.objects[0].mesh.positions.clone();
    let opts = options(24, 8);
    let stats = bucket_against_the_reference("bucket-coincident", &s, &opts);
    assert_eq!(stats.fragments_dropped, Some(0));
    s.objects[2].mesh.positions = s.objects[0].mesh.positions.clone();
    let (_, stats) = render_gpu(&s, &opts, "bucket");
    assert_eq!(stats.fragments_dropped, Some(24 * 24));
}

#[test]
fn bad_k_and_compute_raster_are_refused() {
    let s = scene("builtin:layers?n=4&coverage=1&order=front");
    let mut r = crate::Renderer::new(crate::testing::gpu(), &s, &options(16, 16)).unwrap();
    assert!(r.render("bucket").is_ok());
    for k in [0, 1, 7, 34] {
        let mut r = crate::Renderer::new(crate::testing::gpu(), &s, &options(16, k)).unwrap();
        let e = r.render("bucket").unwrap_err();
        assert!(
            matches!(e, crate::Error::Input(_)) && e.to_string().contains("--k"),
            "{k}: {e}"
        );
    }
    let mut opts = options(16, 8);
    opts.build.raster = crate::raster::Raster::Compute;
    let e = crate::Renderer::new(crate::testing::gpu(), &s, &opts)
        .and_then(|mut r| r.render("bucket").map(|_| ()))
        .unwrap_err();
    assert!(e.to_string().contains("--raster compute"), "{e}");
}

#[test]
fn device_limits_bound_the_slots() {
    let mut limits = wgpu::Limits::default();
    let e = slots_of(Some(16), &limits).unwrap_err();
    assert!(
        matches!(e, crate::Error::Unsupported(_)) && e.to_string().contains("--k 8"),
        "{e}"
    );
    assert_eq!(slots_of(Some(8), &limits).unwrap(), 8);
    // WebGPU's defaults: 32 bytes per sample, two RGBA32F targets.
    assert_eq!(device_max_slots(&limits), 8);
    limits.max_color_attachment_bytes_per_sample = 128;
    assert_eq!(device_max_slots(&limits), 32);
    limits.max_color_attachments = 4;
    assert_eq!(device_max_slots(&limits), 16);
    assert_eq!(target_layers(2), 1);
    assert_eq!(target_layers(6), 2);
    assert_eq!(target_layers(32), 8);
    assert_eq!(
        frame_bytes(10, 8, BucketSplit::Uniform, 1),
        10 * (8 + 32 + 8 + 128) + 16
    );
    assert_eq!(
        frame_bytes(10, 8, BucketSplit::Adaptive, 1),
        10 * (8 + 32 + 8 + 128 + 128) + 16
    );
    // --msaa 4: targets, claims and records per sample, the samples' bounds, two counts.
    assert_eq!(
        frame_bytes(10, 8, BucketSplit::Uniform, 4),
        10 * (8 + 4 + 4 * 8 + 4 + 4 * (32 + 4 + 128)) + 16
    );
}

const U: BucketSplit = BucketSplit::Uniform;
const A: BucketSplit = BucketSplit::Adaptive;

#[test]
fn select_examples() {
    // Two fragments always fit: the range's ends.
    assert_eq!(select(&[0.5, 0.2], 2, U), [true, true]);
    // One bucket: its nearest and farthest survive, the middle collides.
    assert_eq!(select(&[0.5, 0.2, 0.3], 2, U), [true, true, false]);
    // Two buckets over [0.2, 0.6]: 0.3 shares the first with 0.2, 0.5 the second with 0.6.
    assert_eq!(select(&[0.2, 0.3, 0.5, 0.6], 4, U), [true; 4]);
    // Equal depths: two take both ends of their bucket, a third collides.
    assert_eq!(select(&[0.4, 0.4, 0.4], 8, U), [true, true, false]);
    assert!(select(&[], 8, U).is_empty());
    // Clustered depths: uniform buckets over the range put 0.1, 0.11 and 0.12 into the first
    // bucket (one collides); the adaptive split gives each occupied part its own.
    let clustered = [0.1, 0.11, 0.12, 1.0 - f32::EPSILON];
    assert_eq!(select(&clustered, 4, U), [true, false, true, true]);
    assert_eq!(select(&clustered, 8, A), [true; 4]);
    assert_eq!(select(&clustered, 8, U), [true, false, true, true]);
}

/// A pixel's fragment depths from random 24-bit fractions, with their nearest and farthest.
fn pixel_depths(raw: &[u32]) -> (Vec<f32>, f32, f32) {
    let depths: Vec<f32> = raw
        .iter()
        .map(|&r| r as f32 / (1u32 << 24) as f32)
        .collect();
    let nearest = depths.iter().copied().fold(f32::INFINITY, f32::min);
    let farthest = depths.iter().copied().fold(f32::NEG_INFINITY, f32::max);
    (depths, nearest, farthest)
}

/// `select` of `depths` with k = 2 × `half`, which keeps at most k.
fn select_at_most_k(
    depths: &[f32],
    half: u32,
    split: BucketSplit,
) -> std::result::Result<Vec<bool>, TestCaseError> {
    let kept = select(depths, 2 * half, split);
    prop_assert!(kept.iter().filter(|k| **k).count() <= 2 * half as usize);
    Ok(kept)
}

/// A pixel's 1 to 39 random 24-bit depth fractions (see [`pixel_depths`]), and half a k of 2
/// to 32.
fn raw_depths_and_half_k() -> impl Strategy<Value = (Vec<u32>, u32)> {
    (prop::collection::vec(0u32..1 << 24, 1..40), 1u32..=16)
}

proptest! {
    /// Each bucket keeps at most two; the pixel's nearest and farthest always survive; a pixel
    /// whose buckets hold at most two each keeps everything; what survives of a bucket is its
    /// nearest and its farthest.
    #[test]
    fn select_keeps_each_buckets_ends((raw, half) in raw_depths_and_half_k()) {
        let (depths, nearest, farthest) = pixel_depths(&raw);
        let kept = select_at_most_k(&depths, half, U)?;
        prop_assert!(depths.iter().zip(&kept).any(|(&z, &k)| k && z == nearest));
        prop_assert!(depths.iter().zip(&kept).any(|(&z, &k)| k && z == farthest));
        // Group by bucket with an independent float computation of the same fixed point.
        let fixed = |z: f32| (z as f64 * 2147483648.0).floor() as u64;
        let (lo, hi) = (fixed(nearest), fixed(farthest));
        let width = (hi - lo) / half as u64 + 1;
        let bucket = |z: f32| ((fixed(z) - lo) / width).min(half as u64 - 1);
        for b in 0..half as u64 {
            let members: Vec<(f32, bool)> = depths
                .iter()
                .zip(&kept)
                .filter(|(&z, _)| bucket(z) == b)
                .map(|(&z, &k)| (z, k))
                .collect();
            let survivors: Vec<f32> = members.iter().filter(|m| m.1).map(|m| m.0).collect();
            prop_assert!(survivors.len() <= 2);
            if members.len() <= 2 {
                prop_assert_eq!(survivors.len(), members.len());
            } else {
                let near = members.iter().map(|m| m.0).fold(f32::INFINITY, f32::min);
                let far = members.iter().map(|m| m.0).fold(f32::NEG_INFINITY, f32::max);
                prop_assert!(survivors.contains(&near) && survivors.contains(&far));
            }
        }
    }

    /// The adaptive split gives the parts holding fragments buckets in depth order: with at
    /// most `buckets` occupied parts, a fragment is lost only to others in its own part (each
    /// part keeps min(2, its fragments)).
    #[test]
    fn adaptive_split_loses_only_within_a_part((raw, half) in raw_depths_and_half_k()) {
        let (depths, nearest, farthest) = pixel_depths(&raw);
        let kept = select_at_most_k(&depths, half, A)?;
        let (lo, hi) = (depth_fixed(nearest), depth_fixed(farthest));
        let part = |z: f32| part_of(depth_fixed(z), lo, hi, SUBINTERVALS as u64);
        let mut parts: Vec<u64> = depths.iter().map(|&z| part(z)).collect();
        parts.sort();
        parts.dedup();
        if parts.len() <= half as usize {
            for p in parts {
                let members = depths.iter().filter(|&&z| part(z) == p).count();
                let survivors = depths
                    .iter()
                    .zip(&kept)
                    .filter(|(&z, &k)| k && part(z) == p)
                    .count();
                prop_assert_eq!(survivors, members.min(2));
            }
        }
    }
}
