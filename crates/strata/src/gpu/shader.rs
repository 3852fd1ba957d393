//! WGSL composition with naga_oil.
//!
//! Every WGSL file is a module: its first line names it (`#define_import_path strata::…`) and
//! its `#import` lines name what it uses from the modules below it, so no file depends on the
//! order in which sources are put together. A [`Stage`] is one top-level source (the file with
//! the entry points), the [`Library`]s its imports come from, and its shader definitions
//! ([`Defs`]): `#ifdef NAME` picks a variant (multisampled targets, 64-bit keys, coherent
//! storage, a storage layout's accessors) and `#{NAME}` places a number (bind group indices,
//! array sizes). Composition happens on the CPU, once per pipeline; the result goes to wgpu as
//! naga IR, and tests compose every stage, so shader errors fail without a GPU.

use std::borrow::Cow;
use std::collections::{BTreeMap, HashMap};
use std::sync::{LazyLock, Mutex};

use naga_oil::compose::{
    get_preprocessor_data, ComposableModuleDescriptor, Composer, NagaModuleDescriptor,
    ShaderDefValue, ShaderLanguage, ShaderType,
};

/// The WGSL modules of a layer or a method family: each entry is one file's source.
pub type Library = &'static [&'static str];

/// `strata::scene`: group 0's bindings, `vs_scene` and shading.
pub const SCENE: &str = include_str!("../../shaders/shared/scene.wgsl");
/// `strata::color`: color conversions.
pub const COLOR: &str = include_str!("../../shaders/shared/color.wgsl");
/// `strata::fragment`: the 16-byte fragment record and the (depth, primitive) order.
pub const FRAGMENT: &str = include_str!("../../shaders/shared/fragment.wgsl");
/// `strata::composite`: compositing and `Resolved`.
pub const COMPOSITE: &str = include_str!("../../shaders/shared/composite.wgsl");
/// `vs_fullscreen`, one triangle over the target (a stage of its own, see
/// [`crate::gpu::Gpu::fullscreen_vertex_module`]).
pub const FULLSCREEN: &str = include_str!("../../shaders/shared/fullscreen.wgsl");
/// `strata::weight`: weighted blended OIT's weight functions.
pub const WEIGHT: &str = include_str!("../../shaders/shared/weight.wgsl");
/// `strata::tail`: a pixel's tail beyond its k nearest (`--tail blend|weighted`), its sums and
/// its composite, for the k-buffers and tiled.
pub const TAIL: &str = include_str!("../../shaders/shared/tail.wgsl");
/// `strata::dispatch`: a compute thread's number in a grid laid out in rows of workgroups.
pub const DISPATCH: &str = include_str!("../../shaders/shared/dispatch.wgsl");
/// `strata::steps`: an invocation's budget of data-bounded loop steps (docs/watchdog.md).
pub const STEPS: &str = include_str!("../../shaders/shared/steps.wgsl");

/// What every stage may import: scene bindings (group 0), the vertex stage and shading
/// (`strata::scene`), colors (`strata::color`), the fragment record (`strata::fragment`) and the
/// compositing state machine (`strata::composite`), the weights of weighted blended OIT
/// (`strata::weight`), compute threads' numbers (`strata::dispatch`) and the loop-step budget
/// (`strata::steps`).
pub const SHARED: Library = &[
    SCENE, COLOR, FRAGMENT, COMPOSITE, WEIGHT, TAIL, DISPATCH, STEPS,
];

/// The shader definitions a stage is composed with.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Defs(BTreeMap<String, ShaderDefValue>);

impl Defs {
    /// `#ifdef name` holds.
    pub fn flag(mut self, name: &str) -> Defs {
        self.0.insert(name.to_owned(), ShaderDefValue::Bool(true));
        self
    }

    /// `#ifdef name` holds when `on`.
    pub fn flag_if(self, name: &str, on: bool) -> Defs {
        if on {
            self.flag(name)
        } else {
            self
        }
    }

    /// `#{name}` is `value`.
    pub fn value(mut self, name: &str, value: u32) -> Defs {
        self.0.insert(name.to_owned(), ShaderDefValue::UInt(value));
        self
    }

