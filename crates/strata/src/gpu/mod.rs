//! GPU context: adapter and device selection, optional features and limits, and the small
//! pieces every method uses (bindings, shader composition, timing, readback).
//!
//! The device is headless. Vulkan is the default backend; `WGPU_BACKEND` picks another and
//! `WGPU_ADAPTER_NAME` picks an adapter by a case-insensitive substring of its name.

pub mod bandwidth;
pub mod binding;
pub mod ordered;
pub mod passes;
pub mod readback;
pub mod shader;
pub mod timing;
pub mod twin;

#[cfg(feature = "serde")]
use serde::Serialize;

use crate::error::{Error, Result};

/// Optional features the methods use when the adapter has them.
pub fn wanted_features() -> wgpu::Features {
    wgpu::Features::SHADER_INT64
        | wgpu::Features::SHADER_INT64_ATOMIC_ALL_OPS
        | wgpu::Features::SHADER_INT64_ATOMIC_MIN_MAX
        | wgpu::Features::TIMESTAMP_QUERY
        | wgpu::Features::TIMESTAMP_QUERY_INSIDE_ENCODERS
        | wgpu::Features::TIMESTAMP_QUERY_INSIDE_PASSES
        | wgpu::Features::PIPELINE_STATISTICS_QUERY
        | wgpu::Features::MEMORY_DECORATION_COHERENT
        | wgpu::Features::PASSTHROUGH_SHADERS
        | wgpu::Features::FLOAT32_BLENDABLE
        | wgpu::Features::TEXTURE_ADAPTER_SPECIFIC_FORMAT_FEATURES
}

/// A device and queue with the features and limits they were created with: strata's own
/// headless device ([`Gpu::new`]) or the application's ([`Gpu::from_device`]). Cloning shares
/// the device.
#[derive(Clone)]
pub struct Gpu {
    /// The adapter, when strata opened the device itself.
    pub adapter: Option<wgpu::Adapter>,
    /// The device strata records with (the application's, or its own).
    pub device: wgpu::Device,
    /// Its queue.
    pub queue: wgpu::Queue,
    /// The adapter's name, backend and driver.
    pub info: wgpu::AdapterInfo,
    /// The features the device was opened with.
    pub features: wgpu::Features,
    /// The device's limits.
    pub limits: wgpu::Limits,
    /// The scene's vertex stage (`vs_scene`), composed once per device: every geometry pass
    /// draws with it, whatever module its fragment stage comes from.
    scene_vertex: std::sync::OnceLock<wgpu::ShaderModule>,
    /// `vs_fullscreen`, composed once per device.
    fullscreen_vertex: std::sync::OnceLock<wgpu::ShaderModule>,
    /// Why the device was lost, once it is: set by the device-lost callback strata installs on
    /// the devices it opens, or by the application through [`Gpu::device_lost`]. Shared by
    /// every clone.
    lost: std::sync::Arc<std::sync::OnceLock<String>>,
}

/// The limits a device of `adapter` opens with: the adapter's, or those `STRATA_LIMITS` names.
fn limits_from_env(adapter: &wgpu::Adapter) -> Result<wgpu::Limits> {
    match std::env::var("STRATA_LIMITS").ok().as_deref() {
        None | Some("") | Some("adapter") => Ok(adapter.limits()),
        Some("webgl2") => {
            Ok(wgpu::Limits::downlevel_webgl2_defaults().using_resolution(adapter.limits()))
        }
        Some(other) => Err(Error::input(format!(
            "STRATA_LIMITS='{}' is not one of: adapter, webgl2",
            other.chars().take(40).collect::<String>()
        ))),
    }
}

/// Runs `make` (pipelines, layouts, buffers: setup) under validation and internal error scopes,
/// so that what this device cannot make — a limit or a format it lacks, a shader its backend
/// cannot translate — comes back as one line naming `what` and the device's reason instead of
/// wgpu's uncaptured-error panic.
pub fn validated<T>(gpu: &Gpu, what: &str, make: impl FnOnce() -> Result<T>) -> Result<T> {
    gpu.check_device()?;
    // Internal errors too: a backend's shader translation reports what it cannot express (GL's
    // GLSL has no textureLoad from a depth texture) as one, not as a validation error.
    let internal = gpu.device.push_error_scope(wgpu::ErrorFilter::Internal);
    let validation = gpu.device.push_error_scope(wgpu::ErrorFilter::Validation);
    let made = make();
    let invalid = pollster::block_on(validation.pop());
    let failed = pollster::block_on(internal.pop());
    match invalid.or(failed) {
        None => made,
        Some(e) => Err(Error::unsupported(format!(
            "{what} cannot run on '{}': {}",
            gpu.info.name,
            one_line_wgpu(&e)
        ))),
    }
}

