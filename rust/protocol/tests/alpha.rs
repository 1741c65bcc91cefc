//! Alpha materials on the wire (protocol 5, issue 38): meshes' slots and UV maps, images by
//! content hash, materials and objects' slots, converted both ways; bad input named.

mod common;

use std::collections::HashMap;
use std::sync::Arc;

use antumbra_core::alpha::{AlphaImage, AlphaOp, AlphaProgram, Extension, Interpolation};
use antumbra_core::scene::{AlphaMaterial, Mesh, Object, Scene, SceneAlpha, UvMap};
use antumbra_protocol::*;
use glam::DMat4;

fn image() -> AlphaImage {
    AlphaImage {
        width: 2,
        height: 2,
        texels: vec![0.0, 0.25, 0.5, 1.0],
    }
}

/// The tiny scene with a card whose slot 1 reads an image through UV map "Leaves" and whose
/// slot 0 is a constant; the card is also placed by an instance array (added by callers).
fn alpha_scene() -> Scene {
    let mut s = common::tiny_scene(1);
    let card = common::ground().with_alpha(
        vec![0, 1],
        vec![UvMap {
            name: "Leaves".into(),
            corners: vec![
                [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]],
                [[0.0, 0.0], [1.0, 1.0], [0.0, 1.0]],
            ],
        }],
    );
    s.meshes.push(Arc::new(card));
    let mut o = Object::new("card", s.meshes.len() - 1, DMat4::IDENTITY);
    o.materials = vec![Some(0), Some(1), None];
    s.objects.push(o);
    let mut leaf = AlphaProgram::image(0, 0, Interpolation::Cubic, Extension::Mirror);
    leaf.ops = vec![
        AlphaOp::Power(2.0),
        AlphaOp::GreaterThan(0.5),
        AlphaOp::OneMinus,
    ];
    s.alpha = SceneAlpha {
        images: vec![Arc::new(image())],
        materials: vec![
            AlphaMaterial {
                name: "Glass".into(),
                uv_map: String::new(),
                program: AlphaProgram::constant(0.5),
            },
            AlphaMaterial {
                name: "Leaf".into(),
                uv_map: "Leaves".into(),
                program: leaf,
            },
        ],
    };
    s
}

type Meshes = HashMap<u64, Arc<Mesh>>;
type Images = HashMap<u64, Arc<AlphaImage>>;

/// Every upload of `scene_to_messages` stored as the daemon stores it, and the frame.
fn stored(scene: &Scene) -> (Meshes, Images, FrameUpdate) {
    let (uploads, update) = scene_to_messages(scene).unwrap();
    let (mut meshes, mut images) = (Meshes::new(), Images::new());
    for u in uploads {
        match u {
            Request::UploadMesh(u) => {
                let m = mesh_from_upload(&u, &Limits::default()).unwrap();
                meshes.insert(u.hash, Arc::new(m));
            }
            Request::UploadImage(u) => {
                let i = image_from_upload(&u, &Limits::default()).unwrap();
                images.insert(u.hash, Arc::new(i));
            }
            other => panic!("unexpected {}", other.kind()),
        }
    }
    let Request::FrameUpdate(update) = update else {
        panic!("scene_to_messages ends with the frame")
    };
    (meshes, images, update)
}

fn message(e: &ProtocolError) -> String {
    e.to_string()
}

#[test]
fn alpha_scene_round_trips_through_the_messages() {
    let scene = alpha_scene();
    let (meshes, images, update) = stored(&scene);
    assert_eq!(images.len(), 1);
    let card = &scene.meshes[2];
    // The hash of an upload is the core's, slots and UV maps included.
    assert!(meshes.contains_key(&card.content_hash()));
    assert_ne!(card.content_hash(), common::ground().content_hash());
    assert!(images.contains_key(&image().content_hash()));
    let store = (&meshes, &images);
    assert!(missing_images(&update, &store).is_empty());
    let back = scene_from_frame(&update, &store).unwrap();
    assert_eq!(back.alpha, scene.alpha);
    assert_eq!(back.objects[3].materials, vec![Some(0), Some(1), None]);
    assert_eq!(*back.meshes[2], **card);
    back.validate().unwrap();
    // And back to the same messages.
    assert_eq!(frame_update_from_scene(&back).unwrap(), update);
}