    /// These definitions and `other`'s (which win where both name one).
    pub fn merged(mut self, other: &Defs) -> Defs {
        self.0.extend(other.0.iter().map(|(k, v)| (k.clone(), *v)));
        self
    }

    fn map(&self) -> std::collections::HashMap<String, ShaderDefValue> {
        self.0.iter().map(|(k, v)| (k.clone(), *v)).collect()
    }
}

/// The multisampled-target definition: stages that declare their targets as `TargetTexture`
/// read them with `textureLoad(t, pixel, i)` (`i` the mip level, 0, single-sampled; the sample
/// multisampled).
pub fn target_samples(samples: u32) -> Defs {
    Defs::default().flag_if("MULTISAMPLED", samples > 1)
}

/// What `backend`'s shader translation cannot express, as definitions the stages test.
/// `NO_SAMPLE_MASK` on GL: naga's GLSL output (wgpu 30) declares `@builtin(sample_mask)` as a
/// `uint` initialised from GLSL's `int[1]` `gl_SampleMaskIn`/`gl_SampleMask`, which the GLSL
/// compiler rejects; made entries then pass the single-sampled mask, 1, and multisampled frames
/// are refused on GL (`frame::msaa::check_device`).
pub fn backend_defs(backend: wgpu::Backend) -> Defs {
    Defs::default().flag_if("NO_SAMPLE_MASK", !reads_sample_mask(backend))
}

/// Whether shaders on `backend` can read and write `@builtin(sample_mask)` (see
/// [`backend_defs`]).
pub fn reads_sample_mask(backend: wgpu::Backend) -> bool {
    backend != wgpu::Backend::Gl
}

/// A capture step's signature after its name: `fn fs_x_capture(…) {` in a storage-only stage.
const CAPTURE_STEP: &str = "_capture(v: SceneVarying, front_facing: bool, mask: u32) {";

/// A colour step's parameters after its name: `fn fs_x_step(…) -> Out {` in a stage that
/// writes colour targets, `Out` a struct of its outputs.
const COLOR_STEP: &str = "_step(v: SceneVarying, front_facing: bool, mask: u32) -> ";

/// A pixel step's signature after its name: `fn cs_x_pixel(…) {` in a per-pixel compute stage.
const PIXEL_STEP: &str = "_pixel(pixel: vec2<u32>) {";

