//! Multisample anti-aliasing (`--msaa 4|8`) for every capture family.
//!
//! The capture passes rasterize with 4 or 8 samples per pixel at the standard sample positions
//! ([`positions`]; Vulkan's and WebGPU's, which every wgpu backend uses) but shade once per pixel
//! and primitive, as engines do: a fragment is shaded at the pixel center and stores the center's
//! depth, plus its coverage mask (`@builtin(sample_mask)`, the samples inside the primitive).
//! Every sample composites its own fragments in (center depth, primitive) order and the pixel
//! is the samples' average (premultiplied, so blending it over a background equals averaging
//! the samples blended over it): an edge pixel half covered by a layer gets half its
//! contribution, a fully covered pixel exactly the single-sample result, and shading costs what
//! it costs without MSAA. The CPU reference (`crate::reference`) supersamples the same way, so the
//! exact methods stay testable against it. How each family keeps its samples:
//!
//! - **Every fragment per pixel** (`abuffer-ll`, `abuffer-fixed`, `sbuffer`, `kb-ab-ll`,
//!   `kb-ab-fixed`, `kb-sbuffer`): the mask rides in the fragment's tag word —
//!   `primitive << (1 + S) | mask << 1 | front-facing` — so the 16-byte record stays as it is,
//!   and the resolve composites each sample's fragments (each sample's k nearest for `kb-`).
//!   Memory: nothing per sample, but a pixel on a mesh edge stores one fragment per primitive
//!   touching it, which the fixed arrays feel as drops.
//! - **Capture-time choice** (`kplus-array`, `kplus-heap`, `kplus-array-r`, `kplus-semiheap`,
//!   `kplus-sbuffer`, `kb`, `kb-ps`, `kb-ll`, `kb-mdt32`, and `kpeel`'s passes): a choice made
//!   per pixel is not each sample's — an edge pixel would spend its k on fragments some of its
//!   samples do not see — so they keep **per-sample storage**: S sample pixels per pixel with
//!   their own slots (or list, cascade, region), counters, lock and tail; a fragment, shaded
//!   once, enters the storage of each sample it covers, so every sample keeps exactly its own k
//!   nearest and nothing at an edge overflows into the tail. Memory: S× the storage and words,
//!   + 4 bytes per pixel; the capture's atomic work grows with the samples a fragment covers.
//! - **Peeling** (`f2b`, `dual`, `kpeel`): every sample peels on its own, with its own running
//!   composite. `f2b` renders multisampled layer targets: a fragment covers (through its output
//!   sample mask) only the samples still waiting for it and writes its center depth to them, so
//!   each sample's depth test keeps that sample's next fragment. `dual` and `kpeel` keep sample
//!   entries in every per-pixel array. An *account* geometry pass after the last layer counts
//!   each fragment once, each sample's depth complexity (which sets the next frame's layers)
//!   and the fragments some sample composited: one more geometry pass per frame.
//! - **convex**: sample entries with their own claims, slots and state (see its module).
//! - **bucket**: multisampled bounds and bucket targets (MAX blending writes a fragment into the
//!   samples it covers), one routing per pixel (a reduce pass joins the samples' bounds, so a
//!   fragment has one bucket at all its samples), and claims and records per sample entry; the
//!   resolve counts a fragment kept at several samples once, at the lowest.
//! - **In compute** (`tiled`): no multisampled target at all; it tests each fragment's samples on
//!   the snapped edges itself, so it takes 4 or 8 samples on any device and backend (its module
//!   has how it keeps them).
//! - **Blended targets** (`wboit`, `mboit`, `unsorted`, `sorted`): multisampled targets; the
//!   hardware writes each fragment into the samples it covers and the composite averages the
//!   samples' results; mboit weights a fragment by the mean of its covered samples'
//!   transmittances.
//!
//! A fragment counts once in the statistics however many samples kept it. A device may shade
//! one primitive's pixel in more than one invocation, each with its own disjoint part of the
//! mask (lavapipe does, on some partly and some fully covered pixels): every sample still sees
//! the surface once, so the picture is the same, but fragment counts — the statistics and the
//! complexity view — count invocations where the reference counts primitives.
//!
//! With `--pipeline` the lit opaque frame stays single-sampled (multisampled deferred shading,
//! lighting each edge sample, is not built): `--msaa` anti-aliases the transparent surfaces,
//! which are tested against the opaque depth at the pixel center and composited per sample over
//! the lit pixel; opaque edges keep their stairs. The reference does the same.
//!
//! Limits: scenes of at most 2^(31 − S) triangles (8,388,608 at 8×; `f2b`: 2^23, its tag
//! travelling as an exact float because 32-bit integer targets cannot be multisampled); 8× only
//! where the device rasterizes it (lavapipe: 4×); `dual` needs 64-bit atomic min/max. Refused
//! with one error line naming why: `kb-mdt64` and `kb-mdt-pack` (no primitive or mask in their
//! 8-byte keys), `--raster compute` (it samples pixel centers), `--temporal` (its interface is
//! per pixel), and application captures (`strata_capture` takes no mask yet, and WGSL has no
//! early fragment tests to cull the samples an application's multisampled depth hides).

