//! The `gltf` target: arbitrary bytes as a glTF or GLB file, and as the binary buffer of a
//! fixed GLB whose accessors (strided, sparse, indexed) then read whatever the bytes hold.

use super::{check, limits};
use crate::import::load_gltf;

/// Reads `data` as a `.gltf`/`.glb` file (no folder: external buffers are refused), then as
/// the BIN chunk of [`FIXED_JSON`]: each is refused with an error naming the file, or a valid
/// framed scene within the limits. Never panics.
pub fn gltf(data: &[u8]) {
    check(
        "fuzz.gltf",
        load_gltf("fuzz.gltf", data, None, 2, &limits()),
    );
    let glb = fixed_glb(data);
    check("fuzz.glb", load_gltf("fuzz.glb", &glb, None, 2, &limits()));
}

/// A mesh over one buffer of `{length}` bytes: 4 positions (0..48) with one sparse
/// replacement (index u8 at 108, value at 112..124), 6 u16 indices (48..60) and 4 normals
/// strided 16 bytes apart (60..124, overlapping the sparse data on purpose).
const FIXED_JSON: &str = r#"{"asset":{"version":"2.0"},"scenes":[{"nodes":[0]}],
"nodes":[{"mesh":0,"children":[1]},{"mesh":0,"translation":[1,0,0]}],
"meshes":[{"primitives":[{"attributes":{"POSITION":0,"NORMAL":2},"indices":1},
{"attributes":{"POSITION":0},"mode":5}]}],
"buffers":[{"byteLength":{length}}],
"bufferViews":[{"buffer":0,"byteLength":48},{"buffer":0,"byteOffset":48,"byteLength":12},
{"buffer":0,"byteOffset":60,"byteLength":64,"byteStride":16},
{"buffer":0,"byteOffset":108,"byteLength":1},{"buffer":0,"byteOffset":112,"byteLength":12}],
"accessors":[{"bufferView":0,"componentType":5126,"count":4,"type":"VEC3","min":[0,0,0],"max":[1,0,2],
"sparse":{"count":1,"indices":{"bufferView":3,"componentType":5121},"values":{"bufferView":4}}},
{"bufferView":1,"componentType":5123,"count":6,"type":"SCALAR"},
{"bufferView":2,"componentType":5126,"count":4,"type":"VEC3"}]}"#;

/// [`FIXED_JSON`] and `bin` as a GLB file (`bin` as it is: a chunk of any length is input too).
fn fixed_glb(bin: &[u8]) -> Vec<u8> {
    let mut json = FIXED_JSON
        .replace("{length}", &bin.len().to_string())
        .into_bytes();
    json.resize(json.len().next_multiple_of(4), b' ');
    glb_of_chunks(&json, bin)
}

/// `json` and `bin` as a GLB file, the JSON chunk padded with spaces and the binary one with
/// zeros to 4 bytes, as the format asks (seeds and tests write GLB files with it).
pub fn glb(json: &str, bin: &[u8]) -> Vec<u8> {
    let mut json = json.as_bytes().to_vec();
    json.resize(json.len().next_multiple_of(4), b' ');
    let mut bin = bin.to_vec();
    bin.resize(bin.len().next_multiple_of(4), 0);
    glb_of_chunks(&json, &bin)
}

/// The GLB header, the JSON chunk and the BIN chunk, each as given.
fn glb_of_chunks(json: &[u8], bin: &[u8]) -> Vec<u8> {
    let total = 12 + 8 + json.len() + 8 + bin.len();
    let mut glb = Vec::with_capacity(total);
    glb.extend_from_slice(b"glTF");
    glb.extend_from_slice(&2u32.to_le_bytes());
    glb.extend_from_slice(&(total as u32).to_le_bytes());
    glb.extend_from_slice(&(json.len() as u32).to_le_bytes());
    glb.extend_from_slice(b"JSON");
    glb.extend_from_slice(json);
    glb.extend_from_slice(&(bin.len() as u32).to_le_bytes());
    glb.extend_from_slice(b"BIN\0");
    glb.extend_from_slice(bin);
    glb
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_fixed_document_reads_a_good_buffer() {
        let mut bin = Vec::new();
        for c in [0f32, 0., 0., 1., 0., 0., 1., 0., 1., 0., 0., 1.] {
            bin.extend_from_slice(&c.to_le_bytes());
        }
        for i in [0u16, 2, 1, 0, 3, 2] {
            bin.extend_from_slice(&i.to_le_bytes());
        }
        // Normals 0 to 2, 16 bytes apart (60..108); normal 3 overlaps the sparse data.
        for _ in 0..3 {
            for c in [0f32, 1., 0., 0.] {
                bin.extend_from_slice(&c.to_le_bytes());
            }
        }
        // Sparse: vertex 3 (the u8 index at 108) moves to (0, 0, 2) (the value at 112).
        bin.extend_from_slice(&[3, 0, 0, 0]);
        for c in [0f32, 0., 2.] {
            bin.extend_from_slice(&c.to_le_bytes());
        }
        assert_eq!(bin.len(), 124);
        let anim = load_gltf("fixed.glb", &fixed_glb(&bin), None, 1, &limits()).unwrap();
        let scene = anim.frame(1);
        // 2 indexed triangles + a strip of 4 vertices (2 more), on 2 nodes sharing the mesh.
        assert_eq!(scene.meshes.len(), 1);
        assert_eq!(scene.meshes[0].triangles.len(), 4);
        assert_eq!(scene.objects.len(), 2);
        assert_eq!(scene.meshes[0].positions[3], glam::Vec3::new(0.0, 0.0, 2.0));
        // The strip primitive has no NORMAL: the mesh keeps none.
        assert!(scene.meshes[0].normals.is_empty());
    }
}
