use super::*;
use crate::frame::{Effect, Raster};
use crate::methods::kbuffer::KBufferOptions;
use crate::methods::tests::options;
use crate::methods::MethodId;
use crate::scene::{loaders, Scene};
use crate::testing::{
    assert_exact, assert_poison_changes_nothing, gpu, render_gpu, render_reference, Expected,
};

fn scene(spec: &str) -> Scene {
    loaders::load_scene(spec).unwrap()
}

/// tiled's picture and statistics, after checking that its picture equals abuffer-ll's on the
/// compute rasterizer bit for bit.
fn equal_to_compute_lists(
    s: &Scene,
    opts: &crate::frame::RenderOptions,
    what: &str,
) -> crate::FrameStats {
    let mut compute = opts.clone();
    compute.build.raster = Raster::Compute;
    let (tiled, stats) = render_gpu(s, opts, "tiled");
    let (lists, _) = render_gpu(s, &compute, "abuffer-ll");
    assert!(
        tiled == lists,
        "{what}: tiled differs from abuffer-ll --raster compute"
    );
    stats
}

fn frames(
    scene: &Scene,
    opts: &crate::frame::RenderOptions,
    n: usize,
) -> Vec<crate::render::recorder::FrameReport> {
    frames_on(gpu(), scene, opts, n)
}

fn frames_on(
    gpu: &Gpu,
    scene: &Scene,
    opts: &crate::frame::RenderOptions,
    n: usize,
) -> Vec<crate::render::recorder::FrameReport> {
    let mut rec = crate::FrameRecorder::new(gpu, scene, MethodId::Tiled, opts).unwrap();
    (0..n)
        .map(|_| {
            let mut encoder = gpu.device.create_command_encoder(&Default::default());
            rec.record(&mut encoder, &Default::default(), None).unwrap();
            gpu.queue.submit([encoder.finish()]);
            rec.wait_stats().unwrap()
        })
        .collect()
}

/// The device again with 8 KiB of workgroup memory: the one-pass kernel's store then holds 128
/// fragments, and deep tiles go to the rounds, which these tests exercise.
fn rounds_gpu() -> Gpu {
    let mut limits = gpu().limits.clone();
    limits.max_compute_workgroup_storage_size = 8192;
    let small = Gpu::new_restricted(wgpu::Features::empty(), limits).unwrap();
    assert_eq!(fast_fragments(&small), 128);
    small
}

fn render_on(
    gpu: &Gpu,
    s: &Scene,
    opts: &crate::frame::RenderOptions,
) -> (crate::render::LinearImage, crate::FrameStats) {
    crate::Renderer::new(gpu, s, opts)
        .and_then(|mut r| r.render_method(MethodId::Tiled, None))
        .unwrap()
}

#[test]
fn stages_validate() {
    for samples in [1, 4] {
        crate::gpu::shader::validate(&sort_stage(scan_threads(gpu()), samples));
        crate::gpu::shader::validate(&sort_stage(64, samples));
        crate::gpu::shader::validate(&tile_stage(samples));
        crate::gpu::shader::validate(&fast_stage(fast_fragments(gpu()), samples));
    }
}

#[test]
fn params_layout_matches_wgsl() {
    crate::gpu::twin::assert_twin::<TiledParams>();
}

/// The same coverage, depths and order as the exact methods on the compute rasterizer: the
/// picture equals abuffer-ll's there, bit for bit, on every effect.
#[test]
fn equals_abuffer_ll_on_the_compute_rasterizer_bit_for_bit() {
    let s = scene("builtin:nvpro?objects=96&subdiv=12&seed=2");
    for effect in [
        Effect::Transparency,
        Effect::Translucency,
        Effect::Complexity,
    ] {
        let stats = equal_to_compute_lists(&s, &options(72, effect), effect.name());
        assert_eq!(stats.raster, "compute");
        assert_eq!(stats.exact, Some(true));
    }
}

