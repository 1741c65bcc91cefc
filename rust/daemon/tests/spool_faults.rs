//! The spool under fault, with an in-process daemon: a results folder that cannot be written
//! makes the job wait and resume by itself (said once in the log); symbolic links in `jobs/` and
//! `results/` are refused; long and non-UTF-8 job ids end. This binary captures its log.

mod common;

use std::io::Write;
use std::os::unix::fs::{symlink, PermissionsExt};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::{Mutex, Once};
use std::time::Duration;

use antumbra_core::scene::Scene;
use antumbra_daemon::spool::{JobSpec, DONE_FILE, ERROR_FILE};
use common::spool::*;
use common::*;

static LOG: Mutex<Vec<u8>> = Mutex::new(Vec::new());

struct Capture;

impl Write for Capture {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        LOG.lock().unwrap().extend_from_slice(buf);
        Ok(buf.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

/// The log of every test of this binary so far (tests filter it by their job's id).
fn log_lines() -> Vec<String> {
    static INIT: Once = Once::new();
    INIT.call_once(|| {
        tracing_subscriber::fmt()
            .with_writer(|| Capture)
            .with_ansi(false)
            .with_max_level(tracing::Level::INFO)
            .try_init()
            .unwrap();
    });
    String::from_utf8_lossy(&LOG.lock().unwrap())
        .lines()
        .map(str::to_string)
        .collect()
}

fn is_root() -> bool {
    // SAFETY: geteuid has no preconditions.
    unsafe { libc::geteuid() == 0 }
}

fn can_write_in(dir: &Path) -> bool {
    let probe = dir.join(".probe");
    let ok = std::fs::write(&probe, b"").is_ok();
    let _ = std::fs::remove_file(&probe);
    ok
}

/// A spool's job results folder made unwritable for real, also for root: read-only (chmod)
/// for a user; for root (whom chmod does not stop) immutable (`chattr +i`) where the file
/// system allows it, else the whole `results/` folder replaced by a file. Undone on drop.
enum Blocked {
    ReadOnly(PathBuf),
    Immutable(PathBuf),
    ResultsIsAFile(PathBuf),
    Restored,
}

impl Blocked {
    fn new(results_root: &Path, job: &str) -> Blocked {
        let dir = results_root.join(job);
        std::fs::create_dir_all(&dir).unwrap();
        let blocked = if !is_root() {
            std::fs::set_permissions(&dir, std::fs::Permissions::from_mode(0o555)).unwrap();
            Blocked::ReadOnly(dir.clone())
        } else if Command::new("chattr")
            .arg("+i")
            .arg(&dir)
            .status()
            .is_ok_and(|s| s.success())
        {
            Blocked::Immutable(dir.clone())
        } else {
            std::fs::remove_dir_all(results_root).unwrap();
            std::fs::write(results_root, b"not a folder").unwrap();
            Blocked::ResultsIsAFile(results_root.to_path_buf())
        };
        assert!(!can_write_in(&dir), "{} is still writable", dir.display());
        blocked
    }

    fn restore(&mut self) {
        let was = std::mem::replace(self, Blocked::Restored);
        match &was {
            Blocked::ReadOnly(dir) => {
                std::fs::set_permissions(dir, std::fs::Permissions::from_mode(0o755)).unwrap()
            }
            Blocked::Immutable(dir) => {
                let ok = Command::new("chattr").arg("-i").arg(dir).status().unwrap();
                assert!(ok.success(), "chattr -i {}", dir.display());
            }
            Blocked::ResultsIsAFile(results) => {
                std::fs::remove_file(results).unwrap();
                std::fs::create_dir(results).unwrap();
            }
            Blocked::Restored => {}
        }
        std::mem::forget(was);
    }
}

impl Drop for Blocked {
    fn drop(&mut self) {
        self.restore();
    }
}

fn status(root: &Path) -> serde_json::Value {
    std::fs::read(root.join("status.json"))
        .ok()
        .and_then(|b| serde_json::from_slice(&b).ok())
        .unwrap_or(serde_json::Value::Null)
}

fn read(path: &Path) -> String {
    std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

fn scenes(n: i32) -> Vec<Scene> {
    (1..=n).map(|f| tiny_scene(f, 16, 12)).collect()
}

fn start(spool: &Path) -> TestDaemon {
    let root = spool.to_path_buf();
    TestDaemon::start_with("spool-fault", |c| c.spool = Some(root))
}

#[test]
fn failed_writes_wait_with_a_status_and_resume_without_a_restart() {
    let spool = temp_dir("spool-ro");
    let d = start(spool.path());
    let results_root = spool.path().join("results");
    let mut blocked = Blocked::new(&results_root, "job-w");
    submit(spool.path(), "job-w", &scenes(3), &JobSpec::default());
    // The job waits, retrying, and says so in the spool's status file.
    wait_until("a waiting status after two retries", || {
        let s = status(spool.path());
        s["state"] == "waiting" && s["retry"].as_u64().is_some_and(|r| r >= 2)
    });
    let s = status(spool.path());
    let message = s["message"].as_str().unwrap();
    assert!(message.contains("cannot write"), "{s}");
    assert!(message.contains("job-w"), "{s}");
    assert_eq!(s["job"], "job-w", "{s}");
    assert!(s["retry_in_s"].as_f64().is_some(), "{s}");
    let results = results_root.join("job-w");
    assert!(results.join(DONE_FILE).symlink_metadata().is_err());
    assert!(results.join(ERROR_FILE).symlink_metadata().is_err());
    // Writing works again: the job finishes without a restart.
    blocked.restore();
    wait_for_file(&results.join(DONE_FILE));
    let m = manifest(&results);
    assert_eq!(m.frames.len(), 3);
    assert_eq!(d.handle.stats().renders_done, 3);
    wait_until("the status to leave 'waiting'", || {
        status(spool.path())["state"] != "waiting"
    });
}

#[test]
fn symlinked_or_foreign_results_folder_is_refused_and_nothing_is_written_into_it() {
    let spool = temp_dir("spool-link");
    let elsewhere = temp_dir("spool-link-target");
    let results_root = spool.path().join("results");
    std::fs::create_dir_all(&results_root).unwrap();
    symlink(elsewhere.path(), results_root.join("job-link")).unwrap();
    // A folder of another user (only root can make one).
    let foreign = results_root.join("job-foreign");
    if is_root() {
        std::fs::create_dir(&foreign).unwrap();
        std::os::unix::fs::chown(&foreign, Some(65534), Some(65534)).unwrap();
    }
    let d = start(spool.path());
    submit(spool.path(), "job-link", &scenes(2), &JobSpec::default());
    if is_root() {
        submit(spool.path(), "job-foreign", &scenes(2), &JobSpec::default());
    }
    // Submitted last, its id sorts last: once it is done the others were handled.
    submit(spool.path(), "zz-good", &scenes(1), &JobSpec::default());
    wait_for_file(&results_root.join("zz-good").join(DONE_FILE));
    let error = results_root.join("job-link.ERROR");
    assert!(
        error.symlink_metadata().is_ok_and(|m| m.is_file()),
        "no {}",
        error.display()
    );
    let e = read(&error);
    assert!(e.contains("results/job-link"), "{e}");
    assert!(e.contains("symbolic link"), "{e}");
    let written: Vec<_> = std::fs::read_dir(elsewhere.path()).unwrap().collect();
    assert!(written.is_empty(), "written through the link: {written:?}");
    if is_root() {
        let e = read(&results_root.join("job-foreign.ERROR"));
        assert!(e.contains("results/job-foreign"), "{e}");
        assert!(e.contains("owned by"), "{e}");
        assert_eq!(std::fs::read_dir(&foreign).unwrap().count(), 0);
    }
    assert_eq!(d.handle.stats().renders_done, 1);
}

#[test]
fn symlinked_frame_folder_is_not_a_finished_frame() {
    let spool = temp_dir("spool-frame-link");
    let decoy = temp_dir("spool-decoy");
    std::fs::write(decoy.path().join("decoy"), b"x").unwrap();
    let results = spool.path().join("results/job-f");
    std::fs::create_dir_all(&results).unwrap();
    symlink(decoy.path(), results.join("frame_0001")).unwrap();
    let _d = start(spool.path());
    submit(spool.path(), "job-f", &scenes(2), &JobSpec::default());
    submit(spool.path(), "zz-good", &scenes(1), &JobSpec::default());
    wait_for_file(&spool.path().join("results/zz-good").join(DONE_FILE));
    assert!(
        results.join(DONE_FILE).symlink_metadata().is_err(),
        "the job was marked done"
    );
    let e = read(&results.join(ERROR_FILE));
    assert!(e.contains("results/job-f/frame_0001"), "{e}");
    assert!(e.contains("symbolic link"), "{e}");
    let names: Vec<String> = std::fs::read_dir(decoy.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert_eq!(names, vec!["decoy".to_string()]);
}

#[test]
fn symlinked_job_folder_is_refused() {
    let spool = temp_dir("spool-job-link");
    let staging = temp_dir("spool-job-link-real");
    let real = staging.path().join("job-s");
    std::fs::create_dir_all(&real).unwrap();
    std::fs::write(real.join("job.json"), b"{}").unwrap();
    write_recording(&real.join("scene.antrec"), &scenes(1)).unwrap();
    let _d = start(spool.path());
    std::fs::create_dir_all(spool.path().join("jobs")).unwrap();
    symlink(&real, spool.path().join("jobs/job-s")).unwrap();
    submit(spool.path(), "zz-good", &scenes(1), &JobSpec::default());
    let results = spool.path().join("results");
    wait_for_file(&results.join("zz-good").join(DONE_FILE));
    let e = read(&results.join("job-s").join(ERROR_FILE));
    assert!(e.contains("jobs/job-s"), "{e}");
    assert!(e.contains("symbolic link"), "{e}");
}

/// Submits `id` before any daemon runs, under a short id renamed to `id` afterwards: ids that
/// `submit_job` refuses (too long, not UTF-8) can still be made by hand.
fn submit_as(spool: &Path, id: &std::ffi::OsStr, frames: i32) {
    submit(spool, "renamed-later", &scenes(frames), &JobSpec::default());
    let jobs = spool.join("jobs");
    std::fs::rename(jobs.join("renamed-later"), jobs.join(id)).unwrap();
}

/// A job id so long that the temporary name of `results/<id>.ERROR` passed 255 bytes: the
/// refusal was retried for ever and every later job waited (issue 33). Its refusal is now
/// written; an id so long that even `<id>.ERROR` cannot be a name is skipped without a wait.
#[test]
fn long_job_ids_with_a_refused_results_folder_end_and_later_jobs_run() {
    let spool = temp_dir("spool-long-id");
    let elsewhere = temp_dir("spool-long-id-target");
    let long = format!("j{}", "x".repeat(239));
    let too_long = format!("k{}", "x".repeat(251));
    submit_as(spool.path(), long.as_ref(), 1);
    submit_as(spool.path(), too_long.as_ref(), 1);
    submit(spool.path(), "zz-good", &scenes(1), &JobSpec::default());
    let results_root = spool.path().join("results");
    std::fs::create_dir_all(&results_root).unwrap();
    for id in [&long, &too_long] {
        symlink(elsewhere.path(), results_root.join(id)).unwrap();
    }
    let d = start(spool.path());
    wait_for_file(&results_root.join("zz-good").join(DONE_FILE));
    let e = read(&results_root.join(format!("{long}.ERROR")));
    assert!(e.contains("symbolic link"), "{e}");
    assert!(status(spool.path())["state"] != "waiting");
    assert_eq!(std::fs::read_dir(elsewhere.path()).unwrap().count(), 0);
    assert_eq!(d.handle.stats().renders_done, 1);
}

/// A job folder whose name is not UTF-8 ended in ERROR under a name with U+FFFD in it, saying
/// its job.json was missing. Its ERROR is now under the name with `\xNN` escapes, says why, and
/// a later daemon does not write it again.
#[test]
fn job_folder_not_utf8_ends_in_error_under_a_readable_name() {
    use std::os::unix::ffi::OsStrExt;
    let spool = temp_dir("spool-not-utf8");
    submit_as(spool.path(), std::ffi::OsStr::from_bytes(b"bad-\xff"), 1);
    submit(spool.path(), "zz-good", &scenes(1), &JobSpec::default());
    let results_root = spool.path().join("results");
    let error = results_root.join("bad-\\xFF").join(ERROR_FILE);
    let written = {
        let _d = start(spool.path());
        wait_for_file(&results_root.join("zz-good").join(DONE_FILE));
        let e = read(&error);
        assert!(e.contains("jobs/bad-\\xFF"), "{e}");
        assert!(e.contains("not UTF-8"), "{e}");
        std::fs::metadata(&error).unwrap().modified().unwrap()
    };
    let names: Vec<String> = std::fs::read_dir(&results_root)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert!(!names.iter().any(|n| n.contains('\u{FFFD}')), "{names:?}");
    // The next daemon sees the job ended: nothing written again.
    submit(spool.path(), "zz-later", &scenes(1), &JobSpec::default());
    let _d = start(spool.path());
    wait_for_file(&results_root.join("zz-later").join(DONE_FILE));
    assert_eq!(
        std::fs::metadata(&error).unwrap().modified().unwrap(),
        written
    );
}

/// A frame folder that cannot be made was logged at every retry: its message held the
/// temporary folder's name, new at each try (issue 33). Now once per wait, and the status names
/// the frame's folder.
#[test]
fn a_waiting_write_is_logged_once_not_at_every_retry() {
    log_lines();
    let spool = temp_dir("spool-log");
    let root = spool.path().to_path_buf();
    let _d = TestDaemon::start_with("spool-log", |c| {
        c.spool = Some(root);
        c.spool_retry_min = Duration::from_millis(20);
        c.spool_retry_max = Duration::from_millis(40);
    });
    let results_root = spool.path().join("results");
    let results = results_root.join("job-log");
    // attempts.log exists and takes lines; only new names (the frame's folder) fail.
    std::fs::create_dir_all(&results).unwrap();
    std::fs::write(results.join("attempts.log"), b"").unwrap();
    let mut blocked = Blocked::new(&results_root, "job-log");
    submit(spool.path(), "job-log", &scenes(1), &JobSpec::default());
    wait_until("a waiting status after six retries", || {
        let s = status(spool.path());
        s["state"] == "waiting" && s["retry"].as_u64().is_some_and(|r| r >= 6)
    });
    let s = status(spool.path());
    let message = s["message"].as_str().unwrap();
    assert!(!message.contains(".tmp-"), "{s}");
    blocked.restore();
    wait_for_file(&results.join(DONE_FILE));
    let mine: Vec<String> = log_lines()
        .into_iter()
        .filter(|l| l.contains("job-log"))
        .collect();
    let waits = mine
        .iter()
        .filter(|l| l.contains("waiting and retrying"))
        .count();
    assert_eq!(waits, 1, "{mine:#?}");
    let again = mine
        .iter()
        .filter(|l| l.contains("writing works again"))
        .count();
    assert_eq!(again, 1, "{mine:#?}");
}
