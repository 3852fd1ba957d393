//! Copies GPU buffers back to the CPU.

use crate::error::{Error, Result};
use crate::gpu::Gpu;

/// Reads `size` bytes of `src` (which needs COPY_SRC) after all submitted work.
pub fn read_buffer(gpu: &Gpu, src: &wgpu::Buffer, size: u64) -> Result<Vec<u8>> {
    let staging = gpu.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("strata.readback"),
        size,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let mut enc = gpu
        .device
        .create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("strata.readback"),
        });
    enc.copy_buffer_to_buffer(src, 0, &staging, 0, size);
    gpu.queue.submit([enc.finish()]);
    map_and_read(gpu, &staging)
}

/// Maps a MAP_READ buffer and returns its contents.
pub fn map_and_read(gpu: &Gpu, staging: &wgpu::Buffer) -> Result<Vec<u8>> {
    let slice = staging.slice(..);
    let (tx, rx) = std::sync::mpsc::channel();
    slice.map_async(wgpu::MapMode::Read, move |r| {
        let _ = tx.send(r);
    });
    gpu.wait()?;
    rx.recv()
        .map_err(|_| Error::runtime("readback callback never ran"))?
        .map_err(|e| Error::runtime(format!("readback failed: {e}")))?;
    let data = slice
        .get_mapped_range()
        .map_err(|e| Error::runtime(format!("readback mapping failed: {e}")))?
        .to_vec();
    staging.unmap();
    Ok(data)
}

pub fn read_u32s(gpu: &Gpu, src: &wgpu::Buffer, count: u64) -> Result<Vec<u32>> {
    Ok(bytemuck::pod_collect_to_vec(&read_buffer(
        gpu,
        src,
        count * 4,
    )?))
}
