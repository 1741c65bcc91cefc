//! The daemon as a library: an in-process server on a temporary Unix socket, real clients.

mod common;

use std::os::unix::fs::PermissionsExt;
use std::time::{Duration, Instant};

use antumbra_core::render::RenderSettings;
use antumbra_core::scene::{Mesh, Scene};
use antumbra_daemon::{Daemon, DaemonConfig, DaemonError};
use antumbra_protocol::client::Client;
use antumbra_protocol::{
    encode_message, frame_update_from_scene, replay_scenes, upload_from_mesh, ErrorCode,
    LightKindState, LightState, NamedSettings, Passes, RenderRequest, Reply, Request,
    PROTOCOL_VERSION,
};
use common::*;
use glam::{DMat4, Vec3};

#[test]
fn three_city_frames_match_in_process_render_bit_for_bit() {
    let d = TestDaemon::start("bitexact");
    let scenes = city_frames(10_000, 3, 64, 40);
    let expected = render_in_process("bitexact", &scenes, &RenderSettings::default());
    let mut c = d.client("bitexact");
    for (i, (s, want)) in scenes.iter().zip(&expected).enumerate() {
        let sent = c.send_scene(s).unwrap();
        if i == 0 {
            assert!(sent.meshes_uploaded > 0);
        }
        let r = c
            .render(
                s.frame,
                NamedSettings::default(),
                Passes::default(),
                i as u64,
            )
            .unwrap();
        assert_eq!(r.stages, vec!["render", "encode"]);
        assert_same_result(&r.result, want);
    }
    c.close().unwrap();
}

#[test]
fn unchanged_meshes_are_not_uploaded_again() {
    let d = TestDaemon::start("reuse");
    let mut c = d.client("reuse");
    let first = c.send_scene(&tiny_scene(1, 32, 20)).unwrap();
    assert_eq!(first.meshes_uploaded, 2);
    assert!(first.upload_bytes > 0);
    render_reply(&mut c, 1, 1);
    // Frame 2 moves the box: same meshes, only a new FrameUpdate.
    let hashes: Vec<u64> = tiny_scene(2, 32, 20)
        .meshes
        .iter()
        .map(|m| m.content_hash())
        .collect();
    match c.call(&Request::MissingMeshes { hashes }).unwrap() {
        Reply::Missing { hashes } => assert!(hashes.is_empty(), "{hashes:?}"),
        other => panic!("{other:?}"),
    }
    let before = c.bytes_sent();
    let second = c.send_scene(&tiny_scene(2, 32, 20)).unwrap();
    assert_eq!(second.meshes_uploaded, 0);
    assert_eq!(second.upload_bytes, 0);
    let update_bytes = encode_message(&Request::FrameUpdate(
        frame_update_from_scene(&tiny_scene(2, 32, 20)).unwrap(),
    ))
    .unwrap()
    .len() as u64;
    // Only the question and the frame update went out.
    assert!(
        c.bytes_sent() - before < update_bytes + 100,
        "{}",
        c.bytes_sent() - before
    );
    render_reply(&mut c, 2, 2);
    // Another session finds the meshes in the shared cache.
    let mut other = d.client("other");
    assert_eq!(
        other
            .send_scene(&tiny_scene(3, 32, 20))
            .unwrap()
            .meshes_uploaded,
        0
    );
}

// ---------------------------------------------------------------------------------------------
// Bad input: each answered clearly, and another connected client is still served.

#[test]
fn truncated_frame_is_refused_and_the_connection_closed() {
    let d = TestDaemon::start("truncated");
    let mut other = Bystander::new(&d);
    let mut c = d.client("truncated");
    let frame = encode_message(&Request::Stats).unwrap();
    let mut bytes = 100u32.to_le_bytes().to_vec();
    bytes.extend_from_slice(&frame[4..]);
    c.send_raw(&bytes).unwrap();
    c.shutdown_write().unwrap();
    let (code, message, usable, _) = expect_error(c.recv().unwrap());
    assert_eq!(code, ErrorCode::BadFrame);
    assert!(message.contains("truncated"), "{message}");
    assert!(!usable);
    assert_closed(&mut c);
    other.still_served();
}

