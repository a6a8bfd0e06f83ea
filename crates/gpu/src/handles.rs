//! Typed handles to what one step of a frame writes and a later one reads: the depth
//! buffer, the linear HDR image, the display image and the light grids. Every pass that
//! reads or writes one of them takes its handle in its constructor (and, where it records
//! into it, in `record`), so a pass's signature says what it reads and writes; no raw
//! texture view of the frame's targets is passed around (`targets::target_handles` gives a
//! frame's). Depends on the crate's light grid only.

use crate::light_grid::LightGrid;

/// The frame's reversed-Z depth of opaque and masked geometry, `samples` values a pixel
/// (written by the method's head step: depth pre-pass or G-buffer).
#[derive(Clone, Copy)]
pub struct Depth<'a> {
    /// The depth attachment's view.
    pub view: &'a wgpu::TextureView,
    /// MSAA samples per pixel.
    pub samples: u32,
}

/// The frame's linear HDR radiance, one resolved value a pixel (written by the method's
/// shading, then blended geometry composites over it; the tonemap reads it).
#[derive(Clone, Copy)]
pub struct Hdr<'a> {
    /// The HDR image's view.
    pub view: &'a wgpu::TextureView,
}

/// The tonemapped display image (written by the tonemap, then the heat map over it).
#[derive(Clone, Copy)]
pub struct Ldr<'a> {
    /// The display image's view (a render attachment).
    pub view: &'a wgpu::TextureView,
    /// Its storage view (compute writes).
    pub storage: &'a wgpu::TextureView,
}

/// A light grid: per list `(first, count)`, the indices and the header (written by a
/// culling step, read by shading, blended geometry and the heat map).
#[derive(Clone, Copy)]
pub struct Lists<'a> {
    /// The grid.
    pub grid: &'a LightGrid,
}