/// The work counters: each triangle is set up once (by the bin), each fragment evaluated and
/// shaded exactly once by the one-pass kernel, each list entry's record loaded once where a
/// tile fits it whole; every binned item is kept or dropped as empty. In rounds (a device
/// with less workgroup memory), each round evaluates again what lies behind the bound, and
/// shades before it knows what it keeps (issue 64's redundant work, made visible).
#[test]
fn work_counters_count_each_evaluation_and_shading() {
    let shallow = scene("builtin:nvpro?objects=8&subdiv=5&seed=3");
    let frames_of = |s: &Scene| {
        frames(s, &options(64, Effect::Transparency), 3)
            .pop()
            .unwrap()
    };
    let report = frames_of(&shallow);
    let stats = &report.stats;
    let tiled = stats.family::<TiledStats>().cloned().unwrap();
    let raster = stats.compute_raster.clone().unwrap();
    assert!(tiled.deepest_pixel <= KEEP, "{tiled:?}");
    let fragments = stats.fragments_generated.unwrap();
    assert_eq!(tiled.fragment_evaluations, fragments, "{tiled:?}");
    assert_eq!(tiled.shadings, fragments, "{tiled:?}");
    assert_eq!(tiled.items_kept + tiled.items_empty, raster.tile_items);
    assert!(
        tiled.items_empty > 0,
        "bounds meet tiles no pixel center of which is covered"
    );
    let triangles = shallow.triangle_count() as u64;
    assert_eq!(tiled.triangle_setups, raster.triangles_set_up);
    assert!(tiled.triangle_setups <= triangles, "{tiled:?}");
    assert_eq!(tiled.record_loads, tiled.items_kept, "{tiled:?}");
    // A warp sorts at least as long as its pixels' average: one compare per fragment at least.
    assert!(32 * tiled.sort_steps >= fragments, "{tiled:?}");
    // Every pixel resolved in one pass (the finish passes them all by).
    assert_eq!(tiled.one_pass_pixels, 64 * 64, "{tiled:?}");
    assert!(tiled.evaluation_occupancy > 0.0 && tiled.evaluation_occupancy <= 1.0);
    assert_eq!(tiled.tiles_past_capacity, 0, "every tile in one pass");
    // 40 fragments a pixel: whole tiles outgrow the store, their quarters do not.
    let deep = scene("builtin:layers?n=40&coverage=0.9&order=random&seed=4");
    let report = frames_of(&deep);
    let tiled = report.stats.family::<TiledStats>().cloned().unwrap();
    let fragments = report.stats.fragments_generated.unwrap();
    assert_eq!(tiled.tiles_past_capacity, 0, "{tiled:?}");
    assert_eq!(tiled.fragment_evaluations, fragments, "{tiled:?}");
    assert_eq!(tiled.shadings, fragments, "{tiled:?}");
    // Every quad in view, none clipped: one setup per triangle.
    assert_eq!(tiled.triangle_setups, deep.triangle_count() as u64);
    // Quarters load the entries that cover a pixel of theirs: at least once each.
    assert!(tiled.record_loads >= tiled.items_kept, "{tiled:?}");
    // In rounds (a device with less workgroup memory), each round evaluates again what lies
    // behind its pixels' bounds.
    let report = frames_on(&rounds_gpu(), &deep, &options(64, Effect::Transparency), 3)
        .pop()
        .unwrap();
    let tiled = report.stats.family::<TiledStats>().cloned().unwrap();
    assert!(tiled.tiles_past_capacity > 0, "{tiled:?}");
    assert!(tiled.rounds >= 3, "{tiled:?}");
    assert!(tiled.fragment_evaluations > 2 * fragments, "{tiled:?}");
    assert!(tiled.shadings > fragments && tiled.shadings < tiled.fragment_evaluations);
}

/// The one-pass kernel's workgroup memory is what `fast_fragments` budgets: its fixed part and
/// its bytes per stored fragment, as naga lays the composed stage out.
#[test]
fn the_one_pass_kernels_workgroup_memory_is_as_budgeted() {
    let bytes = |fragments: u32| {
        let module = fast_stage(fragments, 1).compose().unwrap();
        let mut layouter = naga::proc::Layouter::default();
        layouter.update(module.to_ctx()).unwrap();
        module
            .global_variables
            .iter()
            .filter(|(_, g)| g.space == naga::AddressSpace::WorkGroup)
            .map(|(_, g)| layouter[g.ty].size)
            .sum::<u32>()
    };
    let (small, large) = (bytes(64), bytes(128));
    assert_eq!((large - small) / 64, FAST_FRAGMENT_BYTES);
    assert!(
        small - 64 * FAST_FRAGMENT_BYTES <= FAST_FIXED_BYTES,
        "{small}"
    );
    let fragments = fast_fragments(gpu());
    assert!(bytes(fragments) <= gpu().limits.max_compute_workgroup_storage_size);
}

