//! The `recording` target: arbitrary bytes as a `.antrec` file, as given and after a valid
//! header, through the reader, the replay and what the CLI and the spool do with its frames.

use antumbra_core::scene::{Animation, Scene};

use crate::check::check_limits;
use crate::convert::{frame_update_from_scene, scene_to_messages};
use crate::limits::Limits;
use crate::messages::Request;
use crate::recording::{
    replay_scenes_from, RecordedAnimation, RecordingError, RecordingReader, Replay, RECORDING_MAGIC,
};

/// Replays `data` as a recording when it starts with the magic header; otherwise checks that it
/// is refused, then replays the header followed by `data` (a valid header over garbage). The
/// reader and the replay agree on where a recording goes wrong; every replayed scene passes the
/// spool's checks or is refused, and converts back to messages that replay to the same scene.
/// Never panics.
pub fn recording(data: &[u8]) {
    if data.starts_with(RECORDING_MAGIC) {
        return replay(data);
    }
    let as_given = replay_scenes_from(data);
    assert!(
        matches!(
            as_given,
            Err(RecordingError::BadMagic | RecordingError::NewerVersion(_))
        ),
        "no header, yet {:?}",
        as_given.map(|s| s.len())
    );
    let mut file = RECORDING_MAGIC.to_vec();
    file.extend_from_slice(data);
    replay(&file);
}

fn replay(file: &[u8]) {
    // Read request by request: the replay fails if and only if the reading or a request does.
    let mut read_ok = true;
    let mut requests = 0usize;
    for r in RecordingReader::new(file).expect("the header was just written") {
        match r {
            Ok(_) => requests += 1,
            Err(_) => read_ok = false,
        }
    }
    let scenes = match replay_scenes_from(file) {
        Ok(scenes) => {
            assert!(read_ok, "replayed a recording the reader refused");
            scenes
        }
        Err(RecordingError::Frame { index, .. }) => {
            assert!(!read_ok && index == requests, "frame error at {index}");
            return;
        }
        Err(RecordingError::Protocol { index, .. } | RecordingError::MissingMesh { index, .. }) => {
            assert!(index < requests, "request {index} of {requests}");
            return;
        }
        Err(e) => panic!("unexpected replay error: {e}"),
    };
    let limits = Limits::default();
    for scene in &scenes {
        // What the spool checks before it renders a recorded frame.
        if let Ok(update) = frame_update_from_scene(scene) {
            let _ = check_limits(&Request::FrameUpdate(update), &limits);
        }
        same_after_messages(scene);
    }
    match RecordedAnimation::from_scenes("fuzz", scenes) {
        Ok(anim) => {
            let range = anim.frame_range();
            let (first, last) = (*range.start(), *range.end());
            for f in [first.saturating_sub(1), first, last, last.saturating_add(1)] {
                assert_eq!(anim.frame(f).frame, f);
            }
            assert!(anim.recorded_frames().count() > 0);
        }
        Err(e) => assert!(matches!(e, RecordingError::NoFrames), "{e}"),
    }
}

/// A replayed scene sent again (as a daemon would receive it) replays to itself.
fn same_after_messages(scene: &Scene) {
    let Ok((uploads, update)) = scene_to_messages(scene) else {
        return;
    };
    let mut replay = Replay::new(Limits::default());
    for u in uploads {
        if let Err(e) = replay.apply(u) {
            panic!(
                "frame {}: a replayed mesh is refused when resent: {e}",
                scene.frame
            );
        }
    }
    let again = replay
        .apply(update)
        .and_then(|()| replay.scenes())
        .unwrap_or_else(|e| panic!("frame {}: refused when resent: {e}", scene.frame));
    assert_eq!(again.len(), 1);
    assert_eq!(
        format!("{:?}", again[0]),
        format!("{scene:?}"),
        "frame {}: changed when resent",
        scene.frame
    );
}