#[test]
fn instances_get_their_arrays_materials() {
    let scene = alpha_scene();
    let (meshes, images, mut update) = stored(&scene);
    update.instances.push(InstanceArrayState {
        name: "cards".into(),
        mesh_hash: update.objects[3].mesh_hash,
        matrices: instances::matrices_to_bytes(
            &[[1.0, 0.0, 0.0, 2.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0]; 3],
        ),
        ids: Default::default(),
        visible_to_camera: true,
        casts_shadow: true,
        unchanged: false,
        materials: vec![None, Some(1)],
    });
    let back = scene_from_frame(&update, &(&meshes, &images)).unwrap();
    assert_eq!(back.objects.len(), 7);
    assert!(back.objects[4..]
        .iter()
        .all(|o| o.materials == vec![None, Some(1)]));
    // An unchanged array sent again keeps the materials it travels with.
    let wire = instances::changed_since(&update, Some(&update));
    assert!(wire.instances[0].unchanged);
    assert_eq!(wire.instances[0].materials, vec![None, Some(1)]);
}

#[test]
fn frame_errors_name_the_frame_object_and_material() {
    let scene = alpha_scene();
    let (meshes, images, update) = stored(&scene);
    let store = (&meshes, &images);

    // An image the daemon does not hold: FrameAccepted lists it, Render's conversion names it.
    let no_images = Images::new();
    let lacking = (&meshes, &no_images);
    assert_eq!(
        missing_images(&update, &lacking),
        vec![image().content_hash()]
    );
    let e = scene_from_frame(&update, &lacking).unwrap_err();
    assert_eq!(e.code(), ErrorCode::UnknownImage);
    let s = message(&e);
    assert!(s.contains("frame 1") && s.contains("'Leaf'"), "{s}");

    // A slot naming a material the frame lacks.
    let mut u = update.clone();
    u.objects[3].materials = vec![Some(2)];
    let s = message(&scene_from_frame(&u, &store).unwrap_err());
    assert!(
        s.contains("frame 1") && s.contains("object 'card'.materials[0]") && s.contains('2'),
        "{s}"
    );
    let mut u = update.clone();
    u.instances.push(InstanceArrayState {
        name: "cards".into(),
        mesh_hash: u.objects[3].mesh_hash,
        matrices: Default::default(),
        ids: Default::default(),
        visible_to_camera: true,
        casts_shadow: true,
        unchanged: false,
        materials: vec![None, Some(7)],
    });
    let s = message(&scene_from_frame(&u, &store).unwrap_err());
    assert!(s.contains("instance array 'cards'.materials[1]"), "{s}");

    // NaN constants, of the source and of an operation.
    let mut u = update.clone();
    u.alpha_materials[0].source = AlphaSourceState::Constant { alpha: f32::NAN };
    let s = message(&scene_from_frame(&u, &store).unwrap_err());
    assert!(
        s.contains("frame 1") && s.contains("'Glass'") && s.contains("source"),
        "{s}"
    );
    let mut u = update.clone();
    u.alpha_materials[1]
        .ops
        .push(AlphaOp::Multiply(f32::INFINITY));
    let s = message(&scene_from_frame(&u, &store).unwrap_err());
    assert!(s.contains("'Leaf'") && s.contains("ops[3]"), "{s}");
}

