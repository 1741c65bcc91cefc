//! The `antumbra` binary as a user runs it: render writes images, heat maps and statistics;
//! bad arguments give clear errors and a non-zero exit code.

use std::path::Path;
use std::process::Command;

use base64::Engine;
use tempfile::TempDir;

fn antumbra() -> Command {
    Command::new(env!("CARGO_BIN_EXE_antumbra"))
}

#[test]
fn render_writes_images_heat_maps_and_statistics() {
    let tmp = TempDir::new().unwrap();
    let out = tmp.path();
    let status = antumbra()
        .args([
            "render", "--scene", "city", "--frames", "1-2", "--size", "64x40",
        ])
        .args(["--triangles", "10000", "--spp", "2", "--out"])
        .arg(out)
        .output()
        .unwrap();
    assert!(
        status.status.success(),
        "{}",
        String::from_utf8_lossy(&status.stderr)
    );
    for frame in [1, 2] {
        let exr = out.join(format!("frame_{frame:04}.exr"));
        let planes = antumbra_core::output::read_exr(&exr).unwrap();
        let names: Vec<&str> = planes.iter().map(|p| p.name.as_str()).collect();
        for expected in [
            "combined",
            "primary.N_B",
            "primary.N_L",
            "primary.N_T",
            "shadow.N_B",
            "shadow.N_T",
        ] {
            assert!(
                names.contains(&expected),
                "{expected} missing from {names:?}"
            );
        }
        assert!(names
            .iter()
            .any(|n| n.starts_with("shadow.") && !n.contains("N_")));
        assert!(planes.iter().all(|p| p.width == 64 && p.height == 40));
        assert!(Path::new(&out.join(format!("frame_{frame:04}_combined.png"))).exists());
        assert!(Path::new(&out.join(format!("frame_{frame:04}_heat_primary.N_B.png"))).exists());
    }
    let csv = std::fs::read_to_string(out.join("stats.csv")).unwrap();
    let mut lines = csv.lines();
    assert!(lines
        .next()
        .unwrap()
        .starts_with("scene,frame,method,pass,light"));
    let rows: Vec<&str> = lines.collect();
    assert!(rows
        .iter()
        .any(|r| r.contains(",1,") && r.contains("primary")));
    assert!(rows
        .iter()
        .any(|r| r.contains(",2,") && r.contains("shadow")));
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("stats.json")).unwrap()).unwrap();
    assert_eq!(json.as_array().unwrap().len(), rows.len());
}

#[test]
fn bad_arguments_fail_with_a_clear_message() {
    let tmp = TempDir::new().unwrap();
    let out = tmp.path();
    for (args, needle) in [
        (
            vec!["render", "--scene", "nowhere", "--out"],
            "unknown scene 'nowhere'",
        ),
        (
            vec!["render", "--scene", "city", "--frames", "9-3", "--out"],
            "--frames",
        ),
        (
            vec!["render", "--scene", "city", "--size", "0x5", "--out"],
            "--size",
        ),
        (
            vec![
                "render",
                "--scene",
                "city",
                "--spp",
                "0",
                "--frames",
                "1",
                "--size",
                "8x8",
                "--triangles",
                "10000",
                "--out",
            ],
            "spp",
        ),
        (
            vec!["render", "--scene", "/does/not/exist.obj", "--out"],
            "exist.obj",
        ),
        (
            vec![
                "render", "--scene", "city", "--build", "srdh", "--order", "sato", "--out",
            ],
            "cannot also be 'sato'",
        ),
        (
            vec!["render", "--scene", "city", "--build", "kd", "--out"],
            "build: expected one of sah, sbvh, abvh, osah, vsah, srdh, auto, got text ('kd')",
        ),
        (
            vec![
                "render",
                "--scene",
                "city",
                "--leaf-size",
                "4",
                "--min-leaf-size",
                "6",
                "--out",
            ],
            "min_leaf_size: must be at most leaf_size (4), got 6",
        ),
        (
            vec!["render", "--scene", "forest", "--instances", "5", "--out"],
            "scene 'forest' does not take an instance count",
        ),
        (
            vec![
                "render",
                "--scene",
                "instanced-forest",
                "--instances",
                "10000001",
                "--out",
            ],
            "instances: must be between 1 and 10000000",
        ),
        (
            vec![
                "render",
                "--scene",
                "/does/not/exist.obj",
                "--instances",
                "5",
                "--out",
            ],
            "--instances applies to built-in scenes only",
        ),
    ] {
        let o = antumbra().args(&args).arg(out).output().unwrap();
        assert!(!o.status.success(), "{args:?} succeeded");
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(err.contains(needle), "{args:?}: {err}");
    }
}

