//! Alpha materials through a daemon (protocol 5): a scene with an alpha image and materials sent
//! by the one client (images uploaded once), recorded by the daemon and replayed to the same
//! alpha; a missing image reported at FrameUpdate and named at Render; hostile images refused;
//! the session goes on after each.

mod common;

use std::sync::Arc;

use antumbra_core::alpha::{AlphaImage, AlphaOp, AlphaProgram, Extension, Interpolation};
use antumbra_core::scene::{AlphaMaterial, Scene, SceneAlpha, UvMap};
use antumbra_protocol::{
    frame_update_from_scene, replay_scenes, upload_from_image, ErrorCode, Reply, Request,
    UploadImage,
};
use common::*;

fn image(seed: f32) -> AlphaImage {
    AlphaImage {
        width: 4,
        height: 2,
        texels: (0..8).map(|i| i as f32 / 8.0 + seed).collect(),
    }
}

/// The tiny scene whose ground's second triangle reads an image through UV map "UVMap".
fn alpha_scene(frame: i32, seed: f32) -> Scene {
    let mut s = tiny_scene(frame, 24, 16);
    let ground = (*s.meshes[0]).clone().with_alpha(
        vec![0, 1],
        vec![UvMap {
            name: "UVMap".into(),
            corners: vec![[[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]]; 2],
        }],
    );
    s.meshes[0] = Arc::new(ground);
    s.objects[0].materials = vec![None, Some(0)];
    let mut leaf = AlphaProgram::image(0, 0, Interpolation::Closest, Extension::Repeat);
    leaf.ops = vec![AlphaOp::LessThan(0.5)];
    s.alpha = SceneAlpha {
        images: vec![Arc::new(image(seed))],
        materials: vec![AlphaMaterial {
            name: "Leaf".into(),
            uv_map: "UVMap".into(),
            program: leaf,
        }],
    };
    s
}

#[test]
fn alpha_scenes_travel_once_record_and_replay() {
    let record = temp_dir("alpha-record");
    let dir = record.path().to_path_buf();
    let d = TestDaemon::start_with("alpha", |c| c.record = Some(dir));
    let mut c = d.client("alpha");
    let first = c.send_scene(&alpha_scene(1, 0.0)).unwrap();
    assert_eq!((first.meshes_uploaded, first.images_uploaded), (2, 1));
    render_reply(&mut c, 1, 1);
    // Frame 2: the same image, nothing uploaded.
    let second = c.send_scene(&alpha_scene(2, 0.0)).unwrap();
    assert_eq!((second.meshes_uploaded, second.images_uploaded), (0, 0));
    render_reply(&mut c, 2, 2);

    // A frame whose image the daemon lacks: accepted with the image missing, a render refused
    // naming the frame and the material.
    let lacking = alpha_scene(3, 0.5);
    let hash = lacking.alpha.images[0].content_hash();
    let update = frame_update_from_scene(&lacking).unwrap();
    match c.call(&Request::FrameUpdate(update)).unwrap() {
        Reply::FrameAccepted { images_missing, .. } => assert_eq!(images_missing, vec![hash]),
        other => panic!("{}", other.kind()),
    }
    let e = c
        .render(3, Default::default(), Default::default(), 3)
        .unwrap_err()
        .to_string();
    assert!(e.contains("frame 3") && e.contains("'Leaf'"), "{e}");

    // Hostile images: too large announced, a wrong hash; the session goes on.
    let huge = UploadImage {
        hash: 1,
        width: u32::MAX,
        height: u32::MAX,
        texels: Default::default(),
    };
    let (code, message, usable, _) = expect_error(c.call(&Request::UploadImage(huge)).unwrap());
    assert_eq!(code, ErrorCode::LimitExceeded);
    assert!(message.contains("max_image_texels"), "{message}");
    assert!(usable);
    let mut wrong = upload_from_image(&image(0.5));
    wrong.hash ^= 1;
    let (code, message, ..) = expect_error(c.call(&Request::UploadImage(wrong)).unwrap());
    assert_eq!(code, ErrorCode::InvalidInput);
    assert!(message.contains("image 0x"), "{message}");
    match c
        .call(&Request::UploadImage(upload_from_image(&image(0.5))))
        .unwrap()
    {
        Reply::ImageStored { hash: stored } => assert_eq!(stored, hash),
        other => panic!("{}", other.kind()),
    }
    render_reply(&mut c, 3, 4);
    assert_eq!(d.handle.stats().images_cached, 2);
    c.close().unwrap();
    d.stop().unwrap();

    // The daemon's recording replays to the scenes it rendered, alpha included.
    let file = std::fs::read_dir(record.path())
        .unwrap()
        .map(|e| e.unwrap().path())
        .find(|p| p.extension().is_some_and(|x| x == "antrec"))
        .expect("a recording");
    let scenes = replay_scenes(&file).unwrap();
    assert_eq!(scenes.len(), 3);
    assert_eq!(scenes[0].alpha, alpha_scene(1, 0.0).alpha);
    assert_eq!(scenes[2].alpha, alpha_scene(3, 0.5).alpha);
    assert_eq!(
        scenes[0].meshes[0].uv_maps,
        alpha_scene(1, 0.0).meshes[0].uv_maps
    );
    assert_eq!(scenes[0].objects[0].materials, vec![None, Some(0)]);
}
