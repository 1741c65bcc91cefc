//! Files made to break the importers (issue 33): accessors of the wrong type or past their
//! buffers, special files, buffer URIs outside the file's folder, counts over the limits. Each
//! is refused with an error naming the file and what is wrong, never a panic, hang or abort.

use std::path::{Path, PathBuf};
use std::sync::mpsc;
use std::time::Duration;

use antumbra_core::Error;
use antumbra_scenes::load_file;
use base64::Engine;
use tempfile::TempDir;

fn write(dir: &Path, name: &str, bytes: &[u8]) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, bytes).unwrap();
    path
}

/// `load_file`'s error message, in a thread with a deadline: a hang (a FIFO opened for reading
/// waits for a writer) fails the test instead of stopping the suite.
fn refusal(path: &Path) -> String {
    let (send, receive) = mpsc::channel();
    let owned = path.to_owned();
    std::thread::spawn(move || {
        let _ = send.send(load_file(&owned, 1).map(|a| a.name().to_owned()));
    });
    match receive.recv_timeout(Duration::from_secs(20)) {
        Ok(Ok(name)) => panic!("{}: loaded as scene '{name}'", path.display()),
        Ok(Err(e)) => {
            let message = e.to_string();
            let name = path.file_name().unwrap().to_string_lossy();
            assert!(message.contains(&*name), "names no file: {message}");
            assert!(
                matches!(e, Error::Invalid { .. } | Error::Io { .. }),
                "{e:?}"
            );
            message
        }
        Err(mpsc::RecvTimeoutError::Disconnected) => {
            panic!("{}: load_file panicked", path.display())
        }
        Err(mpsc::RecvTimeoutError::Timeout) => {
            panic!("{}: load_file did not return in 20 s", path.display())
        }
    }
}

/// Four vertices of a unit quad (48 bytes of f32) then `indices` as given.
fn buffer(indices: &[u8]) -> Vec<u8> {
    let mut bytes = Vec::new();
    for c in [0.0f32, 0., 0., 1., 0., 0., 1., 0., 1., 0., 0., 1.] {
        bytes.extend_from_slice(&c.to_le_bytes());
    }
    bytes.extend_from_slice(indices);
    bytes
}

/// A glTF of one mesh: POSITION is accessor 0 over view 0 (the first 48 bytes), the indices
/// accessor 1 over view 1 (the rest); `index_accessor` is accessor 1's JSON fields.
fn gltf(uri: &str, length: usize, position_accessor: &str, index_accessor: &str) -> String {
    format!(
        r#"{{
  "asset": {{"version": "2.0"}},
  "scenes": [{{"nodes": [0]}}],
  "nodes": [{{"mesh": 0}}],
  "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0}}, "indices": 1}}]}}],
  "buffers": [{{"uri": "{uri}", "byteLength": {length}}}],
  "bufferViews": [
    {{"buffer": 0, "byteOffset": 0, "byteLength": 48}},
    {{"buffer": 0, "byteOffset": 48, "byteLength": {rest}}}
  ],
  "accessors": [{{{position_accessor}}}, {{{index_accessor}}}]
}}"#,
        rest = length.saturating_sub(48)
    )
}

/// Accessor 0: glTF requires POSITION's bounds.
const POSITIONS: &str = r#""bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [0, 0, 0], "max": [1, 0, 1]"#;

fn embedded(bytes: &[u8]) -> String {
    let data = base64::engine::general_purpose::STANDARD.encode(bytes);
    format!("data:application/octet-stream;base64,{data}")
}

#[test]
fn a_valid_indexed_quad_loads() {
    let dir = TempDir::new().unwrap();
    let bytes = buffer(&[0, 2, 1, 0, 3, 2]);
    let index = r#""bufferView": 1, "componentType": 5121, "count": 6, "type": "SCALAR""#;
    let json = gltf(&embedded(&bytes), bytes.len(), POSITIONS, index);
    let path = write(dir.path(), "quad.gltf", json.as_bytes());
    let scene = load_file(&path, 1).unwrap().frame(1);
    assert_eq!(scene.triangle_count(), 2);
}

