//! Instance arrays (`FrameUpdate.instances`): one array of f32 matrices (and ids) per mesh
//! instead of one map per object, and only the arrays that changed since the last frame the
//! session accepted. The daemon expands them into the frame's objects, so nothing below the
//! protocol tells an instance from an object.

use antumbra_core::scene::Object;
use glam::DMat4;
use serde_bytes::ByteBuf;

use crate::error::ProtocolError;
use crate::messages::{FrameUpdate, InstanceArrayState};

/// Bytes of one instance's matrix: three rows of four f32.
pub const MATRIX_BYTES: usize = 48;
/// Bytes of one instance's id: a u32.
pub const ID_BYTES: usize = 4;

/// How many instances the array holds (by its matrices' bytes, rounded down; a length that is
/// not a whole number of matrices is refused by [`instance_objects`]). 0 while `unchanged`.
pub fn instance_count(array: &InstanceArrayState) -> u64 {
    (array.matrices.len() / MATRIX_BYTES) as u64
}

/// The frame's objects: its plain objects and every instance of every array.
pub fn object_count(update: &FrameUpdate) -> u64 {
    update.objects.len() as u64 + update.instances.iter().map(instance_count).sum::<u64>()
}

/// The material slots the frame's objects keep: each object's, and each array's once per
/// instance (every instance gets the array's list). Saturating, so no input overflows.
pub fn material_slot_count(update: &FrameUpdate) -> u64 {
    let objects: u64 = update
        .objects
        .iter()
        .map(|o| o.materials.len() as u64)
        .sum();
    update.instances.iter().fold(objects, |n, a| {
        n.saturating_add((a.materials.len() as u64).saturating_mul(instance_count(a)))
    })
}

/// f32 rows 0..3 of each world matrix (row-major, as Blender's `matrix_world[row][column]`) as
/// the wire's bytes.
pub fn matrices_to_bytes(rows: &[[f32; 12]]) -> ByteBuf {
    ByteBuf::from(
        rows.iter()
            .flat_map(|m| m.iter().flat_map(|v| v.to_le_bytes()))
            .collect::<Vec<u8>>(),
    )
}

fn owner(frame: i32, array: &InstanceArrayState) -> String {
    format!("frame {frame}: instance array '{}'", array.name)
}

/// The objects of one (resolved) array, placing mesh `mesh` of the frame: checks that the
/// matrices are whole, finite and as many as the ids.
pub fn instance_objects(
    frame: i32,
    array: &InstanceArrayState,
    mesh: usize,
) -> Result<Vec<Object>, ProtocolError> {
    let owner = || owner(frame, array);
    if array.unchanged {
        return Err(ProtocolError::invalid(
            format!("{}.unchanged", owner()),
            "an array marked unchanged reached the scene unresolved",
        ));
    }
    let bytes = &array.matrices;
    if !bytes.len().is_multiple_of(MATRIX_BYTES) {
        return Err(ProtocolError::invalid(
            format!("{}.matrices", owner()),
            format!(
                "{} bytes is not a multiple of {MATRIX_BYTES} (three rows of four f32)",
                bytes.len()
            ),
        ));
    }
    let count = bytes.len() / MATRIX_BYTES;
    if !array.ids.is_empty() && array.ids.len() != count * ID_BYTES {
        return Err(ProtocolError::invalid(
            format!("{}.ids", owner()),
            format!(
                "{} bytes for {count} instances (4 bytes each, or none)",
                array.ids.len()
            ),
        ));
    }
    let id = |i: usize| -> u64 {
        match array.ids.get(i * ID_BYTES..(i + 1) * ID_BYTES) {
            Some(b) => u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as u64,
            None => i as u64,
        }
    };
    let mut objects = Vec::with_capacity(count);
    for (i, chunk) in bytes.chunks_exact(MATRIX_BYTES).enumerate() {
        let mut rows = [0f64; 12];
        for (k, v) in chunk.chunks_exact(4).enumerate() {
            let value = f32::from_le_bytes([v[0], v[1], v[2], v[3]]);
            if !value.is_finite() {
                return Err(antumbra_core::Error::NonFinite {
                    owner: format!("{} instance {i}", owner()),
                    what: "world matrix",
                    index: k,
                    value: value as f64,
                }
                .into());
            }
            rows[k] = value as f64;
        }
        let column = |c: usize| [rows[c], rows[4 + c], rows[8 + c], (c == 3) as u8 as f64];
        let world_from_object =
            DMat4::from_cols_array_2d(&[column(0), column(1), column(2), column(3)]);
        objects.push(Object {
            name: format!("{}[{}]", array.name, id(i)),
            mesh,
            world_from_object,
            visible_to_camera: array.visible_to_camera,
            casts_shadow: array.casts_shadow,
            materials: array.materials.clone(),
        });
    }
    Ok(objects)
}

