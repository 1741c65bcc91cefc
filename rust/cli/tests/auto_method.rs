//! `auto` as a build and as an order: its masks and primary hits equal every fixed method's bit
//! for bit on every built-in scene, its choices repeat for a seed, bad values are refused naming
//! the setting, and `antumbra compare` takes it among the methods.

mod common;

use antumbra_core::compare::MethodSpec;
use antumbra_core::render::{FrameResult, Renderer};
use antumbra_core::scene::{Resolution, Scene};
use antumbra_core::settings::NamedSettings;
use antumbra_scenes::{builtin, SceneParams, BUILTIN_SCENES};
use common::{antumbra, ok, read_csv};
use tempfile::TempDir;

/// Fixed methods first (the first is the reference), then `auto` at widths 8 and 2.
const METHODS: &[&str] = &[
    "base=build=sah,width=2,order=fbto",
    "sato8=build=sah,width=8,order=sato",
    "sorted8=build=sah,width=8,order=sorted",
    "osah8=build=osah,width=8,order=sorted",
    "srdh=build=srdh,width=2",
    "auto8=build=auto,width=8,order=auto",
    "auto2=build=auto,width=2,order=auto",
    "auto_order=build=sah,width=4,order=auto",
];

const FRAMES: i32 = 5;

fn frames(name: &str) -> Vec<Scene> {
    frames_at(name, Resolution::new(64, 64))
}

fn frames_at(name: &str, resolution: Resolution) -> Vec<Scene> {
    let params = SceneParams {
        triangles: 3000,
        frames: FRAMES,
        rotated: false,
        instances: None,
    };
    let anim = builtin(name, &params).unwrap();
    anim.frame_range()
        .take(FRAMES as usize)
        .map(|f| {
            let mut s = anim.frame(f);
            s.resolution = resolution;
            s
        })
        .collect()
}

/// Every frame of `scenes` rendered by one renderer with `spec`'s settings.
fn render_all(scene: &str, scenes: &[Scene], spec: &str, seed: i64) -> Vec<FrameResult> {
    // The flat tree: these tests compare auto's builds and orders with the fixed methods' bit
    // for bit (two levels agree with it but at triangle edges: rust/core/tests/two_level*.rs).
    let common = NamedSettings::new()
        .with("spp", 4)
        .with("seed", seed)
        .with("scene_structure", "flat");
    let settings = spec
        .parse::<MethodSpec>()
        .unwrap()
        .resolve(&common)
        .unwrap();
    let mut renderer = Renderer::new();
    scenes
        .iter()
        .map(|s| renderer.render(scene, s, &settings).unwrap())
        .collect()
}

#[test]
fn auto_answers_equal_every_fixed_method_on_every_builtin_scene() {
    let mut chosen = std::collections::BTreeSet::new();
    for name in BUILTIN_SCENES {
        let scenes = frames(name);
        let reference = render_all(name, &scenes, METHODS[0], 0);
        for spec in &METHODS[1..] {
            let results = render_all(name, &scenes, spec, 0);
            for (r, base) in results.iter().zip(&reference) {
                let at = format!("{name} frame {} {spec}", r.frame);
                assert_eq!(r.primary_hits, base.primary_hits, "{at}");
                assert_eq!(r.masks.len(), base.masks.len(), "{at}");
                for (m, b) in r.masks.iter().zip(&base.masks) {
                    let bits = |p: &[f32]| p.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
                    assert_eq!(bits(&m.data), bits(&b.data), "{at}: light {}", m.name);
                }
                let auto = spec.contains("order=auto");
                for row in &r.stats {
                    let marked = !row.auto_choice.is_empty();
                    let expected = match row.pass.as_str() {
                        "primary" => spec.contains("build=auto"),
                        _ => auto,
                    };
                    assert_eq!(marked, expected, "{at}: {row:?}");
                    // `sato;sample=srdh`: traced with SATO, SRDH measured on a sample.
                    let tried = row.auto_choice.trim_start_matches("explore:");
                    chosen.extend(
                        tried
                            .split(";sample=")
                            .filter(|c| !c.is_empty())
                            .map(String::from),
                    );
                }
            }
        }
    }
    // Over these scenes auto tried every build of moving geometry and every order it has (OSAH
    // on larger frames: `osah_is_tried_only_where_its_build_can_pay`).
    for c in ["sah", "fbto", "sato", "sorted", "srdh"] {
        assert!(chosen.contains(c), "auto never chose {c}: {chosen:?}");
    }
}