/// A wgpu error in one line: its message is "Validation Error", "Caused by:" and the reason on
/// later lines.
fn one_line_wgpu(e: &wgpu::Error) -> String {
    let text = e.to_string();
    let reason: Vec<&str> = text
        .lines()
        .map(str::trim)
        .filter(|l| !l.is_empty() && *l != "Validation Error" && *l != "Caused by:")
        .collect();
    reason.join(": ")
}

/// What `strata info` reports.
#[derive(Debug, Clone)]
#[cfg_attr(feature = "serde", derive(Serialize))]
pub struct GpuReport {
    /// The adapter's name.
    pub adapter: String,
    /// Its backend (vulkan, metal, dx12, gl).
    pub backend: String,
    /// Integrated, discrete, virtual or CPU.
    pub device_type: String,
    /// The driver's name.
    pub driver: String,
    /// The driver's version text.
    pub driver_info: String,
    /// PCI vendor id.
    pub vendor: u32,
    /// PCI device id.
    pub device: u32,
    /// The adapter's features, by name.
    pub features: Vec<String>,
    /// The limits strata's methods run into, by name.
    pub limits: std::collections::BTreeMap<&'static str, u64>,
    /// Nanoseconds per timestamp tick; `None` without timestamp queries.
    pub timestamp_period_ns: Option<f32>,
}

impl Gpu {
    /// Opens the adapter chosen by `WGPU_BACKEND` / `WGPU_ADAPTER_NAME` (default: Vulkan, the
    /// first adapter, preferring hardware), with its own limits, or with `STRATA_LIMITS=webgl2`
    /// WebGL2's (`wgpu::Limits::downlevel_webgl2_defaults`, at the adapter's texture sizes):
    /// what strata does on such a device, on any machine.
    pub fn new() -> Result<Gpu> {
        pollster::block_on(Self::new_async())
    }

    async fn new_async() -> Result<Gpu> {
        let instance = wgpu::Instance::new(Self::instance_descriptor());
        Self::open(&instance, None, wgpu::Features::empty(), None).await
    }

    /// Like [`Gpu::new`], without the optional features `missing`: the same adapter standing in
    /// for one that lacks them (what `--method auto` and the refusals then do can be checked on
    /// any machine).
    pub fn new_without(missing: wgpu::Features) -> Result<Gpu> {
        let instance = wgpu::Instance::new(Self::instance_descriptor());
        pollster::block_on(Self::open(&instance, None, missing, None))
    }

    /// Like [`Gpu::new_without`], the device also opened with `limits` (each at most the
    /// adapter's): a stand-in for smaller adapters, such as downlevel storage limits.
    pub fn new_restricted(missing: wgpu::Features, limits: wgpu::Limits) -> Result<Gpu> {
        let instance = wgpu::Instance::new(Self::instance_descriptor());
        pollster::block_on(Self::open(&instance, None, missing, Some(limits)))
    }

    /// The instance [`Gpu::new`] opens its adapter from: the backends of `WGPU_BACKEND`
    /// (default Vulkan).
    pub fn instance_descriptor() -> wgpu::InstanceDescriptor {
        let mut desc = wgpu::InstanceDescriptor::new_without_display_handle();
        desc.backends = Self::backends();
        desc
    }

    fn backends() -> wgpu::Backends {
        wgpu::Backends::from_env().unwrap_or(wgpu::Backends::VULKAN)
    }

    /// Like [`Gpu::new`], choosing among the adapters of `instance` that can present to
    /// `surface` (a window's).
    pub fn for_surface(instance: &wgpu::Instance, surface: &wgpu::Surface<'_>) -> Result<Gpu> {
        pollster::block_on(Self::open(
            instance,
            Some(surface),
            wgpu::Features::empty(),
            None,
        ))
    }