#[test]
fn wrong_protocol_version_is_refused() {
    let d = TestDaemon::start("version");
    let mut other = Bystander::new(&d);
    let mut c = d.raw_client();
    let reply = c
        .call(&Request::Hello {
            version: PROTOCOL_VERSION + 41,
            client: "future".into(),
            token: None,
        })
        .unwrap();
    let (code, message, usable, _) = expect_error(reply);
    assert_eq!(code, ErrorCode::VersionMismatch);
    assert!(
        message.contains(&format!("version {}", PROTOCOL_VERSION + 41)),
        "{message}"
    );
    assert!(!usable);
    assert_closed(&mut c);
    // A version-1 add-on (FNV-1a mesh hashes) is told to update itself.
    let mut old = d.raw_client();
    let reply = old
        .call(&Request::Hello {
            version: 1,
            client: "blender 4.2".into(),
            token: None,
        })
        .unwrap();
    let (code, message, usable, _) = expect_error(reply);
    assert_eq!(code, ErrorCode::VersionMismatch);
    assert!(message.contains("update the Blender add-on"), "{message}");
    assert!(!usable);
    assert_closed(&mut old);
    other.still_served();
}

#[test]
fn length_prefix_of_10_gib_is_refused_before_allocation() {
    let d = TestDaemon::start("huge");
    let mut other = Bystander::new(&d);
    // A client that wrote the length as u64: the daemon reads the low 4 bytes (2 GiB).
    let mut c = d.client("huge");
    let t0 = Instant::now();
    c.send_raw(&(10u64 << 30).to_le_bytes()).unwrap();
    let (code, message, usable, _) = expect_error(c.recv().unwrap());
    assert_eq!(code, ErrorCode::TooLarge);
    assert!(message.contains("max_frame_bytes"), "{message}");
    assert!(!usable);
    assert!(t0.elapsed() < Duration::from_secs(5));
    assert_closed(&mut c);
    // The largest prefix there is.
    let mut c = d.client("huge2");
    c.send_raw(&u32::MAX.to_le_bytes()).unwrap();
    let (code, _, usable, _) = expect_error(c.recv().unwrap());
    assert_eq!((code, usable), (ErrorCode::TooLarge, false));
    assert_closed(&mut c);
    other.still_served();
}

#[test]
fn garbage_bytes_are_refused() {
    let d = TestDaemon::start("garbage");
    let mut other = Bystander::new(&d);
    // A well-framed body that is not MessagePack of a request: the framing is intact, so the
    // daemon answers and the session goes on.
    let mut c = d.client("garbage");
    let body = b"\xc1\xc1\xc1 not a message \xff\x00";
    let mut bytes = (body.len() as u32).to_le_bytes().to_vec();
    bytes.extend_from_slice(body);
    c.send_raw(&bytes).unwrap();
    let (code, message, usable, _) = expect_error(c.recv().unwrap());
    assert_eq!(code, ErrorCode::BadFrame);
    assert!(message.contains("undecodable"), "{message}");
    assert!(usable);
    assert!(matches!(
        c.call(&Request::Stats).unwrap(),
        Reply::DaemonStats(_)
    ));
    // Unframed text: its first four bytes read as a length far above the limit.
    let mut c = d.client("garbage2");
    c.send_raw(b"GARBAGE GARBAGE GARBAGE\n").unwrap();
    let (code, _, usable, _) = expect_error(c.recv().unwrap());
    assert_eq!((code, usable), (ErrorCode::TooLarge, false));
    assert_closed(&mut c);
    // Garbage before Hello.
    let mut c = d.raw_client();
    c.send_raw(&bytes).unwrap();
    let (code, _, _, _) = expect_error(c.recv().unwrap());
    assert_eq!(code, ErrorCode::BadFrame);
    other.still_served();
}

#[test]
fn mesh_with_index_out_of_range_is_refused_and_the_session_goes_on() {
    let d = TestDaemon::start("index");
    let mut other = Bystander::new(&d);
    let mut c = d.client("index");
    let bad = Mesh::new(
        "Suzanne",
        vec![Vec3::ZERO, Vec3::X, Vec3::Y],
        vec![[0, 1, 2], [0, 2, 8]],
    );
    let (code, message, usable, _) = expect_error(
        c.call(&Request::UploadMesh(upload_from_mesh(&bad)))
            .unwrap(),
    );
    assert_eq!(code, ErrorCode::InvalidInput);
    assert!(
        message.contains("Suzanne") && message.contains("vertex 8"),
        "{message}"
    );
    assert!(usable);
    // The same session renders afterwards.
    c.send_scene(&tiny_scene(1, 16, 12)).unwrap();
    render_reply(&mut c, 1, 1);
    other.still_served();
}

