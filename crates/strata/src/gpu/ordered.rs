//! Acquire/release atomics for capture stages, where the adapter takes SPIR-V passthrough
//! shaders (`PASSTHROUGH_SHADERS`, Vulkan).
//!
//! WGSL atomics are relaxed and naga 30 has no way to ask for more: a lock holder's slot stores
//! are visible to the next holder in practice, not by guarantee. Here the composed WGSL of a
//! capture stage is compiled by naga to SPIR-V as wgpu would (restricted indexing, bounded
//! loops), then every atomic instruction gets memory semantics on storage memory
//! (UniformMemory): loads Acquire, stores Release, read-modify-writes AcquireRelease, the
//! failure case of a compare-exchange Acquire. The lock's exchange then acquires the previous
//! holder's writes and the unlock releases this holder's; a published count or list link
//! releases the stores before it. The vertex stage stays on wgpu's own path.

use std::borrow::Cow;

use crate::gpu::Gpu;

const OP_TYPE_INT: u32 = 21;
const OP_CONSTANT: u32 = 43;
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
const ACQUIRE_RELEASE: u32 = 0x8;

/// Whether captures on this adapter can be given acquire/release atomics.
pub fn available(gpu: &Gpu) -> bool {
    gpu.has(wgpu::Features::PASSTHROUGH_SHADERS) && gpu.info.backend == wgpu::Backend::Vulkan
}

/// Gives every atomic instruction of a SPIR-V module acquire/release semantics on storage
/// memory; returns the module and how many instructions changed. A module without a 32-bit
/// unsigned integer type has no atomics to change and is returned as it is.
pub fn with_acquire_release(words: &[u32]) -> (Vec<u32>, usize) {
    const HEADER: usize = 5;
    let mut uint = None;
    let mut at = HEADER;
    while at < words.len() {
        let (count, op) = ((words[at] >> 16) as usize, words[at] & 0xffff);
        if op == OP_TYPE_INT && words[at + 2] == 32 && words[at + 3] == 0 {
            uint = Some(words[at + 1]);
            break;
        }
        at += count.max(1);
    }
    let Some(uint) = uint else {
        return (words.to_vec(), 0);
    };
    let bound = words[3];
    let (acquire, release, acquire_release) = (bound, bound + 1, bound + 2);
    let mut out = Vec::with_capacity(words.len() + 12);
    out.extend_from_slice(&words[..HEADER]);
    out[3] = bound + 3;
    let mut changed = 0;
    let mut at = HEADER;
    while at < words.len() {
        let count = ((words[at] >> 16) as usize).max(1);
        let op = words[at] & 0xffff;
        let mut instruction = words[at..(at + count).min(words.len())].to_vec();
        let semantics: &[(usize, u32)] = match op {
            OP_ATOMIC_LOAD => &[(5, acquire)],
            OP_ATOMIC_STORE => &[(3, release)],
            OP_ATOMIC_EXCHANGE => &[(5, acquire_release)],
            OP_ATOMIC_COMPARE_EXCHANGE | OP_ATOMIC_COMPARE_EXCHANGE_WEAK => {
                &[(5, acquire_release), (6, acquire)]
            }
            op if OP_ATOMIC_RMW.contains(&op) => &[(5, acquire_release)],
            _ => &[],
        };
        for &(operand, id) in semantics {
            if operand < instruction.len() {
                instruction[operand] = id;
            }
        }
        changed += !semantics.is_empty() as usize;
        out.extend_from_slice(&instruction);
        if op == OP_TYPE_INT && instruction.get(1) == Some(&uint) {
            for (id, value) in [
                (acquire, UNIFORM_MEMORY | ACQUIRE),
                (release, UNIFORM_MEMORY | RELEASE),
                (acquire_release, UNIFORM_MEMORY | ACQUIRE_RELEASE),
            ] {
                out.extend_from_slice(&[4 << 16 | OP_CONSTANT, uint, id, value]);
            }
        }
        at += count;
    }
    (out, changed)
}

/// An entry point's name and workgroup size (zero for render stages).
pub type EntryPoint = (String, [u32; 3]);

/// Compiles composed WGSL to SPIR-V the way wgpu does for Vulkan, with acquire/release atomics.
pub fn spirv(label: &str, source: &str) -> Result<(Vec<u32>, Vec<EntryPoint>), String> {
    let module = naga::front::wgsl::parse_str(source)
        .map_err(|e| format!("{label}: {}", e.emit_to_string(source)))?;
    let info = naga::valid::Validator::new(
        naga::valid::ValidationFlags::all(),
        naga::valid::Capabilities::all(),
    )
    .validate(&module)
    .map_err(|e| format!("{label}: {}", e.emit_to_string(source)))?;
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
    let words = naga::back::spv::write_vec(&module, &info, &options, None)
        .map_err(|e| format!("{label}: {e}"))?;
    let entries = module
        .entry_points
        .iter()
        .map(|e| (e.name.clone(), e.workgroup_size))
        .collect();
    Ok((with_acquire_release(&words).0, entries))
}

/// A passthrough shader module of `source` (composed WGSL) with acquire/release atomics, or
/// `None` where the adapter cannot take one or the compilation fails (the caller then uses the
/// WGSL module: relaxed atomics).
pub fn module(gpu: &Gpu, label: &str, source: &str) -> Option<wgpu::ShaderModule> {
    if !available(gpu) {
        return None;
    }
    let (words, entries) = match spirv(label, source) {
        Ok(r) => r,
        Err(e) => {
            log::warn!("{e}; using relaxed atomics");
            return None;
        }
    };
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
    Some(unsafe {
        gpu.device
            .create_shader_module_passthrough(wgpu::ShaderModuleDescriptorPassthrough {
                label: Some(label),
                entry_points: Cow::Owned(entry_points),
                spirv: Some(Cow::Owned(words)),
                ..Default::default()
            })
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every atomic of a lock-based capture stage is rewritten, and the result still compiles
    /// into a SPIR-V module with the new constants.
    #[test]
    fn every_atomic_gets_acquire_release_semantics() {
        let source =
            crate::gpu::shader::with_shared(&crate::methods::kbuffer::slots_capture_source());
        let module = naga::front::wgsl::parse_str(&source).unwrap();
        let info = naga::valid::Validator::new(
            naga::valid::ValidationFlags::all(),
            naga::valid::Capabilities::all(),
        )
        .validate(&module)
        .unwrap();
        let words = naga::back::spv::write_vec(&module, &info, &Default::default(), None).unwrap();
        let (patched, changed) = with_acquire_release(&words);
        let atomics = |w: &[u32]| {
            let mut n = 0;
            let mut at = 5;
            while at < w.len() {
                let op = w[at] & 0xffff;
                if (OP_ATOMIC_LOAD..=242).contains(&op) {
                    n += 1;
                }
                at += ((w[at] >> 16) as usize).max(1);
            }
            n
        };
        assert!(changed > 20, "{changed} atomics changed");
        assert_eq!(changed, atomics(&words));
        assert_eq!(atomics(&patched), atomics(&words));
        assert_eq!(patched.len(), words.len() + 12);
        assert_eq!(patched[3], words[3] + 3);
    }
}
