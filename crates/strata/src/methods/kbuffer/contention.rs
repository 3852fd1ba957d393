//! The contention harness: a k-buffer's capture step, the same WGSL function its fragment
//! stage and the compute rasterizer call, driven from compute dispatches in which thousands of
//! invocations insert fragments into a handful of pixels at once, in a shuffled order; each
//! pixel's kept fragments and the counters are then compared with what the method must keep.
//!
//! Why: a pixel's fragments are shaded at the same time on a GPU, but lavapipe's fragment stage
//! never shades two fragments of one pixel at once, so the image tests cannot see a lock or a
//! cascade go wrong. Lavapipe runs compute workgroups on parallel CPU threads (`LP_NUM_THREADS`,
//! more threads than cores interleaving them at any instruction), which is real contention on a
//! machine without a GPU; on a GPU the same dispatches contend as fragments do.
//!
//! What it can show: fragments lost or stored twice, a wrong set kept, counts that disagree —
//! the results of a lock that does not exclude, a read-modify-write that is not atomic, a
//! publication that comes before what it publishes (where the scheduler interleaves them). What
//! it cannot show on lavapipe: weak memory ordering. x86 keeps stores in order and loads in order,
//! so a missing acquire or release shows only on a GPU (or any weakly ordered machine), where
//! the same harness runs as part of the tests.
//!
//! Passes: clear; poison (garbage in slots and nodes, as a frame may leave); capture (one
//! dispatch per capture pass, 64 invocations a workgroup, or one SIMD vector for ordered
//! captures where `gpu::ordered::workgroup_limit` says the driver needs it); gather (each
//! pixel's stored count and fragments through the method's own resolve accessors). Memory: the
//! method's storage for the handful of pixels.

use crate::gpu::twin::{gpu_struct, wgsl_module};

use super::{
    definitions, group_layout, KParams, COUNTERS, COUNTER_LOCK_FAILURES, COUNTER_LOST, LIBRARY,
};
use crate::error::{Error, Result};
use crate::frame::passes::compute_pipeline;
use crate::gpu::binding::{self, Slot};
use crate::gpu::shader::{Defs, Library, Stage};
use crate::gpu::Gpu;
use crate::methods::MethodId;
use crate::StorageLayout;

const HARNESS_WGSL: &str = include_str!("contention.wgsl");
/// Invocations of a capture workgroup, where the adapter runs ordered atomics in any.
const WORKGROUP: u32 = 64;

gpu_struct! {
    /// The harness's uniforms (`strata::kbuffer::harness_params`).
    struct HarnessParams {
        /// Fragments in the input.
        fragments: u32,
        /// Pixels they are spread over.
        pixels: u32,
        /// Fragments gathered per pixel (at most).
        capacity: u32,
        /// Which capture pass runs (methods of two passes).
        capture_pass: u32,
    }
}

/// The WGSL declaration of [`HarnessParams`].
const HARNESS_PARAMS: Library = &[wgsl_module!(
    "strata::kbuffer::harness_params",
    HarnessParams
)];

/// One run of the harness.
#[derive(Clone, Debug)]
pub struct Case {
    /// The k-buffer method under test.
    pub method: MethodId,
    /// Pixels the fragments are spread over.
    pub pixels: u32,
    /// Fragments per pixel.
    pub per_pixel: u32,
    /// Fragments a pixel keeps.
    pub k: u32,
    /// kplus-semiheap's heap size.
    pub heap_size: u32,
    /// Whether the capture culls behind a full pixel's farthest kept fragment.
    pub culling: bool,
    /// Distinct depths a pixel's fragments draw from: few make many exact ties.
    pub depths: u32,
    /// Seed of the fragments' depths and shuffle.
    pub seed: u64,
    /// Counted lock failures are allowed: each may cost its pixel one of its k nearest (the
    /// fragment went to the tail), and no more. On a CPU adapter with more threads than cores a
    /// lock holder can be descheduled for longer than any bounded spin; on a GPU none is allowed.
    pub allow_starvation: bool,
    /// How the per-pixel arrays lie: slot-major puts the handful of pixels' words and slots
    /// side by side in shared cache lines, pixel-major (the frames' default) apart.
    pub layout: StorageLayout,
}

impl Case {
    /// A case of `method` keeping `k` with the harness's default sizes, drawn from `seed`.
    pub fn new(method: MethodId, k: u32, seed: u64) -> Case {
        Case {
            method,
            pixels: 8,
            per_pixel: 512,
            k,
            heap_size: 3.min(k),
            culling: true,
            depths: 48,
            seed,
            allow_starvation: false,
            // Half the seeds in each layout.
            layout: if seed.is_multiple_of(2) {
                StorageLayout::Pixel
            } else {
                StorageLayout::Slot
            },
        }
    }
}