/// Checks that no two arrays of the frame share a name (an `unchanged` array names the one it
/// repeats).
fn check_names(update: &FrameUpdate) -> Result<(), ProtocolError> {
    let mut seen = std::collections::HashSet::new();
    for array in &update.instances {
        if !seen.insert(array.name.as_str()) {
            return Err(ProtocolError::invalid(
                format!("frame {}: instances", update.frame),
                format!("two instance arrays are named '{}'", array.name),
            ));
        }
    }
    Ok(())
}

/// Fills each `unchanged` array of `update` with the matrices and ids of the array of its name
/// in `previous`, the last frame the session accepted (resolved itself).
pub fn resolve_unchanged(
    update: &mut FrameUpdate,
    previous: Option<&FrameUpdate>,
) -> Result<(), ProtocolError> {
    check_names(update)?;
    let frame = update.frame;
    for array in update.instances.iter_mut().filter(|a| a.unchanged) {
        let owner = owner(frame, array);
        if !array.matrices.is_empty() || !array.ids.is_empty() {
            return Err(ProtocolError::invalid(
                format!("{owner}.unchanged"),
                "an unchanged array carries no matrices or ids",
            ));
        }
        let Some(previous) = previous else {
            return Err(ProtocolError::invalid(
                format!("{owner}.unchanged"),
                "no earlier frame in this session to take it from",
            ));
        };
        let Some(before) = previous.instances.iter().find(|a| a.name == array.name) else {
            return Err(ProtocolError::invalid(
                format!("{owner}.unchanged"),
                format!(
                    "the last frame accepted (frame {}) has no array of that name",
                    previous.frame
                ),
            ));
        };
        array.matrices = before.matrices.clone();
        array.ids = before.ids.clone();
        array.unchanged = false;
    }
    Ok(())
}

/// The update as sent after `previous` was accepted: every array whose matrices and ids equal
/// those of `previous`'s array of the same name is marked `unchanged` and sent empty.
pub fn changed_since(update: &FrameUpdate, previous: Option<&FrameUpdate>) -> FrameUpdate {
    let mut wire = FrameUpdate {
        instances: Vec::with_capacity(update.instances.len()),
        ..update.clone_without_instances()
    };
    for array in &update.instances {
        let same = previous.and_then(|p| p.instances.iter().find(|a| a.name == array.name));
        let unchanged = !array.unchanged
            && same.is_some_and(|b| b.matrices == array.matrices && b.ids == array.ids);
        wire.instances.push(if unchanged {
            InstanceArrayState {
                name: array.name.clone(),
                mesh_hash: array.mesh_hash,
                matrices: ByteBuf::new(),
                ids: ByteBuf::new(),
                visible_to_camera: array.visible_to_camera,
                casts_shadow: array.casts_shadow,
                unchanged: true,
                materials: array.materials.clone(),
            }
        } else {
            array.clone()
        });
    }
    wire
}

