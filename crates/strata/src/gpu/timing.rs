//! GPU timing of passes with timestamp queries written at pass boundaries.
//!
//! Each pass asks for a begin/end pair under a name; passes with the same name (f2b's peel
//! passes, say) add up. Without TIMESTAMP_QUERY every time is `None`, reported as `null`.

use std::collections::BTreeMap;

use crate::error::Result;
use crate::gpu::{readback, Gpu};

/// WebGPU's largest query set.
const MAX_QUERIES: u32 = 4096;

pub struct Timer {
    set: Option<wgpu::QuerySet>,
    resolve: Option<wgpu::Buffer>,
    names: Vec<&'static str>,
    period_ns: f64,
    overflowed: bool,
}

impl Timer {
    pub fn new(gpu: &Gpu) -> Timer {
        let enabled = gpu.has(wgpu::Features::TIMESTAMP_QUERY);
        let set = enabled.then(|| {
            gpu.device.create_query_set(&wgpu::QuerySetDescriptor {
                label: Some("strata.timestamps"),
                ty: wgpu::QueryType::Timestamp,
                count: MAX_QUERIES,
            })
        });
        let resolve = enabled.then(|| {
            gpu.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("strata.timestamps.resolve"),
                size: MAX_QUERIES as u64 * 8,
                usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            })
        });
        Timer {
            set,
            resolve,
            names: Vec::new(),
            period_ns: gpu.queue.get_timestamp_period() as f64,
            overflowed: false,
        }
    }

    /// Starts a new frame's measurements.
    pub fn reset(&mut self) {
        self.names.clear();
        self.overflowed = false;
    }

    fn next_pair(&mut self, name: &'static str) -> Option<(&wgpu::QuerySet, u32)> {
        let set = self.set.as_ref()?;
        let index = self.names.len() as u32 * 2;
        if index + 2 > MAX_QUERIES {
            self.overflowed = true;
            return None;
        }
        self.names.push(name);
        Some((set, index))
    }

    pub fn render_pass(
        &mut self,
        name: &'static str,
    ) -> Option<wgpu::RenderPassTimestampWrites<'_>> {
        self.next_pair(name)
            .map(|(query_set, i)| wgpu::RenderPassTimestampWrites {
                query_set,
                beginning_of_pass_write_index: Some(i),
                end_of_pass_write_index: Some(i + 1),
            })
    }

    pub fn compute_pass(
        &mut self,
        name: &'static str,
    ) -> Option<wgpu::ComputePassTimestampWrites<'_>> {
        self.next_pair(name)
            .map(|(query_set, i)| wgpu::ComputePassTimestampWrites {
                query_set,
                beginning_of_pass_write_index: Some(i),
                end_of_pass_write_index: Some(i + 1),
            })
    }

    /// Reads this frame's timestamps: pass name → milliseconds. `None` when the adapter cannot
    /// time or more passes ran than the query set holds.
    pub fn collect(&mut self, gpu: &Gpu) -> Result<Option<BTreeMap<String, f64>>> {
        let (Some(set), Some(resolve)) = (&self.set, &self.resolve) else {
            return Ok(None);
        };
        if self.overflowed {
            return Ok(None);
        }
        let mut out = BTreeMap::new();
        if self.names.is_empty() {
            return Ok(Some(out));
        }
        let count = self.names.len() as u32 * 2;
        let mut enc = gpu
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("strata.timestamps.resolve"),
            });
        enc.resolve_query_set(set, 0..count, resolve, 0);
        gpu.queue.submit([enc.finish()]);
        let ticks: Vec<u64> =
            bytemuck::pod_collect_to_vec(&readback::read_buffer(gpu, resolve, count as u64 * 8)?);
        for (i, name) in self.names.iter().enumerate() {
            let dt = ticks[2 * i + 1].saturating_sub(ticks[2 * i]) as f64 * self.period_ns / 1e6;
            *out.entry(name.to_string()).or_insert(0.0) += dt;
        }
        Ok(Some(out))
    }
}
