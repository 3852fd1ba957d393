//! The present stage: the last resolved frame OVER the application's color target (with a lit
//! pipeline, over its HDR image, then tone-mapped into the target).

use super::*;

impl FrameRecorder {
    /// Composites the last resolved frame OVER `color` (with a lit pipeline, over its image,
    /// then tone-maps into `color`); `k` scales the complexity heatmap, `timed` times the pass.
    pub(super) fn present_into(
        &mut self,
        encoder: &mut wgpu::CommandEncoder,
        color: Option<(&wgpu::TextureView, wgpu::TextureFormat)>,
        k: Option<u32>,
        timed: bool,
    ) {
        let gpu = &self.gpu;
        // With a pipeline the method presents over the lit image (not over a G-buffer view),
        // and the tone map writes the application's target.
        let hdr = self.lit.as_ref().map(|lit| {
            (
                lit.hdr().create_view(&Default::default()),
                lit.hdr().format(),
            )
        });
        let present_to = match &hdr {
            Some(_) if self.options.build.lighting.gbuffer_debug.is_some() => None,
            Some((view, format)) => Some((view, *format)),
            None => color,
        };
        if let Some((view, format)) = present_to {
            let params = PresentParams {
                size: [self.options.frame.width, self.options.frame.height],
                complexity: (self.options.frame.effect == Effect::Complexity) as u32,
                complexity_full: k.unwrap_or(64).max(1),
            };
            let tinted = self
                .scene
                .blend_modes
                .contains(&crate::scene::Blend::Multiply);
            if tinted && hdr.is_some() {
                if let Some(lit) = &mut self.lit {
                    lit.background_under(encoder, &mut self.timer);
                }
            }
            let stamps = match timed {
                true => self.timer.render_pass("present"),
                false => None,
            };
            self.present.record(
                gpu,
                encoder,
                view,
                format,
                &self.output,
                params,
                tinted,
                stamps,
            );
        }
        if let (Some(lit), Some((view, format))) = (&mut self.lit, color) {
            lit.tonemap(encoder, &mut self.timer, view, format);
        }
    }
}