#[test]
fn nan_and_inf_vertices_are_refused() {
    let d = TestDaemon::start("nan");
    let mut other = Bystander::new(&d);
    let mut c = d.client("nan");
    for (name, v) in [("Rock.nan", f32::NAN), ("Rock.inf", f32::INFINITY)] {
        let bad = Mesh::new(
            name,
            vec![Vec3::ZERO, Vec3::new(1.0, v, 0.0), Vec3::Y],
            vec![[0, 1, 2]],
        );
        let (code, message, usable, _) = expect_error(
            c.call(&Request::UploadMesh(upload_from_mesh(&bad)))
                .unwrap(),
        );
        assert_eq!(code, ErrorCode::InvalidInput);
        assert!(
            message.contains(name) && message.contains("non-finite"),
            "{message}"
        );
        assert!(usable);
    }
    // A NaN in an object's matrix is named too.
    let mut update = frame_update_from_scene(&tiny_scene(1, 16, 12)).unwrap();
    update.objects[1].world_from_object = [f64::NAN; 16];
    let (code, message, usable, _) = expect_error(c.call(&Request::FrameUpdate(update)).unwrap());
    assert_eq!(code, ErrorCode::InvalidInput);
    assert!(
        message.contains("'box'") && message.contains("frame 1"),
        "{message}"
    );
    assert!(usable);
    other.still_served();
}

#[test]
fn render_with_an_unknown_mesh_hash_names_the_object() {
    let d = TestDaemon::start("unknown");
    let mut other = Bystander::new(&d);
    let mut c = d.client("unknown");
    let mut update = frame_update_from_scene(&tiny_scene(1, 16, 12)).unwrap();
    update.objects[1].mesh_hash = 0x1234_5678_9abc_def0;
    match c.call(&Request::FrameUpdate(update)).unwrap() {
        Reply::FrameAccepted { meshes_missing, .. } => {
            assert!(meshes_missing.contains(&0x1234_5678_9abc_def0))
        }
        other => panic!("{other:?}"),
    }
    c.send(&Request::Render(RenderRequest {
        frame: 1,
        settings: NamedSettings::default(),
        passes: Passes::default(),
        request_id: 77,
        warm_up: false,
    }))
    .unwrap();
    let (code, message, usable, request_id) = expect_error(c.recv().unwrap());
    assert_eq!(code, ErrorCode::UnknownMesh);
    assert!(
        message.contains("'box'") && message.contains("0x123456789abcdef0"),
        "{message}"
    );
    assert!(usable);
    assert_eq!(request_id, Some(77));
    // A render of a frame never sent is refused too.
    c.send(&Request::Render(RenderRequest {
        frame: 99,
        settings: NamedSettings::default(),
        passes: Passes::default(),
        request_id: 78,
        warm_up: false,
    }))
    .unwrap();
    let (code, message, _, request_id) = expect_error(c.recv().unwrap());
    assert_eq!(code, ErrorCode::InvalidInput);
    assert!(message.contains("frame 99"), "{message}");
    assert_eq!(request_id, Some(78));
    other.still_served();
}

#[test]
fn image_of_100000_by_100000_is_refused() {
    let d = TestDaemon::start("bigimage");
    let mut other = Bystander::new(&d);
    let mut c = d.client("bigimage");
    c.send_scene(&tiny_scene(1, 16, 12)).unwrap();
    let mut update = frame_update_from_scene(&tiny_scene(2, 16, 12)).unwrap();
    update.resolution.x = 100_000;
    update.resolution.y = 100_000;
    update.resolution.percentage = 100;
    let (code, message, usable, _) = expect_error(c.call(&Request::FrameUpdate(update)).unwrap());
    assert_eq!(code, ErrorCode::LimitExceeded);
    assert!(
        message.contains("frame 2") && message.contains("max_image_pixels"),
        "{message}"
    );
    assert!(usable);
    // The session still renders what it had.
    render_reply(&mut c, 1, 1);
    other.still_served();
}

