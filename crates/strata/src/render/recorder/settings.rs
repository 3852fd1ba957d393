//! What the application changes between frames: the method, geometry, time, camera, size and
//! frame options, the histogram; and what it reads of the last frame (its per-pixel result and
//! picture, the method's buffers for tests that poison them).

use super::*;

impl FrameRecorder {
    /// Switches method; its pipelines are built on first use and kept.
    pub fn set_method(&mut self, method: MethodId) -> Result<()> {
        let triangles = self.scene.triangle_count as u64;
        method
            .descriptor()
            .admit(&self.options, &self.scene.blend_modes, triangles)?;
        if self.scene.application.is_some() {
            method.descriptor().check_app_shaders()?;
        }
        if !self.methods.contains_key(&method) {
            let m = crate::gpu::validated(&self.gpu, method.as_str(), || {
                methods::create(method, &self.gpu, &self.scene, &self.options)
            })?;
            self.methods.insert(method, m);
        }
        self.method = method;
        Ok(())
    }

    /// Replaces the scene's geometry for the next frames (an animated scene's next time step):
    /// written in place when the triangle count is unchanged, else the scene buffers are
    /// rebuilt (pipelines are kept either way). Materials and lights stay those of the first
    /// scene when the count is unchanged.
    pub fn set_geometry(&mut self, scene: &Scene) -> Result<()> {
        let gpu = self.gpu.clone();
        gpu.guarded("replacing the geometry", || self.replace_geometry(scene))
    }

    fn replace_geometry(&mut self, scene: &Scene) -> Result<()> {
        let split;
        let scene = match &mut self.lit {
            None => scene,
            Some(lit) => {
                split = scene.split_by_opacity();
                lit.set_geometry(&split.0)?;
                &split.1
            }
        };
        if !self.scene.update_geometry(&self.gpu, scene)? {
            let camera = self.scene.camera;
            let mut rebuilt = SceneGpu::new_allow_empty(&self.gpu, scene, &self.options)?;
            // The pipelines were made with the first layouts: keep binding through them.
            rebuilt.frame_layout = self.scene.frame_layout.clone();
            rebuilt.raster_layout = self.scene.raster_layout.clone();
            rebuilt.update(&self.gpu, &camera, &self.options);
            self.scene = rebuilt;
            self.order = attach_order(&self.gpu, &self.options, &mut self.scene)?;
        } else if let Some(order) = &self.order {
            order.set_centroids(&self.gpu, &self.scene.centroids);
            if let Some(animation) = &mut self.scene.animation {
                animation.bind(&self.gpu, &self.scene.vertices, Some(order.centroids()));
            }
        }
        self.camera_path = scene.camera_path.clone();
        Ok(())
    }

    /// Moves the scene to time `t` (frames) for the next frames: its moving objects move on
    /// the GPU when the next frame is recorded (no mesh is rebuilt or uploaded), and a camera
    /// path moves the camera ([`FrameRecorder::set_camera`] afterwards overrides it).
    pub fn set_time(&mut self, t: f32) {
        self.scene.set_time(t);
        if let Some(lit) = &mut self.lit {
            lit.set_time(t);
        }
        if let Some(path) = &self.camera_path {
            let camera = path.camera_at(t);
            self.set_camera(&camera);
        }
    }

    /// The time the next frame shows (the scene's own time until [`FrameRecorder::set_time`]).
    pub fn time(&self) -> Option<f32> {
        self.scene.animation.as_ref().map(|a| a.time())
    }

    /// Turns the GPU depth-complexity histogram on or off for the next frames: one more count
    /// geometry pass and a binning pass per frame; the bins arrive with the frame's statistics
    /// (`FrameStats::depth_histogram`).
    pub fn set_histogram(&mut self, on: bool) {
        if !on {
            self.histogram = None;
        } else if self.histogram.is_none() {
            self.histogram = Some(GpuHistogram::new(&self.gpu, &self.scene));
        }
    }