    async fn open(
        instance: &wgpu::Instance,
        surface: Option<&wgpu::Surface<'_>>,
        missing: wgpu::Features,
        limits: Option<wgpu::Limits>,
    ) -> Result<Gpu> {
        let backends = Self::backends();
        let mut adapters = instance.enumerate_adapters(backends).await;
        if let Some(surface) = surface {
            adapters.retain(|a| a.is_surface_supported(surface));
        }
        let wanted_name = std::env::var("WGPU_ADAPTER_NAME")
            .ok()
            .map(|s| s.to_lowercase());
        let adapter = match &wanted_name {
            Some(name) => adapters
                .into_iter()
                .find(|a| a.get_info().name.to_lowercase().contains(name))
                .ok_or_else(|| {
                    Error::unsupported(format!(
                        "no GPU adapter matches WGPU_ADAPTER_NAME='{name}' on backend(s) {backends:?}"
                    ))
                })?,
            None => {
                // Prefer real GPUs over software rasterizers when both exist.
                adapters.sort_by_key(|a| match a.get_info().device_type {
                    wgpu::DeviceType::DiscreteGpu => 0,
                    wgpu::DeviceType::IntegratedGpu => 1,
                    wgpu::DeviceType::VirtualGpu => 2,
                    wgpu::DeviceType::Other => 3,
                    wgpu::DeviceType::Cpu => 4,
                });
                adapters.into_iter().next().ok_or_else(|| {
                    Error::unsupported(format!(
                        "no GPU adapter{} found on backend(s) {backends:?} (on Linux without a GPU, install Mesa's software Vulkan driver: apt-get install mesa-vulkan-drivers)",
                        if surface.is_some() { " that can present to the window" } else { "" }
                    ))
                })?
            }
        };
        let info = adapter.get_info();
        let features = adapter.features() & (wanted_features() - missing);
        let limits = match limits {
            Some(limits) => limits,
            None => limits_from_env(&adapter)?,
        };
        let (device, queue) = adapter
            .request_device(&wgpu::DeviceDescriptor {
                label: Some("strata.device"),
                required_features: features,
                required_limits: limits.clone(),
                ..Default::default()
            })
            .await
            .map_err(|e| {
                Error::unsupported(format!("cannot open device on '{}': {e}", info.name))
            })?;
        let gpu = Gpu {
            adapter: Some(adapter),
            device,
            queue,
            info,
            features,
            limits,
            scene_vertex: Default::default(),
            fullscreen_vertex: Default::default(),
            lost: Default::default(),
        };
        // strata's own device: its loss is noted here (an application's device keeps the
        // application's callback; it tells strata through `device_lost`).
        let lost = gpu.lost.clone();
        gpu.device.set_device_lost_callback(move |reason, message| {
            let _ = lost.set(format!("{reason:?}: {}", message.replace('\n', " ")));
        });
        Ok(gpu)
    }

    /// Wraps the application's device and queue. Methods use the features and limits the
    /// device was created with: request SHADER_INT64_ATOMIC_ALL_OPS for `kb-mdt64`,
    /// TIMESTAMP_QUERY (and _INSIDE_ENCODERS) for pass timings, MEMORY_DECORATION_COHERENT for
    /// coherent k-buffer storage, and the adapter's storage-buffer limits for large frames.
    pub fn from_device(device: wgpu::Device, queue: wgpu::Queue) -> Gpu {
        Gpu {
            adapter: None,
            info: device.adapter_info(),
            features: device.features(),
            limits: device.limits(),
            device,
            queue,
            scene_vertex: Default::default(),
            fullscreen_vertex: Default::default(),
            lost: Default::default(),
        }
    }

    /// `vs_fullscreen`, one triangle covering the target, for full-screen passes that need
    /// nothing from the scene; composed once per device.
    pub fn fullscreen_vertex_module(&self) -> &wgpu::ShaderModule {
        self.fullscreen_vertex.get_or_init(|| {
            shader::Stage::new("strata.fullscreen", shader::FULLSCREEN).module(&self.device)
        })
    }

    /// The module of the scene's vertex stage `vs_scene` (shaders/shared/scene.wgsl).
    pub fn scene_vertex_module(&self) -> &wgpu::ShaderModule {
        self.scene_vertex.get_or_init(|| {
            shader::Stage::new("strata.scene.vertex", shader::SCENE).module(&self.device)
        })
    }