#[test]
fn too_many_lights_and_bad_settings_are_refused() {
    let d = TestDaemon::start("lights");
    let mut other = Bystander::new(&d);
    let mut c = d.client("lights");
    let mut update = frame_update_from_scene(&tiny_scene(1, 16, 12)).unwrap();
    let light = LightState {
        name: "lamp".into(),
        world_from_light: DMat4::IDENTITY.to_cols_array(),
        kind: LightKindState::Point { radius: 0.1 },
        casts_shadow: true,
    };
    update.lights = vec![light; 5000];
    let (code, message, usable, _) = expect_error(c.call(&Request::FrameUpdate(update)).unwrap());
    assert_eq!(code, ErrorCode::LimitExceeded);
    assert!(
        message.contains("lights") && message.contains("max_lights"),
        "{message}"
    );
    assert!(usable);
    c.send_scene(&tiny_scene(1, 16, 12)).unwrap();
    let settings = NamedSettings::new().with("spp", 100000_i64);
    c.send(&Request::Render(RenderRequest {
        frame: 1,
        settings,
        passes: Passes::default(),
        request_id: 5,
        warm_up: false,
    }))
    .unwrap();
    let (code, message, _, request_id) = expect_error(c.recv().unwrap());
    assert_eq!(code, ErrorCode::LimitExceeded);
    assert!(message.contains("spp"), "{message}");
    assert_eq!(request_id, Some(5));
    other.still_served();
}

#[test]
fn client_disconnecting_mid_render_does_not_disturb_others() {
    let d = TestDaemon::start("disconnect");
    let mut other = Bystander::new(&d);
    let mut c = d.client("leaver");
    let scenes = city_frames(60_000, 1, 480, 300);
    c.send_scene(&scenes[0]).unwrap();
    let settings = NamedSettings::new().with("spp", 16_i64);
    c.send(&Request::Render(RenderRequest {
        frame: scenes[0].frame,
        settings,
        passes: Passes::default(),
        request_id: 1,
        warm_up: false,
    }))
    .unwrap();
    // Wait until the render runs, then vanish.
    match c.recv().unwrap() {
        Reply::Progress { stage, .. } => assert_eq!(stage, "render"),
        other => panic!("{other:?}"),
    }
    drop(c);
    other.still_served();
    d.wait_for_stats("the leaver's session to end", |s| s.sessions == 1);
    d.wait_for_stats("the abandoned render to be counted", |s| {
        s.renders_cancelled >= 1
    });
    other.still_served();
}

#[test]
fn queued_render_can_be_cancelled() {
    let d = TestDaemon::start_with("cancel", |c| c.max_renders = 1);
    // A long render holds the only slot.
    let mut busy = d.client("busy");
    let scenes = city_frames(60_000, 1, 480, 300);
    busy.send_scene(&scenes[0]).unwrap();
    let settings = NamedSettings::new().with("spp", 16_i64);
    busy.send(&Request::Render(RenderRequest {
        frame: scenes[0].frame,
        settings,
        passes: Passes::default(),
        request_id: 1,
        warm_up: false,
    }))
    .unwrap();
    assert!(matches!(busy.recv().unwrap(), Reply::Progress { .. }));
    let mut c = d.client("waiter");
    c.send_scene(&tiny_scene(1, 16, 12)).unwrap();
    c.send(&Request::Render(RenderRequest {
        frame: 1,
        settings: NamedSettings::default(),
        passes: Passes::default(),
        request_id: 9,
        warm_up: false,
    }))
    .unwrap();
    match c.recv().unwrap() {
        Reply::Progress {
            request_id, stage, ..
        } => assert_eq!((request_id, stage.as_str()), (9, "queued")),
        other => panic!("{other:?}"),
    }
    c.send(&Request::Cancel { request_id: 9 }).unwrap();
    // The Ack and the render's end, in either order.
    let mut saw_ack = false;
    let mut saw_cancelled = false;
    while !(saw_ack && saw_cancelled) {
        match c.recv().unwrap() {
            Reply::Ack => saw_ack = true,
            Reply::Error {
                code: ErrorCode::Cancelled,
                request_id: Some(9),
                session_usable: true,
                ..
            } => saw_cancelled = true,
            other => panic!("{other:?}"),
        }
    }
    // The busy client still gets its frame.
    let r = busy.finish_render(1).unwrap();
    assert_eq!(r.result.width, 480);
    // And the waiter can render now.
    render_reply(&mut c, 1, 10);
    assert!(d.handle.stats().renders_cancelled >= 1);
}

