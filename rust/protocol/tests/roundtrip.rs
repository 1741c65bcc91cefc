//! Every message type survives encode → frame → decode unchanged.

use antumbra_core::settings::SettingValue;
use antumbra_protocol::*;
use proptest::collection::vec;
use proptest::prelude::*;
use serde_bytes::ByteBuf;

fn f64s() -> impl Strategy<Value = f64> {
    prop_oneof![
        -1e9f64..1e9,
        Just(0.0),
        Just(-0.0),
        Just(f64::MAX),
        Just(f64::MIN_POSITIVE),
        Just(1e-300),
    ]
}

fn matrix() -> impl Strategy<Value = [f64; 16]> {
    prop::array::uniform16(f64s())
}

fn bytes() -> impl Strategy<Value = ByteBuf> {
    vec(any::<u8>(), 0..64).prop_map(ByteBuf::from)
}

fn name() -> impl Strategy<Value = String> {
    // Any unicode, including quotes and newlines, as Blender names can be.
    ".{0,12}"
}

fn camera() -> impl Strategy<Value = CameraState> {
    (
        matrix(),
        (f64s(), f64s(), f64s()),
        prop_oneof![
            Just(SensorFitState::Auto),
            Just(SensorFitState::Horizontal),
            Just(SensorFitState::Vertical)
        ],
        (f64s(), f64s(), f64s(), f64s()),
    )
        .prop_map(|(m, (lens, sw, sh), fit, (sx, sy, cs, ce))| CameraState {
            world_from_camera: m,
            lens_mm: lens,
            sensor_width_mm: sw,
            sensor_height_mm: sh,
            sensor_fit: fit,
            shift_x: sx,
            shift_y: sy,
            clip_start: cs,
            clip_end: ce,
        })
}

fn light_kind() -> impl Strategy<Value = LightKindState> {
    let shape = prop_oneof![
        Just(AreaShapeState::Square),
        Just(AreaShapeState::Rectangle),
        Just(AreaShapeState::Disk),
        Just(AreaShapeState::Ellipse)
    ];
    prop_oneof![
        f64s().prop_map(|radius| LightKindState::Point { radius }),
        f64s().prop_map(|angle| LightKindState::Sun { angle }),
        (f64s(), f64s(), f64s()).prop_map(|(radius, spot_size, spot_blend)| {
            LightKindState::Spot {
                radius,
                spot_size,
                spot_blend,
            }
        }),
        (shape, f64s(), f64s()).prop_map(|(shape, size_x, size_y)| LightKindState::Area {
            shape,
            size_x,
            size_y
        }),
    ]
}

fn light() -> impl Strategy<Value = LightState> {
    (name(), matrix(), light_kind(), any::<bool>()).prop_map(|(name, m, kind, casts_shadow)| {
        LightState {
            name,
            world_from_light: m,
            kind,
            casts_shadow,
        }
    })
}

/// Material slots: opaque (nil) or an index, any u32.
fn slot_materials() -> impl Strategy<Value = Vec<Option<u32>>> {
    vec(proptest::option::of(any::<u32>()), 0..4)
}

fn f32s() -> impl Strategy<Value = f32> {
    prop_oneof![-1e6f32..1e6, Just(0.0), Just(-0.0), Just(f32::MAX)]
}

fn alpha_material() -> impl Strategy<Value = AlphaMaterialState> {
    let interpolation = prop_oneof![
        Just(Interpolation::Closest),
        Just(Interpolation::Linear),
        Just(Interpolation::Cubic)
    ];
    let extension = prop_oneof![
        Just(Extension::Repeat),
        Just(Extension::Extend),
        Just(Extension::Clip),
        Just(Extension::Mirror)
    ];
    let source = prop_oneof![
        f32s().prop_map(|alpha| AlphaSourceState::Constant { alpha }),
        (any::<u64>(), interpolation, extension).prop_map(|(hash, interpolation, extension)| {
            AlphaSourceState::Image {
                hash,
                interpolation,
                extension,
            }
        }),
    ];
    let op = prop_oneof![
        f32s().prop_map(AlphaOp::Multiply),
        f32s().prop_map(AlphaOp::Add),
        f32s().prop_map(AlphaOp::Subtract),
        f32s().prop_map(AlphaOp::Power),
        f32s().prop_map(AlphaOp::GreaterThan),
        f32s().prop_map(AlphaOp::LessThan),
        Just(AlphaOp::OneMinus),
        Just(AlphaOp::Clamp),
    ];
    (name(), name(), source, vec(op, 0..5)).prop_map(|(name, uv_map, source, ops)| {
        AlphaMaterialState {
            name,
            uv_map,
            source,
            ops,
        }
    })
}

