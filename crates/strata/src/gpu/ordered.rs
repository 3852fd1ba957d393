//! Acquire/release atomics for capture stages, where the adapter takes SPIR-V passthrough
//! shaders (`PASSTHROUGH_SHADERS`, Vulkan).
//!
//! WGSL atomics are relaxed and naga 30 has no way to ask for more. Here the composed WGSL of a
//! capture stage is compiled by naga to SPIR-V as wgpu would (restricted indexing, bounded
//! loops), then the atomics of the functions whose names ask for it get memory semantics on
//! storage memory (UniformMemory), which orders the function's atomic and the plain and relaxed
//! accesses around it:
//! - `acquire_*`: loads, read-modify-writes and both cases of a compare-exchange Acquire (taking
//!   the lock; reading a publication count or a list link before what it publishes);
//! - `release_*`: stores, read-modify-writes and the success case of a compare-exchange
//!   Release (dropping the lock; publishing a count or a link after the stores it covers).
//!
//! Every other atomic stays relaxed: a slot access inside the lock is ordered by the lock's
//! acquire and release, and on NVIDIA each ordered access is a fence or an L1 bypass, which
//! would lengthen the critical section every waiter queues behind. A function with an ordering
//! name whose atomic cannot take that ordering (an acquire store, a release load) is an error.
//! The vertex stage stays on wgpu's own path.

use std::borrow::Cow;
use std::collections::HashMap;

use crate::gpu::shader::Stage;
use crate::gpu::Gpu;

const OP_NAME: u32 = 5;
const OP_TYPE_INT: u32 = 21;
const OP_CONSTANT: u32 = 43;
const OP_FUNCTION: u32 = 54;
const OP_FUNCTION_END: u32 = 56;
const OP_ATOMIC_LOAD: u32 = 227;
const OP_ATOMIC_STORE: u32 = 228;
const OP_ATOMIC_EXCHANGE: u32 = 229;
const OP_ATOMIC_COMPARE_EXCHANGE: u32 = 230;
const OP_ATOMIC_COMPARE_EXCHANGE_WEAK: u32 = 231;
/// OpAtomicIIncrement … OpAtomicXor: result type, result, pointer, scope, semantics, (value).
const OP_ATOMIC_RMW: std::ops::RangeInclusive<u32> = 232..=242;

const UNIFORM_MEMORY: u32 = 0x40;
const ACQUIRE: u32 = 0x2;
const RELEASE: u32 = 0x4;

/// The ordering a WGSL function asks of the atomics in its body, by the start of its name.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Order {
    /// The function's atomics are acquire loads (`acquire_` functions).
    Acquire,
    /// The function's atomics are release stores (`release_` functions).
    Release,
}

impl Order {
    /// The ordering `function`'s name asks for, if any.
    pub fn of(function: &str) -> Option<Order> {
        if function.starts_with("acquire_") {
            Some(Order::Acquire)
        } else if function.starts_with("release_") {
            Some(Order::Release)
        } else {
            None
        }
    }
}

/// Whether captures on this adapter can be given acquire/release atomics.
pub fn available(gpu: &Gpu) -> bool {
    gpu.has(wgpu::Features::PASSTHROUGH_SHADERS)
        && gpu.info.backend == wgpu::Backend::Vulkan
        && !relaxed_for_diagnosis()
}

/// The largest compute workgroup whose acquire/release atomics this adapter runs correctly, where
/// that is less than any size: `Some(lanes of one SIMD vector)` on llvmpipe (lavapipe) from Mesa
/// releases before 22.3.7 (and, to be safe, 23.0), else `None`.
///
/// Why: SPIR-V atomics with Acquire or Release semantics become NIR memory barriers before or
/// after the atomic. Those llvmpipe releases compile every such barrier in a compute shader as a
/// workgroup *control* barrier: a coroutine yield (Mesa fixed it in 2178a8da51fe, "gallivm: Fix
/// handling of nir_intrinsic_scoped_barrier", released in 22.3.7). A workgroup runs as one
/// coroutine per SIMD vector of invocations, resumed in turn, and the scheduler stops resuming
/// the others once one has finished: the vectors that passed more ordered atomics (more lock
/// tries, a longer list walk) never finish, and their fragments are lost. With one vector per
/// workgroup every invocation finishes. Measured with the contention harness on Mesa 22.3.6
/// (8 lanes): ordered kb-ll and kplus-array failed every run with workgroups of 64 and of 16
/// invocations (kplus-array also starved: 147 s for 4 runs) and passed every run with 8 (0.7 s).
/// The fragment stage is unaffected: lavapipe drops memory barriers there.
pub fn workgroup_limit(gpu: &Gpu) -> Option<u32> {
    barrier_yield_lanes(&gpu.info.driver, &gpu.info.driver_info, &gpu.info.name)
}