/// Tiles past the one-pass kernel's store go to the rounds: a device with less workgroup
/// memory sends more tiles there, and the bytes of the picture do not change.
#[test]
fn the_one_pass_kernel_and_the_rounds_give_the_same_bytes() {
    let s = scene("builtin:nvpro?objects=64&subdiv=8&seed=2");
    let opts = options(64, Effect::Transparency);
    let mut limits = gpu().limits.clone();
    limits.max_compute_workgroup_storage_size = 8192;
    let small = Gpu::new_restricted(wgpu::Features::empty(), limits).unwrap();
    let render = |gpu: &Gpu| {
        crate::Renderer::new(gpu, &s, &opts)
            .and_then(|mut r| r.render_method(MethodId::Tiled, None))
            .unwrap()
    };
    let (full, full_stats) = render(gpu());
    let (rounds, round_stats) = render(&small);
    let past = |s: &crate::FrameStats| s.family::<TiledStats>().unwrap().tiles_past_capacity;
    assert!(past(&round_stats) > past(&full_stats), "{round_stats:?}");
    assert!(full == rounds, "the one-pass kernel changed the picture");
    assert_eq!(full_stats.exact, Some(true));
}

/// A pixel deeper than the one-pass kernel sorts (128 fragments) in a quarter that fits its
/// store is left to the rounds, and the frame stays exact: 8 pixels of 200 fragments.
#[test]
fn pixels_too_deep_for_the_one_pass_sort_go_to_the_rounds() {
    let s = scene("builtin:layers?n=200&coverage=0.1");
    let opts = options(8, Effect::Transparency);
    let (actual, stats) = render_gpu(&s, &opts, "tiled");
    assert_exact(
        "tiled-deep-pixels",
        &actual,
        &render_reference(&s, &opts),
        opts.frame.effect,
    );
    let tiled = stats.family::<TiledStats>().cloned().unwrap();
    assert_eq!((tiled.deepest_pixel, tiled.tiles_past_capacity), (200, 0));
    assert_eq!(tiled.rounds, rounds_for(200), "{tiled:?}");
    assert_eq!(stats.fragments_dropped, Some(0));
}

/// Pixels deeper than a round's 16 fragments take more rounds and stay exact, with layers in
/// random order and four coincident faces (told apart by their primitive, none lost).
#[test]
fn deep_pixels_take_more_rounds_and_stay_exact() {
    let mut s = scene("builtin:layers?n=40&coverage=0.9&order=random&seed=4");
    for i in 1..4 {
        s.objects[i].mesh.positions = s.objects[0].mesh.positions.clone();
    }
    let rounds = rounds_gpu();
    for effect in [Effect::Transparency, Effect::Complexity] {
        let opts = options(48, effect);
        let (actual, stats) = render_on(&rounds, &s, &opts);
        let expected = render_reference(&s, &opts);
        let name = format!("tiled-deep-{}", effect.name());
        assert_exact(&name, &actual, &expected, effect);
        assert_eq!(stats.fragments_dropped, Some(0));
        assert_eq!(stats.max_depth_complexity, Some(40));
        let tiled = stats.family::<TiledStats>().cloned().unwrap();
        assert_eq!(tiled.deepest_pixel, 40);
        // 40 fragments: rounds of 16, 16 and 8 (exact mode rendered again after a first frame of
        // two rounds left fragments).
        assert_eq!(tiled.rounds, 3);
        assert_eq!(tiled.unfinished_pixels, 0);
        assert_eq!(tiled.tile_rounds.len(), 4, "{:?}", tiled.tile_rounds);
        assert!(tiled.tile_rounds[3] > 0, "{:?}", tiled.tile_rounds);
        let tiles: u64 = tiled.tile_rounds.iter().sum();
        assert_eq!(tiles, 36, "6×6 tiles of 48×48 pixels");
    }
}

/// The determinism check: 20 renders of nvpro, byte for byte the same.
#[test]
fn twenty_renders_are_identical() {
    let s = scene("builtin:nvpro?objects=96&subdiv=12&seed=7");
    let opts = options(64, Effect::Translucency);
    let first = render_gpu(&s, &opts, "tiled").0;
    for run in 1..20 {
        assert!(
            render_gpu(&s, &opts, "tiled").0 == first,
            "run {run} differs"
        );
    }
}