fn object() -> impl Strategy<Value = ObjectState> {
    (
        name(),
        any::<u64>(),
        matrix(),
        any::<bool>(),
        any::<bool>(),
        slot_materials(),
    )
        .prop_map(
            |(name, mesh_hash, m, visible_to_camera, casts_shadow, materials)| ObjectState {
                name,
                mesh_hash,
                world_from_object: m,
                visible_to_camera,
                casts_shadow,
                materials,
            },
        )
}

fn instance_array() -> impl Strategy<Value = InstanceArrayState> {
    (
        name(),
        any::<u64>(),
        vec(any::<u8>(), 0..200),
        vec(any::<u8>(), 0..20),
        any::<[bool; 3]>(),
        slot_materials(),
    )
        .prop_map(
            |(name, mesh_hash, matrices, ids, [camera, shadow, unchanged], materials)| {
                InstanceArrayState {
                    name,
                    mesh_hash,
                    matrices: ByteBuf::from(matrices),
                    ids: ByteBuf::from(ids),
                    visible_to_camera: camera,
                    casts_shadow: shadow,
                    unchanged,
                    materials,
                }
            },
        )
}

fn resolution() -> impl Strategy<Value = ResolutionState> {
    (any::<u32>(), any::<u32>(), any::<u32>(), f64s(), f64s()).prop_map(|(x, y, p, ax, ay)| {
        ResolutionState {
            x,
            y,
            percentage: p,
            pixel_aspect_x: ax,
            pixel_aspect_y: ay,
        }
    })
}

/// Settings maps as any peer may send them: any subset of the schema's names, each with a value
/// of any of the four wire types (the wire carries them; `resolve` judges them).
fn settings() -> impl Strategy<Value = NamedSettings> {
    let value = prop_oneof![
        any::<bool>().prop_map(SettingValue::Bool),
        any::<i64>().prop_map(SettingValue::Int),
        (-1e9f64..1e9).prop_map(SettingValue::Float),
        "[a-z0-9:=.]{0,12}".prop_map(SettingValue::Text),
    ];
    proptest::collection::vec(
        (0..antumbra_core::settings::SCHEMA.len(), value),
        0..antumbra_core::settings::SCHEMA.len(),
    )
    .prop_map(|pairs| {
        let mut n = NamedSettings::new();
        for (i, v) in pairs {
            n.insert(antumbra_core::settings::SCHEMA[i].name, v);
        }
        n
    })
}

fn limits() -> impl Strategy<Value = Limits> {
    (
        (any::<u64>(), any::<u64>(), any::<u64>(), any::<u64>()),
        (any::<u64>(), any::<u32>(), any::<u32>(), any::<u64>()),
        any::<u64>(),
        any::<[u64; 5]>(),
    )
        .prop_map(
            |((fb, tri, meshes, objects), (px, spp, lights, render), passes, alpha)| Limits {
                max_frame_bytes: fb,
                max_triangles_per_mesh: tri,
                max_meshes: meshes,
                max_objects: objects,
                max_image_pixels: px,
                max_spp: spp,
                max_lights: lights,
                max_render_bytes: render,
                max_request_passes: passes,
                max_image_texels: alpha[0],
                max_alpha_materials: alpha[1],
                max_alpha_ops: alpha[2],
                max_uv_maps: alpha[3],
                max_material_slots: alpha[4],
            },
        )
}

