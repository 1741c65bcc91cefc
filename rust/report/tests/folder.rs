//! The report folder on a real comparison of a built-in scene: frames recorded, reopened and
//! listed, the report rewritten from the records byte for byte, other comparisons refused.

use std::path::Path;

use antumbra_core::compare::{Comparison, MethodSpec};
use antumbra_core::scene::Resolution;
use antumbra_core::settings::NamedSettings;
use antumbra_report::{ComparedFrame, ReportFolder, ReportSetup};
use antumbra_scenes::{builtin, SceneParams};
use tempfile::TempDir;

const METHODS: [&str; 3] = [
    "base=build=sah,width=2,order=fbto",
    "sorted4=build=sah,width=4,order=sorted",
    "osah4=build=osah,visibility=previous,width=4,order=sorted",
];
/// Every file `write` makes.
const REPORT: [&str; 8] = [
    "compare.csv",
    "compare.json",
    "summary.md",
    "report.html",
    "plots/shadow_nb.svg",
    "plots/frame_ms.svg",
    "plots/time_parts.svg",
    "plots/pareto.svg",
];

fn specs(methods: &[&str]) -> Vec<MethodSpec> {
    methods.iter().map(|m| m.parse().unwrap()).collect()
}

fn setup(methods: &[&str], baseline: Option<&str>, repeat: usize) -> ReportSetup {
    ReportSetup::new("bedroom", &specs(methods), baseline, repeat).unwrap()
}

/// Frames `frames` of a small bedroom compared with `METHODS` (shared: spp 2).
fn compare(frames: std::ops::RangeInclusive<i32>) -> Vec<ComparedFrame> {
    let params = SceneParams {
        triangles: 3000,
        frames: 4,
        rotated: false,
        instances: None,
    };
    let anim = builtin("bedroom", &params).unwrap();
    let common = NamedSettings::new().with("spp", 2_i64);
    let mut comparison = Comparison::new(&specs(&METHODS), &common, None, 1).unwrap();
    frames
        .map(|f| {
            let mut scene = anim.frame(f);
            scene.resolution = Resolution::new(32, 24);
            let result = comparison.frame("bedroom", &scene).unwrap();
            ComparedFrame::of(&comparison, result)
        })
        .collect()
}

fn read(dir: &Path, file: &str) -> Vec<u8> {
    std::fs::read(dir.join(file)).unwrap_or_else(|e| panic!("{file}: {e}"))
}

#[test]
fn frames_recorded_reopened_and_written_again_byte_for_byte() {
    let tmp = TempDir::new().unwrap();
    let out = tmp.path().join("report");
    let frames = compare(1..=3);
    let mut folder = ReportFolder::open(&out, setup(&METHODS, None, 1)).unwrap();
    assert!(folder.frames().is_empty());
    // Out of order: the report sorts by frame.
    for f in [&frames[2], &frames[0]] {
        folder.add(f.clone()).unwrap();
    }
    assert_eq!(folder.frames(), vec![1, 3]);
    for label in ["sorted4", "osah4"] {
        assert!(out.join(format!("diff/{label}/frame_0003.png")).is_file());
    }
    assert!(
        !out.join("diff/base").exists(),
        "no difference of the baseline with itself"
    );
    drop(folder);

    // Resumed: the frames recorded are listed, the missing one is added.
    let mut folder = ReportFolder::open(&out, setup(&METHODS, None, 1)).unwrap();
    assert_eq!(folder.frames(), vec![1, 3]);
    folder.add(frames[1].clone()).unwrap();
    let html = folder.write().unwrap();
    assert_eq!(html, out.join("report.html"));
    let written: Vec<Vec<u8>> = REPORT.iter().map(|f| read(&out, f)).collect();

    // The same frames recorded in one go, in order, without a reopen: the same files.
    let other = tmp.path().join("other");
    let mut fresh = ReportFolder::create(&other, setup(&METHODS, None, 1)).unwrap();
    for f in &frames {
        fresh.add(f.clone()).unwrap();
    }
    fresh.write().unwrap();
    for (file, bytes) in REPORT.iter().zip(&written) {
        assert!(
            read(&other, file) == *bytes,
            "{file} differs after the reopen"
        );
    }
    let csv = String::from_utf8(read(&out, "compare.csv")).unwrap();
    let mut r = csv.lines().skip(1).map(|l| l.split(',').next().unwrap());
    // Frame order, then method order: base's rows of frame 1 come first.
    assert_eq!(r.next(), Some("base"));
    for m in METHODS.iter().map(|m| m.split_once('=').unwrap().0) {
        assert!(csv.lines().any(|l| l.starts_with(&format!("{m},"))), "{m}");
    }
    let json = String::from_utf8(read(&out, "compare.json")).unwrap();
    assert!(
        json.contains("\"spp\": 2"),
        "shared settings in compare.json"
    );
}

#[test]
fn a_folder_of_another_comparison_is_refused_naming_what_differs() {
    let tmp = TempDir::new().unwrap();
    let out = tmp.path().join("report");
    ReportFolder::open(&out, setup(&METHODS, None, 3)).unwrap();
    let refused = |s: ReportSetup| match ReportFolder::open(&out, s) {
        Ok(_) => panic!("opened"),
        Err(e) => format!("{e:#}"),
    };
    let e = refused(setup(&METHODS[..2], None, 3));
    assert!(
        e.contains("methods: recorded") && !e.contains("repeat"),
        "{e}"
    );
    let e = refused(setup(&METHODS, Some("osah4"), 1));
    assert!(e.contains("baseline: recorded 'base', now 'osah4'"), "{e}");
    assert!(e.contains("repeat: recorded 3, now 1"), "{e}");
    let e = refused(ReportSetup::new("city", &specs(&METHODS), None, 3).unwrap());
    assert!(e.contains("scene: recorded 'bedroom', now 'city'"), "{e}");
    // The same setup opens; a fresh one replaces the folder's.
    ReportFolder::open(&out, setup(&METHODS, None, 3)).unwrap();
    ReportFolder::create(&out, setup(&METHODS[..2], None, 3)).unwrap();
    ReportFolder::open(&out, setup(&METHODS[..2], None, 3)).unwrap();
}

#[test]
fn frames_of_another_comparison_are_refused() {
    let tmp = TempDir::new().unwrap();
    let frames = compare(1..=2);
    let mut folder = ReportFolder::open(tmp.path(), setup(&METHODS, None, 2)).unwrap();
    let e = format!("{:#}", folder.add(frames[0].clone()).unwrap_err());
    assert!(
        e.contains("repeat: the report has 2, the frame has 1"),
        "{e}"
    );
    let mut folder = ReportFolder::create(tmp.path(), setup(&METHODS, None, 1)).unwrap();
    folder.add(frames[0].clone()).unwrap();
    let mut other = frames[1].clone();
    other.settings = NamedSettings::new().with("spp", 4_i64);
    let e = format!("{:#}", folder.add(other).unwrap_err());
    assert!(e.contains("other shared settings"), "{e}");
    assert_eq!(folder.frames(), vec![1]);
    // create forgets what was recorded.
    let folder = ReportFolder::create(tmp.path(), setup(&METHODS, None, 1)).unwrap();
    assert!(folder.frames().is_empty());
}