    /// A buffer holding `contents` (`usage` as given: add COPY_DST to write it again).
    pub fn buffer_with<T: bytemuck::NoUninit>(
        &self,
        label: &str,
        contents: &[T],
        usage: wgpu::BufferUsages,
    ) -> wgpu::Buffer {
        wgpu::util::DeviceExt::create_buffer_init(
            &self.device,
            &wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents: bytemuck::cast_slice(contents),
                usage,
            },
        )
    }

    /// A 2D texture of one mip level and sample.
    pub fn texture_2d(
        &self,
        label: &str,
        size: (u32, u32),
        format: wgpu::TextureFormat,
        usage: wgpu::TextureUsages,
    ) -> wgpu::Texture {
        self.texture_2d_samples(label, size, format, usage, 1)
    }

    /// [`Gpu::texture_2d`] with `samples` per pixel.
    pub fn texture_2d_samples(
        &self,
        label: &str,
        (width, height): (u32, u32),
        format: wgpu::TextureFormat,
        usage: wgpu::TextureUsages,
        samples: u32,
    ) -> wgpu::Texture {
        self.device.create_texture(&wgpu::TextureDescriptor {
            label: Some(label),
            size: wgpu::Extent3d {
                width,
                height,
                depth_or_array_layers: 1,
            },
            mip_level_count: 1,
            sample_count: samples,
            dimension: wgpu::TextureDimension::D2,
            format,
            usage,
            view_formats: &[],
        })
    }

    /// Whether the device was opened with every feature in `f`.
    pub fn has(&self, f: wgpu::Features) -> bool {
        self.features.contains(f)
    }

    /// Whether a render pass may test against a depth attachment that it also reads as a
    /// texture (a read-only depth attachment: wgpu's `READ_ONLY_DEPTH_STENCIL`, which its GL
    /// backend lacks). An application's device without its adapter is judged by its backend.
    pub fn reads_bound_depth_attachment(&self) -> bool {
        match &self.adapter {
            Some(adapter) => adapter
                .get_downlevel_capabilities()
                .flags
                .contains(wgpu::DownlevelFlags::READ_ONLY_DEPTH_STENCIL),
            None => self.info.backend != wgpu::Backend::Gl,
        }
    }

    /// The backend in lower case (vulkan, metal, dx12, gl).
    pub fn backend_name(&self) -> String {
        self.info.backend.to_string().to_lowercase()
    }

    /// Records that the device is lost and why: strata's own devices are told by their
    /// device-lost callback; an application that gave strata its device
    /// ([`Gpu::from_device`]) calls this from its own callback, which strata does not replace.
    /// From then on every strata call on this device returns [`Error::DeviceLost`].
    pub fn device_lost(&self, why: &str) {
        let _ = self.lost.set(why.replace('\n', " "));
    }

    /// [`Error::DeviceLost`] naming why, once the device is lost.
    pub fn check_device(&self) -> Result<()> {
        match self.lost.get() {
            None => Ok(()),
            Some(why) => Err(Error::DeviceLost(format!(
                "the GPU device '{}' was lost ({why}); nothing can be recorded on it again: open a new device and make a new recorder",
                self.info.name
            ))),
        }
    }

    /// Runs `work` (a frame's recording, a wait for its statistics) under the validation,
    /// internal and out-of-memory error scopes: what wgpu reports on its way — a device lost
    /// meanwhile invalidates everything recorded on it, an allocation the device cannot make —
    /// comes back as an error naming `what`, never as wgpu's uncaptured-error panic.
    pub fn guarded<T>(&self, what: &str, work: impl FnOnce() -> Result<T>) -> Result<T> {
        // A non-blocking poll: a device destroyed since the last one calls its lost callback
        // there.
        let _ = self.device.poll(wgpu::PollType::Poll);
        self.check_device()?;
        let memory = self.device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
        let internal = self.device.push_error_scope(wgpu::ErrorFilter::Internal);
        let validation = self.device.push_error_scope(wgpu::ErrorFilter::Validation);
        let done = work();
        let invalid = pollster::block_on(validation.pop());
        let failed = pollster::block_on(internal.pop());
        let out_of_memory = pollster::block_on(memory.pop());
        // A device lost meanwhile is the cause of whatever failed.
        self.check_device()?;
        match (out_of_memory, invalid.or(failed)) {
            (Some(e), _) => Err(Error::runtime(format!(
                "{what}: the device '{}' is out of memory: {}",
                self.info.name,
                one_line_wgpu(&e)
            ))),
            (None, Some(e)) => Err(Error::runtime(format!(
                "{what}: wgpu reported: {}",
                one_line_wgpu(&e)
            ))),
            (None, None) => done,
        }
    }

    /// Blocks until all submitted work is done; whether the queue is then empty (everything
    /// submitted has completed and its mapping callbacks have run).
    pub fn wait_idle(&self) -> Result<bool> {
        self.device
            .poll(wgpu::PollType::wait_indefinitely())
            .map(|status| status.is_queue_empty())
            .map_err(|e| Error::runtime(format!("GPU wait failed: {e}")))
    }

    /// Blocks until all submitted work is done.
    pub fn wait(&self) -> Result<()> {
        self.device
            .poll(wgpu::PollType::wait_indefinitely())
            .map(|_| ())
            .map_err(|e| Error::runtime(format!("GPU wait failed: {e}")))
    }

    /// Largest single storage buffer binding the device allows.
    pub fn max_storage_binding(&self) -> u64 {
        self.limits
            .max_storage_buffer_binding_size
            .min(self.limits.max_buffer_size)
    }

    /// What `strata info` prints about this device.
    pub fn report(&self) -> GpuReport {
        let features = self
            .adapter
            .as_ref()
            .map_or(self.features, |a| a.features())
            .iter_names()
            .map(|(n, _)| n.to_string())
            .collect();
        GpuReport {
            adapter: self.info.name.clone(),
            backend: self.backend_name(),
            device_type: format!("{:?}", self.info.device_type),
            driver: self.info.driver.clone(),
            driver_info: self.info.driver_info.clone(),
            vendor: self.info.vendor,
            device: self.info.device,
            features,
            limits: limits_json(&self.limits),
            timestamp_period_ns: self
                .has(wgpu::Features::TIMESTAMP_QUERY)
                .then(|| self.queue.get_timestamp_period()),
        }
    }

    /// A storage buffer with a `strata.` label, checked against the device's binding limit.
    pub fn storage_buffer(
        &self,
        label: &str,
        size: u64,
        extra: wgpu::BufferUsages,
    ) -> Result<wgpu::Buffer> {
        let size = size.max(16).next_multiple_of(4);
        if size > self.max_storage_binding() {
            return Err(Error::unsupported(format!(
                "{label}: needs a {:.1} MiB buffer, {} ({:.1} MiB)",
                size as f64 / 1048576.0,
                crate::error::OVER_BINDING,
                self.max_storage_binding() as f64 / 1048576.0
            )));
        }
        Ok(self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST | extra,
            mapped_at_creation: false,
        }))
    }
}

