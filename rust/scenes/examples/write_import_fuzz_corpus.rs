//! Writes the seed corpora of the importers' fuzz targets (`obj`, `gltf`) from small valid
//! files, and their libFuzzer dictionaries (`obj.dict`, `gltf.dict`).
//!
//! `cargo run -p antumbra-scenes --example write_import_fuzz_corpus` (from the workspace root); the
//! files go to `rust/protocol/fuzz/corpus/<target>/`, beside the protocol's targets.

use std::path::Path;

use antumbra_scenes::fuzzing;
use base64::Engine;

type Res = Result<(), Box<dyn std::error::Error>>;

fn main() -> Res {
    let fuzz = Path::new(env!("CARGO_MANIFEST_DIR")).join("../protocol/fuzz");
    let obj = fuzz.join("corpus/obj");
    let gltf = fuzz.join("corpus/gltf");
    std::fs::create_dir_all(&obj)?;
    std::fs::create_dir_all(&gltf)?;
    for (name, text) in OBJ_SEEDS {
        std::fs::write(obj.join(name), text)?;
    }
    let bin = quad_bin();
    let uri = format!(
        "data:application/octet-stream;base64,{}",
        base64::engine::general_purpose::STANDARD.encode(&bin)
    );
    std::fs::write(gltf.join("quads.gltf"), quads_json(Some(&uri), bin.len()))?;
    std::fs::write(
        gltf.join("quads.glb"),
        fuzzing::glb(&quads_json(None, bin.len()), &bin),
    )?;
    std::fs::write(gltf.join("modes.gltf"), modes_json(&uri, bin.len()))?;
    std::fs::write(gltf.join("fixed_bin.bin"), fixed_bin())?;
    std::fs::write(fuzz.join("obj.dict"), dict(OBJ_WORDS))?;
    std::fs::write(fuzz.join("gltf.dict"), dict(GLTF_WORDS))?;
    println!(
        "wrote the importers' seeds to {}",
        fuzz.join("corpus").display()
    );
    Ok(())
}

const OBJ_SEEDS: &[(&str, &str)] = &[
    (
        "cube.obj",
        "# a unit cube of quads and a lone triangle\no cube\nv 0 0 0\nv 1 0 0\nv 1 1 0\n\
         v 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\nf 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\n\
         f 2 3 7 6\nf 3 4 8 7\nf 4 1 5 8\no triangle\nv 3 0 0\nv 4 0 0\nv 3 1 0\nf 9 10 11\n",
    ),
    (
        "groups.obj",
        "mtllib none.mtl\nv 0 0 0 1\nv 1 0 0\nv 1 1 0\nv 0 1 0 0.5 0.5 0.5\nvt 0 0\nvt 1 0\n\
         vn 0 0 1\ng first part\nusemtl a\nf 1/1/1 2/2/1 3//1\nf -4 -2 -1\ng\nl 1 2\np 3\n\
         f 1 2 3 4 1 2\ns off\no\nf -1/1 -2/2 -3/1\n",
    ),
];

/// A unit quad: 4 positions (48 bytes) then 6 u16 indices.
fn quad_bin() -> Vec<u8> {
    let mut bytes = Vec::new();
    for c in [0f32, 0., 0., 1., 0., 0., 1., 0., 1., 0., 0., 1.] {
        bytes.extend_from_slice(&c.to_le_bytes());
    }
    for i in [0u16, 2, 1, 0, 3, 2] {
        bytes.extend_from_slice(&i.to_le_bytes());
    }
    bytes
}

