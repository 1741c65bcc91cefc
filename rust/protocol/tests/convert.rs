//! Mesh uploads, frames to scenes, settings, and a real render's result through the wire.

mod common;

use std::collections::HashMap;
use std::sync::Arc;

use antumbra_core::build::{CollapseMethod, CollapseSettings, SpatialAxes};
use antumbra_core::render::{RenderSettings, Renderer, StatsMode};
use antumbra_core::scene::{Mesh, Scene};
use antumbra_core::settings::SettingValue;
use antumbra_protocol::bytes::{f32s_to_bytes, triangles_to_bytes, vec3s_to_bytes};
use antumbra_protocol::*;
use glam::Vec3;
use serde_bytes::ByteBuf;

fn upload(mesh: &Mesh) -> UploadMesh {
    upload_from_mesh(mesh)
}

fn message(e: &ProtocolError) -> String {
    e.to_string()
}

#[test]
fn a_valid_upload_gives_the_mesh_back() {
    let cube = common::cube();
    let u = upload(&cube);
    assert_eq!(u.hash, cube.content_hash());
    assert_eq!(u.positions.len(), 8 * 12);
    assert_eq!(u.triangles.len(), 12 * 12);
    let back = mesh_from_upload(&u, &Limits::default()).unwrap();
    assert_eq!(back, cube);
}

#[test]
fn the_hash_ignores_the_name() {
    let mut renamed = common::cube();
    renamed.name = "other".into();
    assert_eq!(upload(&renamed).hash, upload(&common::cube()).hash);
}

#[test]
fn index_out_of_range_names_the_mesh_and_triangle() {
    let mut m = common::cube();
    m.name = "Suzanne".into();
    m.triangles[5] = [0, 1, 8];
    let e = mesh_from_upload(&upload(&m), &Limits::default()).unwrap_err();
    assert_eq!(e.code(), ErrorCode::InvalidInput);
    let s = message(&e);
    assert!(s.contains("mesh 'Suzanne'"), "{s}");
    assert!(s.contains("triangle 5"), "{s}");
    assert!(s.contains("vertex 8"), "{s}");
}

#[test]
fn nan_and_infinite_vertices_name_the_mesh_and_vertex() {
    for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
        let mut m = common::cube();
        m.name = "Rock.001".into();
        m.positions[6].y = bad;
        let e = mesh_from_upload(&upload(&m), &Limits::default()).unwrap_err();
        let s = message(&e);
        assert!(s.contains("mesh 'Rock.001'"), "{s}");
        assert!(s.contains("index 6"), "{s}");
        assert!(s.contains("non-finite"), "{s}");
    }
}

#[test]
fn bad_byte_lengths_name_the_field() {
    let mut u = upload(&common::cube());
    u.name = "Tree".into();
    u.positions.pop();
    let s = message(&mesh_from_upload(&u, &Limits::default()).unwrap_err());
    assert!(s.contains("mesh 'Tree'.positions"), "{s}");
    assert!(s.contains("95 bytes"), "{s}");

    let mut u = upload(&common::cube());
    u.name = "Tree".into();
    u.triangles.extend_from_slice(&[0, 0, 0, 0]);
    let s = message(&mesh_from_upload(&u, &Limits::default()).unwrap_err());
    assert!(s.contains("mesh 'Tree'.triangles"), "{s}");
    assert!(s.contains("multiple of 12"), "{s}");
}

#[test]
fn a_wrong_hash_names_the_mesh_and_both_hashes() {
    let mut u = upload(&common::cube());
    u.name = "Wall".into();
    let actual = u.hash;
    u.hash ^= 1;
    let e = mesh_from_upload(&u, &Limits::default()).unwrap_err();
    assert_eq!(e.code(), ErrorCode::InvalidInput);
    let s = message(&e);
    assert!(s.contains("mesh 'Wall'"), "{s}");
    assert!(s.contains(&format!("{actual:#018x}")), "{s}");
    assert!(s.contains(&format!("{:#018x}", actual ^ 1)), "{s}");
}

#[test]
fn too_many_triangles_is_a_limit_error() {
    let u = upload(&common::cube());
    let limits = Limits {
        max_triangles_per_mesh: 11,
        ..Limits::default()
    };
    let e = mesh_from_upload(&u, &limits).unwrap_err();
    assert_eq!(e.code(), ErrorCode::LimitExceeded);
    assert!(message(&e).contains("mesh 'cube'"));
}

fn store_of(scene: &Scene) -> HashMap<u64, Arc<Mesh>> {
    let (uploads, _) = scene_to_messages(scene).unwrap();
    uploads
        .iter()
        .map(|r| match r {
            Request::UploadMesh(u) => (
                u.hash,
                Arc::new(mesh_from_upload(u, &Limits::default()).unwrap()),
            ),
            _ => panic!("not an upload"),
        })
        .collect()
}

