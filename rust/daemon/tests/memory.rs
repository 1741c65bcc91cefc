//! The render memory budget: a frame estimated to need more than `max_render_bytes` is refused
//! before any work, over the socket and in the spool, and the daemon goes on serving.

mod common;

use std::path::Path;
use std::time::{Duration, Instant};

use antumbra_core::render::RenderSettings;
use antumbra_daemon::spool::{submit_job, JobSpec, DONE_FILE, ERROR_FILE};
use antumbra_protocol::{
    ErrorCode, NamedSettings, Passes, RecordingWriter, RenderRequest, Request,
};
use common::*;

/// A budget far below what a 2048x2048 frame needs (about 0.9 GiB with counters) and far above
/// what a 64x48 frame needs.
const SMALL_BUDGET: u64 = 64 << 20;

fn wait_for_file(path: &Path) {
    let deadline = Instant::now() + TIMEOUT;
    while !path.exists() {
        assert!(
            Instant::now() < deadline,
            "timed out waiting for {}",
            path.display()
        );
        std::thread::sleep(Duration::from_millis(20));
    }
}

#[test]
fn a_render_over_the_memory_budget_is_refused_and_the_session_goes_on() {
    let d = TestDaemon::start_with("render-memory", |c| {
        c.limits.max_render_bytes = SMALL_BUDGET
    });
    let mut other = Bystander::new(&d);
    let mut c = d.client("big");
    // Only the combined pass is asked for: the per-pixel buffers of the passes still count.
    let passes = Passes {
        masks: false,
        combined: true,
        heat_maps: false,
        visible_set: false,
        object_ids: false,
    };
    // 2048x2048 first: without the budget this one renders (about 1 GB) and the test fails here
    // on its Progress reply, before the 8192x8192 frame could be sent.
    for (frame, size) in [(1, 2048), (2, 8192)] {
        c.send_scene(&tiny_scene(frame, size, size)).unwrap();
        c.send(&Request::Render(RenderRequest {
            frame,
            settings: NamedSettings::default(),
            passes,
            request_id: frame as u64,
            warm_up: false,
        }))
        .unwrap();
        let (code, message, usable, request_id) = expect_error(c.recv().unwrap());
        assert_eq!(code, ErrorCode::LimitExceeded, "{message}");
        assert!(
            message.contains(&format!("frame {frame}"))
                && message.contains(&format!("{size}x{size} pixels"))
                && message.contains("render memory budget of 64.0 MiB")
                && message.contains("max_render_bytes"),
            "{message}"
        );
        assert!(usable);
        assert_eq!(request_id, Some(frame as u64));
    }
    // The session still renders a frame within the budget, exactly as in process.
    let small = tiny_scene(3, 64, 48);
    c.send_scene(&small).unwrap();
    let reply = render_reply(&mut c, 3, 3);
    let want = render_in_process("big", &[small], &RenderSettings::default());
    assert_same_result(&reply, &want[0]);
    let stats = d.wait_for_stats("two refused renders", |s| s.renders_failed >= 2);
    assert_eq!(stats.renders_failed, 2);
    other.still_served();
}

#[test]
fn the_welcome_carries_the_budget() {
    let d = TestDaemon::start_with("render-memory-welcome", |c| {
        c.limits.max_render_bytes = SMALL_BUDGET
    });
    let c = d.client("welcome");
    assert_eq!(c.limits().max_render_bytes, SMALL_BUDGET);
}

#[test]
fn a_spool_job_over_the_memory_budget_gets_an_error_file() {
    let spool = temp_dir("spool-memory");
    let d = TestDaemon::start_with("spool-memory", |c| {
        c.spool = Some(spool.path().to_path_buf());
        c.limits.max_render_bytes = SMALL_BUDGET;
    });
    let submit = |id: &str, size: u32| {
        submit_job(spool.path(), id, &JobSpec::default(), |path| {
            let mut w = RecordingWriter::create(path).map_err(|e| e.to_string())?;
            w.append_scene(&tiny_scene(1, size, size))
                .map_err(|e| e.to_string())?;
            w.finish().map_err(|e| e.to_string())?;
            Ok(())
        })
        .unwrap();
    };
    submit("a-big", 2048);
    submit("b-small", 32);
    let results = spool.path().join("results");
    wait_for_file(&results.join("a-big").join(ERROR_FILE));
    let e = std::fs::read_to_string(results.join("a-big").join(ERROR_FILE)).unwrap();
    assert!(
        e.contains("frame 1")
            && e.contains("2048x2048 pixels")
            && e.contains("render memory budget of 64.0 MiB"),
        "{e}"
    );
    assert!(!results.join("a-big").join("frame_0001").exists());
    // The job behind it still runs.
    wait_for_file(&results.join("b-small").join(DONE_FILE));
    drop(d);
}