/// Too few work items for the first frame: it reports the overflow and is incomplete, the items
/// grow, and the next frame is whole.
#[test]
fn an_item_overflow_is_reported_and_grown_out_of() {
    let s = scene("builtin:layers?n=24&coverage=1");
    let reports = frames(&s, &options(64, Effect::Transparency), 2);
    let raster = reports[0].stats.compute_raster.clone().unwrap();
    assert!(raster.overflow && reports[0].incomplete, "{raster:?}");
    assert_eq!(reports[0].stats.overflow, Some(true));
    let raster = reports[1].stats.compute_raster.clone().unwrap();
    assert!(!raster.overflow && !reports[1].incomplete, "{raster:?}");
    assert_eq!(reports[1].stats.fragments_generated, Some(24 * 64 * 64));
    assert_eq!(reports[1].stats.exact, Some(true));
    let bytes = reports[1].stats.bytes_allocated;
    let tiled = reports[1].stats.family::<TiledStats>().cloned().unwrap();
    assert_eq!(
        bytes,
        raster.bytes_allocated
            + tiled.list_bytes
            + COUNTER_WORDS * 4
            + std::mem::size_of::<TiledParams>() as u64,
        "the catalogue's formula"
    );
}

/// Its buffers and the rasterizer's poisoned before a frame change nothing.
#[test]
fn poisoned_buffers_change_nothing() {
    let s = scene("builtin:nvpro?objects=32&subdiv=10&seed=2");
    let mut opts = options(40, Effect::Transparency);
    assert_poison_changes_nothing(&s, &opts, MethodId::Tiled);
    // With the k nearest and a tail: the state words and the tail sums start from nothing.
    opts.frame.k = Some(6);
    opts.frame.family_mut::<KBufferOptions>().tail = crate::Tail::Blend;
    assert_poison_changes_nothing(&s, &opts, MethodId::Tiled);
    // Multisampled in rounds (a device with less workgroup memory): each sample's composite,
    // the pixel's bound and account start from nothing too.
    let deep = scene("builtin:spheres?layers=24");
    let small = rounds_gpu();
    for k in [None, Some(21)] {
        let mut opts = options(32, Effect::Transparency);
        opts.build.msaa = 4;
        opts.frame.k = k;
        opts.frame.family_mut::<KBufferOptions>().tail = crate::Tail::Blend;
        let mut r = crate::Renderer::new(&small, &deep, &opts).unwrap();
        let (clean, a) = r.render_method(MethodId::Tiled, None).unwrap();
        assert!(
            a.family::<TiledStats>().unwrap().tile_rounds.len() > 1,
            "no round ran"
        );
        r.recorder().unwrap().poison();
        let (poisoned, b) = r.render_method(MethodId::Tiled, None).unwrap();
        assert!(
            clean == poisoned,
            "--msaa 4 --k {k:?}: poisoned memory changed the picture"
        );
        assert_eq!(a.fragments_stored, b.fragments_stored);
    }
}

/// Sizes that are not multiples of a tile, and a camera inside the scene (near clipping).
#[test]
fn partial_tiles_and_near_clipping_match_the_reference() {
    let s = scene("builtin:nvpro?objects=64&subdiv=10&seed=3");
    for (w, h) in [(37, 21), (9, 50)] {
        let mut opts = options(w, Effect::Transparency);
        opts.frame.height = h;
        let (actual, _) = render_gpu(&s, &opts, "tiled");
        Expected::reference(&s, &opts).assert_exact(&format!("tiled-{w}x{h}"), &actual);
    }
}

/// A tile list of 600 triangles walked for 19 rounds: every fragment of every pixel, in order.
/// (One invocation looping over every round lost fragments here on lavapipe, whose invocations
/// stop looping after 65535 iterations in all.)
#[test]
fn long_lists_over_many_rounds_lose_nothing() {
    let s = scene("builtin:layers?n=300&coverage=1&order=random&seed=2");
    let stats = equal_to_compute_lists(&s, &options(16, Effect::Transparency), "300 layers");
    let t = stats.family::<TiledStats>().cloned().unwrap();
    // Each layer's quad puts one triangle on each tile's pixel centers; its other triangle
    // meets the tiles' bounds only, and the count pass drops it.
    assert_eq!((t.rounds, t.deepest_pixel, t.longest_list), (19, 300, 300));
    assert_eq!(stats.fragments_generated, Some(300 * 16 * 16));
}