use crate::error::{Error, Result};
use crate::frame::passes::NullTarget;
use crate::frame::RenderOptions;
use crate::gpu::Gpu;

/// The sample counts `--msaa` takes.
pub const SAMPLE_COUNTS: [u32; 3] = [1, 4, 8];

/// Standard sample positions within a pixel (x right, y down, in pixels), sample i being bit i
/// of the coverage mask.
pub fn positions(samples: u32) -> &'static [[f64; 2]] {
    const ONE: [[f64; 2]; 1] = [[0.5, 0.5]];
    const FOUR: [[f64; 2]; 4] = [
        [0.375, 0.125],
        [0.875, 0.375],
        [0.125, 0.625],
        [0.625, 0.875],
    ];
    const EIGHT: [[f64; 2]; 8] = [
        [0.5625, 0.3125],
        [0.4375, 0.6875],
        [0.8125, 0.5625],
        [0.3125, 0.1875],
        [0.1875, 0.8125],
        [0.0625, 0.4375],
        [0.6875, 0.9375],
        [0.9375, 0.0625],
    ];
    match samples {
        4 => &FOUR,
        8 => &EIGHT,
        _ => &ONE,
    }
}

/// Bits of coverage each fragment's tag carries (0 single-sampled).
pub fn coverage_bits(samples: u32) -> u32 {
    if samples > 1 {
        samples
    } else {
        0
    }
}

/// The most triangles a scene may have at `samples` (their index shares the tag with the mask).
pub fn max_triangles(samples: u32) -> u64 {
    1u64 << (31 - coverage_bits(samples))
}

/// `--msaa` against the other options.
pub fn check_options(options: &RenderOptions) -> Result<()> {
    let samples = options.build.msaa;
    if !SAMPLE_COUNTS.contains(&samples) {
        return Err(Error::input(format!(
            "--msaa {samples} is not 1, 4 or 8 (the sample counts every wgpu backend supports)"
        )));
    }
    if samples == 1 {
        return Ok(());
    }
    let refuse = |what: &str| {
        Err(Error::unsupported(format!(
            "--msaa {samples} does not work with {what} yet; use --msaa 1"
        )))
    };
    if options.build.raster == crate::frame::Raster::Compute {
        return refuse("--raster compute (the compute rasterizer samples pixel centers)");
    }
    if options.frame.temporal.is_some() {
        return refuse("--temporal on");
    }
    Ok(())
}

