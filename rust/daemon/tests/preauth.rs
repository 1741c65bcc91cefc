//! Before authentication: what a TCP (or Unix) client that has not said a valid `Hello` can
//! make the daemon spend: frame size, time and connection slots (issue 24, finding 7).

mod common;

use std::io::{ErrorKind, Read, Write};
use std::net::{SocketAddr, TcpStream};
use std::time::{Duration, Instant};

use antumbra_daemon::DaemonConfig;
use antumbra_protocol::client::Client;
use antumbra_protocol::{encode_message, ErrorCode, Reply, Request, PROTOCOL_VERSION};
use common::*;

const TOKEN: &str = "preauth-token";

fn tcp_daemon(tag: &str, configure: impl FnOnce(&mut DaemonConfig)) -> TestDaemon {
    TestDaemon::start_with(tag, |c| {
        c.tcp = Some("127.0.0.1:0".parse().unwrap());
        c.token = Some(TOKEN.into());
        configure(c);
    })
}

fn tcp_client(addr: SocketAddr) -> Client {
    let c = Client::connect_tcp(addr).unwrap();
    c.set_timeout(Some(TIMEOUT)).unwrap();
    c
}

/// A TCP client with the token renders a frame.
fn tcp_friend_renders(addr: SocketAddr) {
    let mut c = tcp_client(addr);
    c.hello("friend", Some(TOKEN)).unwrap();
    c.send_scene(&tiny_scene(1, 16, 12)).unwrap();
    render_reply(&mut c, 1, 1);
}

/// True once the daemon has closed `s` (end of stream, a reply, or a reset); false while it
/// stays open and silent.
fn closed_by_daemon(s: &mut TcpStream) -> bool {
    s.set_nonblocking(true).unwrap();
    let mut buf = [0u8; 256];
    let closed = match s.read(&mut buf) {
        Ok(_) => true,
        Err(e) => e.kind() != ErrorKind::WouldBlock,
    };
    s.set_nonblocking(false).unwrap();
    closed
}

#[test]
fn a_first_frame_of_300_mb_is_refused_from_its_prefix() {
    let d = tcp_daemon("big-hello", |_| {});
    let addr = d.tcp.unwrap();
    let unix = || {
        let c = Client::connect_unix(&d.socket).unwrap();
        c.set_timeout(Some(TIMEOUT)).unwrap();
        c
    };
    for (socket, mut c) in [("tcp", tcp_client(addr)), ("unix", unix())] {
        // A generous wait, but far below what the 300 MB body would take (it never comes).
        c.set_timeout(Some(Duration::from_secs(15))).unwrap();
        let mut bytes = 300_000_000u32.to_le_bytes().to_vec();
        bytes.extend_from_slice(b"\x83\xa5Hello");
        c.send_raw(&bytes).unwrap();
        let reply = c
            .recv()
            .unwrap_or_else(|e| panic!("{socket}: no answer before the body: {e}"));
        let (code, message, usable, _) = expect_error(reply);
        assert_eq!(code, ErrorCode::TooLarge, "{socket}: {message}");
        assert!(
            message.contains("300000000") && message.contains("65536"),
            "{socket}: {message}"
        );
        assert!(!usable, "{socket}");
        assert_closed(&mut c);
    }
    // Nothing else is disturbed.
    tcp_friend_renders(addr);
    Bystander::new(&d).still_served();
}

#[test]
fn a_hello_sent_a_byte_a_second_is_cut_off_at_the_handshake_deadline() {
    let deadline = Duration::from_secs(2);
    let d = tcp_daemon("slow-hello", |c| c.handshake_timeout = deadline);
    let addr = d.tcp.unwrap();
    let hello = encode_message(&Request::Hello {
        version: PROTOCOL_VERSION,
        client: "slow".into(),
        token: Some(TOKEN.into()),
    })
    .unwrap();
    assert!(hello.len() > 20);
    let mut s = TcpStream::connect(addr).unwrap();
    // Each read waits up to 1 s for the daemon to close: that paces the bytes too.
    s.set_read_timeout(Some(Duration::from_secs(1))).unwrap();
    let start = Instant::now();
    let give_up = Duration::from_secs(15);
    let mut got = Vec::new();
    let mut closed_after = None;
    // Never the last byte: the Hello stays incomplete.
    for &byte in &hello[..hello.len() - 1] {
        if s.write_all(&[byte]).is_err() {
            closed_after = Some(start.elapsed());
            break;
        }
        let mut buf = [0u8; 512];
        match s.read(&mut buf) {
            Ok(n) => {
                got.extend_from_slice(&buf[..n]);
                closed_after = Some(start.elapsed());
                break;
            }
            Err(e) if matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::TimedOut) => {}
            Err(_) => {
                closed_after = Some(start.elapsed());
                break;
            }
        }
        if start.elapsed() > give_up {
            break;
        }
    }
    let closed_after = closed_after.unwrap_or_else(|| {
        panic!(
            "a client sending a byte a second was still connected after {:.1} s (deadline {} s)",
            start.elapsed().as_secs_f64(),
            deadline.as_secs()
        )
    });
    // The deadline, plus a generous margin for a loaded machine.
    assert!(
        closed_after < deadline + Duration::from_secs(8),
        "closed after {closed_after:?}"
    );
    // The reply, if it arrived, says why.
    if !got.is_empty() {
        let _ = s.read_to_end(&mut got);
        let reply: Reply = antumbra_protocol::read_message(
            &mut got.as_slice(),
            &antumbra_protocol::Limits::default(),
        )
        .unwrap();
        let (_, message, usable, _) = expect_error(reply);
        assert!(message.contains("handshake") && !usable, "{message}");
    }
    tcp_friend_renders(addr);
}

#[test]
fn unauthenticated_tcp_connections_cannot_keep_unix_clients_out() {
    let d = tcp_daemon("pending", |c| {
        c.max_sessions = 4;
        c.max_pending_handshakes = 4;
        // Far beyond the test: the idle connections stay until dropped.
        c.handshake_timeout = Duration::from_secs(600);
    });
    let addr = d.tcp.unwrap();
    let mut idle: Vec<TcpStream> = (0..20).map(|_| TcpStream::connect(addr).unwrap()).collect();
    // Once the daemon has accepted all 20 it has closed 16 of them (those past the cap).
    let deadline = Instant::now() + TIMEOUT;
    loop {
        let closed = idle.iter_mut().map(closed_by_daemon).filter(|&c| c).count();
        if closed >= 16 {
            break;
        }
        assert!(
            Instant::now() < deadline,
            "only {closed} of 20 idle connections were closed"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
    // They hold no session: a Unix client gets one and renders.
    let mut local = d.raw_client();
    local
        .hello("local", None)
        .unwrap_or_else(|e| panic!("a unix client was refused: {e}"));
    drop(local);
    Bystander::new(&d).still_served();
    assert!(d.handle.stats().sessions <= 1, "{:?}", d.handle.stats());
    // Once the idle connections leave, a TCP client with the token gets in.
    drop(idle);
    let deadline = Instant::now() + TIMEOUT;
    loop {
        let mut c = tcp_client(addr);
        match c.hello("friend", Some(TOKEN)) {
            Ok(_) => break,
            Err(e) => assert!(Instant::now() < deadline, "{e}"),
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    tcp_friend_renders(addr);
}