/// The names before `signature` of the functions `source` declares with it at the start of a
/// line. The text is read before the preprocessor runs, so a step must not sit inside an
/// `#ifdef` (its made entry would call a function the stage lacks).
fn declared_steps<'a>(source: &'a str, signature: &'static str) -> impl Iterator<Item = &'a str> {
    source.lines().filter_map(move |line| {
        line.strip_prefix("fn ")?
            .strip_suffix(signature)
            .filter(|name| name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_'))
    })
}

/// The fragment entry points whose capture steps `source` declares: `fs_x` for each
/// `fn fs_x_capture(v: SceneVarying, front_facing: bool, mask: u32)` at the start of a line
/// (not inside an `#ifdef`).
pub fn capture_entries(source: &str) -> impl Iterator<Item = &str> {
    declared_steps(source, CAPTURE_STEP)
}

/// The fragment stages of `source`'s capture steps, made so that each step is written once:
/// `@fragment fn fs_x` passes the rasterized fragment, its facing and its sample mask to
/// `fs_x_capture` (which the compute rasterizer's bridge calls too, `raster::capture_stage`).
fn capture_fragment_stages(source: &str) -> String {
    capture_entries(source)
        .map(|entry| {
            format!(
                "\n#ifdef NO_SAMPLE_MASK\n@fragment\nfn {entry}(v: SceneVarying, @builtin(front_facing) front_facing: bool) {{\n    {entry}_capture(v, front_facing, 1u);\n}}\n#else\n@fragment\nfn {entry}(v: SceneVarying, @builtin(front_facing) front_facing: bool, @builtin(sample_mask) mask: u32) {{\n    {entry}_capture(v, front_facing, mask);\n}}\n#endif\n"
            )
        })
        .collect()
}

/// The fragment entry points whose colour steps `source` declares, with the struct each
/// returns: `(fs_x, Out)` for each `fn fs_x_step(v: SceneVarying, front_facing: bool, mask:
/// u32) -> Out {` at the start of a line (not inside an `#ifdef`).
pub fn color_entries(source: &str) -> impl Iterator<Item = (&str, &str)> {
    source.lines().filter_map(|line| {
        let (name, rest) = line.strip_prefix("fn ")?.split_once(COLOR_STEP)?;
        let out = rest.strip_suffix(" {")?;
        let word =
            |w: &str| !w.is_empty() && w.chars().all(|c| c.is_ascii_alphanumeric() || c == '_');
        (word(name) && word(out)).then_some((name, out))
    })
}

/// The fragment stages of `source`'s colour steps, made so that each step is written once:
/// `@fragment fn fs_x` passes the rasterized fragment, its facing and its sample mask to
/// `fs_x_step` and returns its outputs (an application's `strata_capture` calls the same step,
/// `frame::application`).
fn color_fragment_stages(source: &str) -> String {
    color_entries(source)
        .map(|(entry, out)| {
            format!(
                "\n#ifdef NO_SAMPLE_MASK\n@fragment\nfn {entry}(v: SceneVarying, @builtin(front_facing) front_facing: bool) -> {out} {{\n    return {entry}_step(v, front_facing, 1u);\n}}\n#else\n@fragment\nfn {entry}(v: SceneVarying, @builtin(front_facing) front_facing: bool, @builtin(sample_mask) mask: u32) -> {out} {{\n    return {entry}_step(v, front_facing, mask);\n}}\n#endif\n"
            )
        })
        .collect()
}

/// The compute stages of `source`'s pixel steps (`fn cs_x_pixel(pixel: vec2<u32>)` at the start
/// of a line, not inside an `#ifdef`), made so that the pixel grid is written once: `@compute fn
/// cs_x` runs in the 8×8 workgroups of `frame::passes::dispatch_pixels` and calls `cs_x_pixel`
/// with each thread's pixel inside the frame (the source imports `strata::scene::frame`).
fn pixel_compute_stages(source: &str) -> String {
    declared_steps(source, PIXEL_STEP)
        .map(|entry| {
            format!(
                "\n@compute @workgroup_size(8, 8)\nfn {entry}(@builtin(global_invocation_id) id: vec3<u32>) {{\n    if id.x >= frame.size.x || id.y >= frame.size.y {{\n        return;\n    }}\n    {entry}_pixel(id.xy);\n}}\n"
            )
        })
        .collect()
}

/// A shader stage to compose: a top-level source, the libraries its imports come from (the
/// shared one always), its definitions, and modules made for it alone (registered under their
/// own names, replacing an earlier module of that name). A top-level source that declares
/// capture steps gets their fragment stages after its own text ([`capture_entries`]), and one
/// that declares pixel steps their compute stages (`pixel_compute_stages`).
#[derive(Clone, Debug)]
pub struct Stage {
    /// Names the module in wgpu's messages and composition errors.
    pub label: String,
    source: Cow<'static, str>,
    libraries: Vec<Library>,
    made: Vec<String>,
    defs: Defs,
}

impl Stage {
    /// A stage of `source` (a naga_oil module) that may import the shared library.
    pub fn new(label: impl Into<String>, source: impl Into<Cow<'static, str>>) -> Stage {
        Stage {
            label: label.into(),
            source: source.into(),
            libraries: vec![SHARED],
            made: Vec::new(),
            defs: Defs::default(),
        }
    }

    /// Imports may also come from `library`.
    pub fn with(mut self, library: Library) -> Stage {
        if !self.libraries.iter().any(|l| std::ptr::eq(*l, library)) {
            self.libraries.push(library);
        }
        self
    }

    /// Adds a module made at run time (a generated bridge), named by its own
    /// `#define_import_path`.
    pub fn with_module(mut self, source: String) -> Stage {
        self.made.push(source);
        self
    }

    /// Composed with `defs` too.
    pub fn defs(mut self, defs: &Defs) -> Stage {
        self.defs = self.defs.merged(defs);
        self
    }

    /// The top-level WGSL source.
    pub fn source(&self) -> &str {
        &self.source
    }

    /// The libraries its imports come from.
    pub fn libraries(&self) -> &[Library] {
        &self.libraries
    }

    /// The shader definitions it is composed with.
    pub fn definitions(&self) -> &Defs {
        &self.defs
    }

    /// The module path the top-level source names itself by, if any.
    pub fn module_name(&self) -> Option<String> {
        get_preprocessor_data(&self.source).0
    }

    /// The stage as one naga module, or the composer's message.
    pub fn compose(&self) -> Result<naga::Module, String> {
        let mut library = COMPOSER.lock().unwrap_or_else(|e| e.into_inner());
        library.compose(self)
    }

    /// The stage's shader module, composed with the definitions of `device`'s backend
    /// ([`backend_defs`]). strata's stages compose (tested), so a failure is a bug in strata
    /// and panics with the composer's message.
    pub fn module(&self, device: &wgpu::Device) -> wgpu::ShaderModule {
        #[cfg(test)]
        let stage = match TEST_STEP_LIMIT.get() {
            Some(limit) => self
                .clone()
                .defs(&Defs::default().value("STEP_LIMIT", limit)),
            None => self.clone(),
        };
        #[cfg(not(test))]
        let stage = self.clone();
        let module = stage
            .defs(&backend_defs(device.adapter_info().backend))
            .compose()
            .unwrap_or_else(|e| panic!("{}: {e}", self.label));
        device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some(&self.label),
            source: wgpu::ShaderSource::Naga(Cow::Owned(module)),
        })
    }

    /// The composed stage written back as plain WGSL (for an application that concatenates it
    /// into its own shader).
    pub fn wgsl(&self) -> Result<String, String> {
        let module = self.compose()?;
        let info = validator()
            .validate(&module)
            .map_err(|e| format!("{}: {e}", self.label))?;
        naga::back::wgsl::write_string(&module, &info, naga::back::wgsl::WriterFlags::empty())
            .map_err(|e| format!("{}: {e}", self.label))
    }
}