/// The methods the harness drives (`Descriptor::contended`), in catalogue order.
pub fn subjects() -> Vec<MethodId> {
    crate::methods::TABLE
        .iter()
        .filter(|d| d.contended)
        .map(|d| d.id)
        .collect()
}

/// The harness stage of `method` on a storage of its layout, `coherent` where the adapter
/// takes it: the harness entry points over the layout's accessors, and a module made for the
/// method (`strata::kbuffer::harness_step`) whose `harness_capture` is its capture step; and how
/// many capture passes it takes.
pub fn stage(method: MethodId, coherent: bool) -> Result<(Stage, u32)> {
    use MethodId::*;
    let layout = super::descriptor::layout_of(method).ok_or_else(|| {
        Error::unsupported(format!("the contention harness does not drive {method}"))
    })?;
    // Two passes for kb-keys: the keys' cascade, then the payloads of the keys that stayed.
    let (step, passes) = match (method, method.descriptor().capture_step) {
        (KbKeys, _) => ("if capture_pass == 0u {\n        strata::kbuffer::keys::cascade_key(p, f);\n    } else if !strata::kbuffer::keys::store_payload(p, f) {\n        strata::kbuffer::storage::tail_add(p, f);\n    }".to_owned(), 2),
        (_, Some(step)) => (format!("{step};"), 1),
        (_, None) => {
            return Err(Error::unsupported(format!(
                "{method} declares no capture step for the contention harness"
            )))
        }
    };
    let step_module = format!(
        "#define_import_path strata::kbuffer::harness_step\n#import strata::fragment::Fragment\n\nfn harness_capture(capture_pass: u32, p: u32, f: Fragment) {{\n    {step}\n}}\n"
    );
    let stage = Stage::new(format!("strata.contention.{method}"), HARNESS_WGSL)
        .with(LIBRARY)
        .with(HARNESS_PARAMS)
        .with_module(step_module)
        .defs(&definitions(layout, 1, coherent))
        // Each fragment has the same depth in both of kb-keys' passes, as on the hardware
        // rasterizer: its colors pass looks its key up by binary search.
        .defs(
            &Defs::default()
                .value("HARNESS_WORKGROUP", WORKGROUP)
                .flag("INVARIANT_DEPTH"),
        );
    Ok((stage, passes))
}

/// `stage` with a seeded defect: the family module holding `from` made with `to` in its place.
fn with_defect(stage: Stage, (from, to): (&str, &str)) -> Result<Stage> {
    let holder = LIBRARY
        .iter()
        .find(|source| source.contains(from))
        .ok_or_else(|| {
            Error::input(format!(
                "the defect's text is in no k-buffer module: {from}"
            ))
        })?;
    Ok(stage.with_module(holder.replace(from, to)))
}

/// A fragment as the harness feeds it: pixel, depth, tag.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Input {
    /// The pixel the fragment lands on.
    pub pixel: u32,
    /// Its depth.
    pub depth: f32,
    /// Its tag: primitive << 1 | front-facing.
    pub tag: u32,
}

/// Each pixel's fragments, shuffled across pixels: depths from `depths` values in (0, 1) (many
/// ties), tags unique per pixel (primitive i, alternating facing).
pub fn inputs(case: &Case) -> Vec<Input> {
    let mut state = case.seed.wrapping_mul(0x9e37_79b9_7f4a_7c15) | 1;
    let mut next = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        state
    };
    let mut all: Vec<Input> = (0..case.pixels)
        .flat_map(|pixel| (0..case.per_pixel).map(move |i| (pixel, i)))
        .map(|(pixel, i)| Input {
            pixel,
            depth: 0.0,
            tag: i << 1 | (i & 1),
        })
        .collect();
    for f in &mut all {
        f.depth = ((next() % case.depths as u64) as f32 + 0.5) / case.depths as f32;
    }
    for i in (1..all.len()).rev() {
        all.swap(i, (next() % (i as u64 + 1)) as usize);
    }
    all
}

/// What a run kept: per pixel the stored count and the stored (depth bits, tag) pairs in stored
/// order; the fragments each pixel saw; the counters.
#[derive(Clone, Debug, Default)]
pub struct Outcome {
    /// Each pixel's stored count.
    pub stored: Vec<u32>,
    /// Each pixel's stored (depth bits, tag) pairs, in stored order.
    pub kept: Vec<Vec<(u32, u32)>>,
    /// Fragments each pixel saw.
    pub seen: Vec<u32>,
    /// Fragments that gave up on a lock.
    pub lock_failures: u64,
    /// Fragments lost.
    pub lost: u64,
}

