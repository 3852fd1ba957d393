//! Capture from the application's own fragment shaders.
//!
//! Every single-pass method over slot arrays or linked lists exposes its capture step as WGSL
//! that an application's fragment shader calls — its own vertex layout, pipeline and render
//! pass, with strata's bind group placed at a group index of its choosing:
//!
//! ```wgsl
//! // strata::methods::capture::wgsl(MethodId::KplusHeap, 1) is appended to the application's
//! // shader source (plain concatenation); it declares @group(1) bindings 0..5 and defines:
//! fn strata_capture(position: vec4<f32>, premultiplied: vec4<f32>, id: u32, front_facing: bool)
//! ```
//!
//! - `position`: the fragment's `@builtin(position)` (window coordinates and depth);
//! - `premultiplied`: its color with premultiplied alpha (linear);
//! - `id`: the tie-break among fragments at exactly equal depth (use the triangle's index; with
//!   strata's scene order the result equals the CPU reference's);
//! - `front_facing`: the `@builtin(front_facing)` flag (the translucency effect's entering and
//!   leaving rule; tags must then be strata scene primitives).
//!
//! The fragment shader must not write a color (use a color target with an empty write mask, or
//! none): the capture stores into storage buffers. Test against the opaque depth with the
//! pipeline's depth test (LESS, no depth writes). The bindings are the method's group-1 layout
//! ([`crate::FrameRecorder::capture_layout`]); the bind group comes from
//! [`crate::FrameRecorder::begin_capture`], and [`crate::FrameRecorder::end_capture`] resolves.
//! `kb-mdt32` (two geometry passes), the peeling methods and the baselines have no application
//! capture.

use crate::error::{Error, Result};
use crate::gpu::shader;
use crate::methods::kbuffer::{list, slots_capture_functions, Variant};
use crate::methods::MethodId;

/// The methods whose capture an application's shader can call.
pub fn supported(method: MethodId) -> bool {
    call(method).is_some()
}

/// The capture step each method's `strata_capture` calls, on pixel `p` and fragment `f`.
fn call(method: MethodId) -> Option<&'static str> {
    method.descriptor().app_capture
}

/// WGSL defining `strata_capture` for `method`, its bindings at `@group(group)`.
pub fn wgsl(method: MethodId, group: u32) -> Result<String> {
    let step = call(method).ok_or_else(|| {
        Error::unsupported(format!(
            "{method} has no capture an application's shader can call (single-pass slot and list methods do)"
        ))
    })?;
    let functions = if Variant::of(method).is_some() {
        slots_capture_functions()
    } else {
        list::capture_functions()
    };
    let source = [
        shader::FRAGMENT,
        &functions,
        &format!(
            "
// The application's entry into strata's capture.
fn strata_capture(position: vec4<f32>, premultiplied: vec4<f32>, id: u32, front_facing: bool) {{
    let a = premultiplied.a;
    let rgb = select(vec3<f32>(0.0), premultiplied.rgb / a, a > 0.0);
    let f = fragment_new(position.z, id, front_facing, vec4<f32>(rgb, a));
    let p = kpixel(position);
    {step};
}}
"
        ),
    ]
    .join("\n");
    Ok(source.replace("@group(1)", &format!("@group({group})")))
}

/// Adds the capture of `method` to a naga_oil composer as the module `strata::capture`, its
/// bindings at `@group(group)`: an application's shader then writes
/// `#import strata::capture::strata_capture` and calls it.
#[cfg(feature = "naga_oil")]
pub fn add_to_composer(
    composer: &mut naga_oil::compose::Composer,
    method: MethodId,
    group: u32,
) -> Result<()> {
    let source = format!(
        "#define_import_path strata::capture\n{}",
        wgsl(method, group)?
    );
    composer
        .add_composable_module(naga_oil::compose::ComposableModuleDescriptor {
            source: &source,
            file_path: "strata/capture.wgsl",
            language: naga_oil::compose::ShaderLanguage::Wgsl,
            as_name: None,
            additional_imports: &[],
            shader_defs: Default::default(),
        })
        .map(|_| ())
        .map_err(|e| Error::runtime(format!("naga_oil: {e}")))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each module validates on its own with an application entry point calling it.
    #[test]
    fn capture_modules_validate_for_every_supported_method() {
        for m in MethodId::gpu_methods().filter(|m| supported(*m)) {
            let src = wgsl(m, 2).unwrap()
                + "
@fragment
fn fs_app(@builtin(position) p: vec4<f32>, @builtin(front_facing) ff: bool) {
    strata_capture(p, vec4<f32>(0.25, 0.5, 0.125, 0.5), 7u, ff);
}
";
            let module = naga::front::wgsl::parse_str(&src)
                .unwrap_or_else(|e| panic!("{m}: {}", e.emit_to_string(&src)));
            naga::valid::Validator::new(
                naga::valid::ValidationFlags::all(),
                naga::valid::Capabilities::all(),
            )
            .validate(&module)
            .unwrap_or_else(|e| panic!("{m}: {}", e.emit_to_string(&src)));
            assert!(!src.contains("@group(1)"), "{m}: group not replaced");
        }
        assert!(wgsl(MethodId::KbMdt32, 1).is_err());
    }

    /// An application shader composed with naga_oil imports the capture and validates.
    #[cfg(feature = "naga_oil")]
    #[test]
    fn naga_oil_composes_the_capture() {
        use naga_oil::compose::{Composer, NagaModuleDescriptor, ShaderType};
        for m in [MethodId::KplusHeap, MethodId::AbufferLl] {
            let mut composer =
                Composer::default().with_capabilities(naga::valid::Capabilities::all());
            add_to_composer(&mut composer, m, 1).unwrap();
            let app = "
#import strata::capture::strata_capture

@fragment
fn fs_app(@builtin(position) p: vec4<f32>, @builtin(front_facing) ff: bool) {
    strata_capture(p, vec4<f32>(0.25, 0.5, 0.125, 0.5), 7u, ff);
}
";
            let module = composer
                .make_naga_module(NagaModuleDescriptor {
                    source: app,
                    file_path: "app.wgsl",
                    shader_type: ShaderType::Wgsl,
                    ..Default::default()
                })
                .unwrap_or_else(|e| panic!("{m}: {e:?}"));
            assert!(
                module.entry_points.iter().any(|e| e.name == "fs_app"),
                "{m}"
            );
        }
    }
}