#[cfg(test)]
thread_local! {
    /// A smaller `strata::steps` budget for the stages this test thread makes (lavapipe's own
    /// loop limit otherwise ends the loops first, and the budget would go untested there).
    pub(crate) static TEST_STEP_LIMIT: std::cell::Cell<Option<u32>> = const { std::cell::Cell::new(None) };
}

fn validator() -> naga::valid::Validator {
    naga::valid::Validator::new(
        naga::valid::ValidationFlags::all(),
        naga::valid::Capabilities::all(),
    )
}

/// The process's composer and what it holds: naga_oil caches each module per set of
/// definitions, so a module is parsed once however many stages import it.
static COMPOSER: LazyLock<Mutex<ModuleLibrary>> = LazyLock::new(|| {
    Mutex::new(ModuleLibrary {
        composer: Composer::default().with_capabilities(naga::valid::Capabilities::all()),
        sources: HashMap::new(),
        headers: HashMap::new(),
        module_defs: Defs::default(),
    })
});

struct ModuleLibrary {
    composer: Composer,
    /// Each registered module's source, so that a made module of the same name replaces it.
    sources: HashMap<String, String>,
    /// The name and imports of each static library source, by address.
    headers: HashMap<(usize, usize), (Option<String>, Vec<String>)>,
    /// Definitions every module is registered with (none for strata's own composer, whose
    /// stages give theirs when composed; an application's composer gets the stage's).
    module_defs: Defs,
}

/// A static source's identity: its address and length.
fn key(source: &str) -> (usize, usize) {
    (source.as_ptr() as usize, source.len())
}

impl ModuleLibrary {
    fn compose(&mut self, stage: &Stage) -> Result<naga::Module, String> {
        let mut known: HashMap<String, &str> = HashMap::new();
        for source in stage.libraries.iter().flat_map(|l| l.iter().copied()) {
            if let Some(name) = self.name_of(source) {
                known.insert(name, source);
            }
        }
        for source in &stage.made {
            let name = get_preprocessor_data(source)
                .0
                .ok_or_else(|| format!("{}: a made module names no import path", stage.label))?;
            known.insert(name, source);
        }
        let (_, imports, _) = get_preprocessor_data(&stage.source);
        for import in imports {
            self.add(&import.import, &known, &stage.label, &mut Vec::new())?;
        }
        let source = format!(
            "{}{}{}{}",
            stage.source,
            capture_fragment_stages(&stage.source),
            color_fragment_stages(&stage.source),
            pixel_compute_stages(&stage.source)
        );
        self.composer
            .make_naga_module(NagaModuleDescriptor {
                source: &source,
                file_path: &stage.label,
                shader_type: ShaderType::Wgsl,
                shader_defs: stage.defs.map(),
                additional_imports: &[],
            })
            .map_err(|e| e.emit_to_string(&self.composer))
    }

