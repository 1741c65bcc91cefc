//! `antumbra bench --write-rays` and `--ray-files` as a user runs them: a scene's rays written in the
//! two little-endian formats trace back through antumbra (and Embree's every call, with the
//! `embree` feature) with the answers antumbra gave, and each kind of bad file is an error
//! naming the file, the item and the field, never a crash.

mod common;

use std::path::{Path, PathBuf};

use common::{antumbra, ok};
use serde_json::Value;
use tempfile::TempDir;

/// The bedroom's triangles, camera rays and its two lights' shadow rays, written into `dir`.
fn written(dir: &Path) -> [PathBuf; 4] {
    let out = ok(antumbra()
        .args(["bench", "--scene", "bedroom", "--triangles", "3000"])
        .args(["--size", "48x32", "--write-rays"])
        .arg(dir)
        .output()
        .unwrap());
    let names = ["triangles", "camera.rays", "light0.rays", "light1.rays"];
    let files = names.map(|n| dir.join(format!("bedroom_f1.{n}.bin")));
    let listed = String::from_utf8_lossy(&out.stdout);
    for (f, record) in files.iter().zip([36, 32, 32, 32]) {
        assert!(listed.contains(&*f.to_string_lossy()), "{f:?} in {listed}");
        let bytes = std::fs::read(f).unwrap();
        let n = u64::from_le_bytes(bytes[..8].try_into().unwrap());
        assert!(n > 100, "{f:?} holds {n}");
        assert_eq!(bytes.len() as u64, 8 + n * record, "{f:?}");
    }
    // A 48x32 image: one camera ray per pixel.
    let camera = std::fs::read(&files[1]).unwrap();
    assert_eq!(u64::from_le_bytes(camera[..8].try_into().unwrap()), 48 * 32);
    files
}

fn bench_rays(triangles: &Path, rays: &Path, extra: &[&str]) -> Vec<Value> {
    let out = ok(antumbra()
        .args(["bench", "--repeat", "1", "--json", "--ray-files"])
        .args([triangles, rays])
        .args(extra)
        .output()
        .unwrap());
    serde_json::from_slice::<Value>(&out.stdout)
        .unwrap()
        .as_array()
        .unwrap()
        .clone()
}

#[test]
fn written_rays_trace_back_through_antumbra() {
    let dir = TempDir::new().unwrap();
    let [triangles, camera, light0, light1] = written(dir.path());
    for rays in [&camera, &light0] {
        let rows = bench_rays(&triangles, rays, &[]);
        assert_eq!(rows.len(), 2, "one row per thread count: {rows:?}");
        let n = (std::fs::metadata(rays).unwrap().len() - 8) / 32;
        for row in &rows {
            assert_eq!(row["rays"].as_u64(), Some(n), "{row}");
            assert_eq!(row["triangles"].as_u64(), Some(3000), "{row}");
            for key in ["any_hit_mrays", "closest_hit_mrays"] {
                assert!(row[key].as_f64().unwrap() > 0.0, "{key} in {row}");
            }
            assert!(row["embree_kernels"].as_array().unwrap().is_empty());
        }
    }
    // The bedroom's first light is hidden from most pixels; a shadow ray leaves each pixel whose
    // camera ray hit (none where it missed), so no light has more rays than camera hits.
    let shadow = &bench_rays(&triangles, &light0, &[])[0];
    let occluded = shadow["occluded"].as_f64().unwrap();
    assert!(occluded > 0.5 && occluded < 1.0, "{occluded}");
    let camera = &bench_rays(&triangles, &camera, &[])[0];
    let hits = camera["occluded"].as_f64().unwrap() * (48.0 * 32.0);
    assert!(hits > 0.9 * 48.0 * 32.0, "{camera}");
    for light in [&light0, &light1] {
        let n = (std::fs::metadata(light).unwrap().len() - 8) / 32;
        assert!(n as f64 <= hits, "{n} shadow rays from {hits} camera hits");
    }
}

/// Every Embree call on the written rays: each one timed, and the incoherent ones answering
/// every ray as antumbra does.
#[cfg(feature = "embree")]
#[test]
fn written_rays_trace_through_every_embree_call() {
    let dir = TempDir::new().unwrap();
    let [triangles, camera, light0, light1] = written(dir.path());
    for rays in [&camera, &light0, &light1] {
        for row in bench_rays(&triangles, rays, &["--compare", "embree"]) {
            let kernels = row["embree_kernels"].as_array().unwrap();
            let names: Vec<&str> = kernels
                .iter()
                .map(|k| k["kernel"].as_str().unwrap())
                .collect();
            for call in ["rtcOccluded", "rtcIntersect"] {
                for suffix in ["1", "8", "16", "1M"] {
                    let name = format!("{call}{suffix}");
                    let expected = if suffix == "1" { 1 } else { 2 };
                    let found = names.iter().filter(|n| **n == name).count();
                    assert_eq!(found, expected, "{name} incoherent and coherent: {names:?}");
                }
            }
            for k in kernels {
                assert!(k["mrays"].as_f64().unwrap() > 0.0, "{k}");
                if k["context"] == "incoherent" {
                    assert_eq!(k["disagreements"].as_u64(), Some(0), "{k} on {rays:?}");
                }
            }
        }
    }
}

