//! Recordings: write a session, read it back, replay it as scenes and as an Animation.

mod common;

use std::sync::Arc;

use antumbra_core::scene::Animation;
use antumbra_protocol::recording::{replay_scenes_from, RECORDING_MAGIC};
use antumbra_protocol::*;

#[test]
fn write_read_replay_round_trip() {
    let dir = tempfile::TempDir::new().unwrap();
    let path = dir.path().join("tiny shot.antrec");
    let scenes: Vec<_> = (0..5).map(common::tiny_scene).collect();

    let mut w = RecordingWriter::create(&path).unwrap();
    w.append(&Request::Hello {
        version: PROTOCOL_VERSION,
        client: "test".into(),
        token: None,
    })
    .unwrap();
    for s in &scenes {
        w.append_scene(s).unwrap();
        w.append(&Request::Render(RenderRequest {
            frame: s.frame,
            settings: Default::default(),
            passes: Default::default(),
            request_id: s.frame as u64,
            warm_up: false,
        }))
        .unwrap();
    }
    w.append(&Request::Close).unwrap();
    // Hello + 2 uploads (once for the whole animation) + 5 x (frame + render) + Close.
    assert_eq!(w.written(), 1 + 2 + 10 + 1);
    w.finish().unwrap();

    let bytes = std::fs::read(&path).unwrap();
    assert!(bytes.starts_with(RECORDING_MAGIC));

    let kinds: Vec<&str> = RecordingReader::open(&path)
        .unwrap()
        .map(|r| r.unwrap().kind())
        .collect();
    assert_eq!(kinds.len(), 14);
    assert_eq!(
        kinds[..4],
        ["Hello", "UploadMesh", "UploadMesh", "FrameUpdate"]
    );
    assert_eq!(kinds[13], "Close");

    let replayed = replay_scenes(&path).unwrap();
    assert_eq!(replayed.len(), 5);
    for (a, b) in scenes.iter().zip(&replayed) {
        common::assert_same_scene(a, b);
    }
    // Unchanged meshes are the same Arc in every frame, so a renderer reuses its BVHs.
    assert!(Arc::ptr_eq(&replayed[0].meshes[0], &replayed[4].meshes[0]));

    let anim = RecordedAnimation::open(&path).unwrap();
    assert_eq!(anim.name(), "tiny shot");
    assert_eq!(anim.frame_range(), 0..=4);
    for f in 0..5 {
        common::assert_same_scene(&anim.frame(f), &scenes[f as usize]);
    }
}

#[test]
fn gaps_hold_the_previous_frame() {
    let scenes: Vec<_> = [2, 5, 9].into_iter().map(common::tiny_scene).collect();
    let mut w = RecordingWriter::new(Vec::new()).unwrap();
    for s in &scenes {
        w.append_scene(s).unwrap();
    }
    let bytes = w.finish().unwrap();
    let anim =
        RecordedAnimation::from_scenes("gaps", replay_scenes_from(&bytes[..]).unwrap()).unwrap();
    assert_eq!(anim.frame_range(), 2..=9);
    assert_eq!(anim.recorded_frames().collect::<Vec<_>>(), [2, 5, 9]);
    let held = anim.frame(7);
    assert_eq!(held.frame, 7);
    assert_eq!(held.objects, anim.frame(5).objects);
    assert_eq!(anim.frame(0).objects, anim.frame(2).objects);
    assert_eq!(anim.frame(100).objects, anim.frame(9).objects);
}

#[test]
fn bad_recordings_say_what_is_wrong() {
    let dir = tempfile::TempDir::new().unwrap();

    let not_one = dir.path().join("x.antrec");
    std::fs::write(&not_one, b"PNG....").unwrap();
    let e = replay_scenes(&not_one).err().unwrap().to_string();
    assert!(e.contains("x.antrec") && e.contains("ANTREC1"), "{e}");

    let missing = dir.path().join("missing.antrec");
    let e = replay_scenes(&missing).err().unwrap().to_string();
    assert!(e.contains("missing.antrec"), "{e}");

    // Truncated in the middle of the second message.
    let mut w = RecordingWriter::new(Vec::new()).unwrap();
    w.append_scene(&common::tiny_scene(0)).unwrap();
    let bytes = w.finish().unwrap();
    let first = 8 + 4 + u32::from_le_bytes(bytes[8..12].try_into().unwrap()) as usize;
    let cut = dir.path().join("cut.antrec");
    std::fs::write(&cut, &bytes[..first + 10]).unwrap();
    let e = replay_scenes(&cut).err().unwrap().to_string();
    assert!(
        e.contains("cut.antrec") && e.contains("message 1") && e.contains("truncated"),
        "{e}"
    );

    // A corrupted upload is reported with its index and kind, naming the mesh.
    let mut w = RecordingWriter::new(Vec::new()).unwrap();
    let (mut uploads, frame) = scene_to_messages(&common::tiny_scene(0)).unwrap();
    if let Request::UploadMesh(u) = &mut uploads[1] {
        u.hash ^= 1;
    }
    for r in uploads.iter().chain([&frame]) {
        w.append(r).unwrap();
    }
    let e = replay_scenes_from(&w.finish().unwrap()[..])
        .err()
        .unwrap()
        .to_string();
    assert!(
        e.contains("message 1 (UploadMesh)") && e.contains("mesh 'cube'"),
        "{e}"
    );

    // No frames at all.
    let w = RecordingWriter::new(Vec::new()).unwrap();
    let scenes = replay_scenes_from(&w.finish().unwrap()[..]).unwrap();
    assert!(RecordedAnimation::from_scenes("empty", scenes).is_err());
}

