//! Failed TCP token attempts from one address are slowed down and logged once per burst (issue
//! 24, finding 7). Its own test binary: it captures the process's log.

mod common;

use std::io::Write;
use std::sync::Mutex;
use std::time::{Duration, Instant};

use antumbra_protocol::client::Client;
use common::*;

const TOKEN: &str = "throttle-token";

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

fn log_lines() -> Vec<String> {
    String::from_utf8_lossy(&LOG.lock().unwrap())
        .lines()
        .map(str::to_string)
        .collect()
}

#[test]
fn failed_tokens_from_one_address_are_slowed_down_and_logged_once_per_burst() {
    tracing_subscriber::fmt()
        .with_writer(|| Capture)
        .with_ansi(false)
        .with_max_level(tracing::Level::INFO)
        .try_init()
        .unwrap();
    let d = TestDaemon::start_with("throttle", |c| {
        c.tcp = Some("127.0.0.1:0".parse().unwrap());
        c.token = Some(TOKEN.into());
        c.auth_failures_allowed = 3;
        c.auth_backoff = Duration::from_millis(500);
        c.auth_backoff_max = Duration::from_secs(2);
    });
    let addr = d.tcp.unwrap();
    let connect = || {
        let c = Client::connect_tcp(addr).unwrap();
        c.set_timeout(Some(TIMEOUT)).unwrap();
        c
    };
    let attempts = 40;
    let (mut tried, mut held_off) = (0, 0);
    for _ in 0..attempts {
        let message = connect()
            .hello("guesser", Some("wrong-token"))
            .unwrap_err()
            .to_string();
        if message.contains("wrong token") {
            tried += 1;
        } else if message.contains("too many failed") {
            held_off += 1;
        }
    }
    // Three free tries, then a wait that doubles with each failure (up to 2 s).
    assert!(
        held_off > 0,
        "no attempt was held off ({tried} tokens tried)"
    );
    assert!(tried < 10, "{tried} of {attempts} tokens were tried");
    // Once the wait is over, the right token gets in.
    let deadline = Instant::now() + Duration::from_secs(10);
    let mut c = loop {
        let mut c = connect();
        match c.hello("friend", Some(TOKEN)) {
            Ok(_) => break c,
            Err(e) => {
                let message = e.to_string();
                assert!(message.contains("too many failed"), "{message}");
                assert!(Instant::now() < deadline, "still held off: {message}");
            }
        }
        std::thread::sleep(Duration::from_millis(100));
    };
    c.send_scene(&tiny_scene(1, 16, 12)).unwrap();
    render_reply(&mut c, 1, 1);
    drop(c);
    d.stop().unwrap();
    // A few lines for the whole burst, not one (or three) per attempt; one of them sums it up.
    let lines = log_lines();
    let about_peer: Vec<&String> = lines
        .iter()
        .filter(|l| {
            l.contains("127.0.0.1")
                && ["token", "authentication", "Refused", "refused"]
                    .iter()
                    .any(|w| l.contains(w))
        })
        .collect();
    assert!(
        about_peer.len() <= 6,
        "{} log lines for {attempts} attempts:\n{}",
        about_peer.len(),
        lines.join("\n")
    );
    assert!(
        about_peer
            .iter()
            .any(|l| l.contains("failed token attempts from 127.0.0.1")),
        "no summary line:\n{}",
        lines.join("\n")
    );
}