#[test]
fn index_accessors_of_float_byte_or_short_are_refused() {
    let dir = TempDir::new().unwrap();
    // Six indices of each type: FLOAT as 4 bytes, BYTE 1, SHORT 2.
    for (component, name, size) in [(5126, "FLOAT", 4), (5120, "BYTE", 1), (5122, "SHORT", 2)] {
        let bytes = buffer(&vec![0; 6 * size]);
        let index = format!(
            r#""bufferView": 1, "componentType": {component}, "count": 6, "type": "SCALAR""#
        );
        let json = gltf(&embedded(&bytes), bytes.len(), POSITIONS, &index);
        let path = write(dir.path(), &format!("{name}.gltf"), json.as_bytes());
        let message = refusal(&path);
        assert!(
            message.contains("accessor 1") && message.contains("componentType"),
            "{name}: {message}"
        );
    }
}

#[test]
fn accessors_past_their_view_or_buffer_are_refused() {
    let dir = TempDir::new().unwrap();
    let bytes = buffer(&[0, 2, 1, 0, 3, 2]);
    let index = r#""bufferView": 1, "componentType": 5121, "count": 6, "type": "SCALAR""#;
    let cases = [
        // Five vertices in a view of four.
        (
            "count.gltf",
            POSITIONS.replace(r#""count": 4"#, r#""count": 5"#),
            index.to_owned(),
        ),
        // An offset that puts the last index past the view.
        (
            "offset.gltf",
            POSITIONS.to_owned(),
            index.replace(r#""count": 6"#, r#""count": 6, "byteOffset": 3"#),
        ),
        // An offset not a multiple of the component size.
        (
            "align.gltf",
            POSITIONS.replace(r#""count": 4"#, r#""count": 3, "byteOffset": 2"#),
            index.to_owned(),
        ),
    ];
    for (name, positions, indices) in cases {
        let json = gltf(&embedded(&bytes), bytes.len(), &positions, &indices);
        let path = write(dir.path(), name, json.as_bytes());
        let message = refusal(&path);
        assert!(message.contains("accessor "), "{name}: {message}");
    }
    // A view that runs past the buffer's bytes (its byteLength says 54, the data holds 54, the
    // view asks for 60).
    let json = gltf(&embedded(&bytes), bytes.len(), POSITIONS, index).replace(
        r#""byteOffset": 48, "byteLength": 6"#,
        r#""byteOffset": 48, "byteLength": 12"#,
    );
    let path = write(dir.path(), "view.gltf", json.as_bytes());
    let message = refusal(&path);
    assert!(message.contains("bufferView 1"), "{message}");
}

#[test]
fn counts_over_the_limits_are_refused_before_allocating() {
    let dir = TempDir::new().unwrap();
    let bytes = buffer(&[0, 2, 1, 0, 3, 2]);
    // Four billion vertices, zeros but for one sparse value (the spec lets an accessor without
    // a buffer view be all zeros): 48 GB if allocated.
    let positions = POSITIONS
        .replace(r#""bufferView": 0, "#, "")
        .replace(r#""count": 4,"#, r#""count": 4000000000,"#)
        + r#", "sparse": {"count": 1, "indices": {"bufferView": 1, "componentType": 5121},
              "values": {"bufferView": 0}}"#;
    let index = r#""bufferView": 1, "componentType": 5121, "count": 6, "type": "SCALAR""#;
    let json = gltf(&embedded(&bytes), bytes.len(), &positions, index);
    let path = write(dir.path(), "huge.gltf", json.as_bytes());
    let message = refusal(&path);
    assert!(message.contains("exceeds the limit of"), "{message}");

    // A 3 GiB OBJ (a sparse file: no disk used) is refused by its size before it is read.
    let path = dir.path().join("huge.obj");
    std::fs::File::create(&path)
        .unwrap()
        .set_len(3 << 30)
        .unwrap();
    let message = refusal(&path);
    assert!(
        message.contains("exceeds the limit of") && message.contains("max_file_bytes"),
        "{message}"
    );
}

#[cfg(unix)]
#[test]
fn special_files_and_links_to_them_are_refused() {
    let dir = TempDir::new().unwrap();
    for name in ["zero.obj", "zero.gltf", "zero.glb"] {
        let link = dir.path().join(name);
        std::os::unix::fs::symlink("/dev/zero", &link).unwrap();
        let message = refusal(&link);
        assert!(message.contains("not a regular file"), "{message}");
    }
    let fifo = dir.path().join("pipe.obj");
    let status = std::process::Command::new("mkfifo")
        .arg(&fifo)
        .status()
        .unwrap();
    assert!(status.success());
    let message = refusal(&fifo);
    assert!(message.contains("not a regular file"), "{message}");
}

/// Bytes that must never appear in an error message: a file outside the glTF's folder.
const SECRET: &[u8] = b"SECRET-7f3a9 do not print this";

#[cfg(unix)]
#[test]
fn buffer_uris_outside_the_files_folder_are_refused() {
    let outside = TempDir::new().unwrap();
    let secret = write(outside.path(), "secret.bin", &buffer(SECRET));
    let root = TempDir::new().unwrap();
    let folder = root.path().join("scene");
    std::fs::create_dir(&folder).unwrap();
    write(root.path(), "secret.bin", &buffer(SECRET));
    std::os::unix::fs::symlink(&secret, folder.join("link.bin")).unwrap();
    let index = r#""bufferView": 1, "componentType": 5121, "count": 6, "type": "SCALAR""#;
    let length = 48 + SECRET.len();
    for (name, uri) in [
        ("absolute.gltf", secret.display().to_string()),
        ("parent.gltf", "../secret.bin".to_owned()),
        ("encoded.gltf", "%2E%2E/secret.bin".to_owned()),
        ("file.gltf", format!("file://{}", secret.display())),
        ("link.gltf", "link.bin".to_owned()),
    ] {
        let json = gltf(&uri, length, POSITIONS, index);
        let path = write(&folder, name, json.as_bytes());
        let message = refusal(&path);
        assert!(message.contains("buffer 0"), "{name}: {message}");
        assert!(!message.contains("SECRET"), "{name}: {message}");
    }
}

#[test]
fn references_to_what_does_not_exist_are_refused() {
    let dir = TempDir::new().unwrap();
    let bytes = buffer(&[0, 2, 1, 0, 3, 2]);
    let index = r#""bufferView": 1, "componentType": 5121, "count": 6, "type": "SCALAR""#;
    let json = gltf(&embedded(&bytes), bytes.len(), POSITIONS, index);
    // The first, found by the bounded fuzzing: the `gltf` crate's validation indexed the
    // accessors unchecked for POSITION's bounds and panicked.
    for (name, from, to, expected) in [
        (
            "position.gltf",
            r#""POSITION": 0"#,
            r#""POSITION": 7"#,
            "accessor 7",
        ),
        (
            "indices.gltf",
            r#""indices": 1"#,
            r#""indices": 9"#,
            "accessor 9",
        ),
        (
            "view.gltf",
            r#""bufferView": 1,"#,
            r#""bufferView": 5,"#,
            "bufferView 5",
        ),
        (
            "buffer.gltf",
            r#"{"buffer": 0, "byteOffset": 48"#,
            r#"{"buffer": 3, "byteOffset": 48"#,
            "buffer 3",
        ),
        ("mesh.gltf", r#"{"mesh": 0}"#, r#"{"mesh": 4}"#, "mesh 4"),
        (
            "node.gltf",
            r#"{"nodes": [0]}"#,
            r#"{"nodes": [0, 6]}"#,
            "node 6",
        ),
        (
            "scene.gltf",
            r#""scenes""#,
            r#""scene": 2, "scenes""#,
            "scene 2",
        ),
    ] {
        assert!(json.contains(from), "{name}: the test's JSON changed");
        let path = write(dir.path(), name, json.replace(from, to).as_bytes());
        let message = refusal(&path);
        assert!(message.contains(expected), "{name}: {message}");
    }
}

#[test]
fn node_trees_that_place_too_many_nodes_are_refused() {
    let dir = TempDir::new().unwrap();
    let bytes = buffer(&[0, 2, 1, 0, 3, 2]);
    let index = r#""bufferView": 1, "componentType": 5121, "count": 6, "type": "SCALAR""#;
    // Node k lists node k + 1 twice: 2^25 placements of the quad from 26 nodes, past the
    // 2^24 objects a frame may hold.
    let nodes: Vec<String> = (0..25)
        .map(|k| format!(r#"{{"children": [{0}, {0}]}}"#, k + 1))
        .chain([r#"{"mesh": 0}"#.to_owned()])
        .collect();
    let json = gltf(&embedded(&bytes), bytes.len(), POSITIONS, index).replace(
        r#""nodes": [{"mesh": 0}]"#,
        &format!(r#""nodes": [{}]"#, nodes.join(", ")),
    );
    let path = write(dir.path(), "shared.gltf", json.as_bytes());
    let message = refusal(&path);
    assert!(
        message.contains("nodes placed") && message.contains("max_objects"),
        "{message}"
    );
}