    /// The module path a library source names itself by (its first line).
    fn name_of(&mut self, source: &'static str) -> Option<String> {
        self.headers_of(source).0.clone()
    }

    fn imports_of(&mut self, source: &str) -> Vec<String> {
        match self.headers.get(&key(source)) {
            Some((_, imports)) => imports.clone(),
            None => get_preprocessor_data(source)
                .1
                .into_iter()
                .map(|i| i.import)
                .collect(),
        }
    }

    /// A library source's name and imports, read once: library sources are static.
    fn headers_of(&mut self, source: &'static str) -> &(Option<String>, Vec<String>) {
        self.headers.entry(key(source)).or_insert_with(|| {
            let (name, imports, _) = get_preprocessor_data(source);
            (name, imports.into_iter().map(|i| i.import).collect())
        })
    }

    /// Registers module `name` after the modules it imports. A module registered from another
    /// source (a made module, or the library's after one) is replaced, and naga_oil drops the
    /// modules that import it, which are then registered again.
    fn add(
        &mut self,
        name: &str,
        known: &HashMap<String, &str>,
        label: &str,
        path: &mut Vec<String>,
    ) -> Result<(), String> {
        if path.iter().any(|p| p == name) {
            return Err(format!(
                "{label}: modules import each other: {} → {name}",
                path.join(" → ")
            ));
        }
        let source = *known.get(name).ok_or_else(|| {
            format!("{label}: no library given to the stage has the module {name}")
        })?;
        path.push(name.to_owned());
        for import in self.imports_of(source) {
            self.add(&import, known, label, path)?;
        }
        path.pop();
        if self.composer.contains_module(name) {
            if self.sources.get(name).is_some_and(|s| s == source) {
                return Ok(());
            }
            self.composer.remove_composable_module(name);
        }
        let added = self
            .composer
            .add_composable_module(ComposableModuleDescriptor {
                source,
                file_path: name,
                language: ShaderLanguage::Wgsl,
                shader_defs: self.module_defs.map(),
                ..Default::default()
            })
            .map(|_| ());
        added.map_err(|e| e.emit_to_string(&self.composer))?;
        self.sources.insert(name.to_owned(), source.to_string());
        Ok(())
    }
}

/// Composes `stage` and validates the result with naga (tests: shader errors fail without a
/// GPU).
#[cfg(test)]
pub fn validate(stage: &Stage) {
    let module = stage
        .compose()
        .unwrap_or_else(|e| panic!("{}: {e}", stage.label));
    validator()
        .validate(&module)
        .unwrap_or_else(|e| panic!("{}: {e:?}", stage.label));
}