/// The workgroup size for a compute stage with ordered atomics that would have `preferred`
/// invocations: at most [`workgroup_limit`].
pub fn ordered_workgroup(gpu: &Gpu, preferred: u32) -> u32 {
    workgroup_limit(gpu).map_or(preferred, |lanes| lanes.min(preferred))
}

/// [`workgroup_limit`] from an adapter's driver name, driver version text ("Mesa 22.3.6 (LLVM
/// 15.0.6)") and name ("llvmpipe (LLVM 15.0.6, 256 bits)", which gives the vector width; 128
/// bits where it does not).
pub fn barrier_yield_lanes(driver: &str, driver_info: &str, adapter: &str) -> Option<u32> {
    if driver != "llvmpipe" && !adapter.starts_with("llvmpipe") {
        return None;
    }
    let version: Vec<u32> = driver_info
        .split_whitespace()
        .skip_while(|w| *w != "Mesa")
        .nth(1)
        .map(|v| v.split(['.', '-']).map_while(|n| n.parse().ok()).collect())
        .unwrap_or_default();
    let fixed = match version.as_slice() {
        [major, minor, patch, ..] => {
            (*major, *minor, *patch) >= (22, 3, 7) && (*major, *minor) != (23, 0)
        }
        _ => false,
    };
    if fixed {
        return None;
    }
    let bits = adapter
        .split([',', '(', ')'])
        .filter_map(|part| part.trim().strip_suffix(" bits"))
        .find_map(|n| n.trim().parse::<u32>().ok())
        .unwrap_or(128);
    // A power of two (a divisor of the rasterizer's 64 items per workgroup) within one vector.
    Some(1 << (bits / 32).clamp(1, 64).ilog2())
}

/// `STRATA_RELAXED_CAPTURES=1`, a diagnostic: every capture keeps WGSL's relaxed atomics even
/// where the adapter has the ordered path, and the methods that need ordering run without it
/// instead of being refused (their `memory_ordering` says so). Comparing a GPU run with and
/// without it tells a fault of the acquire/release modules from one of a method's protocol. It
/// is unsound wherever fragments of one pixel run at once: never for pictures.
pub fn relaxed_for_diagnosis() -> bool {
    std::env::var_os("STRATA_RELAXED_CAPTURES").is_some_and(|v| v == "1")
}

/// A SPIR-V literal string's text (UTF-8, NUL-terminated, packed little-endian in words).
fn literal_string(words: &[u32]) -> String {
    let bytes: Vec<u8> = words
        .iter()
        .flat_map(|w| w.to_le_bytes())
        .take_while(|&b| b != 0)
        .collect();
    String::from_utf8_lossy(&bytes).into_owned()
}

/// Which atomics the rewrite ordered: (function name, opcode, order), in module order.
pub type OrderedAtomics = Vec<(String, u32, Order)>;

