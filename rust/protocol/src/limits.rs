//! What a daemon accepts: sizes and counts that bound the memory and time one request can take.
//! The daemon sends its limits in `Welcome` so a client can check before it sends.

use antumbra_core::scene::limits::{MAX_MESHES, MAX_OBJECTS, MAX_TRIANGLES_PER_MESH};
use serde::{Deserialize, Serialize};

const GIB: u64 = 1 << 30;

/// The default render memory budget ([`Limits::max_render_bytes`]).
pub const DEFAULT_MAX_RENDER_BYTES: u64 = 8 * GIB;

/// The default bound on the method passes of one request ([`Limits::max_request_passes`]):
/// the default comparison (5 methods, 1 counted and 3 timed passes each) over 5,000 frames.
pub const DEFAULT_MAX_REQUEST_PASSES: u64 = 100_000;

/// The largest body a 4-byte length prefix can announce; larger limits are clamped to it.
pub const MAX_FRAME_BYTES_CEILING: u64 = u32::MAX as u64;

#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(default)]
pub struct Limits {
    /// Largest message body in bytes (the length prefix); default 1 GiB.
    pub max_frame_bytes: u64,
    pub max_triangles_per_mesh: u64,
    /// Most distinct meshes in one frame (and hashes in one `MissingMeshes`).
    pub max_meshes: u64,
    pub max_objects: u64,
    /// Most pixels of the rendered image (after the resolution percentage).
    pub max_image_pixels: u64,
    pub max_spp: u32,
    pub max_lights: u32,
    /// Most bytes one render is estimated to need at its peak
    /// ([`antumbra_core::render::estimate_render_bytes`]); default 8 GiB.
    pub max_render_bytes: u64,
    /// Most method passes one request may ask for, so that no request runs for ever: a
    /// `Compare`'s methods x (1 counted + `repeat` timed), a `Trade`'s knob values likewise
    /// and its reference, a `Render`'s one, times the frames of a command-line run or spool
    /// job ([`crate::admission`]); default [`DEFAULT_MAX_REQUEST_PASSES`].
    pub max_request_passes: u64,
    /// Most texels of one alpha image (and so 4 bytes each of its upload); default 8192².
    pub max_image_texels: u64,
    /// Most alpha materials of one frame (and distinct images it uses, and hashes in one
    /// `MissingImages`).
    pub max_alpha_materials: u64,
    /// Most Math-node operations of one alpha material.
    pub max_alpha_ops: u64,
    /// Most UV maps of one mesh.
    pub max_uv_maps: u64,
    /// Most material slots of one frame, each instance's counted: every object (instance)
    /// keeps its own slot list, so this bounds what an array's list multiplies into.
    pub max_material_slots: u64,
}

impl Default for Limits {
    fn default() -> Self {
        Limits {
            max_frame_bytes: GIB,
            // The figures the importers also check (core's `scene::limits`).
            max_triangles_per_mesh: MAX_TRIANGLES_PER_MESH,
            max_meshes: MAX_MESHES,
            max_objects: MAX_OBJECTS,
            max_image_pixels: 8192 * 8192,
            // Core's RenderSettings::validate allows at most 4096.
            max_spp: 4096,
            max_lights: 1024,
            // Fixed rather than a share of the machine's memory, so a frame refused on one daemon
            // is refused on every one; it holds a 4096x4096 frame with every pass and counters.
            max_render_bytes: DEFAULT_MAX_RENDER_BYTES,
            max_request_passes: DEFAULT_MAX_REQUEST_PASSES,
            // A 64 MP image is 256 MiB of f32 texels: large leaf atlases fit, a frame stays bounded.
            max_image_texels: 8192 * 8192,
            max_alpha_materials: 4096,
            // Node trees of a few Math nodes: 64 is far above any real material.
            max_alpha_ops: 64,
            // Blender allows 8 UV maps per mesh.
            max_uv_maps: 8,
            // 16M slots of 8 bytes: 128 MiB at most, whatever the instances.
            max_material_slots: 1 << 24,
        }
    }
}

impl Limits {
    /// The frame-size limit actually in force (a 4-byte prefix cannot announce more).
    pub fn frame_limit(&self) -> u64 {
        self.max_frame_bytes.min(MAX_FRAME_BYTES_CEILING)
    }
}