/// The pairs a pixel must keep: its `keep` nearest in (depth, tag) order.
fn nearest(inputs: &[Input], pixel: u32, keep: usize) -> Vec<(u32, u32)> {
    let mut mine: Vec<(f32, u32)> = inputs
        .iter()
        .filter(|f| f.pixel == pixel)
        .map(|f| (f.depth, f.tag))
        .collect();
    mine.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    mine.truncate(keep);
    mine.into_iter().map(|(d, t)| (d.to_bits(), t)).collect()
}

/// Checks an outcome against what the method must keep: each pixel saw all its fragments, no
/// lock failed and nothing was lost, and each pixel keeps exactly its k nearest (every
/// fragment for `abuffer-ll`; the first k of `kb-ll`'s sorted list). The first few
/// disagreements are named.
pub fn check(case: &Case, inputs: &[Input], outcome: &Outcome) -> std::result::Result<(), String> {
    let mut problems = Vec::new();
    if outcome.lock_failures > 0 && !case.allow_starvation {
        problems.push(format!("{} lock failures", outcome.lock_failures));
    }
    // Fragments a counted lock failure sent to the tail, which a pixel's kept set may lack.
    let mut starved = if case.allow_starvation {
        outcome.lock_failures
    } else {
        0
    };
    if outcome.lost > 0 {
        problems.push(format!("{} fragments lost", outcome.lost));
    }
    let k = case.k.min(case.per_pixel) as usize;
    for p in 0..case.pixels {
        let seen = outcome.seen[p as usize];
        if seen != case.per_pixel {
            problems.push(format!("pixel {p} saw {seen} of {}", case.per_pixel));
        }
        let (expected_count, keep) = match case.method {
            MethodId::AbufferLl => (case.per_pixel as usize, case.per_pixel as usize),
            // The list holds every fragment linked while it was among the k nearest.
            MethodId::KbLl => (outcome.stored[p as usize] as usize, k),
            _ => (k, k),
        };
        let stored = outcome.stored[p as usize] as usize;
        // A starved fragment among a pixel's first k leaves the pixel one short only while
        // fewer than k others arrived; any other count is a defect.
        let short = expected_count.saturating_sub(stored) as u64;
        if stored != expected_count && !(stored < expected_count && short <= starved) {
            problems.push(format!(
                "pixel {p} stores {stored}, expected {expected_count}"
            ));
            continue;
        }
        let mut kept = outcome.kept[p as usize].clone();
        if case.method == MethodId::KbLl {
            if kept.windows(2).any(|w| {
                let key = |(d, t): (u32, u32)| (f32::from_bits(d), t);
                let (a, b) = (key(w[0]), key(w[1]));
                a.0 > b.0 || (a.0 == b.0 && a.1 >= b.1)
            }) {
                problems.push(format!("pixel {p}: kb-ll's list is out of order"));
                continue;
            }
            kept.truncate(keep);
        }
        kept.sort_by(|a, b| {
            f32::from_bits(a.0)
                .total_cmp(&f32::from_bits(b.0))
                .then(a.1.cmp(&b.1))
        });
        // With s starved fragments the kept set is the k nearest of the others: it lies within
        // the k + s nearest and lacks at most s of the k nearest.
        let slack = starved.min(case.per_pixel as u64) as usize;
        let expected = nearest(inputs, p, keep);
        let within = nearest(inputs, p, keep + slack);
        let missing = expected.iter().filter(|e| !kept.contains(e)).count();
        let duplicates = kept.windows(2).filter(|w| w[0] == w[1]).count();
        let outside = kept.iter().filter(|f| !within.contains(f)).count();
        if kept != expected && (missing > slack || duplicates > 0 || outside > 0) {
            problems.push(format!(
                "pixel {p}: kept set differs ({missing} of its {keep} nearest missing, {duplicates} stored twice, {outside} beyond the {} nearest)",
                keep + slack
            ));
        }
        starved -= (missing as u64).min(starved);
    }
    if problems.is_empty() {
        Ok(())
    } else {
        let shown = problems.len().min(6);
        Err(format!(
            "{} (k = {}, {} pixels × {}, seed {}): {}{}",
            case.method,
            case.k,
            case.pixels,
            case.per_pixel,
            case.seed,
            problems[..shown].join("; "),
            if problems.len() > shown {
                format!("; and {} more", problems.len() - shown)
            } else {
                String::new()
            }
        ))
    }
}