#[test]
fn bad_uploads_are_named() {
    let limits = Limits::default();
    let mut card = upload_from_mesh(&alpha_scene().meshes[2]);
    // One slot short.
    let mut u = card.clone();
    u.material_slots.truncate(4);
    let s = message(&mesh_from_upload(&u, &limits).unwrap_err());
    assert!(s.contains("'ground'.material_slots"), "{s}");
    // Corners not a whole number of triangles.
    let mut u = card.clone();
    u.uv_maps[0].corners.truncate(30);
    let s = message(&mesh_from_upload(&u, &limits).unwrap_err());
    assert!(s.contains("uv_maps['Leaves'].corners"), "{s}");
    // Two maps of one name.
    let mut u = card.clone();
    u.uv_maps.push(u.uv_maps[0].clone());
    let s = message(&mesh_from_upload(&u, &limits).unwrap_err());
    assert!(s.contains("two UV maps"), "{s}");
    // Too many maps.
    let tight = Limits {
        max_uv_maps: 0,
        ..Limits::default()
    };
    let e = mesh_from_upload(&card, &tight).unwrap_err();
    assert!(message(&e).contains("max_uv_maps"), "{e}");
    assert!(check_limits(&Request::UploadMesh(card.clone()), &tight).is_err());
    // A hash that does not cover the slots.
    card.hash = common::ground().content_hash();
    assert!(matches!(
        mesh_from_upload(&card, &limits),
        Err(ProtocolError::HashMismatch { .. })
    ));

    let good = upload_from_image(&image());
    assert_eq!(image_from_upload(&good, &limits).unwrap(), image());
    let mut u = good.clone();
    u.texels.truncate(12);
    let s = message(&image_from_upload(&u, &limits).unwrap_err());
    assert!(
        s.contains(&image_label(good.hash)) && s.contains("texels"),
        "{s}"
    );
    let mut u = good.clone();
    u.texels[0..4].copy_from_slice(&f32::NAN.to_le_bytes());
    let s = message(&image_from_upload(&u, &limits).unwrap_err());
    assert!(s.contains(&image_label(good.hash)), "{s}");
    let mut u = good.clone();
    u.hash ^= 1;
    assert!(matches!(
        image_from_upload(&u, &limits),
        Err(ProtocolError::ImageHashMismatch { .. })
    ));
    // A huge announced size is refused before anything is decoded, naming the limit.
    let mut u = good.clone();
    u.width = u32::MAX;
    u.height = u32::MAX;
    let e = check_limits(&Request::UploadImage(u.clone()), &limits).unwrap_err();
    assert_eq!(e.code(), ErrorCode::LimitExceeded);
    let s = message(&e);
    assert!(
        s.contains("max_image_texels") && s.contains("image 0x"),
        "{s}"
    );
    assert!(image_from_upload(&u, &limits).is_err());
}

#[test]
fn frame_limits_bound_materials_ops_and_slots() {
    let (_, _, update) = stored(&alpha_scene());
    let check =
        |u: &FrameUpdate, limits: &Limits| check_limits(&Request::FrameUpdate(u.clone()), limits);
    check(&update, &Limits::default()).unwrap();
    let e = check(
        &update,
        &Limits {
            max_alpha_materials: 1,
            ..Limits::default()
        },
    )
    .unwrap_err();
    assert!(message(&e).contains("max_alpha_materials"), "{e}");
    let e = check(
        &update,
        &Limits {
            max_alpha_ops: 2,
            ..Limits::default()
        },
    )
    .unwrap_err();
    let s = message(&e);
    assert!(s.contains("'Leaf'") && s.contains("max_alpha_ops"), "{s}");
    // An array's slots count once per instance: a million instances of 20 slots is refused
    // before the instances are expanded.
    let mut u = update.clone();
    u.instances.push(InstanceArrayState {
        name: "many".into(),
        mesh_hash: u.objects[0].mesh_hash,
        matrices: serde_bytes::ByteBuf::from(vec![0u8; 48 * 1_000_000]),
        ids: Default::default(),
        visible_to_camera: true,
        casts_shadow: true,
        unchanged: false,
        materials: vec![None; 20],
    });
    let e = check(&u, &Limits::default()).unwrap_err();
    let s = message(&e);
    assert!(
        s.contains("max_material_slots") && s.contains("frame 1"),
        "{s}"
    );
    assert_eq!(instances::material_slot_count(&u), 3 + 20_000_000);
}