fn update_of(scene: &Scene) -> FrameUpdate {
    match scene_to_messages(scene).unwrap().1 {
        Request::FrameUpdate(u) => u,
        _ => panic!("not a frame"),
    }
}

#[test]
fn scene_to_messages_and_back() {
    let scene = common::tiny_scene(2);
    let (uploads, _) = scene_to_messages(&scene).unwrap();
    // Two distinct meshes, though three objects.
    assert_eq!(uploads.len(), 2);
    let store = store_of(&scene);
    let update = update_of(&scene);
    assert!(missing_meshes(&update, &store).is_empty());
    let back = scene_from_frame(&update, &store).unwrap();
    common::assert_same_scene(&scene, &back);
    // Each distinct mesh once, shared by the objects that use it, and the store's own Arc.
    assert_eq!(back.meshes.len(), 2);
    assert_eq!(back.objects[1].mesh, back.objects[2].mesh);
    assert!(Arc::ptr_eq(
        &back.meshes[back.objects[1].mesh],
        &store[&update.objects[1].mesh_hash]
    ));
}

#[test]
fn an_unknown_mesh_names_the_object_and_hash() {
    let scene = common::tiny_scene(4);
    let mut store = store_of(&scene);
    let update = update_of(&scene);
    let box_hash = update.objects[1].mesh_hash;
    store.remove(&box_hash);
    assert_eq!(missing_meshes(&update, &store), vec![box_hash]);
    let e = scene_from_frame(&update, &store).unwrap_err();
    assert_eq!(e.code(), ErrorCode::UnknownMesh);
    let s = message(&e);
    assert!(s.contains("object 'box'"), "{s}");
    assert!(s.contains(&format!("{box_hash:#018x}")), "{s}");
    assert!(s.contains("frame 4"), "{s}");
}

#[test]
fn invalid_frames_name_the_field() {
    let scene = common::tiny_scene(7);
    let store = store_of(&scene);

    let mut u = update_of(&scene);
    u.objects[2].world_from_object[13] = f64::NAN;
    let s = message(&scene_from_frame(&u, &store).unwrap_err());
    assert!(s.contains("object 'hidden box' (frame 7)"), "{s}");
    assert!(s.contains("index 13"), "{s}");

    let mut u = update_of(&scene);
    u.camera.lens_mm = -1.0;
    let s = message(&scene_from_frame(&u, &store).unwrap_err());
    assert!(s.contains("frame 7") && s.contains("camera.lens"), "{s}");

    let mut u = update_of(&scene);
    u.lights[0].kind = LightKindState::Sun { angle: 4.0 };
    let s = message(&scene_from_frame(&u, &store).unwrap_err());
    assert!(
        s.contains("frame 7") && s.contains("light 'sun'.angle"),
        "{s}"
    );

    let mut u = update_of(&scene);
    u.resolution.x = 0;
    let s = message(&scene_from_frame(&u, &store).unwrap_err());
    assert!(s.contains("frame 7") && s.contains("resolution"), "{s}");
}

#[test]
fn an_object_with_a_bad_mesh_index_cannot_be_sent() {
    let mut scene = common::tiny_scene(0);
    scene.objects[1].mesh = 9;
    let s = message(&scene_to_messages(&scene).unwrap_err());
    assert!(s.contains("object 'box'"), "{s}");
}

#[test]
fn settings_round_trip_and_validate() {
    let core = RenderSettings {
        spp: 16,
        seed: 3,
        stats: StatsMode::CountsAndTiming,
        ..RenderSettings::baseline()
    };
    let state = core.to_named();
    assert_eq!(render_settings(&state).unwrap(), core);
    // Non-default settings of every kind travel both ways, through MessagePack too.
    let mut other = core.clone();
    other.build_settings.osah_strict_viability = false;
    other.collapse = CollapseSettings::new(CollapseMethod::Greedy);
    other.build_settings.spatial.axes = SpatialAxes::All;
    other.build_settings.spatial.clip_min_refs = 0;
    other.shadow_order = "sorted:logging=fbto:p=area:depth=3:budget=0.1"
        .parse()
        .unwrap();
    let wire: NamedSettings = decode_body(&encode_body(&other.to_named()).unwrap()).unwrap();
    assert_eq!(
        wire.get("osah_viability"),
        Some(&SettingValue::from("paper"))
    );
    assert_eq!(wire.get("clip_min_refs"), Some(&SettingValue::Int(0)));
    assert_eq!(render_settings(&wire).unwrap(), other);
    // An empty map is the core defaults.
    assert_eq!(
        render_settings(&NamedSettings::default()).unwrap(),
        RenderSettings::default()
    );

    let bad = state.clone().with("spp", 0i64);
    let e = render_settings(&bad).unwrap_err();
    assert_eq!(e.code(), ErrorCode::InvalidInput);
    assert!(message(&e).contains("spp"), "{e}");
    let bad = state.with("bins", 1i64);
    assert!(message(&render_settings(&bad).unwrap_err()).contains("bins"));
}