fn stats_row() -> impl Strategy<Value = StatsRowState> {
    (
        (name(), any::<i32>(), name(), name(), name(), any::<bool>()),
        (
            f64s(),
            any::<u64>(),
            any::<u64>(),
            any::<u64>(),
            any::<u64>(),
        ),
        (f64s(), f64s(), any::<bool>(), f64s()),
        (f64s(), f64s(), f64s(), f64s(), any::<u64>(), any::<u64>()),
    )
        .prop_map(
            |(
                (scene, frame, method, pass, light, rebuilt),
                (build_ms, bvh_nodes, bvh_bytes, triangles, rays),
                (trace_ms, mrays_per_s, timed_without_counters, occluded_fraction),
                (nb, nl, nt, nbox, back_facing, unreached),
            )| StatsRowState {
                scene,
                frame,
                method,
                pass,
                light,
                rebuilt,
                build_ms,
                bvh_nodes,
                bvh_bytes,
                triangles,
                rays,
                trace_ms,
                mrays_per_s,
                timed_without_counters,
                occluded_fraction,
                nb_per_ray: nb,
                nl_per_ray: nl,
                nt_per_ray: nt,
                nbox_per_ray: nbox,
                back_facing,
                unreached,
                prepare_ms: trace_ms * 0.5,
                references: bvh_nodes ^ rays,
                visible_input: triangles / 2,
                visibility_ms: trace_ms,
                nts_per_ray: nb,
                auto_choice: format!("explore:{frame}"),
                auto_estimate_ms: nl,
                alpha_lookups_per_ray: nt,
                trees_refit: rays / 3,
                packets: rays / 16,
                steps_per_packet: nbox,
                handoffs_per_ray: nt,
            },
        )
}

fn request() -> impl Strategy<Value = Request> {
    prop_oneof![
        (any::<u32>(), name()).prop_map(|(version, client)| Request::Hello {
            version,
            client,
            token: None,
        }),
        vec(any::<u64>(), 0..8).prop_map(|hashes| Request::MissingMeshes { hashes }),
        (
            (any::<u64>(), name(), bytes(), bytes(), bytes()),
            bytes(),
            vec((name(), bytes()), 0..3)
        )
            .prop_map(
                |((hash, name, positions, triangles, normals), material_slots, uv_maps)| {
                    Request::UploadMesh(UploadMesh {
                        hash,
                        name,
                        positions,
                        triangles,
                        normals,
                        material_slots,
                        uv_maps: uv_maps
                            .into_iter()
                            .map(|(name, corners)| UvMapState { name, corners })
                            .collect(),
                    })
                }
            ),
        vec(any::<u64>(), 0..8).prop_map(|hashes| Request::MissingImages { hashes }),
        (any::<u64>(), any::<u32>(), any::<u32>(), bytes()).prop_map(
            |(hash, width, height, texels)| Request::UploadImage(UploadImage {
                hash,
                width,
                height,
                texels,
            })
        ),
        (
            any::<i32>(),
            vec(object(), 0..4),
            vec(instance_array(), 0..3),
            camera(),
            vec(light(), 0..4),
            resolution(),
            vec(alpha_material(), 0..3)
        )
            .prop_map(
                |(frame, objects, instances, camera, lights, resolution, alpha_materials)| {
                    Request::FrameUpdate(FrameUpdate {
                        frame,
                        objects,
                        instances,
                        camera,
                        lights,
                        resolution,
                        alpha_materials,
                    })
                }
            ),
        (
            any::<i32>(),
            settings(),
            prop::array::uniform6(any::<bool>()),
            any::<u64>()
        )
            .prop_map(
                |(frame, settings, p, request_id)| Request::Render(RenderRequest {
                    frame,
                    settings,
                    passes: Passes {
                        masks: p[0],
                        combined: p[1],
                        heat_maps: p[2],
                        visible_set: p[3],
                        object_ids: p[4],
                    },
                    request_id,
                    warm_up: p[5],
                })
            ),
        (
            (any::<i32>(), any::<u64>(), settings()),
            vec((name(), settings()), 0..3),
            proptest::option::of(name()),
            (any::<u32>(), any::<bool>(), any::<bool>())
        )
            .prop_map(
                |((frame, request_id, settings), methods, baseline, (repeat, images, warm_up))| {
                    Request::Compare(CompareRequest {
                        frame,
                        request_id,
                        settings,
                        methods: methods
                            .into_iter()
                            .map(|(label, settings)| CompareMethod { label, settings })
                            .collect(),
                        baseline,
                        repeat,
                        images,
                        warm_up,
                    })
                }
            ),
        any::<u64>().prop_map(|request_id| Request::Cancel { request_id }),
        Just(Request::Stats),
        Just(Request::Close),
        Just(Request::Shutdown),
    ]
}

