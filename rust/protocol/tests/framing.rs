//! Framing errors: truncation, oversized prefixes, garbage, trailing bytes, the handshake.

use std::io::Read;
use std::time::{Duration, Instant};

use antumbra_protocol::*;

fn hello() -> Request {
    Request::Hello {
        version: PROTOCOL_VERSION,
        client: "test".into(),
        token: None,
    }
}

#[test]
fn clean_end_of_stream_is_closed() {
    let limits = Limits::default();
    let mut empty: &[u8] = &[];
    assert!(matches!(
        read_message::<_, Request>(&mut empty, &limits),
        Err(FrameError::Closed)
    ));
    let framed = encode_message(&hello()).unwrap();
    let mut r = &framed[..];
    assert_eq!(
        read_message::<_, Request>(&mut r, &limits).unwrap(),
        hello()
    );
    assert!(matches!(
        read_message::<_, Request>(&mut r, &limits),
        Err(FrameError::Closed)
    ));
}

#[test]
fn truncated_frames_are_truncated_not_closed() {
    let limits = Limits::default();
    let framed = encode_message(&hello()).unwrap();
    for cut in 1..framed.len() {
        let mut r = &framed[..cut];
        let err = read_message::<_, Request>(&mut r, &limits).unwrap_err();
        match err {
            FrameError::Truncated { expected, got } => {
                if cut < 4 {
                    assert_eq!((expected, got), (4, cut as u64));
                } else {
                    assert_eq!((expected, got), (framed.len() as u64 - 4, cut as u64 - 4));
                }
            }
            other => panic!("cut at {cut}: {other}"),
        }
        let mut d = FrameDecoder::new(&limits);
        d.push(&framed[..cut]);
        assert!(d.next_message::<Request>().unwrap().is_none());
        assert!(matches!(d.finish(), FrameError::Truncated { .. }));
        assert_eq!(d.finish().code(), ErrorCode::BadFrame);
    }
}

/// A reader that reports how much was asked of it and never runs dry of a repeating byte.
struct Endless {
    read: u64,
}

impl Read for Endless {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        buf.fill(0x90);
        self.read += buf.len() as u64;
        Ok(buf.len())
    }
}

#[test]
fn huge_length_prefix_is_refused_before_reading_the_body() {
    // A 4-byte prefix can announce at most 4 GiB - 1; with the default 1 GiB limit, any prefix
    // above 1 GiB is refused after the 4 prefix bytes, with no body read or allocated.
    // (tests/no_alloc.rs checks the allocation side with a counting allocator.)
    let limits = Limits::default();
    for len in [u32::MAX, (1u32 << 30) + 1, 3 << 30] {
        let mut stream = len.to_le_bytes().to_vec();
        stream.extend_from_slice(&[0u8; 16]);
        let start = Instant::now();
        let mut r = &stream[..];
        let err = read_message::<_, Request>(&mut r, &limits).unwrap_err();
        assert!(start.elapsed() < Duration::from_millis(100));
        match &err {
            FrameError::TooLarge { len: l, max } => {
                assert_eq!((*l, *max), (len as u64, 1 << 30));
            }
            other => panic!("{other}"),
        }
        assert_eq!(r.len(), 16, "the body must not be read");
        assert_eq!(err.code(), ErrorCode::TooLarge);
        assert!(!err.session_usable());
        assert!(err.to_string().contains("max_frame_bytes"), "{err}");

        let mut d = FrameDecoder::new(&limits);
        d.push(&stream);
        assert!(matches!(
            d.next_message::<Request>(),
            Err(FrameError::TooLarge { .. })
        ));
        // Sticky: the stream cannot be resynchronised, and later input is dropped.
        d.push(&encode_message(&hello()).unwrap());
        assert_eq!(d.buffered(), 0);
        assert!(matches!(
            d.next_message::<Request>(),
            Err(FrameError::TooLarge { .. })
        ));
    }
    // A 10 GiB limit is clamped to what a 4-byte prefix can announce.
    let limits = Limits {
        max_frame_bytes: 10 << 30,
        ..Limits::default()
    };
    assert_eq!(limits.frame_limit(), u32::MAX as u64);
}

#[test]
fn replies_above_the_limit_are_refused_when_encoding() {
    let limits = Limits {
        max_frame_bytes: 64,
        ..Limits::default()
    };
    let small = Reply::Ack;
    assert_eq!(
        encode_message_within(&small, &limits).unwrap(),
        encode_message(&small).unwrap()
    );
    let big = Reply::Missing {
        hashes: vec![u64::MAX; 16],
    };
    let err = encode_message_within(&big, &limits).unwrap_err();
    assert!(matches!(err, FrameError::TooLarge { max: 64, .. }), "{err}");
}