/// First frames record two rounds; a deeper frame is incomplete, counts what it left as
/// dropped, and the next frame records enough rounds.
#[test]
fn rounds_follow_the_last_frames_deepest_pixel() {
    let s = scene("builtin:layers?n=40&coverage=1&order=random&seed=5");
    // One tile, whose items fit the rasterizer's first buffer, and past the one-pass store.
    let reports = frames_on(&rounds_gpu(), &s, &options(8, Effect::Transparency), 2);
    assert!(!reports[0].stats.compute_raster.as_ref().unwrap().overflow);
    let first = reports[0].stats.family::<TiledStats>().cloned().unwrap();
    assert_eq!((first.rounds, first.deepest_pixel), (FIRST_ROUNDS, 40));
    assert_eq!(first.unfinished_pixels, 64);
    assert!(reports[0].incomplete);
    assert_eq!(reports[0].stats.fragments_dropped, Some(8 * 64));
    assert_eq!(reports[0].stats.exact, Some(false));
    let second = reports[1].stats.family::<TiledStats>().cloned().unwrap();
    assert_eq!((second.rounds, second.unfinished_pixels), (3, 0));
    assert!(!reports[1].incomplete);
    assert_eq!(reports[1].stats.fragments_dropped, Some(0));
}

/// `--k N` composites each pixel's N nearest, like the reference with k, and counts the rest as
/// dropped.
#[test]
fn k_composites_the_k_nearest() {
    let s = scene("builtin:layers?n=40&coverage=0.9&order=random&seed=6");
    for k in [5, 16, 21] {
        let mut opts = options(32, Effect::Transparency);
        opts.frame.k = Some(k);
        let (actual, stats) = render_gpu(&s, &opts, "tiled");
        Expected::reference(&s, &opts).assert_exact(&format!("tiled-k{k}"), &actual);
        assert_eq!(
            stats.fragments_stored.unwrap(),
            stats.fragments_generated.unwrap() - stats.fragments_dropped.unwrap()
        );
        assert!(stats.fragments_dropped.unwrap() > 0, "k = {k}");
        assert_eq!(
            stats.family::<TiledStats>().cloned().unwrap().rounds,
            rounds_for(k)
        );
    }
}

/// `--k N --tail drop|blend|weighted` composites each pixel's N nearest and the rest as the
/// k-buffers do: equal bit for bit to `kb-ab-fixed` on the same compute rasterizer (whose tails
/// are held to their closed forms in kbuffer's tests), in the one-pass kernel and in rounds (a
/// device with less workgroup memory), with k within the first round and past it.
#[test]
fn k_nearest_with_each_tail_equals_the_fixed_k_buffer() {
    let s = scene("builtin:layers?n=40&coverage=0.9&order=random&seed=6");
    let small = rounds_gpu();
    for tail in [crate::Tail::Drop, crate::Tail::Blend, crate::Tail::Weighted] {
        for k in [5, 21] {
            let mut opts = options(32, Effect::Transparency);
            opts.frame.k = Some(k);
            opts.frame.family_mut::<KBufferOptions>().tail = tail;
            let mut compute = opts.clone();
            compute.build.raster = Raster::Compute;
            let (expected, kb) = render_gpu(&s, &compute, "kb-ab-fixed");
            let what = format!("k = {k}, --tail {tail:?}");
            let (one_pass, stats) = render_gpu(&s, &opts, "tiled");
            assert!(one_pass == expected, "{what}: the one-pass kernel");
            assert_eq!(stats.fragments_dropped, kb.fragments_dropped, "{what}");
            let (rounds, stats) = render_on(&small, &s, &opts);
            let tiled = stats.family::<TiledStats>().cloned().unwrap();
            assert!(tiled.tile_rounds.len() > 1, "{what}: no round ran");
            assert!(rounds == expected, "{what}: the rounds");
        }
    }
}

