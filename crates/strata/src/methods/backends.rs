//! Which methods run on which wgpu backend, and what each lacks where one does not: the table
//! `strata methods --backend` prints and the README carries.
//!
//! A method's needs come from its descriptor: the device features it names (`needs`), its
//! capture's memory ordering (`ordering`: a per-pixel lock or linked lists need acquire/release
//! atomics, which strata gets from SPIR-V passthrough, so on Vulkan only) and its samples
//! (`min_samples`: stochastic's stipples are written through `@builtin(sample_mask)`). What a
//! backend offers is either read off an adapter of it ([`Offer::of_adapter`]: measured, and
//! `tests/backends.rs` renders every method on this machine's Vulkan and GL adapters and
//! checks the verdicts) or taken from wgpu 30's documentation of its features
//! ([`Offer::documented`]), which says where a feature can exist, not that a device has it.
//!
//! What the GL backend cannot do, as wgpu 30 translates to GLSL: read or write
//! `@builtin(sample_mask)` (naga declares it `uint` from GLSL's `int[]`), so no `--msaa` there
//! but in `tiled`, which finds its samples in compute;
//! no 64-bit atomics, no FLOAT32_BLENDABLE, no passthrough. A WebGL2 context (no compute, no
//! storage buffers) runs f2b and wboit only, through [`super::downlevel::DownlevelFrame`].

use std::fmt;

use super::table::{Descriptor, Ordering};
use super::MethodId;
use crate::error::{Error, Result};
use crate::gpu::Gpu;

/// A wgpu backend the support table speaks of.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Backend {
    /// Vulkan (Linux, Windows, Android; lavapipe without a GPU).
    Vulkan,
    /// OpenGL 4.3+ / GLES 3.1+ (Mesa's llvmpipe here), and WebGL2 through the downlevel path.
    Gl,
    /// Metal (macOS, iOS).
    Metal,
    /// Direct3D 12 (Windows).
    Dx12,
    /// WebGPU in a browser.
    WebGpu,
}

impl Backend {
    /// Every backend, in the table's order.
    pub const ALL: [Backend; 5] = [
        Backend::Vulkan,
        Backend::Gl,
        Backend::Metal,
        Backend::Dx12,
        Backend::WebGpu,
    ];

    /// Its name on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Backend::Vulkan => "vulkan",
            Backend::Gl => "gl",
            Backend::Metal => "metal",
            Backend::Dx12 => "dx12",
            Backend::WebGpu => "webgpu",
        }
    }

    /// The backend named `name`, or an error listing them.
    pub fn parse(name: &str) -> Result<Backend> {
        Backend::ALL
            .into_iter()
            .find(|b| b.name() == name)
            .ok_or_else(|| {
                let names: Vec<&str> = Backend::ALL.iter().map(|b| b.name()).collect();
                Error::input(format!(
                    "unknown backend '{name}' (available: {})",
                    names.join(", ")
                ))
            })
    }

    /// The table's name for wgpu's `backend` (`None`: wgpu's no-op backend).
    pub fn of(backend: wgpu::Backend) -> Option<Backend> {
        match backend {
            wgpu::Backend::Vulkan => Some(Backend::Vulkan),
            wgpu::Backend::Gl => Some(Backend::Gl),
            wgpu::Backend::Metal => Some(Backend::Metal),
            wgpu::Backend::Dx12 => Some(Backend::Dx12),
            wgpu::Backend::BrowserWebGpu => Some(Backend::WebGpu),
            _ => None,
        }
    }

    /// wgpu's backend of this name (`None`: WebGPU, which strata's native build does not open).
    pub fn wgpu(self) -> Option<wgpu::Backends> {
        match self {
            Backend::Vulkan => Some(wgpu::Backends::VULKAN),
            Backend::Gl => Some(wgpu::Backends::GL),
            Backend::Metal => Some(wgpu::Backends::METAL),
            Backend::Dx12 => Some(wgpu::Backends::DX12),
            Backend::WebGpu => None,
        }
    }
}

impl fmt::Display for Backend {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// The features strata's methods may need ([`Descriptor::needs`]).
const NEEDED: wgpu::Features =
    wgpu::Features::FLOAT32_BLENDABLE.union(wgpu::Features::SHADER_INT64_ATOMIC_ALL_OPS);

/// What a backend gives strata's methods.
#[derive(Clone, Debug)]
pub struct Offer {
    /// The backend.
    pub backend: Backend,
    /// Of the features methods need, those it has (measured) or may have (documented).
    pub features: wgpu::Features,
    /// Acquire/release atomics for locks and list links (strata's SPIR-V passthrough).
    pub ordered_atomics: bool,
    /// `@builtin(sample_mask)` in fragment shaders, so `--msaa` and stochastic.
    pub sample_mask: bool,
    /// The adapter it was read off (measured), or `None` (wgpu's documentation).
    pub adapter: Option<String>,
}

impl Offer {
    /// What wgpu 30 documents `backend` may offer: FLOAT32_BLENDABLE on Vulkan and WebGPU,
    /// 64-bit atomics on Vulkan (VK_KHR_shader_atomic_int64) and DX12 (shader model 6.6);
    /// passthrough with strata's ordered-atomics SPIR-V on Vulkan; the sample mask everywhere
    /// but GL.
    pub fn documented(backend: Backend) -> Offer {
        use wgpu::Features as F;
        let features = match backend {
            Backend::Vulkan => NEEDED,
            Backend::Gl | Backend::Metal => F::empty(),
            Backend::Dx12 => F::SHADER_INT64_ATOMIC_ALL_OPS,
            Backend::WebGpu => F::FLOAT32_BLENDABLE,
        };
        Offer {
            backend,
            features,
            ordered_atomics: backend == Backend::Vulkan,
            sample_mask: backend != Backend::Gl,
            adapter: None,
        }
    }