/// Two nodes sharing the quad mesh, the child moved.
fn quads_json(uri: Option<&str>, length: usize) -> String {
    let uri = uri.map(|u| format!(r#""uri":"{u}","#)).unwrap_or_default();
    format!(
        r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[0]}}],
"nodes":[{{"name":"root","mesh":0,"translation":[2,0,0],"children":[1]}},
{{"name":"child","mesh":0,"translation":[0,5,0],"rotation":[0,0,0.7071068,0.7071068]}}],
"meshes":[{{"name":"quad","primitives":[{{"attributes":{{"POSITION":0}},"indices":1}}]}}],
"buffers":[{{{uri}"byteLength":{length}}}],
"bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":48,"byteStride":12}},
{{"buffer":0,"byteOffset":48,"byteLength":12}}],
"accessors":[{{"bufferView":0,"componentType":5126,"count":4,"type":"VEC3","min":[0,0,0],"max":[1,0,1]}},
{{"bufferView":1,"componentType":5123,"count":6,"type":"SCALAR"}}]}}"#
    )
}

/// No scene (the roots are found); strip, fan, unindexed triangles and points, u8 indices
/// read from the u16 data, a matrix transform and a node without a mesh.
fn modes_json(uri: &str, length: usize) -> String {
    format!(
        r#"{{"asset":{{"version":"2.0"}},
"nodes":[{{"mesh":0,"matrix":[1,0,0,0,0,1,0,0,0,0,1,0,0,0,3,1]}},{{"children":[2]}},{{"mesh":1}}],
"meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}},"mode":5}},{{"attributes":{{"POSITION":0}},"mode":6}}]}},
{{"primitives":[{{"attributes":{{"POSITION":2}}}},{{"attributes":{{"POSITION":0}},"mode":0}},
{{"attributes":{{"POSITION":0}},"indices":3}}]}}],
"buffers":[{{"uri":"{uri}","byteLength":{length}}}],
"bufferViews":[{{"buffer":0,"byteLength":48}},{{"buffer":0,"byteOffset":48,"byteLength":12}}],
"accessors":[{{"bufferView":0,"componentType":5126,"count":4,"type":"VEC3","min":[0,0,0],"max":[1,0,1]}},
{{"bufferView":1,"componentType":5123,"count":6,"type":"SCALAR"}},
{{"bufferView":0,"byteOffset":12,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,0,1]}},
{{"bufferView":1,"componentType":5121,"count":3,"type":"SCALAR"}}]}}"#
    )
}

/// A good buffer for the target's fixed GLB document (`antumbra_scenes::fuzzing::gltf`):
/// positions, u16 indices, normals 16 bytes apart, a sparse index and value.
fn fixed_bin() -> Vec<u8> {
    let mut bin = quad_bin();
    for _ in 0..3 {
        for c in [0f32, 1., 0., 0.] {
            bin.extend_from_slice(&c.to_le_bytes());
        }
    }
    bin.extend_from_slice(&[3, 0, 0, 0]);
    for c in [0f32, 0., 2.] {
        bin.extend_from_slice(&c.to_le_bytes());
    }
    bin
}

const OBJ_WORDS: &[&str] = &[
    "v ", "f ", "o ", "g ", "vt ", "vn ", "/", "//", "-1", "\\x0A", "#",
];

const GLTF_WORDS: &[&str] = &[
    "accessors",
    "bufferView",
    "bufferViews",
    "byteOffset",
    "byteLength",
    "byteStride",
    "componentType",
    "count",
    "type",
    "SCALAR",
    "VEC3",
    "normalized",
    "sparse",
    "indices",
    "values",
    "buffers",
    "buffer",
    "uri",
    "data:application/octet-stream;base64,",
    "meshes",
    "primitives",
    "attributes",
    "POSITION",
    "NORMAL",
    "mode",
    "nodes",
    "children",
    "mesh",
    "matrix",
    "translation",
    "rotation",
    "scale",
    "scenes",
    "scene",
    "5120",
    "5121",
    "5122",
    "5123",
    "5125",
    "5126",
    "4294967295",
    "glTF",
    "JSON",
    "BIN\\x00",
];

/// A libFuzzer dictionary: one quoted word a line (bytes other than printable ASCII as `\xNN`).
fn dict(words: &[&str]) -> String {
    words.iter().map(|w| format!("\"{w}\"\n")).collect()
}
