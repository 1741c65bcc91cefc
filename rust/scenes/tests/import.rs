//! OBJ and glTF/GLB import: triangle counts, transforms, static frames, error messages.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use antumbra_core::Error;
use antumbra_scenes::load_file;
use glam::DVec3;
use tempfile::TempDir;

/// Writes `bytes` to `name` in `dir`; returns the file's path.
fn write(dir: &TempDir, name: &str, bytes: &[u8]) -> PathBuf {
    let path = dir.path().join(name);
    std::fs::write(&path, bytes).unwrap();
    path
}

const CUBE_AND_TRIANGLE_OBJ: &str = "\
# a unit cube of quads and a lone triangle
o cube
v 0 0 0
v 1 0 0
v 1 1 0
v 0 1 0
v 0 0 1
v 1 0 1
v 1 1 1
v 0 1 1
f 1 4 3 2
f 5 6 7 8
f 1 2 6 5
f 2 3 7 6
f 3 4 8 7
f 4 1 5 8
o triangle
v 3 0 0
v 4 0 0
v 3 1 0
f 9 10 11
";

#[test]
fn obj_loads_as_a_static_scene() {
    let dir = TempDir::new().unwrap();
    let path = write(&dir, "things.obj", CUBE_AND_TRIANGLE_OBJ.as_bytes());
    let anim = load_file(&path, 5).unwrap();
    assert_eq!(anim.name(), "things");
    assert_eq!(anim.frame_range(), 1..=5);
    let (a, b) = (anim.frame(1), anim.frame(4));
    assert_eq!(b.frame, 4);
    assert_eq!(a.triangle_count(), 13);
    assert_eq!(a.objects.len(), 2);
    assert!(a
        .meshes
        .iter()
        .zip(&b.meshes)
        .all(|(x, y)| Arc::ptr_eq(x, y)));
    a.validate().unwrap();
    assert!(!a.lights.is_empty());
    // Y-up file: the cube's top (file y = 1) is at world z = 1.
    let top = a.objects[0]
        .world_from_object
        .transform_point3(DVec3::new(0.0, 1.0, 0.0));
    assert!((top - DVec3::Z).length() < 1e-12, "{top}");
    // The camera looks at the geometry and keeps it between its clip planes.
    let cam = &a.camera;
    let forward = -cam.world_from_camera.z_axis.truncate().normalize();
    let centre = DVec3::new(2.0, -0.5, 0.5);
    let to_centre = centre - cam.position();
    assert!(forward.dot(to_centre.normalize()) > 0.95);
    let depth = forward.dot(to_centre);
    assert!(cam.clip_start < depth - 2.5 && cam.clip_end > depth + 2.5);
    // The last frame is the snapshot itself, numbered as asked.
    let last = anim.into_frame(5);
    assert_eq!(last.frame, 5);
    assert_eq!((last.objects, last.camera), (b.objects, b.camera));
    assert!(last
        .meshes
        .iter()
        .zip(&b.meshes)
        .all(|(x, y)| Arc::ptr_eq(x, y)));
}

fn base64(bytes: &[u8]) -> String {
    use base64::Engine;
    base64::engine::general_purpose::STANDARD.encode(bytes)
}