/// Gives the atomics of the `acquire_*` and `release_*` functions of a SPIR-V module (compiled
/// with names, `WriterFlags::DEBUG`) their ordering on storage memory; returns the module and the
/// atomics it ordered. A module without a 32-bit unsigned integer type has no atomics and is
/// returned as it is.
pub fn with_ordering(words: &[u32]) -> Result<(Vec<u32>, OrderedAtomics), String> {
    const HEADER: usize = 5;
    let instructions = || {
        let mut at = HEADER;
        std::iter::from_fn(move || {
            (at < words.len()).then(|| {
                let count = ((words[at] >> 16) as usize).max(1);
                let range = at..(at + count).min(words.len());
                at += count;
                range
            })
        })
    };
    let mut uint = None;
    let mut names = HashMap::new();
    for range in instructions() {
        let ins = &words[range];
        match ins[0] & 0xffff {
            OP_TYPE_INT if uint.is_none() && ins.get(2) == Some(&32) && ins.get(3) == Some(&0) => {
                uint = Some(ins[1])
            }
            OP_NAME if ins.len() > 2 => {
                names.insert(ins[1], literal_string(&ins[2..]));
            }
            _ => {}
        }
    }
    let Some(uint) = uint else {
        return Ok((words.to_vec(), Vec::new()));
    };
    let bound = words[3];
    let (acquire, release) = (bound, bound + 1);
    let mut out = Vec::with_capacity(words.len() + 8);
    out.extend_from_slice(&words[..HEADER]);
    out[3] = bound + 2;
    let mut ordered = Vec::new();
    let mut function: Option<(&str, Order)> = None;
    for range in instructions() {
        let mut ins = words[range].to_vec();
        let op = ins[0] & 0xffff;
        match op {
            OP_FUNCTION if ins.len() > 2 => {
                function = names
                    .get(&ins[2])
                    .and_then(|name| Order::of(name).map(|o| (name.as_str(), o)));
            }
            OP_FUNCTION_END => function = None,
            _ => {}
        }
        if let Some((name, order)) = function {
            let is_rmw = OP_ATOMIC_RMW.contains(&op) || op == OP_ATOMIC_EXCHANGE;
            let semantics: &[(usize, u32)] = match (op, order) {
                (OP_ATOMIC_LOAD, Order::Acquire) => &[(5, acquire)],
                (OP_ATOMIC_STORE, Order::Release) => &[(3, release)],
                (OP_ATOMIC_COMPARE_EXCHANGE | OP_ATOMIC_COMPARE_EXCHANGE_WEAK, Order::Acquire) => {
                    &[(5, acquire), (6, acquire)]
                }
                (OP_ATOMIC_COMPARE_EXCHANGE | OP_ATOMIC_COMPARE_EXCHANGE_WEAK, Order::Release) => {
                    &[(5, release)]
                }
                (_, Order::Acquire) if is_rmw => &[(5, acquire)],
                (_, Order::Release) if is_rmw => &[(5, release)],
                (OP_ATOMIC_LOAD | OP_ATOMIC_STORE, _) => {
                    return Err(format!(
                        "{name}: an atomic {} cannot be {order:?}",
                        if op == OP_ATOMIC_LOAD {
                            "load"
                        } else {
                            "store"
                        }
                    ))
                }
                _ => &[],
            };
            for &(operand, id) in semantics {
                if operand < ins.len() {
                    ins[operand] = id;
                }
            }
            if !semantics.is_empty() {
                ordered.push((name.to_string(), op, order));
            }
        }
        out.extend_from_slice(&ins);
        if op == OP_TYPE_INT && ins.get(1) == Some(&uint) {
            for (id, value) in [
                (acquire, UNIFORM_MEMORY | ACQUIRE),
                (release, UNIFORM_MEMORY | RELEASE),
            ] {
                out.extend_from_slice(&[4 << 16 | OP_CONSTANT, uint, id, value]);
            }
        }
    }
    Ok((out, ordered))
}

/// An entry point's name and workgroup size (zero for render stages).
pub type EntryPoint = (String, [u32; 3]);

/// Compiles a composed stage to SPIR-V the way wgpu does for Vulkan, with the ordering its
/// `acquire_*` and `release_*` functions ask for (naga_oil keeps an imported function's name
/// as the prefix of its decorated one).
pub fn spirv(stage: &Stage) -> Result<(Vec<u32>, Vec<EntryPoint>), String> {
    spirv_of(&stage.label, &stage.compose()?)
}