/// Parses plain WGSL `source` (no naga_oil directives) and validates it with naga; panics
/// naming `label` with naga's message where either fails (tests).
#[cfg(test)]
pub fn validate_wgsl(label: &str, source: &str) -> naga::Module {
    let module = naga::front::wgsl::parse_str(source)
        .unwrap_or_else(|e| panic!("{label}: {}\n{source}", e.emit_to_string(source)));
    validator()
        .validate(&module)
        .unwrap_or_else(|e| panic!("{label}: {}\n{source}", e.emit_to_string(source)));
    module
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The shared modules compose on their own, each as a stage's top level.
    #[test]
    fn shared_modules_compose() {
        for (label, source) in [
            ("scene", SCENE),
            ("color", COLOR),
            ("fragment", FRAGMENT),
            ("composite", COMPOSITE),
            ("dispatch", DISPATCH),
            ("fullscreen", FULLSCREEN),
        ] {
            validate(&Stage::new(label, source));
        }
    }

    /// `stored_color`'s hand decoding of f16 bits gives every one of the 65536 halves exactly
    /// (NaNs as NaNs), subnormals included: the k-buffer tail sums rely on it.
    #[test]
    fn stored_color_decodes_every_half_exactly() {
        use crate::gpu::binding::{self, Slot};
        let gpu = crate::testing::gpu();
        let source = "#import strata::fragment::{Fragment, stored_color}
@group(0) @binding(0) var<storage, read_write> out: array<vec2<f32>>;
@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let h = id.x;
    if h < 65536u {
        let f = Fragment(0.0, 0u, h, 0u);
        out[h] = vec2<f32>(stored_color(f).r, stored_color(Fragment(0.0, 0u, h << 16u, 0u)).g);
    }
}
";
        let module = Stage::new("stored-color-test", source).module(&gpu.device);
        let layout = binding::layout(&gpu.device, "stored-color-test", &[Slot::StorageRw]);
        let pipeline = crate::gpu::passes::compute_pipeline(
            gpu,
            "stored-color-test",
            (&module, "main"),
            &[&layout],
        );
        let out = gpu
            .storage_buffer(
                "strata.test.halves",
                65536 * 8,
                wgpu::BufferUsages::COPY_SRC,
            )
            .unwrap();
        let group = binding::group(
            &gpu.device,
            "stored-color-test",
            &layout,
            &[out.as_entire_binding()],
        );
        let mut encoder = gpu.device.create_command_encoder(&Default::default());
        {
            let mut pass = encoder.begin_compute_pass(&Default::default());
            pass.set_pipeline(&pipeline);
            pass.set_bind_group(0, &group, &[]);
            pass.dispatch_workgroups(65536 / 64, 1, 1);
        }
        gpu.queue.submit([encoder.finish()]);
        let words = crate::gpu::readback::read_u32s(gpu, &out, 65536 * 2).unwrap();
        // Each half decoded twice, as the low and as the high half of a word, against the
        // exact value.
        let differing: Vec<_> = (0..65536usize)
            .filter_map(|h| {
                let exact = half::f16::from_bits(h as u16).to_f32();
                let decoded = [words[2 * h], words[2 * h + 1]].map(f32::from_bits);
                let same =
                    |d: f32| d.to_bits() == exact.to_bits() || (d.is_nan() && exact.is_nan());
                (!decoded.into_iter().all(same)).then_some((h, decoded, exact))
            })
            .collect();
        assert!(
            differing.is_empty(),
            "{} halves differ, first {:?}",
            differing.len(),
            &differing[..differing.len().min(8)]
        );
    }

    /// A pixel step gets its compute stage, over the 8×8 workgroups `dispatch_pixels` runs.
    #[test]
    fn pixel_steps_get_their_compute_stages() {
        let source = "#import strata::scene::{frame, pixel_index}\n@group(1) @binding(0) var<storage, read_write> filled: array<u32>;\nfn cs_fill_pixel(pixel: vec2<u32>) {\n    filled[pixel_index(pixel)] = 1u;\n}\n";
        let module = Stage::new("pixel step", source).compose().unwrap();
        let entry = module.entry_points.iter().find(|e| e.name == "cs_fill");
        let entry = entry.expect("the made entry point");
        assert_eq!(entry.stage, naga::ShaderStage::Compute);
        assert_eq!(entry.workgroup_size, [8, 8, 1]);
    }

    /// A made module replaces the earlier one of its name, and a missing module is named.
    #[test]
    fn made_modules_replace_and_missing_ones_are_named() {
        let top = "#import strata::test_made::value\n@compute @workgroup_size(1)\nfn main() {\n    _ = value();\n}\n";
        for v in [1u32, 2] {
            let made = format!(
                "#define_import_path strata::test_made\nfn value() -> u32 {{\n    return {v}u;\n}}\n"
            );
            let stage = Stage::new("made", top).with_module(made);
            let wgsl = stage.wgsl().unwrap();
            assert!(wgsl.contains(&format!("return {v}u;")), "{wgsl}");
        }
        let missing = Stage::new(
            "missing",
            "#import strata::nowhere::x\nfn f() -> u32 {\n    return x;\n}\n",
        );
        let e = missing.compose().unwrap_err();
        assert!(e.contains("strata::nowhere"), "{e}");
    }
}