/// A unit quad (4 vertices, 6 u16 indices) as one buffer: positions then indices.
fn quad_buffer() -> Vec<u8> {
    let mut bytes = Vec::new();
    for p in [
        [0.0f32, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [1.0, 0.0, 1.0],
        [0.0, 0.0, 1.0],
    ] {
        for c in p {
            bytes.extend_from_slice(&c.to_le_bytes());
        }
    }
    for i in [0u16, 2, 1, 0, 3, 2] {
        bytes.extend_from_slice(&i.to_le_bytes());
    }
    bytes
}

/// Two nodes share the quad mesh: the root moved by (2, 0, 0), its child by (0, 5, 0) more.
fn gltf_json(buffer_uri: Option<&str>, length: usize) -> String {
    let uri = buffer_uri
        .map(|u| format!(r#""uri": "{u}", "#))
        .unwrap_or_default();
    format!(
        r#"{{
  "asset": {{"version": "2.0"}},
  "scene": 0,
  "scenes": [{{"nodes": [0]}}],
  "nodes": [
    {{"name": "root", "mesh": 0, "translation": [2, 0, 0], "children": [1]}},
    {{"name": "child", "mesh": 0, "translation": [0, 5, 0]}}
  ],
  "meshes": [{{"name": "quad", "primitives": [{{"attributes": {{"POSITION": 0}}, "indices": 1}}]}}],
  "buffers": [{{{uri}"byteLength": {length}}}],
  "bufferViews": [
    {{"buffer": 0, "byteOffset": 0, "byteLength": 48}},
    {{"buffer": 0, "byteOffset": 48, "byteLength": 12}}
  ],
  "accessors": [
    {{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [0, 0, 0], "max": [1, 0, 1]}},
    {{"bufferView": 1, "componentType": 5123, "count": 6, "type": "SCALAR"}}
  ]
}}"#
    )
}

fn check_two_quads(path: &Path) {
    let anim = load_file(path, 3).unwrap_or_else(|e| panic!("{e}"));
    let scene = anim.frame(2);
    scene.validate().unwrap();
    assert_eq!(scene.triangle_count(), 4);
    assert_eq!(scene.objects.len(), 2);
    assert!(scene.meshes[0].normals.is_empty(), "no NORMAL, no normals");
    // One mesh, instanced by both nodes.
    assert_eq!(scene.meshes.len(), 1);
    let child = scene.objects.iter().find(|o| o.name == "child").unwrap();
    // glTF (2, 5, 0) is Blender's (2, 0, 5): Y up becomes Z up.
    let origin = child.world_from_object.transform_point3(DVec3::ZERO);
    assert!(
        (origin - DVec3::new(2.0, 0.0, 5.0)).length() < 1e-9,
        "{origin}"
    );
}

#[test]
fn gltf_with_embedded_buffer_applies_node_transforms() {
    let dir = TempDir::new().unwrap();
    let buffer = quad_buffer();
    let uri = format!("data:application/octet-stream;base64,{}", base64(&buffer));
    let path = write(
        &dir,
        "quads.gltf",
        gltf_json(Some(&uri), buffer.len()).as_bytes(),
    );
    check_two_quads(&path);
}

#[test]
fn gltf_normals_become_corner_normals() {
    let dir = TempDir::new().unwrap();
    let mut buffer = quad_buffer();
    let normals = [
        [0.0f32, -1.0, 0.0],
        [0.6, -0.8, 0.0],
        [0.0, -0.8, 0.6],
        [0.0, -1.0, 0.0],
    ];
    for c in normals.iter().flatten() {
        buffer.extend_from_slice(&c.to_le_bytes());
    }
    let uri = format!("data:application/octet-stream;base64,{}", base64(&buffer));
    let json = gltf_json(Some(&uri), buffer.len())
        .replace(r#"{"POSITION": 0}"#, r#"{"POSITION": 0, "NORMAL": 2}"#)
        .replace(
            r#"{"buffer": 0, "byteOffset": 48, "byteLength": 12}"#,
            r#"{"buffer": 0, "byteOffset": 48, "byteLength": 12},
    {"buffer": 0, "byteOffset": 60, "byteLength": 48}"#,
        )
        .replace(
            r#"{"bufferView": 1, "componentType": 5123, "count": 6, "type": "SCALAR"}"#,
            r#"{"bufferView": 1, "componentType": 5123, "count": 6, "type": "SCALAR"},
    {"bufferView": 2, "componentType": 5126, "count": 4, "type": "VEC3"}"#,
        );
    let path = write(&dir, "normals.gltf", json.as_bytes());
    let scene = load_file(&path, 1).unwrap().frame(1);
    let mesh = &scene.meshes[0];
    let n = normals.map(glam::Vec3::from_array);
    // Indices 0 2 1, 0 3 2: each corner takes its vertex's normal.
    assert_eq!(mesh.normals, vec![[n[0], n[2], n[1]], [n[0], n[3], n[2]]]);
}

#[test]
fn gltf_with_external_buffer_and_glb() {
    let dir = TempDir::new().unwrap();
    let buffer = quad_buffer();
    write(&dir, "quads.bin", &buffer);
    let path = write(
        &dir,
        "quads.gltf",
        gltf_json(Some("quads.bin"), buffer.len()).as_bytes(),
    );
    check_two_quads(&path);

    let glb = antumbra_scenes::fuzzing::glb(&gltf_json(None, buffer.len()), &buffer);
    let path = write(&dir, "quads.glb", &glb);
    check_two_quads(&path);
}

fn message(err: &Error) -> String {
    err.to_string()
}

#[test]
fn missing_garbage_and_unsupported_files_are_errors_naming_the_file() {
    let dir = TempDir::new().unwrap();
    let missing = dir.path().join("nowhere.obj");
    let err = load_file(&missing, 1).err().expect("missing file");
    assert!(matches!(err, Error::Io { .. }), "{err:?}");
    assert!(message(&err).contains("nowhere.obj"));

    for (name, bytes) in [
        (
            "garbage.obj",
            &b"\x00\x9f\x92\x96 this is not an obj file\nf 1 2 3\n"[..],
        ),
        ("words.obj", &b"hello world\nnothing here\n"[..]),
        ("garbage.gltf", &b"{ not json"[..]),
        ("garbage.glb", &b"glTF\x02\x00\x00\x00junk"[..]),
        ("notes.txt", &b"v 0 0 0"[..]),
    ] {
        let path = write(&dir, name, bytes);
        let err = load_file(&path, 1)
            .err()
            .unwrap_or_else(|| panic!("{name} loaded"));
        assert!(
            matches!(err, Error::Io { .. } | Error::Invalid { .. }),
            "{name}: {err:?}"
        );
        assert!(message(&err).contains(name), "{name}: {err}");
    }

    let path = write(&dir, "ok.obj", CUBE_AND_TRIANGLE_OBJ.as_bytes());
    assert!(load_file(&path, 0).is_err());
}

#[test]
fn gltf_index_out_of_range_is_an_error() {
    let dir = TempDir::new().unwrap();
    let mut buffer = quad_buffer();
    // Last index 2 -> 9: past the 4 vertices.
    let n = buffer.len();
    buffer[n - 2..].copy_from_slice(&9u16.to_le_bytes());
    let uri = format!("data:application/octet-stream;base64,{}", base64(&buffer));
    let path = write(
        &dir,
        "bad.gltf",
        gltf_json(Some(&uri), buffer.len()).as_bytes(),
    );
    let err = load_file(&path, 1).err().expect("bad index");
    assert!(
        message(&err).contains("bad.gltf") && message(&err).contains("out of range"),
        "{err}"
    );
}