// ---------------------------------------------------------------------------------------------
// Sockets and security

#[test]
fn socket_is_0600_in_a_0700_folder() {
    let d = TestDaemon::start("mode");
    let mode = std::fs::metadata(&d.socket).unwrap().permissions().mode() & 0o777;
    assert_eq!(mode, 0o600, "{mode:o}");
    let dir_mode = std::fs::metadata(d.socket.parent().unwrap())
        .unwrap()
        .permissions()
        .mode()
        & 0o777;
    assert_eq!(dir_mode, 0o700, "{dir_mode:o}");
    let path = d.socket.clone();
    d.stop().unwrap();
    assert!(!path.exists(), "the socket file is removed at exit");
}

#[test]
fn tcp_needs_the_token() {
    let d = TestDaemon::start_with("tcp", |c| {
        c.tcp = Some("127.0.0.1:0".parse().unwrap());
        c.token = Some("s3cret-token".into());
    });
    let addr = d.tcp.unwrap();
    let connect = || {
        let c = Client::connect_tcp(addr).unwrap();
        c.set_timeout(Some(TIMEOUT)).unwrap();
        c
    };
    for token in [None, Some("wrong"), Some("s3cret-toke"), Some("")] {
        let mut c = connect();
        let err = c.hello("intruder", token).unwrap_err();
        let message = err.to_string();
        assert_eq!(err.code(), Some(ErrorCode::InvalidInput), "{message}");
        assert!(message.contains("authentication failed"), "{message}");
        assert_closed(&mut c);
    }
    // A first message that is not Hello is refused as well.
    let mut c = connect();
    let (_, message, usable, _) = expect_error(c.call(&Request::Stats).unwrap());
    assert!(
        message.contains("authentication failed") && !usable,
        "{message}"
    );
    assert_closed(&mut c);
    // With the token: a full session.
    let mut c = connect();
    c.hello("friend", Some("s3cret-token")).unwrap();
    c.send_scene(&tiny_scene(1, 16, 12)).unwrap();
    render_reply(&mut c, 1, 1);
    // The Unix socket needs no token.
    let mut u = d.client("local");
    assert!(matches!(
        u.call(&Request::Stats).unwrap(),
        Reply::DaemonStats(_)
    ));
}

#[test]
fn non_loopback_tcp_is_refused() {
    let dir = temp_dir("nonloop");
    let socket = dir.path().join("d.sock");
    for addr in ["0.0.0.0:0", "[::]:0"] {
        let mut config = DaemonConfig::new(&socket);
        config.tcp = Some(addr.parse().unwrap());
        config.token = Some("t".into());
        assert!(matches!(
            Daemon::bind(config),
            Err(DaemonError::NotLoopback { .. })
        ));
        assert!(!socket.exists());
    }
    // TCP without a token is refused too.
    let mut config = DaemonConfig::new(&socket);
    config.tcp = Some("127.0.0.1:0".parse().unwrap());
    assert!(matches!(
        Daemon::bind(config),
        Err(DaemonError::MissingToken)
    ));
}

#[test]
fn stale_socket_is_replaced_live_one_and_other_files_are_not() {
    let dir = temp_dir("stale");
    let socket = dir.path().join("d.sock");
    // A socket nobody listens on (a daemon that was killed).
    drop(std::os::unix::net::UnixListener::bind(&socket).unwrap());
    assert!(socket.exists());
    let d1 = Daemon::bind(DaemonConfig::new(&socket)).expect("stale socket replaced");
    let h1 = d1.handle();
    let t1 = std::thread::spawn(move || d1.run());
    // A live daemon is not replaced.
    match Daemon::bind(DaemonConfig::new(&socket)) {
        Err(e @ DaemonError::AlreadyRunning { .. }) => {
            assert!(e.to_string().contains("already listening"))
        }
        Err(e) => panic!("{e}"),
        Ok(_) => panic!("a second daemon bound the live socket"),
    }
    h1.stop();
    t1.join().unwrap().unwrap();
    // Not a socket: refused, and left alone.
    std::fs::write(&socket, b"precious").unwrap();
    assert!(matches!(
        Daemon::bind(DaemonConfig::new(&socket)),
        Err(DaemonError::NotASocket { .. })
    ));
    assert_eq!(std::fs::read(&socket).unwrap(), b"precious");
}

