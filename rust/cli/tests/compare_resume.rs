//! `antumbra compare`'s report folder read back by the library: the same frames' records,
//! resumed in another folder, write the CLI's report byte for byte.

use std::path::Path;
use std::process::Command;

use antumbra_report::{ReportFolder, ReportSetup};
use tempfile::TempDir;

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

fn copy_tree(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for entry in std::fs::read_dir(from).unwrap() {
        let entry = entry.unwrap();
        let target = to.join(entry.file_name());
        if entry.file_type().unwrap().is_dir() {
            copy_tree(&entry.path(), &target);
        } else {
            std::fs::copy(entry.path(), target).unwrap();
        }
    }
}

#[test]
fn the_records_of_a_cli_run_write_its_report_byte_for_byte() {
    let tmp = TempDir::new().unwrap();
    let out = tmp.path().join("cli");
    let run = Command::new(env!("CARGO_BIN_EXE_antumbra"))
        .args(["compare", "--scene", "bedroom", "--triangles", "3000"])
        .args([
            "--frames", "1-2", "--size", "40x30", "--spp", "2", "--repeat", "1",
        ])
        .args(["--method", "base=width=2,order=fbto"])
        .args(["--method", "s4=width=4,order=sorted"])
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let copy = tmp.path().join("copy");
    copy_tree(&out.join("frames"), &copy.join("frames"));
    copy_tree(&out.join("diff"), &copy.join("diff"));
    let text = std::fs::read_to_string(out.join("frames/setup.json")).unwrap();
    let setup: ReportSetup = serde_json::from_str(&text).unwrap();
    let folder = ReportFolder::open(&copy, setup).unwrap();
    assert_eq!(folder.frames(), vec![1, 2]);
    folder.write().unwrap();
    for file in REPORT {
        let cli = std::fs::read(out.join(file)).unwrap();
        let again = std::fs::read(copy.join(file)).unwrap();
        assert!(cli == again, "{file} differs from the CLI's");
    }
}