#[test]
fn record_then_render_the_recording_equals_rendering_the_scene() {
    let tmp = TempDir::new().unwrap();
    let dir = tmp.path();
    let rec = dir.join("city.antrec");
    let scene_args = [
        "--scene",
        "city",
        "--frames",
        "2-3",
        "--size",
        "48x30",
        "--triangles",
        "8000",
    ];
    let recorded = antumbra()
        .arg("record")
        .args(scene_args)
        .arg("--out")
        .arg(&rec)
        .output()
        .unwrap();
    assert!(
        recorded.status.success(),
        "{}",
        String::from_utf8_lossy(&recorded.stderr)
    );
    assert!(String::from_utf8_lossy(&recorded.stdout).contains("recorded 2 frames of city"));
    let frames = antumbra_protocol::replay_scenes(&rec).unwrap();
    assert_eq!(frames.iter().map(|s| s.frame).collect::<Vec<_>>(), [2, 3]);
    assert!(frames
        .iter()
        .all(|s| s.resolution.x == 48 && s.resolution.y == 30));
    // The recording renders to the same images as the scene it came from.
    for (name, scene) in [("direct", "city"), ("replayed", rec.to_str().unwrap())] {
        let out = antumbra()
            .args([
                "render", "--scene", scene, "--frames", "3", "--size", "48x30",
            ])
            .args(["--triangles", "8000", "--spp", "1", "--out"])
            .arg(dir.join(name))
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
    let direct = std::fs::read(dir.join("direct/frame_0003.exr")).unwrap();
    let replayed = std::fs::read(dir.join("replayed/frame_0003.exr")).unwrap();
    assert!(
        direct == replayed,
        "the replayed frame differs from the scene's"
    );
    let bad = antumbra()
        .args(["record", "--scene", "nowhere", "--out"])
        .arg(dir.join("x.antrec"))
        .output()
        .unwrap();
    assert!(!bad.status.success());
    assert!(String::from_utf8_lossy(&bad.stderr).contains("nowhere"));
}

/// Issue 33: a glTF whose index accessor is FLOAT made every command that opens a scene panic
/// (exit 101), and an OBJ linked to /dev/zero abort (exit 134). Both are refused, naming the
/// file, with exit code 1.
#[cfg(unix)]
#[test]
fn commands_refuse_scene_files_that_crashed_the_importers() {
    let tmp = TempDir::new().unwrap();
    let dir = tmp.path();
    // A quad's 4 positions and 6 FLOAT "indices" (zeros), base64 in a data: URI.
    let mut bytes = Vec::new();
    for c in [0f32, 0., 0., 1., 0., 0., 1., 0., 1., 0., 0., 1.] {
        bytes.extend_from_slice(&c.to_le_bytes());
    }
    bytes.resize(48 + 24, 0);
    let gltf = dir.join("float_indices.gltf");
    std::fs::write(
        &gltf,
        format!(
            r#"{{"asset":{{"version":"2.0"}},"scenes":[{{"nodes":[0]}}],"nodes":[{{"mesh":0}}],
"meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}},"indices":1}}]}}],
"buffers":[{{"uri":"data:application/octet-stream;base64,{}","byteLength":72}}],
"bufferViews":[{{"buffer":0,"byteLength":48}},{{"buffer":0,"byteOffset":48,"byteLength":24}}],
"accessors":[{{"bufferView":0,"componentType":5126,"count":4,"type":"VEC3"}},
{{"bufferView":1,"componentType":5126,"count":6,"type":"SCALAR"}}]}}"#,
            base64::engine::general_purpose::STANDARD.encode(&bytes)
        ),
    )
    .unwrap();
    let zero = dir.join("zero.obj");
    std::os::unix::fs::symlink("/dev/zero", &zero).unwrap();
    for (scene, needle) in [
        (
            &gltf,
            "float_indices.gltf: accessor 1 (indices): componentType 5126",
        ),
        (&zero, "zero.obj: not a regular file"),
    ] {
        for command in ["render", "record", "compare", "trade"] {
            let out = dir.join(format!("{command}.out"));
            let o = antumbra()
                .args([command, "--scene"])
                .arg(scene)
                .arg("--out")
                .arg(&out)
                .output()
                .unwrap();
            let err = String::from_utf8_lossy(&o.stderr);
            assert_eq!(o.status.code(), Some(1), "{command} {needle}: {err}");
            assert!(err.contains(needle), "{command}: {err}");
        }
    }
}