impl FrameUpdate {
    /// The update without its instance arrays (cloning them is the cost a delta avoids).
    fn clone_without_instances(&self) -> FrameUpdate {
        FrameUpdate {
            frame: self.frame,
            objects: self.objects.clone(),
            instances: Vec::new(),
            camera: self.camera.clone(),
            lights: self.lights.clone(),
            resolution: self.resolution,
            alpha_materials: self.alpha_materials.clone(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::messages::{CameraState, ResolutionState, SensorFitState};

    fn array(name: &str, rows: &[[f32; 12]], ids: &[u32]) -> InstanceArrayState {
        InstanceArrayState {
            name: name.into(),
            mesh_hash: 7,
            matrices: matrices_to_bytes(rows),
            ids: ByteBuf::from(
                ids.iter()
                    .flat_map(|i| i.to_le_bytes())
                    .collect::<Vec<u8>>(),
            ),
            visible_to_camera: true,
            casts_shadow: false,
            unchanged: false,
            materials: Vec::new(),
        }
    }

    fn update(frame: i32, instances: Vec<InstanceArrayState>) -> FrameUpdate {
        FrameUpdate {
            frame,
            objects: Vec::new(),
            instances,
            camera: CameraState {
                world_from_camera: DMat4::IDENTITY.to_cols_array(),
                lens_mm: 50.0,
                sensor_width_mm: 36.0,
                sensor_height_mm: 24.0,
                sensor_fit: SensorFitState::Auto,
                shift_x: 0.0,
                shift_y: 0.0,
                clip_start: 0.1,
                clip_end: 100.0,
            },
            lights: Vec::new(),
            resolution: ResolutionState {
                x: 8,
                y: 8,
                percentage: 100,
                pixel_aspect_x: 1.0,
                pixel_aspect_y: 1.0,
            },
            alpha_materials: Vec::new(),
        }
    }

    const A: [f32; 12] = [
        1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0, 10.0, 11.0, 12.0,
    ];

    #[test]
    fn rows_become_an_affine_matrix_named_by_id() {
        let objects = instance_objects(3, &array("Tree", &[A, A], &[40, 2]), 5).unwrap();
        assert_eq!(objects.len(), 2);
        assert_eq!(objects[0].name, "Tree[40]");
        assert_eq!(objects[1].name, "Tree[2]");
        let m = objects[0].world_from_object;
        assert_eq!(m.row(0).to_array(), [1.0, 2.0, 3.0, 4.0]);
        assert_eq!(m.row(2).to_array(), [9.0, 10.0, 11.0, 12.0]);
        assert_eq!(m.row(3).to_array(), [0.0, 0.0, 0.0, 1.0]);
        assert_eq!((objects[0].mesh, objects[0].casts_shadow), (5, false));
        let unnamed = instance_objects(3, &array("Tree", &[A, A], &[]), 0).unwrap();
        assert_eq!(unnamed[1].name, "Tree[1]");
    }

    #[test]
    fn bad_arrays_name_the_array_and_instance() {
        let mut nan = A;
        nan[7] = f32::NAN;
        let e = instance_objects(3, &array("Tree", &[A, nan], &[]), 0).unwrap_err();
        let e = e.to_string();
        assert!(
            e.contains("instance array 'Tree' instance 1") && e.contains("index 7"),
            "{e}"
        );
        let mut short = array("Tree", &[A], &[]);
        short.matrices.pop();
        let e = instance_objects(3, &short, 0).unwrap_err().to_string();
        assert!(e.contains("'Tree'.matrices: 47 bytes"), "{e}");
        let e = instance_objects(3, &array("Tree", &[A, A], &[1]), 0).unwrap_err();
        assert!(
            e.to_string()
                .contains("'Tree'.ids: 4 bytes for 2 instances"),
            "{e}"
        );
    }

    #[test]
    fn unchanged_arrays_travel_empty_and_come_back_whole() {
        let first = update(
            1,
            vec![array("Trees", &[A], &[1]), array("Rocks", &[A, A], &[])],
        );
        let mut moved = A;
        moved[3] = 4.5;
        let second = update(
            2,
            vec![array("Trees", &[moved], &[1]), array("Rocks", &[A, A], &[])],
        );
        let wire = changed_since(&second, Some(&first));
        assert!(!wire.instances[0].unchanged && wire.instances[0].matrices.len() == 48);
        assert!(wire.instances[1].unchanged && wire.instances[1].matrices.is_empty());
        // Nothing before: everything travels.
        assert!(changed_since(&second, None)
            .instances
            .iter()
            .all(|a| !a.unchanged));
        let mut received = wire.clone();
        resolve_unchanged(&mut received, Some(&first)).unwrap();
        assert_eq!(received, second);
    }

    #[test]
    fn an_unchanged_array_needs_its_earlier_self() {
        let mut wire = update(2, vec![array("Rocks", &[A], &[])]);
        wire.instances[0].matrices = ByteBuf::new();
        wire.instances[0].unchanged = true;
        let e = resolve_unchanged(&mut wire.clone(), None)
            .unwrap_err()
            .to_string();
        assert!(e.contains("'Rocks'.unchanged: no earlier frame"), "{e}");
        let other = update(1, vec![array("Trees", &[A], &[])]);
        let e = resolve_unchanged(&mut wire.clone(), Some(&other)).unwrap_err();
        assert!(
            e.to_string().contains("frame 1) has no array of that name"),
            "{e}"
        );
        let mut carrying = wire.clone();
        carrying.instances[0].matrices = matrices_to_bytes(&[A]);
        let e = resolve_unchanged(&mut carrying, Some(&other)).unwrap_err();
        assert!(e.to_string().contains("carries no matrices"), "{e}");
        let twice = update(
            1,
            vec![array("Trees", &[A], &[]), array("Trees", &[A], &[])],
        );
        let e = resolve_unchanged(&mut twice.clone(), None).unwrap_err();
        assert!(
            e.to_string()
                .contains("two instance arrays are named 'Trees'"),
            "{e}"
        );
    }
}