#[test]
fn a_large_announced_body_is_read_only_as_far_as_it_arrives() {
    // 900 MiB announced (within the limit), then the stream ends after 100 bytes: Truncated,
    // quickly, without reserving 900 MiB first.
    let limits = Limits::default();
    let mut stream = (900u32 << 20).to_le_bytes().to_vec();
    stream.extend_from_slice(&[0xc0; 100]);
    let start = Instant::now();
    let err = read_message::<_, Request>(&mut &stream[..], &limits).unwrap_err();
    assert!(start.elapsed() < Duration::from_millis(100));
    assert!(matches!(
        err,
        FrameError::Truncated {
            expected: 943718400,
            got: 100
        }
    ));
}

#[test]
fn a_frame_within_the_limit_is_read_exactly() {
    // The reader stops at the frame's end even on an endless stream.
    let limits = Limits {
        max_frame_bytes: 1 << 20,
        ..Limits::default()
    };
    let mut r = std::io::Cursor::new(300_000u32.to_le_bytes()).chain(Endless { read: 0 });
    let body = read_frame(&mut r, &limits).unwrap();
    assert_eq!(body.len(), 300_000);
    assert_eq!(r.get_ref().1.read, 300_000);
}

#[test]
fn garbage_is_a_decode_error_and_the_stream_goes_on() {
    let limits = Limits::default();
    let garbage: [&[u8]; 6] = [
        b"\xc1",                             // reserved marker
        b"\x81\xa9Undefined\xc0",            // unknown message type
        b"\x81\xa5Hello\x81\xa7version\x01", // missing field
        b"\xa5Hello",                        // struct variant given as a unit
        b"\xa5Stats\xa5Stats",               // trailing bytes
        &[0xdd, 0xff, 0xff, 0xff, 0xff],     // array of 4 billion elements, none present
    ];
    let mut stream = Vec::new();
    for g in garbage {
        stream.extend_from_slice(&(g.len() as u32).to_le_bytes());
        stream.extend_from_slice(g);
    }
    write_message(&mut stream, &hello()).unwrap();

    let mut r = &stream[..];
    for g in garbage {
        let err = read_message::<_, Request>(&mut r, &limits).unwrap_err();
        assert!(matches!(err, FrameError::Decode(_)), "{g:x?}: {err}");
        assert!(err.session_usable());
        let reply = err.to_reply();
        assert!(matches!(
            reply,
            Reply::Error {
                code: ErrorCode::BadFrame,
                session_usable: true,
                ..
            }
        ));
    }
    assert_eq!(
        read_message::<_, Request>(&mut r, &limits).unwrap(),
        hello()
    );

    let mut d = FrameDecoder::new(&limits);
    d.push(&stream);
    for _ in garbage {
        assert!(matches!(
            d.next_message::<Request>(),
            Err(FrameError::Decode(_))
        ));
    }
    assert_eq!(d.next_message::<Request>().unwrap(), Some(hello()));
    assert!(d.next_message::<Request>().unwrap().is_none());
}

#[test]
fn decode_errors_name_the_problem() {
    // A value of the wrong type names its path and what was expected.
    let err = decode_body::<Request>(
        b"\x81\xa6Render\x83\xa5frame\x01\xaarequest_id\x02\xa6passes\x81\xa5masks\x03",
    )
    .unwrap_err()
    .to_string();
    assert!(
        err.contains("Render.passes.masks") && err.contains("expected a boolean"),
        "{err}"
    );
    let err = decode_body::<Request>(b"\x81\xa5Hello\x81\xa7version\x01").unwrap_err();
    assert!(err.to_string().contains("client"), "{err}");
    let err = decode_body::<Request>(b"\x81\xa9Undefined\xc0").unwrap_err();
    assert!(err.to_string().contains("Undefined"), "{err}");
}

/// A `FrameUpdate` of the tiny scene with `edit` applied to its lights[0].kind, decoded.
fn light_kind_error(edit: impl FnOnce(&mut serde_json::Map<String, serde_json::Value>)) -> String {
    let update = frame_update_from_scene(&common::tiny_scene(1)).unwrap();
    let mut value = serde_json::to_value(Request::FrameUpdate(update)).unwrap();
    let kind = value["FrameUpdate"]["lights"][0]["kind"]
        .as_object_mut()
        .unwrap();
    edit(kind);
    let body = rmp_serde::to_vec_named(&value).unwrap();
    decode_body::<Request>(&body).unwrap_err().to_string()
}

#[test]
fn light_kind_errors_name_the_field_and_the_kinds() {
    // Issue 33: `lights[0].kind: invalid type: string "wide", expected f64` named no field.
    let e = light_kind_error(|k| {
        k.insert("angle".into(), "wide".into());
    });
    assert!(e.contains("FrameUpdate.lights[0].kind"), "{e}");
    assert!(e.contains("angle") && e.contains("Sun"), "{e}");
    let e = light_kind_error(|k| {
        k.insert("type".into(), "Laser".into());
    });
    assert!(e.contains("Laser"), "{e}");
    assert!(e.contains("Point, Sun, Spot, Area"), "{e}");
    let e = light_kind_error(|k| {
        k.remove("angle");
    });
    assert!(e.contains("Sun") && e.contains("angle"), "{e}");
    // The valid kinds still decode, each with its own fields.
    let update = frame_update_from_scene(&common::tiny_scene(2)).unwrap();
    let body = encode_body(&Request::FrameUpdate(update.clone())).unwrap();
    assert_eq!(
        decode_body::<Request>(&body).unwrap(),
        Request::FrameUpdate(update)
    );
}