// ---------------------------------------------------------------------------------------------
// Cache, stats, recordings, shutdown

#[test]
fn unused_meshes_are_evicted_beyond_the_budget() {
    // Budget below one tiny scene: everything not in use goes.
    let d = TestDaemon::start_with("evict", |c| c.memory_budget = 100);
    let mut a = d.client("a");
    a.send_scene(&tiny_scene(1, 16, 12)).unwrap();
    render_reply(&mut a, 1, 1);
    // In use by a live session: kept.
    assert_eq!(d.handle.stats().meshes_cached, 2);
    assert_eq!(d.handle.stats().meshes_evicted, 0);
    a.close().unwrap();
    let s = d.wait_for_stats("eviction", |s| s.meshes_evicted == 2);
    assert_eq!(s.meshes_cached, 0);
    assert_eq!(s.bytes_cached, 0);
    // A new session uploads them again and renders.
    let mut b = d.client("b");
    assert_eq!(
        b.send_scene(&tiny_scene(2, 16, 12))
            .unwrap()
            .meshes_uploaded,
        2
    );
    render_reply(&mut b, 2, 2);
    match b.call(&Request::Stats).unwrap() {
        Reply::DaemonStats(s) => {
            assert_eq!(s.meshes_evicted, 2);
            assert_eq!(s.sessions, 1);
            assert!(s.sessions_total >= 2);
        }
        other => panic!("{other:?}"),
    }
    // A render counts as done once its frame is written to the socket, which can be just
    // after the client has read it: wait for the count rather than race it.
    d.wait_for_stats("two renders done", |s| s.renders_done == 2);
}

#[test]
fn sessions_are_recorded_and_replay() {
    // A folder the daemon makes itself.
    let rec = temp_dir("rec");
    let rec_dir = rec.path().join("recordings");
    let d = TestDaemon::start_with("record", |c| c.record = Some(rec_dir.clone()));
    let mut c = d.client("recorder");
    let scenes: Vec<Scene> = (1..=3).map(|f| tiny_scene(f, 24, 16)).collect();
    for s in &scenes {
        c.send_scene(s).unwrap();
        render_reply(&mut c, s.frame, s.frame as u64);
    }
    c.close().unwrap();
    d.wait_for_stats("the session to end", |s| s.sessions == 0);
    let files: Vec<_> = std::fs::read_dir(&rec_dir)
        .unwrap()
        .flatten()
        .map(|e| e.path())
        .collect();
    assert_eq!(files.len(), 1, "{files:?}");
    assert!(files[0].extension().is_some_and(|e| e == "antrec"));
    let replayed = replay_scenes(&files[0]).unwrap();
    assert_eq!(replayed.len(), 3);
    for (r, s) in replayed.iter().zip(&scenes) {
        assert_eq!(
            frame_update_from_scene(r).unwrap(),
            frame_update_from_scene(s).unwrap()
        );
    }
}

/// Sends a frame as the add-on does: its update first, then the meshes the daemon says it lacks.
/// Returns how many meshes were uploaded.
fn send_frame_first(c: &mut Client, scene: &Scene) -> usize {
    let update = frame_update_from_scene(scene).unwrap();
    let missing = match c.call(&Request::FrameUpdate(update)).unwrap() {
        Reply::FrameAccepted { meshes_missing, .. } => meshes_missing,
        other => panic!("FrameUpdate: {}", other.kind()),
    };
    for h in &missing {
        let mesh = scene
            .meshes
            .iter()
            .find(|m| m.content_hash() == *h)
            .unwrap();
        let reply = c
            .call(&Request::UploadMesh(upload_from_mesh(mesh)))
            .unwrap();
        assert!(
            matches!(reply, Reply::MeshStored { .. }),
            "{}",
            reply.kind()
        );
    }
    missing.len()
}