/// What each bad file does to `--ray-files`: a failure whose message names the file and `needles`.
fn refused(triangles: &Path, rays: &Path, bad: &Path, needles: &[&str]) {
    let out = antumbra()
        .args(["bench", "--repeat", "1", "--ray-files"])
        .args([triangles, rays])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "accepted {bad:?}");
    assert!(!err.contains("panicked"), "{err}");
    assert!(
        err.contains(&*bad.to_string_lossy()),
        "names the file: {err}"
    );
    for needle in needles {
        assert!(err.contains(needle), "'{needle}' in: {err}");
    }
}

fn file(dir: &Path, name: &str, n: u64, values: &[f32]) -> PathBuf {
    let path = dir.join(name);
    let mut bytes = n.to_le_bytes().to_vec();
    bytes.extend(values.iter().flat_map(|v| v.to_le_bytes()));
    std::fs::write(&path, bytes).unwrap();
    path
}

#[test]
fn bad_ray_files_are_errors_naming_file_item_and_field() {
    let dir = TempDir::new().unwrap();
    let d = dir.path();
    let triangle = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0];
    let tris = file(d, "ok.tris", 1, &triangle);
    let ray = |o: [f32; 3], tnear: f32, dir: [f32; 3], tfar: f32| {
        [o[0], o[1], o[2], tnear, dir[0], dir[1], dir[2], tfar]
    };
    let good = ray([0.2, 0.2, 1.0], 0.0, [0.0, 0.0, -1.0], f32::INFINITY);
    let rays_of = |name: &str, bad: [f32; 8]| file(d, name, 2, &[good, bad].concat());

    // Triangle files.
    let short = d.join("short.tris");
    std::fs::write(&short, [1, 0, 0]).unwrap();
    let ok_rays = file(d, "ok.rays", 1, &good);
    refused(&short, &ok_rays, &short, &["3 bytes", "8-byte header"]);
    let truncated = file(d, "truncated.tris", 2, &triangle);
    refused(
        &truncated,
        &ok_rays,
        &truncated,
        &["truncated", "n = 2 triangles", "80 bytes"],
    );
    let huge = file(d, "huge.tris", 1 << 40, &triangle);
    refused(
        &huge,
        &ok_rays,
        &huge,
        &["n = 1099511627776", "limit of 100000000"],
    );
    let extra = file(d, "extra.tris", 1, &[&triangle[..], &[0.0]].concat());
    refused(&extra, &ok_rays, &extra, &["4 bytes after"]);
    let mut nan = triangle;
    nan[4] = f32::NAN;
    let nan = file(d, "nan.tris", 1, &nan);
    refused(&nan, &ok_rays, &nan, &["triangle 0, y1", "not finite"]);
    let mut large = triangle;
    large[8] = -2e18;
    let large = file(d, "large.tris", 1, &large);
    refused(&large, &ok_rays, &large, &["triangle 0, z2", "1.844e18"]);

    // Ray files: each field's limit.
    let cases: [(&str, [f32; 8], &[&str]); 7] = [
        (
            "inf.rays",
            ray([f32::INFINITY, 0.0, 0.0], 0.0, [0.0, 0.0, 1.0], 1.0),
            &["ray 1", "ox", "not finite"],
        ),
        (
            "nan_dir.rays",
            ray([0.0; 3], 0.0, [0.0, f32::NAN, 1.0], 1.0),
            &["ray 1", "dy", "not finite"],
        ),
        (
            "far.rays",
            ray([0.0, 0.0, 3e18], 0.0, [0.0, 0.0, 1.0], 1.0),
            &["ray 1", "oz", "1.844e18"],
        ),
        (
            "negative.rays",
            ray([0.0; 3], -1.0, [0.0, 0.0, 1.0], 1.0),
            &["ray 1", "tnear = -1", ">= 0"],
        ),
        (
            "reversed.rays",
            ray([0.0; 3], 2.0, [0.0, 0.0, 1.0], 1.0),
            &["ray 1", "tfar = 1", ">= tnear = 2"],
        ),
        (
            "nan_far.rays",
            ray([0.0; 3], 0.0, [0.0, 0.0, 1.0], f32::NAN),
            &["ray 1", "tfar = NaN"],
        ),
        (
            "zero.rays",
            ray([0.0; 3], 0.0, [0.0; 3], 1.0),
            &["ray 1", "direction must not be zero"],
        ),
    ];
    for (name, bad, needles) in cases {
        let rays = rays_of(name, bad);
        refused(&tris, &rays, &rays, needles);
    }
    let truncated = file(d, "truncated.rays", 3, &[good, good].concat());
    refused(
        &tris,
        &truncated,
        &truncated,
        &["truncated", "n = 3 rays", "104 bytes"],
    );
    let huge = file(d, "huge.rays", u64::MAX, &good);
    refused(&tris, &huge, &huge, &["n = 18446744073709551615", "limit"]);
    let missing = d.join("missing.rays");
    refused(&tris, &missing, &missing, &["cannot open"]);
}