/// Buffers and textures a method keeps between frames, keyed by label and re-created only when
/// their size changes, so a steady frame allocates nothing.
#[derive(Default)]
pub struct ResourceCache {
    buffers: std::collections::HashMap<&'static str, wgpu::Buffer>,
    textures: std::collections::HashMap<&'static str, wgpu::Texture>,
}

impl ResourceCache {
    /// A storage buffer (see [`Gpu::storage_buffer`]) that only shaders read and write.
    pub fn storage(&mut self, gpu: &Gpu, label: &'static str, size: u64) -> Result<wgpu::Buffer> {
        self.storage_with(gpu, label, size, wgpu::BufferUsages::empty())
    }

    /// A storage buffer the CPU reads back (counters, statistics): `COPY_SRC` as well.
    pub fn readable(&mut self, gpu: &Gpu, label: &'static str, size: u64) -> Result<wgpu::Buffer> {
        self.storage_with(gpu, label, size, wgpu::BufferUsages::COPY_SRC)
    }

    /// A storage buffer with `extra` usages (see [`Gpu::storage_buffer`]).
    pub fn storage_with(
        &mut self,
        gpu: &Gpu,
        label: &'static str,
        size: u64,
        extra: wgpu::BufferUsages,
    ) -> Result<wgpu::Buffer> {
        let usage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST | extra;
        if let Some(b) = self.buffers.get(label) {
            if b.size() == size.max(16).next_multiple_of(4) && b.usage() == usage {
                return Ok(b.clone());
            }
        }
        let b = gpu.storage_buffer(label, size, extra)?;
        self.buffers.insert(label, b.clone());
        Ok(b)
    }

    /// The buffer made under `label`, if any.
    pub fn get(&self, label: &str) -> Option<&wgpu::Buffer> {
        self.buffers.get(label)
    }