    /// Moves the camera for the next frames.
    pub fn set_camera(&mut self, camera: &Camera) {
        self.scene.update(&self.gpu, camera, &self.options);
        if let Some(lit) = &mut self.lit {
            lit.set_camera(camera, &self.options);
        }
    }

    /// The lit opaque frame, with `options.pipeline` (its HDR image and depth).
    pub fn lit(&self) -> Option<&LitFrame> {
        self.lit.as_ref()
    }

    /// Changes the frame size; pipelines are kept and per-pixel buffers follow on the next frame.
    pub fn resize(&mut self, width: u32, height: u32) -> Result<()> {
        let gpu = self.gpu.clone();
        gpu.guarded("resizing the frame", || self.resized(width, height))
    }

    fn resized(&mut self, width: u32, height: u32) -> Result<()> {
        let mut options = self.options.clone();
        options.frame.width = width;
        options.frame.height = height;
        options.validate()?;
        check_size(&self.gpu, &options)?;
        self.output = output_buffer(&self.gpu, &options)?;
        self.no_opaque = no_opaque_depth(&self.gpu, &options);
        self.options = options;
        let camera = self.scene.camera;
        self.set_camera(&camera);
        Ok(())
    }

    /// The options of the next frames: size, effect, k and every family's parameters, order,
    /// temporal culling. What the recorder was made with ([`crate::frame::BuildOptions`]) stays;
    /// another rasterizer, sample count or pipeline needs another recorder.
    pub fn set_frame_options(&mut self, frame: &FrameOptions) -> Result<()> {
        let gpu = self.gpu.clone();
        gpu.guarded("changing the frame's options", || {
            self.take_frame_options(frame)
        })
    }

    fn take_frame_options(&mut self, frame: &FrameOptions) -> Result<()> {
        let options = RenderOptions {
            build: self.options.build.clone(),
            frame: frame.clone(),
        };
        options.validate()?;
        if self.scene.application.is_some() {
            check_application_options(&options)?;
        }
        let triangles = self.scene.triangle_count as u64;
        self.method
            .descriptor()
            .admit(&options, &self.scene.blend_modes, triangles)?;
        let old = &self.options.frame;
        if (frame.width, frame.height) != (old.width, old.height) {
            self.resized(frame.width, frame.height)?;
        }
        let old = &self.options.frame;
        if (frame.order, frame.order_seed) != (old.order, old.order_seed) {
            self.order = attach_order(&self.gpu, &options, &mut self.scene)?;
        }
        self.frame_k = frame.k;
        self.options = options;
        let camera = self.scene.camera;
        self.set_camera(&camera);
        Ok(())
    }

    /// The per-pixel result of the last recorded frame ([`crate::frame::Resolved`]; COPY_SRC).
    pub fn resolved(&self) -> &wgpu::Buffer {
        &self.output
    }

    /// The last submitted frame's picture over the options' background, read back (a blocking
    /// readback: screenshots and checks, not the real-time loop).
    pub fn picture(&self) -> Result<crate::LinearImage> {
        self.gpu.guarded("reading the frame back", || {
            let bytes = self.options.pixels() * crate::frame::RESOLVED_BYTES;
            let raw = crate::gpu::readback::read_buffer(&self.gpu, &self.output, bytes)?;
            let resolved: Vec<crate::frame::Resolved> = bytemuck::pod_collect_to_vec(&raw);
            Ok(crate::render::over_background(&self.options, &resolved))
        })
    }

    /// The buffers the current method keeps between frames (for tests that poison them).
    pub fn method_resources(&self) -> Vec<&crate::gpu::ResourceCache> {
        self.methods[&self.method].resources()
    }

    /// Fills the current method's buffers, the resolved frame and the totals with garbage
    /// before the next frame (tests: a correct frame reads nothing it did not write).
    pub fn poison(&self) {
        for cache in self.method_resources() {
            cache.poison(&self.gpu);
        }
        if let Some(raster) = &self.raster {
            raster.resources().poison(&self.gpu);
        }
        for b in [&self.output, &self.scene.totals] {
            self.gpu
                .queue
                .write_buffer(b, 0, &crate::gpu::garbage(b.size()));
        }
    }
}