#[test]
fn recordings_replay_whatever_the_order_and_what_the_daemon_held() {
    let rec = temp_dir("rec2");
    let rec_dir = rec.path().join("recordings");
    let d = TestDaemon::start_with("record2", |c| c.record = Some(rec_dir.clone()));
    let scenes = city_frames(3_000, 3, 48, 32);
    // Two sessions in a row: the second finds every mesh in the cache and uploads none.
    let mut sessions = Vec::new();
    for name in ["first", "second"] {
        let mut c = d.client(name);
        let mut uploaded = 0;
        let mut results = Vec::new();
        for (i, s) in scenes.iter().enumerate() {
            uploaded += send_frame_first(&mut c, s);
            results.push(render_reply(&mut c, s.frame, i as u64));
        }
        c.close().unwrap();
        d.wait_for_stats("the session to end", |s| s.sessions == 0);
        sessions.push((name, uploaded, results));
    }
    let distinct: std::collections::HashSet<u64> = scenes
        .iter()
        .flat_map(|s| s.meshes.iter().map(|m| m.content_hash()))
        .collect();
    assert_eq!(sessions[0].1, distinct.len());
    assert_eq!(sessions[1].1, 0);

    let mut files: Vec<_> = std::fs::read_dir(&rec_dir)
        .unwrap()
        .flatten()
        .map(|e| e.path())
        .collect();
    files.sort();
    assert_eq!(files.len(), 2, "{files:?}");
    for (file, (name, _, results)) in files.iter().zip(&sessions) {
        // Each file alone replays to the daemon's own images, bit for bit.
        let replayed = replay_scenes(file).unwrap();
        assert_eq!(replayed.len(), scenes.len());
        let expected = render_in_process(name, &replayed, &RenderSettings::default());
        for (reply, want) in results.iter().zip(&expected) {
            assert_same_result(reply, want);
        }
        // Each mesh the frames use is in the file once.
        let uploads: Vec<u64> = antumbra_protocol::RecordingReader::open(file)
            .unwrap()
            .filter_map(|r| match r.unwrap() {
                Request::UploadMesh(u) => Some(u.hash),
                _ => None,
            })
            .collect();
        assert_eq!(uploads.len(), distinct.len(), "{}", file.display());
        assert_eq!(
            uploads
                .iter()
                .copied()
                .collect::<std::collections::HashSet<_>>(),
            distinct
        );
    }
}

#[test]
fn shutdown_request_stops_the_daemon_after_current_requests() {
    let d = TestDaemon::start("shutdown");
    let socket = d.socket.clone();
    let mut other = d.client("other");
    other.send_scene(&tiny_scene(1, 16, 12)).unwrap();
    let mut c = d.client("admin");
    assert!(matches!(c.call(&Request::Shutdown).unwrap(), Reply::Ack));
    let t0 = Instant::now();
    d.stop().unwrap();
    assert!(t0.elapsed() < Duration::from_secs(10));
    assert!(!socket.exists());
    // The other session was ended: its next request finds the connection closed.
    let _ = other.send(&Request::Stats);
    assert!(other.recv().is_err());
}

#[test]
fn invalid_content_keeps_the_session_usable_for_uploads_after() {
    // An upload whose hash does not match its content, then a good one.
    let d = TestDaemon::start("hash");
    let mut c = d.client("hash");
    let mut up = upload_from_mesh(&cube());
    up.hash ^= 1;
    let (code, message, usable, _) = expect_error(c.call(&Request::UploadMesh(up)).unwrap());
    assert_eq!(code, ErrorCode::InvalidInput);
    assert!(
        message.contains("'cube'") && message.contains("hash"),
        "{message}"
    );
    assert!(usable);
    match c
        .call(&Request::UploadMesh(upload_from_mesh(&cube())))
        .unwrap()
    {
        Reply::MeshStored { triangles, .. } => assert_eq!(triangles, 12),
        other => panic!("{other:?}"),
    }
    // Hello twice is an error, not the end.
    let (code, _, usable, _) = expect_error(
        c.call(&Request::Hello {
            version: PROTOCOL_VERSION,
            client: "again".into(),
            token: None,
        })
        .unwrap(),
    );
    assert_eq!((code, usable), (ErrorCode::InvalidInput, true));
    // A first message that is not Hello is answered and Hello is still awaited.
    let mut raw = d.raw_client();
    let (code, message, usable, _) = expect_error(raw.call(&Request::Stats).unwrap());
    assert_eq!((code, usable), (ErrorCode::InvalidInput, true));
    assert!(message.contains("Hello"), "{message}");
    raw.hello("late", None).unwrap();
}
