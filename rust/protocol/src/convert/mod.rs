//! Between the wire types and antumbra-core's, one file per job: meshes and images
//! (`meshes`), scene parts (`parts`), alpha materials (`alpha`), frames (`frames`),
//! results (`results`); settings here.
//!
//! Daemon side: [`mesh_from_upload`], [`scene_from_frame`], [`render_settings`],
//! [`frame_result_reply`]. Client side (Python client, recordings): [`upload_from_mesh`],
//! [`scene_to_messages`], [`planes_from_reply`], [`visible_from_reply`], [`stats_from_reply`].

mod alpha;
mod frames;
mod meshes;
mod parts;
mod results;

use std::collections::HashMap;
use std::hash::BuildHasher;
use std::sync::Arc;

use antumbra_core::alpha::AlphaImage;
use antumbra_core::render::RenderSettings;
use antumbra_core::scene::Mesh;
use antumbra_core::settings::NamedSettings;

use crate::error::ProtocolError;

pub use frames::{
    distinct_lacking, frame_image_hashes, frame_mesh_hashes, frame_update_from_scene,
    missing_images, missing_meshes, scene_from_frame, scene_to_messages,
};
pub use meshes::{
    image_from_upload, image_label, mesh_from_upload, upload_from_image, upload_from_mesh,
};
pub use results::{
    frame_result_reply, planes_from_reply, stats_from_reply, visible_from_reply, warm_up_reply,
};
pub(crate) use results::{image, plane_from_image};

/// Where the daemon keeps uploaded meshes (and alpha images), by content hash.
pub trait MeshStore {
    fn mesh(&self, hash: u64) -> Option<Arc<Mesh>>;
    /// The alpha image with this hash; a store of meshes alone holds none.
    fn image(&self, _hash: u64) -> Option<Arc<AlphaImage>> {
        None
    }
}

impl<S: BuildHasher> MeshStore for HashMap<u64, Arc<Mesh>, S> {
    fn mesh(&self, hash: u64) -> Option<Arc<Mesh>> {
        self.get(&hash).cloned()
    }
}

/// Meshes from one map and alpha images from another (a session's, a replay's).
impl<S: BuildHasher, T: BuildHasher> MeshStore
    for (
        &HashMap<u64, Arc<Mesh>, S>,
        &HashMap<u64, Arc<AlphaImage>, T>,
    )
{
    fn mesh(&self, hash: u64) -> Option<Arc<Mesh>> {
        self.0.get(&hash).cloned()
    }

    fn image(&self, hash: u64) -> Option<Arc<AlphaImage>> {
        self.1.get(&hash).cloned()
    }
}
/// The core settings of a request: [`NamedSettings::resolve`], every error naming its setting.
pub fn render_settings(s: &NamedSettings) -> Result<RenderSettings, ProtocolError> {
    Ok(s.resolve()?)
}