#[test]
fn hello_checks() {
    assert!(check_hello(&hello()).is_ok());
    let err = check_hello(&Request::Hello {
        version: PROTOCOL_VERSION + 1,
        client: "future".into(),
        token: None,
    })
    .unwrap_err();
    assert_eq!(err.code(), ErrorCode::VersionMismatch);
    let future = format!("version {}", PROTOCOL_VERSION + 1);
    assert!(err.to_string().contains(&future), "{err}");
    assert!(
        err.to_string().contains("update the antumbra daemon"),
        "{err}"
    );
    // A version-1 client (FNV-1a mesh hashes) is told to update the add-on.
    let err = check_hello(&Request::Hello {
        version: 1,
        client: "blender 4.2".into(),
        token: None,
    })
    .unwrap_err();
    assert_eq!(err.code(), ErrorCode::VersionMismatch);
    assert!(err.to_string().contains("version 1"), "{err}");
    let ours = format!("version {PROTOCOL_VERSION}");
    assert!(err.to_string().contains(&ours), "{err}");
    assert!(
        err.to_string().contains("update the Blender add-on"),
        "{err}"
    );
    let Reply::Error {
        code,
        session_usable,
        ..
    } = err.to_reply()
    else {
        panic!()
    };
    assert_eq!(code, ErrorCode::VersionMismatch);
    assert!(!session_usable);

    let err = check_hello(&Request::Stats).unwrap_err();
    assert_eq!(err.code(), ErrorCode::InvalidInput);
    assert!(err.to_string().contains("Hello"), "{err}");
    assert!(err.to_string().contains("Stats"), "{err}");

    let Reply::Welcome {
        version, limits, ..
    } = welcome("antumbrad", &Limits::default())
    else {
        panic!()
    };
    assert_eq!(version, PROTOCOL_VERSION);
    assert_eq!(*limits, Limits::default());
}

#[test]
fn limits_are_checked_and_named() {
    let limits = Limits {
        max_triangles_per_mesh: 1,
        max_objects: 1,
        max_lights: 0,
        max_image_pixels: 100,
        max_spp: 8,
        ..Limits::default()
    };
    let upload = Request::UploadMesh(UploadMesh {
        hash: 0,
        name: "big".into(),
        positions: Default::default(),
        triangles: serde_bytes::ByteBuf::from(vec![0; 24]),
        normals: Default::default(),
        material_slots: Default::default(),
        uv_maps: Vec::new(),
    });
    let err = check_limits(&upload, &limits).unwrap_err();
    assert_eq!(err.code(), ErrorCode::LimitExceeded);
    assert!(err.to_string().contains("mesh 'big'"), "{err}");
    assert!(err.to_string().contains("max_triangles_per_mesh"), "{err}");

    let (_, frame) = antumbra_protocol::scene_to_messages(&common::tiny_scene(3)).unwrap();
    let err = check_limits(&frame, &limits).unwrap_err();
    assert!(err.to_string().contains("frame 3: objects"), "{err}");
    let lim = Limits {
        max_objects: 10,
        ..limits.clone()
    };
    let err = check_limits(&frame, &lim).unwrap_err();
    assert!(err.to_string().contains("frame 3: lights"), "{err}");
    let lim = Limits {
        max_objects: 10,
        max_lights: 10,
        ..limits.clone()
    };
    let err = check_limits(&frame, &lim).unwrap_err();
    assert!(err.to_string().contains("resolution 32x24"), "{err}");
    let lim = Limits {
        max_objects: 10,
        max_lights: 10,
        max_meshes: 1,
        ..limits.clone()
    };
    assert!(check_limits(&frame, &lim)
        .unwrap_err()
        .to_string()
        .contains("distinct meshes"));
    let ok = Limits {
        max_objects: 10,
        max_lights: 10,
        max_image_pixels: 32 * 24,
        ..limits.clone()
    };
    check_limits(&frame, &ok).unwrap();

    let render = Request::Render(RenderRequest {
        frame: 9,
        settings: NamedSettings::new().with("spp", 9i64),
        passes: Passes::default(),
        request_id: 1,
        warm_up: false,
    });
    let err = check_limits(&render, &limits).unwrap_err();
    assert!(err.to_string().contains("frame 9: settings.spp"), "{err}");
    assert!(check_limits(&Request::Stats, &limits).is_ok());

    // Overflowing resolutions do not wrap around.
    let mut big = frame.clone();
    if let Request::FrameUpdate(u) = &mut big {
        u.resolution.x = u32::MAX;
        u.resolution.y = u32::MAX;
        u.resolution.percentage = u32::MAX;
    }
    assert!(check_limits(&big, &ok).is_err());
}

mod common;
