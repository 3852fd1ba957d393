//! Copies GPU buffers back to the CPU.

use crate::error::{Error, Result};
use crate::gpu::Gpu;

/// Reads `size` bytes of `src` (which needs COPY_SRC) after all submitted work.
pub fn read_buffer(gpu: &Gpu, src: &wgpu::Buffer, size: u64) -> Result<Vec<u8>> {
    copy_and_read(gpu, "strata.readback", size, |enc, staging| {
        enc.copy_buffer_to_buffer(src, 0, staging, 0, size)
    })
}

/// A buffer of `size` bytes that copies write into and the CPU maps to read.
pub fn staging_buffer(gpu: &Gpu, label: &str, size: u64) -> wgpu::Buffer {
    gpu.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    })
}

/// Submits `copy` into a new staging buffer of `size` bytes and reads the buffer back after all
/// submitted work.
fn copy_and_read(
    gpu: &Gpu,
    label: &str,
    size: u64,
    copy: impl FnOnce(&mut wgpu::CommandEncoder, &wgpu::Buffer),
) -> Result<Vec<u8>> {
    let staging = staging_buffer(gpu, label, size);
    let mut enc = gpu
        .device
        .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some(label) });
    copy(&mut enc, &staging);
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

/// Reads `count` u32 words of `src` (which needs COPY_SRC), waiting for the GPU.
pub fn read_u32s(gpu: &Gpu, src: &wgpu::Buffer, count: u64) -> Result<Vec<u32>> {
    Ok(bytemuck::pod_collect_to_vec(&read_buffer(
        gpu,
        src,
        count * 4,
    )?))
}

/// Reads a texture back, rows unpadded: `bytes_per_texel` bytes per texel, row-major.
pub fn read_texture(gpu: &Gpu, texture: &wgpu::Texture) -> Result<Vec<u8>> {
    let (w, h) = (texture.width(), texture.height());
    let texel = texture
        .format()
        .block_copy_size(Some(wgpu::TextureAspect::All))
        .ok_or_else(|| Error::runtime("texture format has no single copy size"))?;
    let row = (w * texel).next_multiple_of(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT);
    let data = copy_and_read(
        gpu,
        "strata.readback.texture",
        (row * h) as u64,
        |enc, staging| {
            enc.copy_texture_to_buffer(
                texture.as_image_copy(),
                wgpu::TexelCopyBufferInfo {
                    buffer: staging,
                    layout: wgpu::TexelCopyBufferLayout {
                        offset: 0,
                        bytes_per_row: Some(row),
                        rows_per_image: Some(h),
                    },
                },
                texture.size(),
            )
        },
    )?;
    let tight = (w * texel) as usize;
    Ok(data
        .chunks(row as usize)
        .take(h as usize)
        .flat_map(|r| r[..tight].iter().copied())
        .collect())
}

/// Reads an Rgba16Float texture back as f32 RGBA per texel, row-major.
pub fn read_rgba16f(gpu: &Gpu, texture: &wgpu::Texture) -> Result<Vec<[f32; 4]>> {
    if texture.format() != wgpu::TextureFormat::Rgba16Float {
        return Err(Error::runtime("read_rgba16f needs an Rgba16Float texture"));
    }
    let bytes = read_texture(gpu, texture)?;
    Ok(bytes
        .chunks_exact(8)
        .map(|t| {
            let c = |i: usize| half::f16::from_le_bytes([t[2 * i], t[2 * i + 1]]).to_f32();
            [c(0), c(1), c(2), c(3)]
        })
        .collect())
}

/// Buffer ranges a method asks to have read back with its frame's statistics, in order.
#[derive(Default)]
pub struct ReadbackList {
    pub(crate) entries: Vec<(wgpu::Buffer, u64, u64)>,
}

impl ReadbackList {
    /// Reads `words` u32 words of `buffer` (which needs COPY_SRC) from byte `offset`.
    pub fn words(&mut self, buffer: &wgpu::Buffer, offset: u64, words: u64) {
        self.entries.push((buffer.clone(), offset, words));
    }

    /// Words of every range together.
    pub fn total_words(&self) -> u64 {
        self.entries.iter().map(|e| e.2).sum()
    }
}

/// A frame's readback as segments, one per stage that reads words back: each stage appends its
/// [`ReadbackList`] and keeps the [`Segment`] it got, which finds its words again when they
/// come back; no stage knows where another's lie.
#[derive(Default)]
pub struct Segments {
    entries: Vec<(wgpu::Buffer, u64, u64)>,
    words: u64,
}

/// Where one stage's words lie in its frame's readback.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Segment {
    start: u64,
    words: u64,
}

impl Segments {
    /// Appends `list`'s ranges as one segment.
    pub fn push(&mut self, list: ReadbackList) -> Segment {
        let segment = Segment {
            start: self.words,
            words: list.total_words(),
        };
        self.words += segment.words;
        self.entries.extend(list.entries);
        segment
    }

    /// The segment of the ranges `read` asks for (a stage appending its words).
    pub fn read(&mut self, read: impl FnOnce(&mut ReadbackList)) -> Segment {
        let mut list = ReadbackList::default();
        read(&mut list);
        self.push(list)
    }

    /// The ranges to copy, in order.
    pub fn entries(&self) -> &[(wgpu::Buffer, u64, u64)] {
        &self.entries
    }
}

impl Segment {
    /// This segment's words in a frame's readback.
    pub fn of<'w>(&self, words: &'w [u32]) -> &'w [u32] {
        &words[self.start as usize..(self.start + self.words) as usize]
    }
}
