//! Writes the seed corpora of the fuzz targets from real valid inputs: framed request streams
//! (`decode_frame`), recordings of a tiny scene (`recording`), settings maps and flags
//! (`settings`, with its dictionary `settings.dict`).
//!
//! `cargo run -p antumbra-protocol --example write_fuzz_corpus` (from the workspace root); the
//! files go to `rust/protocol/fuzz/corpus/<target>/`.

use std::path::Path;

use antumbra_core::alpha::{AlphaImage, AlphaOp, AlphaProgram, Extension, Interpolation};
use antumbra_core::render::RenderSettings;
use antumbra_core::scene::{
    AlphaMaterial, Camera, Light, LightKind, Mesh, Object, Resolution, Scene, SceneAlpha, UvMap,
};
use antumbra_core::settings::{Kind, SCHEMA};
use antumbra_protocol::*;
use glam::{DMat4, DVec3, Vec3};
use std::sync::Arc;

fn scene() -> Scene {
    let tri = Mesh::new("tri", vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]]);
    Scene {
        frame: 1,
        meshes: vec![Arc::new(tri)],
        objects: vec![Object::new("tri", 0, DMat4::IDENTITY)],
        camera: Camera::look_at(DVec3::new(0.0, 0.0, 5.0), DVec3::ZERO, DVec3::Y),
        lights: vec![Light::new(
            "lamp",
            DMat4::IDENTITY,
            LightKind::Area {
                shape: antumbra_core::scene::AreaShape::Disk,
                size_x: 1.0,
                size_y: 1.0,
            },
        )],
        resolution: Resolution::new(4, 3),
        alpha: Default::default(),
    }
}