/// The sample counts the device rasterizes the capture passes' target at: 1 and 4 everywhere
/// (WebGPU's guarantee), 8 where the adapter reports it.
pub fn device_sample_counts(gpu: &Gpu) -> Vec<u32> {
    SAMPLE_COUNTS
        .into_iter()
        .filter(|&n| {
            n <= 4
                || gpu.has(wgpu::Features::TEXTURE_ADAPTER_SPECIFIC_FORMAT_FEATURES)
                    && gpu.adapter.as_ref().is_some_and(|a| {
                        a.get_texture_format_features(NullTarget::FORMAT)
                            .flags
                            .sample_count_supported(n)
                    })
        })
        .collect()
}

/// `--msaa` against the device.
pub fn check_device(gpu: &Gpu, samples: u32) -> Result<()> {
    if samples > 1 && !crate::gpu::shader::reads_sample_mask(gpu.info.backend) {
        return Err(Error::unsupported(format!(
            "--msaa {samples} on {}: a multisampled frame keeps each fragment's coverage from @builtin(sample_mask), which naga's GLSL output (wgpu 30) cannot read",
            gpu.backend_name()
        )));
    }
    let counts = device_sample_counts(gpu);
    if counts.contains(&samples) {
        return Ok(());
    }
    let list: Vec<String> = counts.iter().map(|n| n.to_string()).collect();
    Err(Error::unsupported(format!(
        "--msaa {samples}: this device rasterizes {} samples per pixel only ({})",
        list.join(" or "),
        gpu.info.name
    )))
}

