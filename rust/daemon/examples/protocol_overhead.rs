//! Protocol overhead beside render time: a 1M-triangle mesh upload and a 1920x1080 result of
//! four images, each encoded, sent through a Unix socket pair, decoded and validated as the
//! daemon and the client do; and the same for the default demo scene's meshes and frame result
//! beside that frame's render time.
//!
//! `cargo run --release -p antumbra-daemon --example protocol_overhead`

use std::io::BufReader;
use std::os::unix::net::UnixStream;
use std::time::Instant;

use antumbra_core::image::ImagePlane;
use antumbra_core::render::{RenderSettings, Renderer};
use antumbra_core::scene::Mesh;
use antumbra_protocol::bytes::f32s_to_bytes;
use antumbra_protocol::{
    frame_result_reply, mesh_from_upload, planes_from_reply, read_message, upload_from_mesh,
    write_message, FrameResultReply, Image, Limits, Passes, Reply, Request,
};
use glam::Vec3;

/// Sends `message` through a socket pair and decodes it on the other side; returns the decoded
/// message and the milliseconds from encoding to decoded.
fn round_trip<T>(message: &T) -> (T, f64)
where
    T: serde::Serialize + serde::de::DeserializeOwned + Send + 'static,
{
    let (mut a, b) = UnixStream::pair().expect("socket pair");
    let start = Instant::now();
    let reader = std::thread::spawn(move || {
        let mut r = BufReader::with_capacity(1 << 20, b);
        read_message::<_, T>(&mut r, &Limits::default()).expect("decode")
    });
    write_message(&mut a, message).expect("encode and send");
    let decoded = reader.join().expect("reader thread");
    (decoded, start.elapsed().as_secs_f64() * 1e3)
}

fn grid_mesh(quads_per_side: u32) -> Mesh {
    let n = quads_per_side;
    let mut positions = Vec::new();
    for j in 0..=n {
        for i in 0..=n {
            positions.push(Vec3::new(
                i as f32,
                j as f32,
                ((i * 7 + j * 3) % 11) as f32 * 0.01,
            ));
        }
    }
    let mut triangles = Vec::new();
    for j in 0..n {
        for i in 0..n {
            let v = j * (n + 1) + i;
            triangles.push([v, v + 1, v + n + 2]);
            triangles.push([v, v + n + 2, v + n + 1]);
        }
    }
    Mesh::new("grid", positions, triangles)
}

fn upload_ms(mesh: &Mesh) -> f64 {
    let start = Instant::now();
    let upload = upload_from_mesh(mesh);
    let (decoded, _) = round_trip(&Request::UploadMesh(upload));
    let Request::UploadMesh(u) = decoded else {
        panic!("not an upload")
    };
    let stored = mesh_from_upload(&u, &Limits::default()).expect("valid mesh");
    assert_eq!(stored.triangles.len(), mesh.triangles.len());
    start.elapsed().as_secs_f64() * 1e3
}

fn result_ms(reply: FrameResultReply) -> f64 {
    let start = Instant::now();
    let (decoded, _) = round_trip(&Reply::FrameResult(reply));
    let Reply::FrameResult(r) = decoded else {
        panic!("not a result")
    };
    let planes: Vec<ImagePlane> = planes_from_reply(&r).expect("planes");
    assert!(!planes.is_empty());
    start.elapsed().as_secs_f64() * 1e3
}

fn main() {
    let mesh = grid_mesh(708);
    println!("1M-triangle mesh ({} triangles): upload {:.1} ms (hash + encode + socket + decode + validate + hash check)",
        mesh.triangles.len(), upload_ms(&mesh));

    let (w, h) = (1920u32, 1080u32);
    let data = vec![0.5f32; (w * h) as usize];
    let images = (0..4)
        .map(|i| Image {
            name: format!("image{i}"),
            width: w,
            height: h,
            data: f32s_to_bytes(&data),
        })
        .collect();
    let reply = FrameResultReply {
        request_id: 1,
        frame: 1,
        width: w,
        height: h,
        images,
        stats: Vec::new(),
        visible: None,
    };
    println!(
        "1920x1080 result with 4 images: {:.1} ms (encode + socket + decode + to planes)",
        result_ms(reply)
    );

    // The default demo scene (antumbra demo): bedroom, 100k triangles, its 640x360 camera.
    let anim = antumbra_scenes::builtin("bedroom", &antumbra_scenes::SceneParams::default())
        .expect("built-in scene");
    let scene = anim.frame(1);
    let start = Instant::now();
    let result = Renderer::new()
        .render("bedroom", &scene, &RenderSettings::default())
        .expect("render");
    let render_ms = start.elapsed().as_secs_f64() * 1e3;
    let uploads: f64 = scene.meshes.iter().map(|m| upload_ms(m)).sum();
    let passes = Passes {
        masks: true,
        combined: true,
        heat_maps: true,
        visible_set: true,
        object_ids: true,
    };
    let result_ms = result_ms(frame_result_reply(&result, 1, &passes));
    println!(
        "demo scene frame 1: render {render_ms:.1} ms; all mesh uploads {uploads:.1} ms ({:.1}% of the render, once per animation); \
         result with every pass ({} images) {result_ms:.1} ms ({:.1}% of the render, every frame)",
        100.0 * uploads / render_ms,
        result.masks.len() + 7,
        100.0 * result_ms / render_ms
    );
}