/// The camera-tree choices (`auto_choice` of the primary rows) of `auto8` on `scenes`.
fn build_choices(name: &str, scenes: &[Scene]) -> Vec<String> {
    let results = render_all(name, scenes, "auto8=build=auto,width=8,order=auto", 0);
    let base = render_all(name, scenes, METHODS[0], 0);
    for (r, b) in results.iter().zip(&base) {
        assert_eq!(r.primary_hits, b.primary_hits, "frame {}", r.frame);
    }
    let primary = results.iter().flat_map(|r| &r.stats);
    primary
        .filter(|row| row.pass == "primary")
        .map(|row| row.auto_choice.clone())
        .collect()
}

#[test]
fn osah_is_tried_only_where_its_build_can_pay() {
    // 64x64 camera rays cannot win back what an OSAH build costs beyond SAH; 160x120 can.
    let small = build_choices("city", &frames_at("city", Resolution::new(64, 64)));
    assert!(small.iter().all(|c| c == "sah"), "{small:?}");
    let large = build_choices("city", &frames_at("city", Resolution::new(160, 120)));
    assert!(large.iter().any(|c| c == "explore:osah"), "{large:?}");
}

#[test]
fn auto_keeps_the_tree_of_unmoved_geometry() {
    let still = vec![frames("city").remove(0); 4];
    let base = render_all("city", &still, METHODS[0], 0);
    let auto = render_all("city", &still, "a=build=auto,width=8,order=fbto", 0);
    let builds: Vec<&str> = auto
        .iter()
        .map(|r| r.stats[0].auto_choice.as_str())
        .collect();
    assert_eq!(builds[0], "sah");
    assert!(builds[1..].contains(&"keep"), "{builds:?}");
    for (a, b) in auto.iter().zip(&base) {
        assert_eq!(a.primary_hits, b.primary_hits);
        for (m, n) in a.masks.iter().zip(&b.masks) {
            assert!(m
                .data
                .iter()
                .zip(&n.data)
                .all(|(x, y)| x.to_bits() == y.to_bits()));
        }
    }
}

#[test]
fn lights_with_few_rays_are_traced_with_nothing_prepared() {
    // 16x15 pixels at 4 samples: fewer than MIN_PREP_RAYS rays for every light of every frame,
    // so no light is sorted, given SRDH or SATO, or sampled (its sample could hold no ray).
    const { assert!(16 * 15 * 4 < antumbra_core::render::auto::MIN_PREP_RAYS) };
    for name in ["city", "bedroom"] {
        let scenes = frames_at(name, Resolution::new(16, 15));
        let auto = render_all(name, &scenes, "a=build=auto,width=8,order=auto", 0);
        let shadow: Vec<_> = auto
            .iter()
            .flat_map(|r| &r.stats)
            .filter(|s| s.pass == "shadow")
            .collect();
        assert!(!shadow.is_empty());
        for s in shadow {
            assert_eq!(
                (s.auto_choice.as_str(), s.prepare_ms),
                ("fbto", 0.0),
                "{name} frame {} light {}",
                s.frame,
                s.light
            );
        }
    }
}

/// The `auto_choice` and `auto_estimate_ms` columns of every row of a run.
fn choices(results: &[FrameResult]) -> Vec<(i32, String, String, String, u64)> {
    results
        .iter()
        .flat_map(|r| &r.stats)
        .map(|s| {
            let estimate = s.auto_estimate_ms.to_bits();
            (
                s.frame,
                s.pass.clone(),
                s.light.clone(),
                s.auto_choice.clone(),
                estimate,
            )
        })
        .collect()
}

#[test]
fn choices_repeat_for_a_seed() {
    // Frames large enough for OSAH to be tried (an exploration of the camera tree).
    let scenes = frames_at("bedroom", Resolution::new(160, 120));
    let spec = "a=build=auto,width=8,order=auto";
    let first = choices(&render_all("bedroom", &scenes, spec, 7));
    assert_eq!(first, choices(&render_all("bedroom", &scenes, spec, 7)));
    assert!(
        first.iter().any(|c| c.3.starts_with("explore:")),
        "{first:?}"
    );
}

#[test]
fn bad_auto_values_are_refused_naming_the_setting() {
    for (flag, value) in [("--order", "auto:xyz"), ("--build", "autox")] {
        let out = antumbra()
            .args([
                "render",
                "--scene",
                "bedroom",
                "--triangles",
                "500",
                "--size",
                "8x8",
            ])
            .args([flag, value])
            .output()
            .unwrap();
        assert!(!out.status.success(), "{flag} {value} accepted");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains(&flag[2..]) && err.contains(value), "{err}");
    }
    let named = NamedSettings::new().with("order", "auto:budget=0.1");
    let err = named.resolve().unwrap_err().to_string();
    assert!(err.contains("order") && err.contains("auto"), "{err}");
}

