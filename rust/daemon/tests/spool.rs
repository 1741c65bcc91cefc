//! The spool folder with an in-process daemon: jobs picked up, rendered, resumed.

mod common;

use std::path::{Path, PathBuf};

use antumbra_core::output::read_exr;
use antumbra_core::render::RenderSettings;
use antumbra_core::scene::Scene;
use antumbra_daemon::spool::{JobSpec, DONE_FILE, ERROR_FILE};
use common::spool::*;
use common::*;

#[test]
fn job_is_rendered_into_complete_frame_folders() {
    let spool = temp_dir("spool-job");
    let d = TestDaemon::start_with("spool", |c| c.spool = Some(spool.path().to_path_buf()));
    let scenes: Vec<Scene> = (1..=4).map(|f| tiny_scene(f, 24, 16)).collect();
    // Submitted while the daemon runs: the watcher (or the rescan) picks it up.
    let spec = JobSpec {
        name: Some("shot".into()),
        ..JobSpec::default()
    };
    submit(spool.path(), "job-a", &scenes, &spec);
    let results = spool.path().join("results/job-a");
    wait_for_file(&results.join(DONE_FILE));
    let m = manifest(&results);
    assert!(m.done);
    assert_eq!(m.frames_total, 4);
    assert_eq!(
        m.frames.iter().map(|f| f.frame).collect::<Vec<_>>(),
        vec![1, 2, 3, 4]
    );
    let expected = render_in_process("shot", &scenes, &RenderSettings::default());
    for (f, want) in m.frames.iter().zip(&expected) {
        let dir = results.join(&f.dir);
        assert!(f.files.contains(&"stats.json".to_string()));
        assert!(
            f.files.iter().any(|n| n.ends_with("_combined.png")),
            "{:?}",
            f.files
        );
        let planes = read_exr(&dir.join(format!("{}.exr", f.dir))).unwrap();
        let want_planes = antumbra_core::output::planes(want);
        assert_eq!(planes.len(), want_planes.len());
        for w in &want_planes {
            let g = planes
                .iter()
                .find(|p| p.name == w.name)
                .expect("plane in the EXR");
            assert!(g
                .data
                .iter()
                .zip(&w.data)
                .all(|(a, b)| a.to_bits() == b.to_bits()));
        }
        let stats: Vec<antumbra_core::stats::StatsRow> =
            serde_json::from_slice(&std::fs::read(dir.join("stats.json")).unwrap()).unwrap();
        assert_eq!(stats.len(), want.stats.len());
        assert_eq!(stats[0].scene, "shot");
    }
    assert_eq!(d.handle.stats().renders_done, 4);
    // No temporaries left.
    for e in std::fs::read_dir(&results).unwrap().flatten() {
        let n = e.file_name().to_string_lossy().into_owned();
        assert!(!n.starts_with('.'), "leftover {n}");
    }
}

#[test]
fn restart_skips_finished_frames_and_cleans_temporaries() {
    let spool = temp_dir("spool-resume");
    let scenes: Vec<Scene> = (1..=3).map(|f| tiny_scene(f, 24, 16)).collect();
    let spec = JobSpec {
        frames: Some(vec![3, 1, 2, 1]),
        outputs: antumbra_core::output::Outputs {
            png: false,
            ..Default::default()
        },
        ..JobSpec::default()
    };
    submit(spool.path(), "job-b", &scenes, &spec);
    // What a killed daemon leaves: frame 1 finished, frame 2 half-written in a temp folder, a
    // temporary manifest.
    let results = spool.path().join("results/job-b");
    std::fs::create_dir_all(results.join("frame_0001")).unwrap();
    std::fs::write(results.join("frame_0001/marker"), b"kept").unwrap();
    std::fs::create_dir_all(results.join(".tmp-frame_0002-999-0")).unwrap();
    std::fs::write(
        results.join(".tmp-frame_0002-999-0/frame_0002.exr"),
        b"half",
    )
    .unwrap();
    std::fs::write(results.join(".manifest.json.999-0.antumbra-tmp"), b"{").unwrap();
    let d = TestDaemon::start_with("spool-resume", |c| {
        c.spool = Some(spool.path().to_path_buf())
    });
    wait_for_file(&results.join(DONE_FILE));
    let m = manifest(&results);
    assert_eq!(
        m.frames.iter().map(|f| f.frame).collect::<Vec<_>>(),
        vec![3, 1, 2]
    );
    // Frame 1 was not rendered again.
    assert_eq!(
        std::fs::read(results.join("frame_0001/marker")).unwrap(),
        b"kept"
    );
    assert_eq!(m.frames[1].files, vec!["marker".to_string()]);
    assert_eq!(d.handle.stats().renders_done, 2);
    assert_eq!(
        m.frames[0].files,
        vec!["frame_0003.exr".to_string(), "stats.json".to_string()]
    );
    assert!(!results.join(".tmp-frame_0002-999-0").exists());
    assert!(!results.join(".manifest.json.999-0.antumbra-tmp").exists());
}