/// `--msaa 4|8` (issue 64, item 7): each sample composites the fragments covering it — with
/// `--k` its own k nearest — and the pixel is the samples' mean, as `reference --msaa N`, with
/// the reference's fragment counts (a fragment counted once however many samples composited
/// it); in the one-pass kernel and in rounds (a device with less workgroup memory) bit for bit.
/// 8 samples too: tiled finds its samples in compute, so lavapipe, whose render targets take 4
/// at most, renders them.
#[test]
fn multisampled_frames_equal_the_multisampled_reference() {
    let cases = [
        (
            "builtin:nvpro?objects=64&subdiv=10&seed=3",
            64,
            Effect::Transparency,
        ),
        (
            "builtin:layers?n=8&coverage=0.6&order=random&seed=5",
            40,
            Effect::Translucency,
        ),
        ("builtin:spheres?layers=24", 32, Effect::Transparency),
    ];
    let small = rounds_gpu();
    for (spec, size, effect) in cases {
        let s = scene(spec);
        for msaa in [4, 8] {
            for k in [None, Some(3)] {
                let mut opts = options(size, effect);
                opts.build.msaa = msaa;
                opts.frame.k = k;
                let what = format!("{spec} --msaa {msaa} --k {k:?}");
                let (expected, truth) = crate::reference::render(&s, &opts).unwrap();
                let (one_pass, stats) = render_gpu(&s, &opts, "tiled");
                assert_exact(&what, &one_pass, &expected, effect);
                let counts = |s: &crate::FrameStats| {
                    (
                        s.fragments_generated,
                        s.fragments_stored,
                        s.fragments_dropped,
                        s.max_depth_complexity,
                    )
                };
                assert_eq!(counts(&stats), counts(&truth), "{what}");
                let (rounds, round_stats) = render_on(&small, &s, &opts);
                let tiled = round_stats.family::<TiledStats>().cloned().unwrap();
                if spec.contains("spheres") {
                    assert!(tiled.tile_rounds.len() > 1, "{what}: no round ran");
                }
                assert!(rounds == one_pass, "{what}: the rounds differ");
                assert_eq!(counts(&round_stats), counts(&truth), "{what}: the rounds");
            }
        }
    }
}

/// Multisampled `--k N --tail blend|weighted`: each sample joins the fragments past its own k
/// nearest to its own tail — in the one-pass kernel from the pixel's sorted run, in rounds as a
/// sample fills — the same bytes both ways, with k within a round and past it; the tail brings
/// the picture nearer the whole scene's than dropping does.
#[test]
fn multisampled_tails_are_the_same_in_one_pass_and_in_rounds() {
    let s = scene("builtin:spheres?layers=24");
    let small = rounds_gpu();
    let mut all = options(32, Effect::Transparency);
    all.build.msaa = 4;
    let whole = render_reference(&s, &all);
    for k in [3, 21] {
        let mut errors = Vec::new();
        for tail in [crate::Tail::Drop, crate::Tail::Blend, crate::Tail::Weighted] {
            let mut opts = all.clone();
            opts.frame.k = Some(k);
            opts.frame.family_mut::<KBufferOptions>().tail = tail;
            let what = format!("k = {k}, --tail {tail:?}");
            let (one_pass, stats) = render_gpu(&s, &opts, "tiled");
            let (rounds, round_stats) = render_on(&small, &s, &opts);
            assert!(
                round_stats
                    .family::<TiledStats>()
                    .unwrap()
                    .tile_rounds
                    .len()
                    > 1,
                "{what}: no round ran"
            );
            assert!(rounds == one_pass, "{what}: the rounds differ");
            assert_eq!(
                stats.fragments_dropped, round_stats.fragments_dropped,
                "{what}"
            );
            assert!(stats.fragments_dropped.unwrap() > 0, "{what}");
            let error: f64 = one_pass
                .pixels
                .iter()
                .zip(&whole.pixels)
                .map(|(a, b)| (0..3).map(|c| (a[c] - b[c]).abs() as f64).sum::<f64>())
                .sum();
            errors.push(error);
            if tail == crate::Tail::Drop {
                Expected::reference(&s, &opts).assert_exact(&what, &one_pass);
            }
        }
        assert!(errors[1] < errors[0], "k = {k}: blend {errors:?}");
    }
}

/// A scene whose vertices outgrow one storage binding is refused up front in one line, never
/// by wgpu's validation panic.
#[test]
fn vertices_beyond_one_storage_binding_are_refused_in_one_line() {
    let s = scene("builtin:nvpro?objects=32&subdiv=10&seed=2");
    let mut limits = gpu().limits.clone();
    limits.max_storage_buffer_binding_size = 64 << 10;
    let small = Gpu::new_restricted(wgpu::Features::empty(), limits).unwrap();
    let e = crate::Renderer::new(&small, &s, &options(16, Effect::Transparency))
        .and_then(|mut r| r.render_method(MethodId::Tiled, None))
        .expect_err("refused");
    let message = e.to_string();
    assert!(
        message.contains("one storage binding") && !message.contains('\n'),
        "{message}"
    );
}

