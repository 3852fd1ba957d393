//! Explicit bind group layouts from a short list of slot kinds, so a pipeline's layout and the
//! bind groups made for it each frame come from one description.

/// The kind of one binding; its index is its position in the slice.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Slot {
    /// Uniform buffer (visible to every stage).
    Uniform,
    /// Read-only storage buffer (visible to every stage).
    Storage,
    /// Read-write storage buffer (fragment and compute stages).
    StorageRw,
    /// `texture_2d<f32>` read with `textureLoad`.
    TextureFloat,
    /// `texture_multisampled_2d<f32>` read with `textureLoad` (`--msaa` targets).
    TextureFloatMultisampled,
    /// `texture_2d<u32>` read with `textureLoad`.
    TextureUint,
    /// A depth texture read as `texture_2d<f32>` with `textureLoad` (its `.r` is the depth).
    /// wgpu binds depth views as unfilterable float on every backend, and this form translates
    /// everywhere: naga's GLSL output cannot load from a `texture_depth_2d`.
    TextureDepth,
}

impl Slot {
    /// A float render target of `samples` samples per pixel as a later pass reads it (the
    /// `TargetTexture` of a stage composed with `shader::target_samples`).
    pub fn target(samples: u32) -> Slot {
        if samples > 1 {
            Slot::TextureFloatMultisampled
        } else {
            Slot::TextureFloat
        }
    }
}

fn entry(binding: u32, slot: Slot) -> wgpu::BindGroupLayoutEntry {
    let all =
        wgpu::ShaderStages::VERTEX | wgpu::ShaderStages::FRAGMENT | wgpu::ShaderStages::COMPUTE;
    let texture = |sample_type| wgpu::BindingType::Texture {
        sample_type,
        view_dimension: wgpu::TextureViewDimension::D2,
        multisampled: slot == Slot::TextureFloatMultisampled,
    };
    let (visibility, ty) = match slot {
        Slot::Uniform => (
            all,
            wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Uniform,
                has_dynamic_offset: false,
                min_binding_size: None,
            },
        ),
        Slot::Storage => (
            all,
            wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Storage { read_only: true },
                has_dynamic_offset: false,
                min_binding_size: None,
            },
        ),
        Slot::StorageRw => (
            wgpu::ShaderStages::FRAGMENT | wgpu::ShaderStages::COMPUTE,
            wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Storage { read_only: false },
                has_dynamic_offset: false,
                min_binding_size: None,
            },
        ),
        Slot::TextureFloat | Slot::TextureFloatMultisampled => (
            wgpu::ShaderStages::FRAGMENT | wgpu::ShaderStages::COMPUTE,
            texture(wgpu::TextureSampleType::Float { filterable: false }),
        ),
        Slot::TextureUint => (
            wgpu::ShaderStages::FRAGMENT | wgpu::ShaderStages::COMPUTE,
            texture(wgpu::TextureSampleType::Uint),
        ),
        Slot::TextureDepth => (
            wgpu::ShaderStages::FRAGMENT | wgpu::ShaderStages::COMPUTE,
            texture(wgpu::TextureSampleType::Float { filterable: false }),
        ),
    };
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility,
        ty,
        count: None,
    }
}

/// A bind group layout with one binding per slot, numbered from 0.
pub fn layout(device: &wgpu::Device, label: &str, slots: &[Slot]) -> wgpu::BindGroupLayout {
    let entries: Vec<_> = slots
        .iter()
        .enumerate()
        .map(|(i, &s)| entry(i as u32, s))
        .collect();
    device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some(label),
        entries: &entries,
    })
}

/// A layout with the given binding indices, which need not be dense (passes that read a
/// subset of a shared WGSL binding list).
pub fn layout_at(
    device: &wgpu::Device,
    label: &str,
    slots: &[(u32, Slot)],
) -> wgpu::BindGroupLayout {
    let entries: Vec<_> = slots.iter().map(|&(i, s)| entry(i, s)).collect();
    device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some(label),
        entries: &entries,
    })
}

/// Bind group with the given (binding index, resource) entries, for [`layout_at`] layouts.
pub fn group_at(
    device: &wgpu::Device,
    label: &str,
    layout: &wgpu::BindGroupLayout,
    resources: &[(u32, wgpu::BindingResource<'_>)],
) -> wgpu::BindGroup {
    let entries: Vec<_> = resources
        .iter()
        .map(|(i, r)| wgpu::BindGroupEntry {
            binding: *i,
            resource: r.clone(),
        })
        .collect();
    device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some(label),
        layout,
        entries: &entries,
    })
}

/// Bind group whose entry `i` is `resources[i]`.
pub fn group(
    device: &wgpu::Device,
    label: &str,
    layout: &wgpu::BindGroupLayout,
    resources: &[wgpu::BindingResource<'_>],
) -> wgpu::BindGroup {
    let numbered: Vec<_> = resources
        .iter()
        .enumerate()
        .map(|(i, r)| (i as u32, r.clone()))
        .collect();
    group_at(device, label, layout, &numbered)
}

/// A pipeline layout of `groups`, in group order.
pub fn pipeline_layout(
    device: &wgpu::Device,
    label: &str,
    groups: &[&wgpu::BindGroupLayout],
) -> wgpu::PipelineLayout {
    let groups: Vec<Option<&wgpu::BindGroupLayout>> = groups.iter().map(|g| Some(*g)).collect();
    device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some(label),
        bind_group_layouts: &groups,
        immediate_size: 0,
    })
}