#[test]
fn bad_jobs_get_an_error_file_and_others_still_run() {
    let spool = temp_dir("spool-bad");
    let d = TestDaemon::start_with("spool-bad", |c| c.spool = Some(spool.path().to_path_buf()));
    // Each bad job is made in a side folder and renamed into jobs/ whole, as clients must:
    // a half-made folder in jobs/ is itself a bad job.
    let jobs = spool.path().join("jobs");
    let staging = spool.path().join("staging");
    std::fs::create_dir_all(&jobs).unwrap();
    let place = |id: &str, make: &dyn Fn(&Path)| {
        let dir = staging.join(id);
        std::fs::create_dir_all(&dir).unwrap();
        make(&dir);
        std::fs::rename(&dir, jobs.join(id)).unwrap();
    };
    let mkfifo = |p: PathBuf| {
        let ok = std::process::Command::new("mkfifo")
            .arg(&p)
            .status()
            .unwrap();
        assert!(ok.success(), "mkfifo {}", p.display());
    };
    // Unknown field in job.json.
    place("bad-json", &|d| {
        std::fs::write(d.join("job.json"), br#"{"frmaes": [1]}"#).unwrap()
    });
    // A recording that is not one.
    place("bad-scene", &|d| {
        std::fs::write(d.join("job.json"), b"{}").unwrap();
        std::fs::write(d.join("scene.antrec"), b"not a recording").unwrap();
    });
    // A FIFO as job.json or as the recording: opening one for reading would block the spool
    // for good (the jobs sort before "good", so "good" finishing shows they did not block).
    place("fifo-json", &|d| mkfifo(d.join("job.json")));
    place("fifo-scene", &|d| {
        std::fs::write(d.join("job.json"), b"{}").unwrap();
        mkfifo(d.join("scene.antrec"));
    });
    let scenes = vec![tiny_scene(1, 16, 12)];
    submit(spool.path(), "good", &scenes, &JobSpec::default());
    let results = spool.path().join("results");
    wait_for_file(&results.join("good").join(DONE_FILE));
    for fifo in ["fifo-json", "fifo-scene"] {
        wait_for_file(&results.join(fifo).join(ERROR_FILE));
        let e = std::fs::read_to_string(results.join(fifo).join(ERROR_FILE)).unwrap();
        assert!(e.contains("not a regular file"), "{fifo}: {e}");
    }
    wait_for_file(&results.join("bad-json").join(ERROR_FILE));
    wait_for_file(&results.join("bad-scene").join(ERROR_FILE));
    let e = std::fs::read_to_string(results.join("bad-json").join(ERROR_FILE)).unwrap();
    assert!(e.contains("frmaes"), "{e}");
    let e = std::fs::read_to_string(results.join("bad-scene").join(ERROR_FILE)).unwrap();
    assert!(e.contains("not an antumbra recording"), "{e}");
    drop(d);
}

#[test]
fn one_daemon_per_spool() {
    let spool = temp_dir("spool-lock");
    let _d = TestDaemon::start_with("spool-lock", |c| c.spool = Some(spool.path().to_path_buf()));
    let dir = temp_dir("spool-lock2");
    let mut config = antumbra_daemon::DaemonConfig::new(dir.path().join("d.sock"));
    config.spool = Some(spool.path().to_path_buf());
    let err = antumbra_daemon::Daemon::bind(config)
        .err()
        .expect("second daemon refused");
    assert!(err.to_string().contains("another daemon"), "{err}");
}