/// A method's harness pipelines: built once, run for many cases.
pub struct Harness<'g> {
    gpu: &'g Gpu,
    method: MethodId,
    passes: u32,
    /// Whether the capture runs with acquire/release atomics.
    pub ordered: bool,
    /// Invocations of a capture workgroup.
    pub workgroup: u32,
    empty: wgpu::BindGroupLayout,
    kbuffer: wgpu::BindGroupLayout,
    layout: wgpu::BindGroupLayout,
    capture: wgpu::ComputePipeline,
    gather: wgpu::ComputePipeline,
}

impl<'g> Harness<'g> {
    /// The harness of `method`, its capture ordered where `ordered` asks and the adapter can,
    /// its source changed by `defect` (seeded protocol defects).
    pub fn new(
        gpu: &'g Gpu,
        method: MethodId,
        ordered: bool,
        defect: Option<(&str, &str)>,
    ) -> Result<Harness<'g>> {
        let coherent = gpu.has(wgpu::Features::MEMORY_DECORATION_COHERENT);
        let (mut stage, passes) = stage(method, coherent)?;
        if let Some(defect) = defect {
            stage = with_defect(stage, defect)?;
        }
        if method == MethodId::KbKeys && !gpu.has(wgpu::Features::SHADER_INT64_ATOMIC_ALL_OPS) {
            return Err(Error::unsupported(format!(
                "kb-keys needs SHADER_INT64_ATOMIC_ALL_OPS, which '{}' lacks",
                gpu.info.name
            )));
        }
        let device = &gpu.device;
        let label = stage.label.clone();
        let ordered = ordered && crate::gpu::ordered::available(gpu);
        let workgroup = match ordered {
            true => crate::gpu::ordered::ordered_workgroup(gpu, WORKGROUP),
            false => WORKGROUP,
        };
        let stage = stage.defs(&Defs::default().value("HARNESS_WORKGROUP", workgroup));
        let ordered_module = match ordered {
            true => crate::gpu::ordered::module(gpu, &stage),
            false => None,
        };
        let ordered = ordered_module.is_some();
        let module = ordered_module.unwrap_or_else(|| stage.module(device));
        let empty = binding::layout(device, "strata.contention.empty", &[]);
        let kbuffer = group_layout(gpu);
        let layout = binding::layout(
            device,
            "strata.contention.layout",
            &[Slot::Uniform, Slot::Storage, Slot::StorageRw],
        );
        let layouts = [&empty, &kbuffer, &layout];
        let capture = compute_pipeline(gpu, &label, (&module, "cs_harness_capture"), &layouts);
        let gather = compute_pipeline(gpu, &label, (&module, "cs_harness_gather"), &layouts);
        Ok(Harness {
            gpu,
            method,
            passes,
            ordered,
            workgroup,
            empty,
            kbuffer,
            layout,
            capture,
            gather,
        })
    }

    /// Runs one case (its method must be the harness's): returns its inputs and outcome.
    pub fn run(&self, case: &Case) -> Result<(Vec<Input>, Outcome)> {
        assert_eq!(case.method, self.method, "a harness runs its own method");
        let gpu = self.gpu;
        let device = &gpu.device;
        let inputs = inputs(case);
        let pixels = case.pixels as u64;
        let fragments = inputs.len() as u64;
        let params = KParams {
            k: case.k,
            stride: case.k,
            // The longest spin allowed: what is measured is the protocol, not the try budget.
            max_tries: super::MAX_TRIES_LIMIT,
            culling: case.culling as u32,
            tail_blend: 0,
            aux: if case.method == MethodId::KplusSemiheap {
                case.heap_size
            } else {
                0
            },
            width: case.pixels,
            pixels: case.pixels,
            sample_slots: 1,
            tail_weight: 0,
            tail_depth_p: 0.0,
            tail_depth_q: 0.0,
            storage_layout: case.layout.index(),
        };
        let (storage_bytes, poison) = match case.method {
            MethodId::AbufferLl | MethodId::KbLl => (20 * fragments, true),
            // Keys of 0 mark empty slots: the method clears them.
            MethodId::KbKeys => (16 * pixels * case.k as u64, false),
            _ => (16 * pixels * case.k as u64, true),
        };
        let readable = wgpu::BufferUsages::COPY_SRC;
        let buffer = |name: &str, bytes: u64| gpu.storage_buffer(name, bytes, readable);
        let storage = buffer("strata.contention.storage", storage_bytes)?;
        if poison {
            gpu.queue
                .write_buffer(&storage, 0, &crate::gpu::garbage(storage.size()));
        }
        let pixel_words = buffer("strata.contention.pixels", 16 * pixels + 4 * pixels)?;
        let counters = buffer("strata.contention.counters", COUNTERS * 4)?;
        let uniform = |label: &str, contents: &[u8]| {
            let b = device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: contents.len() as u64,
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            });
            gpu.queue.write_buffer(&b, 0, contents);
            b
        };
        let params_buffer = uniform("strata.contention.params", bytemuck::bytes_of(&params));
        // The tail (dropped: tail_blend 0), kpeel's output and temporal culling's bindings
        // (off: its parameters are zero) are bound but unused.
        let unused: Vec<wgpu::Buffer> = [40, 64, 256, 16, 4 * pixels + 16, 16, 64]
            .into_iter()
            .map(|bytes| buffer("strata.contention.unused", bytes))
            .collect::<Result<_>>()?;
        let mut resources = vec![
            params_buffer.as_entire_binding(),
            storage.as_entire_binding(),
            pixel_words.as_entire_binding(),
            counters.as_entire_binding(),
        ];
        resources.extend(unused.iter().map(|b| b.as_entire_binding()));
        let group = binding::group(device, "strata.contention.group", &self.kbuffer, &resources);
        let capacity = case.per_pixel;
        let words: Vec<[u32; 4]> = inputs
            .iter()
            .map(|f| [f.pixel, f.depth.to_bits(), f.tag, 0x3c00_3c00])
            .collect();
        let input_buffer = buffer("strata.contention.input", 16 * fragments)?;
        gpu.queue
            .write_buffer(&input_buffer, 0, bytemuck::cast_slice(&words));
        let stride = 1 + 2 * capacity as u64;
        let gathered = buffer("strata.contention.gathered", 4 * pixels * stride)?;
        let harness_groups: Vec<wgpu::BindGroup> = (0..=self.passes)
            .map(|pass| {
                let p = HarnessParams {
                    fragments: fragments as u32,
                    pixels: case.pixels,
                    capacity,
                    capture_pass: pass,
                };
                let b = uniform("strata.contention.harness", bytemuck::bytes_of(&p));
                binding::group(
                    device,
                    "strata.contention.harness",
                    &self.layout,
                    &[
                        b.as_entire_binding(),
                        input_buffer.as_entire_binding(),
                        gathered.as_entire_binding(),
                    ],
                )
            })
            .collect();
        let none = binding::group(device, "strata.contention.none", &self.empty, &[]);
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("strata.contention"),
        });
        encoder.clear_buffer(&pixel_words, 0, None);
        encoder.clear_buffer(&counters, 0, None);
        if !poison {
            encoder.clear_buffer(&storage, 0, None);
        }
        for pass in 0..=self.passes {
            let (pipeline, workgroups) = if pass < self.passes {
                (&self.capture, fragments.div_ceil(self.workgroup as u64))
            } else {
                (&self.gather, pixels.div_ceil(64))
            };
            // Each pass in a compute pass of its own, as a method's geometry passes are.
            let mut cp = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("strata.contention.pass"),
                timestamp_writes: None,
            });
            cp.set_pipeline(pipeline);
            cp.set_bind_group(0, &none, &[]);
            cp.set_bind_group(1, &group, &[]);
            cp.set_bind_group(2, &harness_groups[pass as usize], &[]);
            cp.dispatch_workgroups(workgroups as u32, 1, 1);
        }
        gpu.queue.submit([encoder.finish()]);
        let read = |b: &wgpu::Buffer, n: u64| crate::gpu::readback::read_u32s(gpu, b, n);
        let out = read(&gathered, pixels * stride)?;
        let words = read(&pixel_words, 4 * pixels)?;
        let counts = read(&counters, COUNTERS)?;
        let wide = |at: usize| counts[at] as u64 | (counts[at + 1] as u64) << 32;
        let stride = stride as usize;
        let outcome = Outcome {
            stored: (0..pixels as usize).map(|p| out[p * stride]).collect(),
            kept: (0..pixels as usize)
                .map(|p| {
                    let n = (out[p * stride] as usize).min(capacity as usize);
                    (0..n)
                        .map(|i| (out[p * stride + 1 + 2 * i], out[p * stride + 2 + 2 * i]))
                        .collect()
                })
                .collect(),
            seen: (0..pixels)
                .map(|p| {
                    words[case
                        .layout
                        .item(p, super::SEEN_WORD, super::PIXEL_WORDS, pixels)
                        as usize]
                })
                .collect(),
            lock_failures: wide(COUNTER_LOCK_FAILURES),
            lost: wide(COUNTER_LOST),
        };
        Ok((inputs, outcome))
    }
}

#[cfg(test)]
mod tests;