/// A recording of these requests, in this order.
fn recording_of(requests: &[Request]) -> Vec<u8> {
    let mut w = RecordingWriter::new(Vec::new()).unwrap();
    for r in requests {
        w.append(r).unwrap();
    }
    w.finish().unwrap()
}

#[test]
fn frames_before_their_uploads_replay() {
    // As the add-on sends them: each frame, then the meshes the daemon said it lacks.
    let scenes: Vec<_> = (1..=3).map(common::tiny_scene).collect();
    let mut requests = Vec::new();
    let mut sent = std::collections::HashSet::new();
    for s in &scenes {
        let (uploads, update) = scene_to_messages(s).unwrap();
        requests.push(update);
        for u in uploads {
            if let Request::UploadMesh(m) = &u {
                if sent.insert(m.hash) {
                    requests.push(u);
                }
            }
        }
    }
    assert_eq!(requests[0].kind(), "FrameUpdate");
    let replayed = replay_scenes_from(&recording_of(&requests)[..]).unwrap();
    assert_eq!(replayed.len(), 3);
    for (a, b) in scenes.iter().zip(&replayed) {
        common::assert_same_scene(a, b);
    }
    assert!(Arc::ptr_eq(&replayed[0].meshes[0], &replayed[2].meshes[0]));
}

#[test]
fn a_mesh_never_uploaded_is_named() {
    let (uploads, update) = scene_to_messages(&common::tiny_scene(4)).unwrap();
    let Request::UploadMesh(lost) = &uploads[1] else {
        panic!("{:?}", uploads[1].kind())
    };
    let e = replay_scenes_from(&recording_of(&[update, uploads[0].clone()])[..])
        .err()
        .unwrap()
        .to_string();
    let hash = format!("{:#018x}", lost.hash);
    assert!(
        e.contains("message 0 (FrameUpdate)")
            && e.contains("frame 4")
            && e.contains(&hash)
            && e.contains("never uploads"),
        "{e}"
    );
}

#[test]
fn newer_versions_are_refused_naming_theirs() {
    let mut w = RecordingWriter::new(Vec::new()).unwrap();
    w.append_scene(&common::tiny_scene(0)).unwrap();
    let mut bytes = w.finish().unwrap();
    assert_eq!(&bytes[..8], b"ANTREC1\n");
    assert_eq!(RecordingReader::new(&bytes[..]).unwrap().version(), 1);
    bytes[6] = b'2';
    let e = replay_scenes_from(&bytes[..]).err().unwrap().to_string();
    assert!(e.contains("version 2") && e.contains("newer"), "{e}");
    bytes[6] = b'0';
    let e = replay_scenes_from(&bytes[..]).err().unwrap().to_string();
    assert!(e.contains("not an antumbra recording"), "{e}");
}

#[test]
fn retired_camera_paths_of_older_recordings_are_skipped() {
    // Written as protocol version 2 wrote a `CameraPath` (the camera of every frame up front).
    let scenes: Vec<_> = (1..=2).map(common::tiny_scene).collect();
    let (uploads, update) = scene_to_messages(&scenes[0]).unwrap();
    let Request::FrameUpdate(first) = &update else {
        panic!("scene_to_messages gives a FrameUpdate")
    };
    let camera_path = std::collections::BTreeMap::from([(
        "CameraPath",
        std::collections::BTreeMap::from([("frames", vec![(1, first.camera.clone())])]),
    )]);
    let body = rmp_serde::to_vec_named(&camera_path).unwrap();
    let mut bytes = recording_of(&uploads);
    bytes.extend((body.len() as u32).to_le_bytes());
    bytes.extend(&body);
    let mut rest = Vec::new();
    for s in &scenes {
        let (_, update) = scene_to_messages(s).unwrap();
        rest.push(update);
    }
    bytes.extend(&recording_of(&rest)[RECORDING_MAGIC.len()..]);

    let kinds: Vec<&str> = RecordingReader::new(&bytes[..])
        .unwrap()
        .map(|r| r.unwrap().kind())
        .collect();
    assert_eq!(
        kinds,
        ["UploadMesh", "UploadMesh", "FrameUpdate", "FrameUpdate"]
    );
    let replayed = replay_scenes_from(&bytes[..]).unwrap();
    assert_eq!(replayed.len(), 2);
    for (a, b) in scenes.iter().zip(&replayed) {
        common::assert_same_scene(a, b);
    }
    // Anything else that does not decode is still an error naming the message.
    let unknown =
        rmp_serde::to_vec_named(&std::collections::BTreeMap::from([("Teleport", 1)])).unwrap();
    let mut bad = recording_of(&uploads);
    bad.extend((unknown.len() as u32).to_le_bytes());
    bad.extend(&unknown);
    let e = replay_scenes_from(&bad[..]).err().unwrap().to_string();
    assert!(e.contains("Teleport"), "{e}");
}
