//! Capture from the application's own fragment shaders.
//!
//! Every single-pass method over slot arrays or linked lists exposes its capture step as WGSL
//! that an application's fragment shader calls — its own vertex layout, pipeline and render
//! pass, with strata's bind group placed at a group index of its choosing:
//!
//! ```wgsl
//! // strata::methods::capture::wgsl(MethodId::KplusHeap, 1) is appended to the application's
//! // shader source (plain WGSL, composed by strata); it declares @group(1) bindings and defines:
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
use crate::gpu::shader::{self, Stage};
use crate::methods::kbuffer::{self, Layout, Variant};
use crate::methods::MethodId;

/// The methods whose capture an application's shader can call.
pub fn supported(method: MethodId) -> bool {
    call(method).is_some()
}

/// The capture step each method's `strata_capture` calls, on pixel `p` and fragment `f` (a
/// WGSL call with module-qualified names).
fn call(method: MethodId) -> Option<&'static str> {
    method.descriptor().app_capture
}

/// The module `strata::capture` of `method` with its bindings at `@group(group)`: strata's
/// k-buffer modules and `strata_capture`, which builds the fragment and calls the method's step.
pub fn stage(method: MethodId, group: u32) -> Result<Stage> {
    let step = call(method).ok_or_else(|| {
        Error::unsupported(format!(
            "{method} has no capture an application's shader can call (single-pass slot and list methods do)"
        ))
    })?;
    let layout = if Variant::of(method).is_some() {
        Layout::Slots
    } else {
        Layout::List
    };
    let source = format!(
        "#define_import_path strata::capture
#import strata::fragment::fragment_new
#import strata::kbuffer::storage::kpixel

// The application's entry into strata's capture.
fn strata_capture(position: vec4<f32>, premultiplied: vec4<f32>, id: u32, front_facing: bool) {{
    let a = premultiplied.a;
    let rgb = select(vec3<f32>(0.0), premultiplied.rgb / a, a > 0.0);
    let f = fragment_new(position.z, id, front_facing, vec4<f32>(rgb, a));
    let p = kpixel(position);
    {step};
}}
"
    );
    Ok(Stage::new(format!("strata.capture.{method}"), source)
        .with(kbuffer::LIBRARY)
        .defs(&kbuffer::definitions(layout, group, false)))
}

/// WGSL defining `strata_capture` for `method`, its bindings at `@group(group)`: the composed
/// module written back as one plain source, for an application to append to its own.
///
/// ```
/// use strata::{methods::capture, MethodId};
///
/// let capture = capture::wgsl(MethodId::AbufferLl, 1)?;
/// assert!(capture.contains("fn strata_capture("));
/// // Append it to your shader and call it from your fragment stage:
/// let shader = format!(
///     "{capture}
/// @fragment
/// fn fs_glass(@builtin(position) p: vec4<f32>, @builtin(front_facing) front: bool,
///             @location(0) color: vec4<f32>, @location(1) @interpolate(flat) id: u32) {{
///     strata_capture(p, vec4(color.rgb * color.a, color.a), id, front);
/// }}"
/// );
/// naga::front::wgsl::parse_str(&shader).expect("the application's shader parses");
/// # Ok::<(), strata::Error>(())
/// ```
pub fn wgsl(method: MethodId, group: u32) -> Result<String> {
    stage(method, group)?.wgsl().map_err(Error::runtime)
}

/// Adds the capture of `method` to a naga_oil composer as the module `strata::capture`, its
/// bindings at `@group(group)`: an application's shader then writes
/// `#import strata::capture::strata_capture` and calls it.
pub fn add_to_composer(
    composer: &mut naga_oil::compose::Composer,
    method: MethodId,
    group: u32,
) -> Result<()> {
    shader::add_to_composer(composer, &stage(method, group)?)
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
            shader::validate_wgsl(&m.to_string(), &src);
            assert!(!src.contains("@group(1)"), "{m}: group not replaced");
        }
        assert!(wgsl(MethodId::KbMdt32, 1).is_err());
    }

    /// An application shader composed with naga_oil imports the capture and validates.
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