fn error_code() -> impl Strategy<Value = ErrorCode> {
    prop_oneof![
        Just(ErrorCode::BadFrame),
        Just(ErrorCode::VersionMismatch),
        Just(ErrorCode::TooLarge),
        Just(ErrorCode::InvalidInput),
        Just(ErrorCode::UnknownMesh),
        Just(ErrorCode::LimitExceeded),
        Just(ErrorCode::Busy),
        Just(ErrorCode::Cancelled),
        Just(ErrorCode::Internal),
    ]
}

fn image() -> impl Strategy<Value = Image> {
    (name(), any::<u32>(), any::<u32>(), bytes()).prop_map(|(name, width, height, data)| Image {
        name,
        width,
        height,
        data,
    })
}

fn timing() -> impl Strategy<Value = antumbra_core::compare::Timing> {
    (f64s(), f64s(), f64s()).prop_map(|(median, min, max)| antumbra_core::compare::Timing {
        median,
        min,
        max,
    })
}

fn compare_row() -> impl Strategy<Value = CompareRowState> {
    (
        name(),
        stats_row(),
        [timing(), timing(), timing(), timing()],
    )
        .prop_map(
            |(label, stats, [build_ms, prepare_ms, trace_ms, frame_ms])| CompareRowState {
                label,
                stats,
                build_ms,
                prepare_ms,
                trace_ms,
                frame_ms,
            },
        )
}

fn mismatch() -> impl Strategy<Value = MismatchState> {
    (any::<i32>(), name(), name(), any::<u32>(), any::<bool>()).prop_map(
        |(frame, label, what, pixels, across_structures)| MismatchState {
            frame,
            label,
            what,
            pixels: pixels as usize,
            across_structures,
        },
    )
}

fn reply() -> impl Strategy<Value = Reply> {
    prop_oneof![
        (any::<u32>(), name(), limits()).prop_map(|(version, server, limits)| Reply::Welcome {
            version,
            server,
            limits: Box::new(limits)
        }),
        vec(any::<u64>(), 0..8).prop_map(|hashes| Reply::Missing { hashes }),
        (any::<u64>(), any::<u32>())
            .prop_map(|(hash, triangles)| Reply::MeshStored { hash, triangles }),
        any::<u64>().prop_map(|hash| Reply::ImageStored { hash }),
        (
            any::<i32>(),
            vec(any::<u64>(), 0..8),
            vec(any::<u64>(), 0..3)
        )
            .prop_map(
                |(frame, meshes_missing, images_missing)| Reply::FrameAccepted {
                    frame,
                    meshes_missing,
                    images_missing,
                }
            ),
        Just(Reply::Ack),
        (any::<u64>(), name(), any::<u32>(), any::<u32>()).prop_map(
            |(request_id, stage, done, total)| Reply::Progress {
                request_id,
                stage,
                done,
                total
            }
        ),
        (
            (any::<u64>(), any::<i32>(), any::<u32>(), any::<u32>()),
            vec(image(), 0..3),
            vec(stats_row(), 0..3),
            proptest::option::of(bytes()),
        )
            .prop_map(
                |((request_id, frame, width, height), images, stats, visible)| {
                    Reply::FrameResult(FrameResultReply {
                        request_id,
                        frame,
                        width,
                        height,
                        images,
                        stats,
                        visible,
                    })
                }
            ),
        (
            (any::<u64>(), any::<i32>()),
            vec(name(), 0..3),
            vec(compare_row(), 0..3),
            vec(mismatch(), 0..3),
            vec(image(), 0..3),
        )
            .prop_map(|((request_id, frame), methods, rows, mismatches, heat)| {
                Reply::CompareResult(CompareResultReply {
                    request_id,
                    frame,
                    methods,
                    rows,
                    mismatches,
                    heat,
                })
            }),
        (
            (any::<u32>(), any::<u64>(), any::<u64>(), any::<u64>()),
            (any::<u64>(), any::<u64>(), any::<u64>(), f64s()),
        )
            .prop_map(|((s, st, mc, bc), (rd, rc, rf, up))| {
                Reply::DaemonStats(DaemonStats {
                    sessions: s,
                    sessions_total: st,
                    meshes_cached: mc,
                    bytes_cached: bc,
                    renders_done: rd,
                    renders_cancelled: rc,
                    renders_failed: rf,
                    uptime_s: up,
                    ..DaemonStats::default()
                })
            }),
        (
            error_code(),
            name(),
            any::<bool>(),
            proptest::option::of(any::<u64>())
        )
            .prop_map(|(code, message, session_usable, request_id)| {
                Reply::Error {
                    code,
                    message,
                    session_usable,
                    request_id,
                }
            }),
    ]
}