    /// What `adapter`, of `backend`, offers (measured).
    pub fn of_adapter(backend: Backend, adapter: &wgpu::Adapter) -> Offer {
        let documented = Offer::documented(backend);
        let features = adapter.features();
        Offer {
            features: features & NEEDED,
            ordered_atomics: documented.ordered_atomics
                && features.contains(wgpu::Features::PASSTHROUGH_SHADERS),
            adapter: Some(adapter.get_info().name),
            ..documented
        }
    }

    /// What the device strata records with offers (measured: the features it was opened
    /// with).
    pub fn of_gpu(gpu: &Gpu) -> Offer {
        let backend = Backend::of(gpu.info.backend).unwrap_or(Backend::Vulkan);
        Offer {
            backend,
            features: gpu.features & NEEDED,
            ordered_atomics: crate::gpu::ordered::available(gpu),
            sample_mask: crate::gpu::shader::reads_sample_mask(gpu.info.backend),
            adapter: Some(gpu.info.name.clone()),
        }
    }

    /// Whether its features are a device's own rather than what the backend may have.
    pub fn measured(&self) -> bool {
        self.adapter.is_some()
    }
}

/// What `backend` offers on this machine: its first adapter's features (measured; a GPU
/// before a software rasterizer), else what wgpu documents for it.
pub fn offer_here(backend: Backend) -> Offer {
    let Some(backends) = backend.wgpu() else {
        return Offer::documented(backend);
    };
    let instance = wgpu::Instance::new(wgpu::InstanceDescriptor {
        backends,
        ..wgpu::InstanceDescriptor::new_without_display_handle()
    });
    let mut adapters = pollster::block_on(instance.enumerate_adapters(backends));
    adapters.sort_by_key(|a| a.get_info().device_type == wgpu::DeviceType::Cpu);
    match adapters.first() {
        Some(adapter) => Offer::of_adapter(backend, adapter),
        None => Offer::documented(backend),
    }
}

/// Whether a method runs on a backend.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Verdict {
    /// It runs.
    Runs,
    /// It runs where the device has these features, which the backend may offer.
    RunsWith(wgpu::Features),
    /// It does not run: what it lacks, in a few words, and why it needs it.
    No {
        /// The missing feature or capability (the README table's cell).
        lacks: String,
        /// The whole reason, in one line.
        why: String,
    },
}

impl Verdict {
    /// Whether it runs, on every device of the backend or on some.
    pub fn runs(&self) -> bool {
        !matches!(self, Verdict::No { .. })
    }

    /// The verdict in a few words: `yes`, `with FEATURE`, `no: lacks …`.
    pub fn short(&self) -> String {
        match self {
            Verdict::Runs => "yes".into(),
            Verdict::RunsWith(features) => format!("with {}", feature_names(*features)),
            Verdict::No { lacks, .. } => format!("no: {lacks}"),
        }
    }
}

impl fmt::Display for Verdict {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Verdict::Runs => f.write_str("yes"),
            Verdict::RunsWith(features) => {
                write!(f, "where the device has {}", feature_names(*features))
            }
            Verdict::No { why, .. } => write!(f, "no: {why}"),
        }
    }
}

/// The names of `features` as wgpu spells its flags, joined with "and".
pub fn feature_names(features: wgpu::Features) -> String {
    let names: Vec<&str> = features.iter_names().map(|(name, _)| name).collect();
    names.join(" and ")
}