/// Where the rasterizer's items (8 bytes each) would fit one storage binding but tiled's lists of
/// them (12 bytes each) would not, the frame is refused in one line naming the items it needs,
/// not by the failure to make the list buffer.
#[test]
fn items_beyond_the_lists_binding_are_refused_in_one_line() {
    // Many items for few pixels, so that the pixels' buffers fit where the lists do not.
    let s = scene("builtin:layers?n=200&coverage=1");
    let opts = options(64, Effect::Transparency);
    let needed = frames(&s, &opts, 2)[1]
        .stats
        .compute_raster
        .clone()
        .unwrap()
        .tile_items;
    let mut limits = gpu().limits.clone();
    // Room for the list entries at 4 bytes, not for the items at 16.
    limits.max_storage_buffer_binding_size = needed * 10;
    let small = Gpu::new_restricted(wgpu::Features::empty(), limits).unwrap();
    let e = crate::Renderer::new(&small, &s, &opts)
        .and_then(|mut r| r.render_method(MethodId::Tiled, None))
        .expect_err("refused");
    let message = e.to_string();
    assert!(
        message.contains(&format!("needs {needed} tile items"))
            && message.contains("16 bytes each")
            && !message.contains('\n'),
        "{message}"
    );
}

/// In bands, the picture is the whole frame's and the statistics add up over the bands.
#[test]
fn bands_add_up_to_the_whole_frame() {
    let s = scene("builtin:layers?n=20&coverage=0.8&order=random&seed=8");
    let opts = options(64, Effect::Transparency);
    let (whole, one) = render_gpu(&s, &opts, "tiled");
    let mut r = crate::Renderer::new(gpu(), &s, &opts).unwrap();
    r.set_max_band_rows(Some(crate::frame::BAND_ALIGN));
    let (banded, stats) = r.render_method(MethodId::Tiled, None).unwrap();
    assert_eq!(stats.bands, Some(2));
    assert!(banded == whole, "bands changed the picture");
    assert_eq!(stats.fragments_generated, one.fragments_generated);
    let (a, b) = (
        stats.family::<TiledStats>().cloned().unwrap(),
        one.family::<TiledStats>().cloned().unwrap(),
    );
    assert_eq!(a.tile_rounds.iter().sum::<u64>(), 64);
    assert_eq!(
        (a.deepest_pixel, a.tile_rounds),
        (b.deepest_pixel, b.tile_rounds)
    );
}

/// The deferred pipeline's transparent part: over the lit opaque surfaces (whose depth it
/// tests), tiled's picture is abuffer-ll's.
#[test]
fn the_deferred_pipelines_transparent_part_is_abuffer_lls() {
    let s = scene("builtin:demo");
    let mut opts = options(48, Effect::Transparency);
    opts.build.lighting.pipeline = Some(crate::scene::Pipeline::Deferred);
    let (tiled, stats) = render_gpu(&s, &opts, "tiled");
    let (lists, reference) = render_gpu(&s, &opts, "abuffer-ll");
    assert_exact("tiled-deferred", &tiled, &lists, opts.frame.effect);
    assert!(stats.lighting.is_some());
    assert_eq!(stats.fragments_generated, reference.fragments_generated);
}

/// The rounds follow the deepest pixel left to them, keep growing after an item overflow (the
/// deepest seen is then a lower bound), and a frame records at most MAX_ROUNDS of them
/// (docs/watchdog.md, T1): 65,536 fragments a pixel.
#[test]
fn the_rounds_follow_the_deepest_pixel_up_to_their_cap() {
    assert_eq!(next_rounds(9, false, 500, 0), 1);
    assert_eq!(next_rounds(9, false, 500, 33), 3);
    assert_eq!(next_rounds(9, true, 33, 0), 9);
    assert_eq!(next_rounds(2, true, 33, 0), 3);
    assert_eq!(MAX_ROUNDS * KEEP, 65_536);
    assert!(next_rounds(2, false, 0, 65_537) > MAX_ROUNDS);
}