fn round_trip<T>(msg: &T) -> T
where
    T: serde::Serialize + serde::de::DeserializeOwned,
{
    let framed = encode_message(msg).unwrap();
    let limits = Limits::default();
    // Blocking reader and incremental decoder give the same message.
    let a: T = read_message(&mut &framed[..], &limits).unwrap();
    let mut d = FrameDecoder::new(&limits);
    d.push(&framed);
    let b: T = d.next_message().unwrap().unwrap();
    assert!(d.next_message::<T>().unwrap().is_none());
    assert_eq!(
        encode_message(&a).unwrap(),
        encode_message(&b).unwrap(),
        "decoders disagree"
    );
    a
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(512))]

    #[test]
    fn every_request_round_trips(req in request()) {
        prop_assert_eq!(round_trip(&req), req);
    }

    #[test]
    fn every_reply_round_trips(reply in reply()) {
        prop_assert_eq!(round_trip(&reply), reply);
    }

    /// A stream of several messages comes back in order, however the bytes are split.
    #[test]
    fn streams_split_anywhere(reqs in vec(request(), 1..5), cuts in vec(any::<prop::sample::Index>(), 0..6)) {
        let mut stream = Vec::new();
        for r in &reqs {
            write_message(&mut stream, r).unwrap();
        }
        let mut cuts: Vec<usize> = cuts.iter().map(|c| c.index(stream.len() + 1)).collect();
        cuts.push(0);
        cuts.push(stream.len());
        cuts.sort_unstable();
        let mut d = FrameDecoder::new(&Limits::default());
        let mut out = Vec::new();
        for w in cuts.windows(2) {
            d.push(&stream[w[0]..w[1]]);
            while let Some(r) = d.next_message::<Request>().unwrap() {
                out.push(r);
            }
        }
        prop_assert!(matches!(d.finish(), FrameError::Closed));
        prop_assert_eq!(out, reqs);
    }
}

#[test]
fn wire_shape_is_named_maps_externally_tagged() {
    // What a Python client (msgpack) sees: {"Hello": {"version": 1, "client": "blender"}}.
    let body = encode_body(&Request::Hello {
        version: 1,
        client: "blender".into(),
        token: None,
    })
    .unwrap();
    let mut expected = vec![0x81, 0xa5];
    expected.extend_from_slice(b"Hello");
    expected.extend_from_slice(&[0x82, 0xa7]);
    expected.extend_from_slice(b"version");
    expected.push(0x01);
    expected.push(0xa6);
    expected.extend_from_slice(b"client");
    expected.push(0xa7);
    expected.extend_from_slice(b"blender");
    assert_eq!(body, expected);
    // Unit variants are bare strings.
    assert_eq!(encode_body(&Request::Stats).unwrap(), b"\xa5Stats");
    // Bulk data is bin (0xc4 = bin8), not an array of numbers.
    let body = encode_body(&Image {
        name: "c".into(),
        width: 1,
        height: 1,
        data: ByteBuf::from(1.0f32.to_le_bytes().to_vec()),
    })
    .unwrap();
    let tail = [&[0xa4][..], b"data", &[0xc4, 4], &1.0f32.to_le_bytes()].concat();
    assert!(body.ends_with(&tail), "{body:x?}");
}

