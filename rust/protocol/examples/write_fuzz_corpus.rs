//! Writes the seed corpus of the `decode_frame` fuzz target: a few valid framed request streams.
//!
//! `cargo run -p antumbra-protocol --example write_fuzz_corpus` (from the workspace root); the
//! files go to `rust/protocol/fuzz/corpus/decode_frame/`.

use std::path::Path;

use antumbra_core::scene::{Camera, Light, LightKind, Mesh, Object, Resolution, Scene};
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
    }
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("fuzz/corpus/decode_frame");
    std::fs::create_dir_all(&dir)?;
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
    });
    let mut camera_path = Vec::new();
    if let Request::FrameUpdate(u) = &frame {
        camera_path = vec![(1, u.camera.clone()), (2, u.camera.clone())];
    }
    let mut session = vec![
        hello.clone(),
        Request::MissingMeshes {
            hashes: vec![1, u64::MAX],
        },
    ];
    session.extend(uploads.iter().cloned());
    session.extend([
        frame.clone(),
        Request::CameraPath {
            frames: camera_path,
        },
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
    println!("wrote the seed corpus to {}", dir.display());
    Ok(())
}