/// [`spirv`] of a module already composed (an application's shader with strata's capture,
/// `frame::application`): its `acquire_*` and `release_*` functions order their atomics.
pub fn spirv_of(label: &str, module: &naga::Module) -> Result<(Vec<u32>, Vec<EntryPoint>), String> {
    let info = naga::valid::Validator::new(
        naga::valid::ValidationFlags::all(),
        naga::valid::Capabilities::all(),
    )
    .validate(module)
    .map_err(|e| format!("{label}: {e}"))?;
    let restrict = naga::proc::BoundsCheckPolicy::Restrict;
    let options = naga::back::spv::Options {
        bounds_check_policies: naga::proc::BoundsCheckPolicies {
            index: restrict,
            buffer: restrict,
            image_load: restrict,
            binding_array: restrict,
        },
        force_loop_bounding: true,
        ..Default::default()
    };
    // Function names, which say which atomics are ordered (release builds leave them out).
    let options = naga::back::spv::Options {
        flags: options.flags | naga::back::spv::WriterFlags::DEBUG,
        ..options
    };
    let words = naga::back::spv::write_vec(module, &info, &options, None)
        .map_err(|e| format!("{label}: {e}"))?;
    let entries = module
        .entry_points
        .iter()
        .map(|e| (e.name.clone(), e.workgroup_size))
        .collect();
    let (words, _) = with_ordering(&words).map_err(|e| format!("{label}: {e}"))?;
    Ok((words, entries))
}

/// A passthrough shader module of `stage` with acquire/release atomics, or `None` where the
/// adapter cannot take one or the compilation fails (the caller then uses the stage's own
/// module: relaxed atomics).
pub fn module(gpu: &Gpu, stage: &Stage) -> Option<wgpu::ShaderModule> {
    if !available(gpu) {
        return None;
    }
    match spirv(stage) {
        Ok(compiled) => Some(passthrough(gpu, &stage.label, compiled)),
        Err(e) => {
            log::warn!("{e}; using relaxed atomics");
            None
        }
    }
}