#[test]
fn a_real_render_survives_the_wire_bit_exact() {
    let scene = common::tiny_scene(0);
    let settings = RenderSettings {
        spp: 4,
        ..RenderSettings::baseline()
    };
    let result = Renderer::new().render("tiny", &scene, &settings).unwrap();
    assert_eq!(result.masks.len(), 2);
    let heat = result.heat.as_ref().unwrap();

    let passes = Passes {
        visible_set: true,
        ..Passes::default()
    };
    let reply = Reply::FrameResult(frame_result_reply(&result, 42, &passes));
    let framed = encode_message(&reply).unwrap();
    let Reply::FrameResult(back) = read_message(&mut &framed[..], &Limits::default()).unwrap()
    else {
        panic!("not a FrameResult")
    };
    assert_eq!((back.request_id, back.frame), (42, 0));
    assert_eq!((back.width, back.height), (32, 24));

    let planes = planes_from_reply(&back).unwrap();
    let names: Vec<&str> = planes.iter().map(|p| p.name.as_str()).collect();
    assert_eq!(
        names,
        [
            "shadow.sun",
            "shadow.spot",
            "combined",
            "primary.N_B",
            "primary.N_L",
            "primary.N_T",
            "shadow.N_B",
            "shadow.N_L",
            "shadow.N_T"
        ]
    );
    let originals = result
        .masks
        .iter()
        .chain([&result.combined])
        .chain(heat.primary.iter())
        .chain(heat.shadow.iter());
    for (got, want) in planes.iter().zip(originals) {
        assert_eq!((got.width, got.height), (want.width, want.height));
        let bits = |d: &[f32]| d.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&got.data), bits(&want.data), "{}", got.name);
    }
    // The shadows are real: the box shadows part of the ground.
    let combined = &planes[2];
    assert!(combined.data.iter().any(|&v| v < 0.5));
    assert!(combined.data.iter().any(|&v| v > 0.99));

    assert_eq!(visible_from_reply(&back).unwrap().unwrap(), result.visible);
    assert_eq!(stats_from_reply(&back), result.stats);

    // Only what was asked for.
    let only = frame_result_reply(
        &result,
        1,
        &Passes {
            masks: false,
            combined: true,
            heat_maps: false,
            visible_set: false,
            object_ids: false,
        },
    );
    assert_eq!(only.images.len(), 1);
    assert_eq!(only.images[0].name, "combined");
    assert!(only.visible.is_none());
    assert!(visible_from_reply(&only).unwrap().is_none());

    // The object-id pass comes last, as the core's plane: object indices, -1 for misses.
    let with_ids = frame_result_reply(
        &result,
        2,
        &Passes {
            object_ids: true,
            ..Passes::default()
        },
    );
    let planes = planes_from_reply(&with_ids).unwrap();
    let ids = planes.last().unwrap();
    assert_eq!(ids.name, "primary.object");
    assert_eq!(ids.data, result.object_plane().data);
    assert!(ids.data.contains(&-1.0) && ids.data.contains(&0.0) && ids.data.contains(&1.0));
    assert!(ids
        .data
        .iter()
        .all(|&v| v == -1.0 || (v >= 0.0 && v < scene.objects.len() as f32 && v.fract() == 0.0)));
}

#[test]
fn malformed_images_name_the_image() {
    let reply = FrameResultReply {
        request_id: 1,
        frame: 12,
        width: 2,
        height: 2,
        images: vec![Image {
            name: "combined".into(),
            width: 2,
            height: 2,
            data: f32s_to_bytes(&[1.0; 3]),
        }],
        stats: vec![],
        visible: Some(ByteBuf::from(vec![0; 5])),
    };
    let s = message(&planes_from_reply(&reply).unwrap_err());
    assert!(s.contains("frame 12: image 'combined'.data"), "{s}");
    assert!(s.contains("needs 4 values, has 3"), "{s}");
    let mut odd = reply.clone();
    odd.images[0].data.push(0);
    assert!(message(&planes_from_reply(&odd).unwrap_err()).contains("not a multiple of 4"));
    let s = message(&visible_from_reply(&reply).unwrap_err());
    assert!(s.contains("frame 12: visible"), "{s}");
}

#[test]
fn byte_helpers_match_the_documented_layout() {
    let p = vec3s_to_bytes(&[Vec3::new(1.0, 2.0, 3.0)]);
    assert_eq!(
        p.as_slice(),
        [1.0f32, 2.0, 3.0]
            .iter()
            .flat_map(|v| v.to_le_bytes())
            .collect::<Vec<_>>()
    );
    let t = triangles_to_bytes(&[[1, 2, 258]]);
    assert_eq!(t.as_slice(), [1, 0, 0, 0, 2, 0, 0, 0, 2, 1, 0, 0]);
}