/// Whether `method` runs where `offer` holds.
pub fn verdict(method: &Descriptor, offer: &Offer) -> Verdict {
    if method.id == MethodId::Reference {
        return Verdict::Runs;
    }
    let lacking = |what: String| match &offer.adapter {
        Some(adapter) => format!("{what}, which '{adapter}' lacks"),
        None => format!("{what}, which wgpu 30 does not offer on {}", offer.backend),
    };
    if method.min_samples > 1 && !offer.sample_mask {
        return Verdict::No {
            lacks: "sample mask".into(),
            why: format!(
                "it writes @builtin(sample_mask), which naga's GLSL output cannot express on {}",
                offer.backend
            ),
        };
    }
    let missing = method.needs - offer.features;
    if !missing.is_empty() {
        let names = feature_names(missing);
        return Verdict::No {
            why: lacking(names.clone()),
            lacks: names,
        };
    }
    let ordered = "acquire/release atomics (strata's SPIR-V passthrough, Vulkan only)";
    let mut with = method.needs;
    match method.ordering {
        Ordering::Relaxed => {}
        Ordering::Locks if !offer.ordered_atomics => {
            return Verdict::No {
                lacks: "ordered atomics".into(),
                why: format!(
                    "its per-pixel lock or linked lists need {}",
                    lacking(ordered.to_string())
                ),
            };
        }
        Ordering::Locks => {}
        Ordering::LockedFallback if offer.ordered_atomics => {}
        Ordering::LockedFallback => {
            // Its lock-free key cascade needs 64-bit atomics; its locked fallback, ordering.
            let cascade = wgpu::Features::SHADER_INT64_ATOMIC_ALL_OPS;
            if !offer.features.contains(cascade) {
                return Verdict::No {
                    lacks: "SHADER_INT64_ATOMIC_ALL_OPS or ordered atomics".into(),
                    why: format!(
                        "its key cascade needs SHADER_INT64_ATOMIC_ALL_OPS and its fallback capture {}",
                        lacking(ordered.to_string())
                    ),
                };
            }
            with |= cascade;
        }
    }
    if offer.measured() || with.is_empty() {
        Verdict::Runs
    } else {
        Verdict::RunsWith(with)
    }
}

/// Refuses a device without a feature the method needs, naming the methods of its family
/// that run there.
pub fn check_features(method: &Descriptor, gpu: &Gpu) -> crate::error::Result<()> {
    let missing = method.needs - gpu.features;
    if missing.is_empty() {
        return Ok(());
    }
    let offer = Offer::of_gpu(gpu);
    let instead: Vec<&str> = super::TABLE
        .iter()
        .filter(|d| d.family == method.family && d.id != method.id && verdict(d, &offer).runs())
        .map(|d| d.name)
        .collect();
    let instead = if instead.is_empty() {
        String::new()
    } else {
        format!("; of its family, {} run here", instead.join(", "))
    };
    Err(crate::error::Error::unsupported(format!(
        "{} needs {}, which '{}' ({}) lacks{instead}",
        method.name,
        feature_names(missing),
        gpu.info.name,
        gpu.backend_name()
    )))
}

/// The README's table: every GPU method on every backend, from wgpu 30's documented features
/// (`strata methods --backend all`).
pub fn markdown_table() -> String {
    let offers: Vec<Offer> = Backend::ALL.into_iter().map(Offer::documented).collect();
    let mut out = String::from("| method |");
    for b in Backend::ALL {
        out.push_str(&format!(" {b} |"));
    }
    out.push_str("\n|---|");
    out.push_str(&"---|".repeat(Backend::ALL.len()));
    out.push('\n');
    for method in super::catalogue().filter(|d| d.id != MethodId::Reference) {
        out.push_str(&format!("| {} |", method.name));
        for offer in &offers {
            out.push_str(&format!(" {} |", verdict(method, offer).short()));
        }
        out.push('\n');
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::methods::catalogue;

    fn documented(backend: Backend) -> Vec<(&'static str, Verdict)> {
        let offer = Offer::documented(backend);
        catalogue().map(|d| (d.name, verdict(d, &offer))).collect()
    }

    #[test]
    fn vulkan_runs_every_method_where_the_device_has_the_features() {
        for (name, v) in documented(Backend::Vulkan) {
            assert!(v.runs(), "{name}: {v}");
        }
    }

    #[test]
    fn gl_refuses_what_its_translation_and_features_lack() {
        let gl = documented(Backend::Gl);
        let refused: Vec<&str> = gl.iter().filter(|(_, v)| !v.runs()).map(|x| x.0).collect();
        for name in ["stochastic", "mboit", "kb-keys", "kb-ll", "kpeel"] {
            assert!(refused.contains(&name), "{name} on gl: {gl:?}");
        }
        for name in ["abuffer-ll", "tiled", "f2b", "unsorted", "kb-mdt32"] {
            assert!(!refused.contains(&name), "{name} on gl: {gl:?}");
        }
    }

    #[test]
    fn dx12_runs_kpeel_through_its_key_cascade_only_where_the_device_has_64_bit_atomics() {
        let dx12 = documented(Backend::Dx12);
        let kpeel = &dx12.iter().find(|x| x.0 == "kpeel").unwrap().1;
        assert_eq!(
            *kpeel,
            Verdict::RunsWith(wgpu::Features::SHADER_INT64_ATOMIC_ALL_OPS)
        );
        let kb = &dx12.iter().find(|x| x.0 == "kb-ps").unwrap().1;
        assert!(!kb.runs(), "{kb}");
    }

    #[test]
    fn the_readme_carries_the_table() {
        let readme =
            std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../../README.md"))
                .expect("the workspace README");
        let table = markdown_table();
        assert!(
            readme.contains(&table),
            "README.md's backend table differs from `strata methods --backend all`:\n{table}"
        );
    }

    #[test]
    fn backends_parse_by_name() {
        for b in Backend::ALL {
            assert_eq!(Backend::parse(b.name()).unwrap(), b);
        }
        let e = Backend::parse("d3d9").unwrap_err().to_string();
        assert!(e.contains("d3d9") && e.contains("webgpu"), "{e}");
    }
}
