//! Alpha materials both ways: a frame's materials resolved against the stored images, and a
//! scene's materials named by image hash.

use std::collections::HashMap;

use antumbra_core::alpha::{AlphaProgram, AlphaSource};
use antumbra_core::scene::{AlphaMaterial, Scene, SceneAlpha};

use super::MeshStore;
use crate::error::ProtocolError;
use crate::messages::{AlphaMaterialState, AlphaSourceState, FrameUpdate};

/// The frame's alpha images and materials: each distinct image once (the store's `Arc`), in
/// order of first use; errors name the frame and the material (an image the store lacks, a
/// constant that is not finite).
pub(super) fn scene_alpha(
    update: &FrameUpdate,
    store: &impl MeshStore,
) -> Result<SceneAlpha, ProtocolError> {
    let frame = update.frame;
    let mut alpha = SceneAlpha::default();
    let mut index_of: HashMap<u64, u32> = HashMap::new();
    for (i, m) in update.alpha_materials.iter().enumerate() {
        let owner = format!("frame {frame}: alpha_materials[{i}] '{}'", m.name);
        let source = match m.source {
            AlphaSourceState::Constant { alpha } => AlphaSource::Constant(alpha),
            AlphaSourceState::Image {
                hash,
                interpolation,
                extension,
            } => {
                let image = match index_of.get(&hash) {
                    Some(&k) => k,
                    None => {
                        let image =
                            store
                                .image(hash)
                                .ok_or_else(|| ProtocolError::UnknownImage {
                                    frame,
                                    material: m.name.clone(),
                                    hash,
                                })?;
                        alpha.images.push(image);
                        let k = (alpha.images.len() - 1) as u32;
                        index_of.insert(hash, k);
                        k
                    }
                };
                // One UV map per material, by name: the mesh's map of that name is UV set 0.
                AlphaSource::Image {
                    image,
                    uv_set: 0,
                    interpolation,
                    extension,
                }
            }
        };
        let program = AlphaProgram {
            source,
            ops: m.ops.clone(),
        };
        program.validate(&owner, alpha.images.len(), 1)?;
        alpha.materials.push(AlphaMaterial {
            name: m.name.clone(),
            uv_map: m.uv_map.clone(),
            program,
        });
    }
    Ok(alpha)
}
/// A scene's alpha materials as the wire's, images by content hash (`image_hashes`, parallel
/// to `scene.alpha.images`).
pub(super) fn alpha_materials_state(
    scene: &Scene,
    image_hashes: &[u64],
) -> Result<Vec<AlphaMaterialState>, ProtocolError> {
    scene
        .alpha
        .materials
        .iter()
        .enumerate()
        .map(|(i, m)| {
            let source = match m.program.source {
                AlphaSource::Constant(alpha) => AlphaSourceState::Constant { alpha },
                AlphaSource::Image {
                    image,
                    interpolation,
                    extension,
                    ..
                } => AlphaSourceState::Image {
                    hash: *image_hashes.get(image as usize).ok_or_else(|| {
                        ProtocolError::invalid(
                            format!("alpha.materials[{i}] '{}'.source.image", m.name),
                            format!(
                                "image {image}, but the scene has {} alpha images",
                                image_hashes.len()
                            ),
                        )
                    })?,
                    interpolation,
                    extension,
                },
            };
            Ok(AlphaMaterialState {
                name: m.name.clone(),
                uv_map: m.uv_map.clone(),
                source,
                ops: m.program.ops.clone(),
            })
        })
        .collect()
}