#[test]
fn field_order_unknown_fields_and_defaults() {
    // A hand-written Render body: fields in another order, an unknown field, no settings or
    // passes (defaults), and an integer where a float is expected elsewhere.
    let mut body = vec![0x81, 0xa6];
    body.extend_from_slice(b"Render");
    body.push(0x83);
    body.push(0xaa);
    body.extend_from_slice(b"request_id");
    body.push(0x07);
    body.push(0xa6);
    body.extend_from_slice(b"future");
    body.push(0xc3);
    body.push(0xa5);
    body.extend_from_slice(b"frame");
    body.push(0x05);
    let r: Request = decode_body(&body).unwrap();
    assert_eq!(
        r,
        Request::Render(RenderRequest {
            frame: 5,
            settings: NamedSettings::default(),
            passes: Passes::default(),
            request_id: 7,
            warm_up: false,
        })
    );
    assert_eq!(
        render_settings(&NamedSettings::default()).unwrap(),
        Default::default()
    );

    // Partial nested defaults, and integers where floats are expected (as Python may send).
    let body = b"\x81\xa6Render\x84\xa5frame\x01\xaarequest_id\x02\xa8settings\x81\xa3spp\x10\xa6passes\x81\xabvisible_set\xc3";
    let Request::Render(r) = decode_body::<Request>(body).unwrap() else {
        panic!()
    };
    assert_eq!(r.settings.get("spp"), Some(&SettingValue::Int(16)));
    let resolved = render_settings(&r.settings).unwrap();
    assert_eq!(
        resolved,
        antumbra_core::render::RenderSettings {
            spp: 16,
            ..Default::default()
        },
        "every setting left out takes the core default"
    );
    // A wrong type decodes (the map holds any value) and is named when resolved.
    let body = b"\x81\xa6Render\x83\xa5frame\x01\xaarequest_id\x02\xa8settings\x81\xa3spp\xc3";
    let Request::Render(wrong) = decode_body::<Request>(body).unwrap() else {
        panic!()
    };
    let e = render_settings(&wrong.settings).unwrap_err().to_string();
    assert!(
        e.contains("spp") && e.contains("integer") && e.contains("boolean"),
        "{e}"
    );
    assert!(r.passes.visible_set && r.passes.masks && r.passes.heat_maps);
    // A field added later (the object-id pass) takes its default when an older peer omits it.
    assert!(!r.passes.object_ids);
    let kind: LightKindState = decode_body(b"\x82\xa4type\xa3Sun\xa5angle\x00").unwrap();
    assert_eq!(kind, LightKindState::Sun { angle: 0.0 });
    let res: ResolutionState = decode_body(
        b"\x85\xa1x\x02\xa1y\x03\xaapercentage\x64\xaepixel_aspect_x\x01\xaepixel_aspect_y\xca\x3f\x80\x00\x00",
    )
    .unwrap();
    assert_eq!((res.pixel_aspect_x, res.pixel_aspect_y), (1.0, 1.0));
    // An Error without request_id (an older peer) reads as None.
    let e: Reply =
        decode_body(b"\x81\xa5Error\x83\xa4code\xa4Busy\xa7message\xa0\xaesession_usable\xc3")
            .unwrap();
    assert!(matches!(
        e,
        Reply::Error {
            request_id: None,
            code: ErrorCode::Busy,
            ..
        }
    ));
}

#[test]
fn nan_and_infinity_survive_bit_exact() {
    let mut m = [1.0; 16];
    m[3] = f64::NAN;
    m[7] = f64::NEG_INFINITY;
    let obj = ObjectState {
        name: "o".into(),
        mesh_hash: 1,
        world_from_object: m,
        visible_to_camera: true,
        casts_shadow: false,
        materials: vec![None, Some(3)],
    };
    let back = round_trip(&obj);
    assert_eq!(
        back.world_from_object.map(f64::to_bits),
        m.map(f64::to_bits)
    );
}