/// The passthrough shader module of SPIR-V that [`spirv`] or [`spirv_of`] made (only where
/// [`available`]).
pub fn passthrough(
    gpu: &Gpu,
    label: &str,
    (words, entries): (Vec<u32>, Vec<EntryPoint>),
) -> wgpu::ShaderModule {
    let entry_points: Vec<wgpu::PassthroughShaderEntryPoint<'_>> = entries
        .iter()
        .map(|(name, size)| wgpu::PassthroughShaderEntryPoint {
            name: Cow::Borrowed(name.as_str()),
            // Render stages have none (naga says 0); compute captures (the compute rasterizer)
            // need theirs.
            workgroup_size: (size[0].max(1), size[1].max(1), size[2].max(1)),
        })
        .collect();
    // SAFETY: the SPIR-V is naga's output for a module naga validated, with only the memory
    // semantics operands of its atomic instructions changed to valid values for their opcodes;
    // its bindings are the WGSL's group and binding numbers, which equal their positions in
    // strata's contiguous layouts.
    unsafe {
        gpu.device
            .create_shader_module_passthrough(wgpu::ShaderModuleDescriptorPassthrough {
                label: Some(label),
                entry_points: Cow::Owned(entry_points),
                spirv: Some(Cow::Owned(words)),
                ..Default::default()
            })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::methods::kbuffer::{definitions, Layout, LIBRARY, SLOTS_ENTRIES_WGSL};

    /// The slot methods' capture stage.
    fn slots_capture() -> Stage {
        Stage::new("slots.capture", SLOTS_ENTRIES_WGSL)
            .with(LIBRARY)
            .defs(&definitions(Layout::Slots, 1, false))
    }

    /// The atomics of a module and the semantics operand of each (the word's value is an id).
    fn atomics(words: &[u32]) -> Vec<(u32, Vec<u32>)> {
        let mut all = Vec::new();
        let mut at = 5;
        while at < words.len() {
            let count = ((words[at] >> 16) as usize).max(1);
            let op = words[at] & 0xffff;
            if (OP_ATOMIC_LOAD..=242).contains(&op) {
                let operands = match op {
                    OP_ATOMIC_STORE => vec![3],
                    OP_ATOMIC_COMPARE_EXCHANGE | OP_ATOMIC_COMPARE_EXCHANGE_WEAK => vec![5, 6],
                    _ => vec![5],
                };
                all.push((op, operands.iter().map(|&o| words[at + o]).collect()));
            }
            at += count;
        }
        all
    }

    /// In a lock-based capture only the lock and the publication words are ordered: the lock's
    /// exchange acquires, its release store releases, the direct stores' count is published
    /// with a release add and read with an acquire load; every slot access stays relaxed.
    #[test]
    fn only_the_lock_and_publication_words_are_ordered() {
        let module = slots_capture().compose().unwrap();
        let info = naga::valid::Validator::new(
            naga::valid::ValidationFlags::all(),
            naga::valid::Capabilities::all(),
        )
        .validate(&module)
        .unwrap();
        let options = naga::back::spv::Options {
            flags: naga::back::spv::WriterFlags::DEBUG,
            ..Default::default()
        };
        let words = naga::back::spv::write_vec(&module, &info, &options, None).unwrap();
        let (patched, ordered) = with_ordering(&words).unwrap();
        let has = |name: &str, op: u32, order: Order| {
            ordered
                .iter()
                .any(|(n, o, r)| n.starts_with(name) && *o == op && *r == order)
        };
        assert!(
            has("acquire_lock", OP_ATOMIC_EXCHANGE, Order::Acquire),
            "{ordered:?}"
        );
        assert!(
            has("release_lock", OP_ATOMIC_STORE, Order::Release),
            "{ordered:?}"
        );
        assert!(has("release_published", 234, Order::Release), "{ordered:?}");
        assert!(
            has("acquire_published", OP_ATOMIC_LOAD, Order::Acquire),
            "{ordered:?}"
        );
        let (bound, before, after) = (words[3], atomics(&words), atomics(&patched));
        assert_eq!(before.len(), after.len());
        assert!(after.len() > 20, "{} atomics", after.len());
        // The new constants are the two ids past the old bound.
        let ordered_ids = |(_, ids): &(u32, Vec<u32>)| ids.iter().any(|&id| id >= bound);
        assert_eq!(
            after.iter().filter(|a| ordered_ids(a)).count(),
            ordered.len()
        );
        assert!(before.iter().all(|a| !ordered_ids(a)));
        assert!(ordered.len() < after.len() / 4, "{ordered:?}");
        assert_eq!(patched.len(), words.len() + 8);
        assert_eq!(patched[3], bound + 2);
        // What the device compiles is the same rewrite.
        let (compiled, _) = spirv(&slots_capture()).unwrap();
        assert_eq!(
            atomics(&compiled).iter().filter(|a| ordered_ids(a)).count(),
            ordered.len()
        );
    }

    /// Lavapipe before Mesa 22.3.7 gets workgroups of one SIMD vector for ordered atomics;
    /// later lavapipe and other drivers get any size.
    #[test]
    fn old_lavapipe_gets_one_vector_workgroups() {
        let name = "llvmpipe (LLVM 15.0.6, 256 bits)";
        assert_eq!(
            barrier_yield_lanes("llvmpipe", "Mesa 22.3.6 (LLVM 15.0.6)", name),
            Some(8)
        );
        assert_eq!(
            barrier_yield_lanes(
                "llvmpipe",
                "Mesa 21.2.6",
                "llvmpipe (LLVM 12.0.0, 512 bits)"
            ),
            Some(16)
        );
        assert_eq!(
            barrier_yield_lanes("llvmpipe", "Mesa 23.0.4", "llvmpipe (LLVM 15)"),
            Some(4)
        );
        assert_eq!(barrier_yield_lanes("llvmpipe", "", name), Some(8));
        assert_eq!(
            barrier_yield_lanes("llvmpipe", "Mesa 22.3.7 (LLVM 15.0.6)", name),
            None
        );
        assert_eq!(
            barrier_yield_lanes(
                "llvmpipe",
                "Mesa 24.2.8-1ubuntu1~24.04.1 (LLVM 19.1.1)",
                name
            ),
            None
        );
        assert_eq!(
            barrier_yield_lanes("NVIDIA", "570.195.03", "NVIDIA H100 80GB HBM3"),
            None
        );
    }

    /// An ordering an atomic cannot take is refused, naming the function.
    #[test]
    fn an_acquire_store_is_refused() {
        let source = "@group(0) @binding(0) var<storage, read_write> w: array<atomic<u32>>;\n\
            fn acquire_wrong(i: u32) { atomicStore(&w[i], 1u); }\n\
            @compute @workgroup_size(1) fn main() { acquire_wrong(0u); }";
        let err = spirv(&Stage::new("test", source)).unwrap_err();
        assert!(
            err.contains("acquire_wrong") && err.contains("store"),
            "{err}"
        );
    }
}
