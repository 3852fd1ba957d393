//! WGSL composition. WGSL has no includes, so a stage's module is the shared sources it names
//! followed by the stage file; naga validates the result in tests.

/// Shared WGSL, in dependency order. Keep the Rust twins in sync (see each file's header).
pub const SCENE: &str = include_str!("../../shaders/shared/scene.wgsl");
pub const COLOR: &str = include_str!("../../shaders/shared/color.wgsl");
pub const FRAGMENT: &str = include_str!("../../shaders/shared/fragment.wgsl");
pub const COMPOSITE: &str = include_str!("../../shaders/shared/composite.wgsl");

/// Everything a capture or resolve stage may call: scene bindings (group 0), the vertex stage,
/// shading, the fragment record and the compositing state machine.
pub fn with_shared(stage: &str) -> String {
    [SCENE, COLOR, FRAGMENT, COMPOSITE, stage].join("\n")
}

/// A compute or fragment stage that declares its render targets' bindings as `TargetTexture`
/// and reads them with `textureLoad(t, pixel, i)` (`i` the mip level, 0, single-sampled; the
/// sample multisampled): the alias it needs for `samples` per pixel, then the stage.
pub fn with_target_samples(source: &str, samples: u32) -> String {
    format!("alias TargetTexture = {};\n{source}", texture_type(samples))
}

/// The WGSL type of a sampled float target with `samples` per pixel (`--msaa`).
pub fn texture_type(samples: u32) -> &'static str {
    if samples > 1 {
        "texture_multisampled_2d<f32>"
    } else {
        "texture_2d<f32>"
    }
}

pub fn module(device: &wgpu::Device, label: &str, stage: &str) -> wgpu::ShaderModule {
    device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some(label),
        source: wgpu::ShaderSource::Wgsl(with_shared(stage).into()),
    })
}

/// Validates a composed module with naga (used by tests, so shader errors fail without a GPU).
#[cfg(test)]
pub fn validate(label: &str, stage: &str) {
    validate_source(label, &with_shared(stage));
}

/// Validates a complete WGSL module with naga (tests).
#[cfg(test)]
pub fn validate_source(label: &str, src: &str) {
    let module = naga::front::wgsl::parse_str(src)
        .unwrap_or_else(|e| panic!("{label}: {}", e.emit_to_string(src)));
    naga::valid::Validator::new(
        naga::valid::ValidationFlags::all(),
        naga::valid::Capabilities::all(),
    )
    .validate(&module)
    .unwrap_or_else(|e| panic!("{label}: {}", e.emit_to_string(src)));
}