    /// Drops the buffer or texture made under `label`, if any (a frame that needs less).
    pub fn forget(&mut self, label: &str) {
        self.buffers.remove(label);
        self.textures.remove(label);
    }

    /// A uniform buffer holding `contents`, written on every call.
    pub fn uniform(&mut self, gpu: &Gpu, label: &'static str, contents: &[u8]) -> wgpu::Buffer {
        let size = contents.len() as u64;
        let b = match self.buffers.get(label) {
            Some(b) if b.size() == size => b.clone(),
            _ => {
                let b = gpu.device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some(label),
                    size,
                    usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                    mapped_at_creation: false,
                });
                self.buffers.insert(label, b.clone());
                b
            }
        };
        gpu.queue.write_buffer(&b, 0, contents);
        b
    }

    /// Fills every storage buffer the cache holds with garbage (a fixed pseudo-random stream
    /// with NaN, infinity and all-ones words mixed in), as memory left by another frame or
    /// another application would be. Uniform buffers are left alone. Takes effect at the next
    /// submission.
    pub fn poison(&self, gpu: &Gpu) {
        for b in self.buffers.values() {
            if !b.usage().contains(wgpu::BufferUsages::UNIFORM) {
                gpu.queue.write_buffer(b, 0, &garbage(b.size()));
            }
        }
    }

    /// A 2D texture of one mip level and sample.
    pub fn texture(
        &mut self,
        gpu: &Gpu,
        label: &'static str,
        size: (u32, u32),
        format: wgpu::TextureFormat,
        usage: wgpu::TextureUsages,
    ) -> wgpu::Texture {
        self.texture_samples(gpu, label, size, format, usage, 1)
    }

    /// [`ResourceCache::texture`] with `samples` per pixel.
    pub fn texture_samples(
        &mut self,
        gpu: &Gpu,
        label: &'static str,
        (width, height): (u32, u32),
        format: wgpu::TextureFormat,
        usage: wgpu::TextureUsages,
        samples: u32,
    ) -> wgpu::Texture {
        if let Some(t) = self.textures.get(label) {
            if (t.width(), t.height()) == (width, height)
                && t.format() == format
                && t.usage() == usage
                && t.sample_count() == samples
            {
                return t.clone();
            }
        }
        let t = gpu.texture_2d_samples(label, (width, height), format, usage, samples);
        self.textures.insert(label, t.clone());
        t
    }
}

/// `size` bytes of deterministic garbage.
pub fn garbage(size: u64) -> Vec<u8> {
    let mut x = 0x9e37_79b9u32;
    (0..size / 4)
        .flat_map(|i| {
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            let word = match i % 7 {
                0 => f32::NAN.to_bits(),
                1 => u32::MAX,
                2 => f32::INFINITY.to_bits(),
                _ => x,
            };
            word.to_le_bytes()
        })
        .collect()
}

fn limits_json(l: &wgpu::Limits) -> std::collections::BTreeMap<&'static str, u64> {
    std::collections::BTreeMap::from([
        (
            "max_texture_dimension_2d",
            l.max_texture_dimension_2d as u64,
        ),
        (
            "max_storage_buffer_binding_size",
            l.max_storage_buffer_binding_size,
        ),
        ("max_buffer_size", l.max_buffer_size),
        (
            "max_storage_buffers_per_shader_stage",
            l.max_storage_buffers_per_shader_stage as u64,
        ),
        (
            "max_storage_textures_per_shader_stage",
            l.max_storage_textures_per_shader_stage as u64,
        ),
        ("max_bind_groups", l.max_bind_groups as u64),
        (
            "max_compute_workgroup_storage_size",
            l.max_compute_workgroup_storage_size as u64,
        ),
        ("max_color_attachments", l.max_color_attachments as u64),
        (
            "max_color_attachment_bytes_per_sample",
            l.max_color_attachment_bytes_per_sample as u64,
        ),
        (
            "max_compute_workgroup_size_x",
            l.max_compute_workgroup_size_x as u64,
        ),
        (
            "max_compute_invocations_per_workgroup",
            l.max_compute_invocations_per_workgroup as u64,
        ),
        (
            "max_compute_workgroups_per_dimension",
            l.max_compute_workgroups_per_dimension as u64,
        ),
        (
            "max_uniform_buffer_binding_size",
            l.max_uniform_buffer_binding_size,
        ),
    ])
}