/// `--msaa` against the scene's size (which methods take it is in their descriptors).
pub fn check_triangles(samples: u32, triangles: u64) -> Result<()> {
    if samples > 1 && triangles > max_triangles(samples) {
        return Err(Error::unsupported(format!(
            "--msaa {samples} takes at most {} triangles (each fragment's tag holds the triangle's index and the {samples}-bit coverage mask); the scene has {triangles}",
            max_triangles(samples)
        )));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frame::BuildOptions;

    #[test]
    fn positions_are_distinct_inside_the_pixel_and_on_the_sixteenth_grid() {
        for n in SAMPLE_COUNTS {
            let p = positions(n);
            assert_eq!(p.len(), n as usize);
            for (i, a) in p.iter().enumerate() {
                assert!(a.iter().all(|c| *c > 0.0 && *c < 1.0));
                // Exact in the reference's 1/256-pixel integer grid.
                assert!(a.iter().all(|c| (c * 16.0).fract() == 0.0));
                assert!(p[..i].iter().all(|b| b != a));
            }
            // Balanced: the mean position is the center.
            let mean = p.iter().fold([0.0; 2], |m, a| [m[0] + a[0], m[1] + a[1]]);
            assert_eq!(mean.map(|m| m / n as f64), [0.5, 0.5]);
        }
    }

    #[test]
    fn bad_counts_and_combinations_are_refused() {
        let with = |msaa| RenderOptions {
            build: BuildOptions {
                msaa,
                ..Default::default()
            },
            ..Default::default()
        };
        assert!(check_options(&with(2)).is_err());
        assert!(check_options(&with(4)).is_ok());
        assert!(check_triangles(8, 1 << 23).is_ok());
        assert!(check_triangles(8, (1 << 23) + 1).is_err());
        assert!(check_triangles(1, u64::MAX).is_ok());
    }
}

/// The GPU against the multisampled reference, on lavapipe.
#[cfg(test)]
mod gpu_tests {
    use crate::frame::{Effect, RenderOptions};
    use crate::methods::tests::options;
    use crate::scene::{loaders::load_scene, Background};
    use crate::testing::{assert_close, assert_exact, render_gpu, render_reference};

    /// As the exact methods' tolerance (methods/tests.rs): ≤ 2/255 on ≥ 99.9% of pixels.
    use crate::testing::{EXACT_MAX_DIFF as MAX_DIFF, EXACT_MAX_FRACTION as MAX_FRACTION};

    fn multisampled(size: u32, effect: Effect, msaa: u32, k: Option<u32>) -> RenderOptions {
        {
            let mut options = options(size, effect);
            options.build.msaa = msaa;
            options.frame.k = k;
            options
        }
    }

    /// Every method that supports --msaa equals `reference --msaa N`, with each sample's k
    /// nearest where the method keeps k; the spheres' deepest pixels take more than the
    /// resolve's 64 local fragments (the per-sample k-depth sort).
    #[test]
    fn exact_methods_equal_the_multisampled_reference() {
        let cases = [
            ("builtin:spheres?layers=4", 48, Effect::Transparency),
            (
                "builtin:layers?n=8&coverage=0.6&order=random&seed=5",
                40,
                Effect::Translucency,
            ),
            ("builtin:spheres?layers=24", 32, Effect::Transparency),
        ];
        let counts = super::device_sample_counts(crate::testing::gpu());
        for (spec, size, effect) in cases {
            let scene = load_scene(spec).unwrap();
            // kb- methods keep each sample's k nearest (by default 16: the spheres' 24 layers
            // beyond it add less than 2/255).
            for msaa in [4, 8] {
                if !counts.contains(&msaa) {
                    // lavapipe rasterizes 1 or 4 samples: the request is refused, not botched.
                    let opts = multisampled(size, effect, msaa, None);
                    let mut r = crate::Renderer::new(crate::testing::gpu(), &scene, &opts).unwrap();
                    let err = r.render("abuffer-ll").unwrap_err().to_string();
                    assert!(err.contains("samples per pixel only"), "{err}");
                    continue;
                }
                let all = multisampled(size, effect, msaa, None);
                // At the device's own depths and samples every pixel matches (kbuffer/tests.rs).
                let truth = crate::methods::kbuffer::tests::exact_truth(
                    &scene,
                    &all,
                    render_reference(&scene, &all),
                );
                let (expected, at_device) = (&truth.expected, &truth.at_device);
                let exactly = if truth.unmatched == 0 {
                    0.0
                } else {
                    MAX_FRACTION
                };
                for method in ["abuffer-ll", "sbuffer", "kb-ab-ll", "kb-sbuffer"] {
                    let (actual, stats) = render_gpu(&scene, &all, method);
                    let name = format!("msaa{msaa}-{method}-{spec}");
                    assert_exact(&name, &actual, expected, effect);
                    let at = format!("{name}-device-depths");
                    assert_close(&at, &actual, at_device, effect, MAX_DIFF, exactly);
                    if !method.starts_with("kb-") {
                        assert_eq!(stats.fragments_dropped, Some(0), "{name}");
                    }
                }
                // k-depth peeling, 3 per sample and pass: every sample peels all of its own.
                let (abuffer, abuffer_stats) = render_gpu(&scene, &all, "abuffer-ll");
                let three = multisampled(size, effect, msaa, Some(3));
                let (peeled, stats) = render_gpu(&scene, &three, "kpeel");
                let name = format!("msaa{msaa}-kpeel-{spec}");
                assert_exact(&name, &peeled, expected, effect);
                assert_exact(&name, &peeled, &abuffer, effect);
                let counts = |s: &crate::FrameStats| {
                    (
                        s.fragments_generated,
                        s.fragments_stored,
                        s.fragments_dropped,
                    )
                };
                assert_eq!(counts(&stats), counts(&abuffer_stats), "{name}");
                // Front-to-back peeling: each sample its own layers, the hardware's depth test
                // per sample over the fragments' center depths.
                for method in ["f2b", "dual"] {
                    let (peeled, stats) = render_gpu(&scene, &all, method);
                    let name = format!("msaa{msaa}-{method}-{spec}");
                    assert_exact(&name, &peeled, expected, effect);
                    assert_eq!(counts(&stats), counts(&abuffer_stats), "{name}");
                }
                let wide = multisampled(size, effect, msaa, Some(256));
                for method in ["abuffer-fixed", "kplus-heap", "kplus-array"] {
                    let (actual, stats) = render_gpu(&scene, &wide, method);
                    let name = format!("msaa{msaa}-k256-{method}-{spec}");
                    assert_exact(&name, &actual, expected, effect);
                    assert_eq!(stats.fragments_dropped, Some(0), "{name}");
                }
                // Each sample's 3 nearest: the capture-time k-buffers keep them in each
                // sample's own storage, the others select them in the resolve.
                let three = multisampled(size, effect, msaa, Some(3));
                let expected = render_reference(&scene, &three);
                let mut selected_in_resolve = None;
                for method in [
                    "kb-ab-ll",
                    "kb-ab-fixed",
                    "kb-sbuffer",
                    "kb-keys",
                    "kplus-array",
                    "kplus-heap",
                    "kplus-array-r",
                    "kplus-semiheap",
                    "kb-ps",
                    "kb",
                    "kb-ll",
                    "kb-mdt32",
                    "kplus-sbuffer",
                ]
                .into_iter()
                .filter(|&m| {
                    // kb races where a pixel's fragments run at once (see
                    // k_methods_with_k_at_depth_complexity_equal_the_full_reference).
                    m != "kb" || crate::testing::gpu().info.device_type == wgpu::DeviceType::Cpu
                }) {
                    let (actual, stats) = render_gpu(&scene, &three, method);
                    let name = format!("msaa{msaa}-k3-{method}-{spec}");
                    assert_exact(&name, &actual, &expected, effect);
                    let counts = (
                        stats.fragments_generated,
                        stats.fragments_stored,
                        stats.fragments_dropped,
                    );
                    assert!(counts.2.unwrap() > 0, "{name}");
                    // Per-sample storage counts a fragment once however many samples kept
                    // it, as kb-ab-ll (one list per pixel) does on the same device.
                    let selected = *selected_in_resolve.get_or_insert(counts);
                    if crate::methods::kbuffer::sample_storage(method.parse().unwrap(), msaa) > 1 {
                        assert_eq!(counts, selected, "{name}");
                    }
                }
            }
        }
    }

    /// Peeling too few layers: each sample composites its own nearest ones — f2b's and kpeel's
    /// 2 layers are `reference --k 2 --msaa 4` — and what no sample reached is counted as
    /// dropped, as kb-ab-ll (each sample's 2 nearest from one list per pixel) counts it.
    #[test]
    fn peeling_too_few_layers_keeps_each_samples_nearest_and_counts_the_rest() {
        let scene = load_scene("builtin:spheres?layers=4").unwrap();
        let two = multisampled(40, Effect::Transparency, 4, Some(2));
        let expected = render_reference(&scene, &two);
        let (_, selected) = render_gpu(&scene, &two, "kb-ab-ll");
        assert!(selected.fragments_dropped.unwrap() > 0);
        let layers = {
            let mut options = two.clone();
            options
                .frame
                .family_mut::<crate::methods::peeling::PeelingOptions>()
                .layers = Some(2);
            options.frame.k = Some(1);
            options
        };
        for method in ["f2b", "kpeel"] {
            let mut r = crate::Renderer::new(crate::testing::gpu(), &scene, &layers).unwrap();
            let (img, stats) = r.render(method).unwrap();
            assert_exact(method, &img, &expected, layers.frame.effect);
            assert_eq!(
                stats.fragments_dropped, selected.fragments_dropped,
                "{method}"
            );
            assert_eq!(stats.max_depth_complexity, Some(4), "{method}");
        }
    }

    /// The baselines blend into multisampled targets: where submission order is depth order
    /// (layers sent back to front; screen-aligned layers sorted by centroid) they equal
    /// `reference --msaa N`, edges included; out of order `unsorted` is wrong as single-sampled.
    #[test]
    fn baselines_blend_per_sample_and_equal_the_reference_where_order_holds() {
        let counts = super::device_sample_counts(crate::testing::gpu());
        let back = load_scene("builtin:layers?n=8&coverage=0.6&order=back&seed=5").unwrap();
        let shuffled = load_scene("builtin:layers?n=8&coverage=0.6&order=random&seed=5").unwrap();
        for msaa in [4, 8] {
            if !counts.contains(&msaa) {
                continue;
            }
            // 37 pixels: the layers' edges fall between sample positions, not on pixel edges.
            let opts = multisampled(37, Effect::Transparency, msaa, None);
            let expected = render_reference(&back, &opts);
            let (unsorted, _) = render_gpu(&back, &opts, "unsorted");
            let name = format!("msaa{msaa}-unsorted-back");
            assert_exact(&name, &unsorted, &expected, opts.frame.effect);
            let (sorted, _) = render_gpu(&shuffled, &opts, "sorted");
            let name = format!("msaa{msaa}-sorted-random");
            assert_exact(&name, &sorted, &expected, opts.frame.effect);
            // The layers' edges are where samples differ: some pixel is partly covered.
            let lists = crate::reference::fragments(&back, &opts).unwrap();
            let full = (1u32 << msaa) - 1;
            assert!(lists
                .iter()
                .any(|l| l.iter().any(|f| u32::from(f.coverage) != full)));
        }
    }

    /// A pixel whose fragments all cover every sample resolves exactly as single-sampled.
    #[test]
    fn fully_covered_pixels_equal_the_single_sample_result() {
        let scene = load_scene("builtin:layers?n=8&coverage=0.6&order=random&seed=5").unwrap();
        let single = options(48, Effect::Transparency);
        let four = {
            let mut options = single.clone();
            options.build.msaa = 4;
            options
        };
        let lists = crate::reference::fragments(&scene, &four).unwrap();
        let (one, _) = render_gpu(&scene, &single, "abuffer-ll");
        let (many, _) = render_gpu(&scene, &four, "abuffer-ll");
        let mut interior = 0;
        for (i, list) in lists.iter().enumerate() {
            if list.is_empty() || list.iter().any(|f| f.coverage != 0b1111) {
                continue;
            }
            interior += 1;
            // Colors only: counts are invocations (see the module docs).
            for c in 0..3 {
                let (a, b) = (one.pixels[i][c], many.pixels[i][c]);
                assert!((a - b).abs() <= 1e-5, "pixel {i} channel {c}: {a} vs {b}");
            }
        }
        assert!(interior > 1000, "only {interior} fully covered pixels");
    }

    /// A layer whose edge runs through a column of pixel centers covers two of each pixel's
    /// four samples there: the pixel gets half the layer's contribution.
    #[test]
    fn a_half_covered_edge_pixel_gets_half_the_contribution() {
        // 32 pixels span x ∈ [-1, 1]: the layer's right edge at 16.5 pixels.
        let scene = load_scene("builtin:layers?n=1&coverage=0.515625").unwrap();
        let opts = {
            let mut options = options(32, Effect::Transparency);
            options.build.msaa = 4;
            options.frame.background = Background::Color([0.2, 0.3, 0.4]);
            options
        };
        for method in [
            "abuffer-ll",
            "kb-ab-fixed",
            "kplus-heap",
            "kpeel",
            "f2b",
            "dual",
            "unsorted",
            "mboit",
        ] {
            let (img, _) = render_gpu(&scene, &opts, method);
            for y in 4..28 {
                let at = |x: u32| img.pixels[(y * 32 + x) as usize];
                let (covered, edge, bare) = (at(15), at(16), at(17));
                for c in 0..3 {
                    let half = 0.5 * (covered[c] + bare[c]);
                    assert!(
                        (edge[c] - half).abs() < 1e-3,
                        "{method} row {y} channel {c}: {} vs {half}",
                        edge[c]
                    );
                }
                assert!((bare[0] - 0.2).abs() < 1e-6 && covered[0] != bare[0]);
            }
        }
    }
}