/// The tiny scene with alpha (issue 38): a two-triangle card whose slot 1 reads a 2x2 image
/// through UV map "Leaves", slot 0 a constant; its triangles have slots and corner UVs.
fn alpha_scene(frame: i32) -> Scene {
    let mut s = scene_at(frame);
    let card = Mesh::new(
        "card",
        vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::new(1.0, 1.0, 0.0)],
        vec![[0, 1, 2], [1, 3, 2]],
    )
    .with_alpha(
        vec![0, 1],
        vec![UvMap {
            name: "Leaves".into(),
            corners: vec![
                [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]],
                [[1.0, 0.0], [1.0, 1.0], [0.0, 1.0]],
            ],
        }],
    );
    s.meshes.push(Arc::new(card));
    let mut object = Object::new("card", 1, DMat4::IDENTITY);
    object.materials = vec![Some(0), Some(1)];
    s.objects.push(object);
    let mut leaf = AlphaProgram::image(0, 0, Interpolation::Linear, Extension::Clip);
    leaf.ops = vec![AlphaOp::Multiply(2.0), AlphaOp::OneMinus, AlphaOp::Clamp];
    s.alpha = SceneAlpha {
        images: vec![Arc::new(AlphaImage {
            width: 2,
            height: 2,
            texels: vec![0.0, 0.25, 0.5, 1.0],
        })],
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

type Res = Result<(), Box<dyn std::error::Error>>;

fn main() -> Res {
    let fuzz = Path::new(env!("CARGO_MANIFEST_DIR")).join("fuzz");
    decode_frame(&fuzz.join("corpus/decode_frame"))?;
    recording(&fuzz.join("corpus/recording"))?;
    settings(&fuzz)?;
    println!(
        "wrote the seed corpora to {}",
        fuzz.join("corpus").display()
    );
    Ok(())
}

/// The tiny scene at `frame`, its object moved a little each frame (the mesh stays the same).
fn scene_at(frame: i32) -> Scene {
    let mut s = scene();
    s.frame = frame;
    s.objects[0].world_from_object =
        DMat4::from_translation(DVec3::new(0.1 * f64::from(frame), 0.0, 0.0));
    s
}

/// What `antumbra record` writes (scenes only) and what `antumbra serve --record` writes (a
/// whole session: hello, uploads, frames, renders).
fn recording(dir: &Path) -> Res {
    std::fs::create_dir_all(dir)?;
    let mut w = RecordingWriter::new(Vec::new())?;
    for frame in 1..=2 {
        w.append_scene(&scene_at(frame))?;
    }
    std::fs::write(dir.join("record.antrec"), w.finish()?)?;

    let mut w = RecordingWriter::new(Vec::new())?;
    w.append(&Request::Hello {
        version: PROTOCOL_VERSION,
        client: "blender 4.2".into(),
        token: None,
    })?;
    for frame in [3, 5] {
        w.append_scene(&scene_at(frame))?;
        w.append(&Request::Render(RenderRequest {
            frame,
            settings: NamedSettings::new().with("spp", 4i64),
            passes: Passes::default(),
            request_id: frame as u64,
            warm_up: false,
        }))?;
    }
    // Instances: an array of the mesh, then the same array again, sent as unchanged.
    let ring = |frame: i32, unchanged: bool| -> Result<Request, ProtocolError> {
        let mut update = frame_update_from_scene(&scene_at(frame))?;
        let rows: Vec<[f32; 12]> = (0..3)
            .map(|i| {
                [
                    1.0, 0.0, 0.0, i as f32, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0,
                ]
            })
            .collect();
        update.instances.push(InstanceArrayState {
            name: "ring".into(),
            mesh_hash: update.objects[0].mesh_hash,
            matrices: instances::matrices_to_bytes(if unchanged { &[] } else { &rows }),
            ids: Default::default(),
            visible_to_camera: true,
            casts_shadow: true,
            unchanged,
            materials: Vec::new(),
        });
        Ok(Request::FrameUpdate(update))
    };
    w.append(&ring(7, false)?)?;
    w.append(&ring(8, true)?)?;
    // Alpha: a mesh with slots and UVs, an image, materials, an object's slots.
    w.append_scene(&alpha_scene(9))?;
    w.append(&Request::Close)?;
    std::fs::write(dir.join("session.antrec"), w.finish()?)?;
    Ok(())
}

/// Settings maps as a spool job (JSON) and the wire (MessagePack) carry them, command-line flags,
/// and bare values of the text settings.
fn settings(fuzz: &Path) -> Res {
    let dir = fuzz.join("corpus/settings");
    std::fs::create_dir_all(&dir)?;
    let maps = [
        ("defaults", RenderSettings::default().to_named()),
        (
            "osah",
            NamedSettings::new()
                .with("spp", 8i64)
                .with("build", "osah")
                .with("osah_w", 0.5)
                .with("spatial_splits", false)
                .with("visibility", "prepass:64x48"),
        ),
        (
            "srdh",
            NamedSettings::new().with("build", "srdh").with(
                "order",
                "srdh:rays=16x16:bins=32:leaf=1:kernels=all:min_occluded=0.2",
            ),
        ),
        (
            "sorted",
            NamedSettings::new()
                .with("order", "sorted:logging=fbto:p=area:depth=4:budget=0.01")
                .with("width", 8i64)
                .with("collapse", "greedy")
                .with("leaf_size", 4i64)
                .with("min_leaf_size", 2i64),
        ),
    ];
    for (name, map) in &maps {
        std::fs::write(dir.join(format!("{name}.json")), serde_json::to_vec(map)?)?;
        std::fs::write(dir.join(format!("{name}.msgpack")), encode_body(map)?)?;
    }
    std::fs::write(
        dir.join("flags.txt"),
        "--spp 8\n--build sbvh\n--order sorted:depth=4:budget=5%\n--visibility exact\n\
         --width 4\n--spatial-splits false\n--split-alpha 0.1\n--timing on\n",
    )?;
    std::fs::write(
        dir.join("values.txt"),
        "srdh:rays=all:bins=8:kernels=constant\nsrdh:rays=0.05:leaf=4\nrandom:seed=7\n\
         near\nprepass:16x16\n16x16\nsbvh\ngreedy\nobject\n8\n",
    )?;
    // libFuzzer's dictionary: the settings' names, every choice's words (from the schema) and
    // the order grammar's words.
    let mut words: Vec<String> = SCHEMA.iter().map(|s| s.name.to_string()).collect();
    words.extend(
        SCHEMA
            .iter()
            .map(|s| format!("--{}", s.name.replace('_', "-"))),
    );
    for spec in SCHEMA {
        if let Kind::Choice(choices) = spec.kind {
            words.extend(choices.iter().map(|w| w.to_string()));
        }
    }
    words.extend(
        [
            "auto",
            "stored",
            "fbto",
            "near",
            "sato",
            "rtsah",
            "random",
            "sorted",
            "srdh",
            ":seed=",
            ":logging=",
            ":p=",
            "area",
            ":depth=",
            ":budget=",
            ":rays=",
            "all",
            ":bins=",
            ":leaf=",
            ":kernels=",
            "constant",
            "directional",
            ":min_occluded=",
            "prepass:",
            "previous",
            "exact",
            "x",
            "%",
            "0",
            "-1",
            "4294967296",
            "NaN",
            "inf",
            "1e39",
        ]
        .map(String::from),
    );
    let mut seen = std::collections::HashSet::new();
    words.retain(|w| seen.insert(w.clone()));
    let dict: String = words.iter().map(|w| format!("{:?}\n", w)).collect();
    std::fs::write(fuzz.join("settings.dict"), dict)?;
    Ok(())
}

fn decode_frame(dir: &Path) -> Res {
    std::fs::create_dir_all(dir)?;
    let hello = Request::Hello {
        version: PROTOCOL_VERSION,
        client: "blender 4.2".into(),
        token: None,
    };
    let (uploads, frame) = scene_to_messages(&scene())?;
    let render = Request::Render(RenderRequest {
        frame: 1,
        settings: NamedSettings::new()
            .with("spp", 8i64)
            .with("build", "osah")
            .with("osah_w", 0.5)
            .with("spatial_splits", false),
        passes: Passes::default(),
        request_id: 7,
        warm_up: false,
    });
    let (alpha_uploads, alpha_frame) = scene_to_messages(&alpha_scene(2))?;
    let mut session = vec![
        hello.clone(),
        Request::MissingMeshes {
            hashes: vec![1, u64::MAX],
        },
        Request::MissingImages {
            hashes: vec![2, u64::MAX],
        },
    ];
    session.extend(uploads.iter().cloned());
    session.extend(alpha_uploads.iter().cloned());
    session.push(alpha_frame.clone());
    session.extend([
        frame.clone(),
        render.clone(),
        Request::Cancel { request_id: 7 },
        Request::Stats,
        Request::Close,
        Request::Shutdown,
    ]);
    let seeds: Vec<(&str, Vec<Request>)> = vec![
        ("hello", vec![hello]),
        ("upload_mesh", uploads),
        ("frame_update", vec![frame]),
        ("alpha", {
            let mut alpha = alpha_uploads;
            alpha.push(alpha_frame);
            alpha
        }),
        ("render", vec![render]),
        ("session", session),
    ];
    for (name, requests) in seeds {
        let mut bytes = Vec::new();
        for r in &requests {
            write_message(&mut bytes, r)?;
        }
        std::fs::write(dir.join(format!("{name}.bin")), bytes)?;
    }
    Ok(())
}