#[test]
fn a_render_told_no_method_renders_with_auto_at_width_8() {
    let tmp = TempDir::new().unwrap();
    let render = |out: &str, method: &[&str]| {
        ok(antumbra()
            .args(["render", "--scene", "indoors", "--triangles", "3000"])
            .args(["--frames", "1-3", "--size", "48x32", "--spp", "2"])
            .args(method)
            .arg("--out")
            .arg(tmp.path().join(out))
            .output()
            .unwrap());
        read_csv(&tmp.path().join(out).join("stats.csv"))
    };
    let told_nothing = render("default", &[]);
    assert!(!told_nothing.is_empty());
    for row in &told_nothing {
        assert_eq!(row["method"], "auto/bin8/auto", "{row:?}");
        assert!(!row["auto_choice"].is_empty(), "{row:?}");
    }
    // The papers' baseline is one flag set away, and answers the same.
    let baseline = render(
        "baseline",
        &["--build", "sah", "--width", "2", "--order", "fbto"],
    );
    assert!(baseline.iter().all(|r| r["method"] == "sah/bin2/fbto"));
    let columns = |rows: &common::Rows| -> Vec<(String, String, String, String)> {
        rows.iter()
            .map(|r| {
                let key = |k: &str| r[k].clone();
                (key("frame"), key("pass"), key("light"), key("rays"))
            })
            .collect()
    };
    assert_eq!(columns(&told_nothing), columns(&baseline));
}

#[test]
fn compare_takes_auto_among_the_methods() {
    let tmp = TempDir::new().unwrap();
    let out = tmp.path().join("cmp");
    ok(antumbra()
        .args([
            "compare",
            "--scene",
            "bedroom",
            "--triangles",
            "3000",
            "--frames",
            "1-4",
        ])
        .args(["--size", "48x32", "--spp", "2", "--repeat", "1"])
        .args(["--method", "base=build=sah,width=2,order=fbto"])
        .args(["--method", "sorted8=build=sah,width=8,order=sorted"])
        .args(["--method", "auto8=build=auto,width=8,order=auto"])
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap());
    let rows = read_csv(&out.join("compare.csv"));
    let auto: Vec<_> = rows.iter().filter(|r| r["label"] == "auto8").collect();
    assert_eq!(auto.len() * 3, rows.len());
    assert!(auto.iter().all(|r| r["method"] == "auto/bin8/auto"));
    assert!(
        auto.iter().all(|r| !r["auto_choice"].is_empty()),
        "{auto:?}"
    );
    assert!(rows
        .iter()
        .filter(|r| r["label"] != "auto8")
        .all(|r| r["auto_choice"].is_empty()));
    let summary = std::fs::read_to_string(out.join("summary.md")).unwrap();
    assert!(summary.contains("auto8"), "{summary}");
    // The hindsight bounds are over the fixed methods only; auto is judged against them.
    assert!(
        summary.contains("Choosing per frame, in hindsight"),
        "{summary}"
    );
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("compare.json")).unwrap()).unwrap();
    let h = &json["hindsight"];
    let total = |label: &str| -> f64 {
        let mut frames: Vec<(&str, f64)> = rows
            .iter()
            .filter(|r| r["label"] == label)
            .map(|r| (r["frame"].as_str(), r["frame_ms"].parse::<f64>().unwrap()))
            .collect();
        frames.dedup();
        frames.iter().map(|(_, ms)| ms).sum()
    };
    let best = h["best_label"].as_str().unwrap();
    let (base, sorted) = (total("base"), total("sorted8"));
    assert_eq!(best, if base <= sorted { "base" } else { "sorted8" });
    let best_ms = h["best_ms"].as_f64().unwrap();
    assert!((best_ms - base.min(sorted)).abs() < 1e-9, "{h}");
    let per_frame = h["per_frame_ms"].as_f64().unwrap();
    let per_pass = h["per_pass_ms"].as_f64().unwrap();
    // Equal up to rounding where one method wins every pass of a frame.
    assert!(
        per_pass <= per_frame + 1e-6 && per_frame <= best_ms + 1e-6,
        "{h}"
    );
    assert_eq!(h["frames"], 4);
    assert_eq!(h["choosers"][0][0], "auto8");
    assert!((h["choosers"][0][1].as_f64().unwrap() - total("auto8")).abs() < 1e-9);
}
