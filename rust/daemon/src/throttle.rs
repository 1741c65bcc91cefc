//! Failed TCP handshakes per IP address: after a few, the address waits (a back-off that doubles
//! with each failure), and its failures are logged once per burst instead of once per attempt.

use std::collections::HashMap;
use std::net::IpAddr;
use std::time::{Duration, Instant};

use crate::config::DaemonConfig;
use crate::lock;

/// Addresses tracked at once; past it, new addresses share one entry, so a flood of source
/// addresses (all of 127.0.0.0/8 is loopback) cannot grow memory nor escape the back-off.
pub const MAX_TRACKED_PEERS: usize = 1024;

/// A burst's first event is logged at once; the rest are summed up at most once per window.
pub const LOG_WINDOW: Duration = Duration::from_secs(10);

/// Counts events to log once per [`LOG_WINDOW`]: the first at once, the rest as a sum.
#[derive(Default)]
pub(crate) struct Burst {
    /// When the window began (at the last line logged); `None` between bursts.
    since: Option<Instant>,
    /// Events since then not yet in a line.
    counted: u64,
}

impl Burst {
    /// Records an event: true if it should be logged now (the first of a burst).
    pub fn record(&mut self, now: Instant) -> bool {
        if self.since.is_none() {
            self.since = Some(now);
            return true;
        }
        self.counted += 1;
        false
    }

    /// Opens a window without logging (for events that are only ever summed up).
    fn touch(&mut self, now: Instant) {
        self.since.get_or_insert(now);
    }

    /// The events to sum up in a line now (their count and the window's length), once the
    /// window is over or when `force`d; `others` says events counted elsewhere are waiting. A
    /// window with nothing to log ends the burst.
    pub fn due(&mut self, now: Instant, force: bool, others: bool) -> Option<(u64, Duration)> {
        let since = self.since?;
        let span = now.saturating_duration_since(since);
        if span < LOG_WINDOW && !force {
            return None;
        }
        if self.counted == 0 && !others {
            self.since = None;
            return None;
        }
        self.since = Some(now);
        Some((std::mem::take(&mut self.counted), span))
    }

    fn idle(&self) -> bool {
        self.since.is_none() && self.counted == 0
    }
}

#[derive(Default)]
struct Peer {
    failures: u32,
    last_failure: Option<Instant>,
    blocked_until: Option<Instant>,
    /// Failed attempts, and connections refused while the address waits, to log.
    failed_log: Burst,
    refused: u64,
}

struct Peers {
    by_ip: HashMap<IpAddr, Peer>,
    /// The addresses that found the table full.
    others: Peer,
}

/// The back-off of failed handshakes per address (see the module doc).
pub(crate) struct Throttle {
    allowed: u32,
    backoff: Duration,
    backoff_max: Duration,
    peers: std::sync::Mutex<Peers>,
}

/// Names an address in logs: the table's overflow entry has none.
fn who(ip: Option<IpAddr>) -> String {
    ip.map_or_else(|| "other addresses".into(), |ip| ip.to_string())
}

impl Throttle {
    pub fn new(config: &DaemonConfig) -> Self {
        Throttle {
            allowed: config.auth_failures_allowed,
            backoff: config.auth_backoff,
            backoff_max: config.auth_backoff_max.max(config.auth_backoff),
            peers: std::sync::Mutex::new(Peers {
                by_ip: HashMap::new(),
                others: Peer::default(),
            }),
        }
    }

    /// At accept: `Err(wait)` while `ip` must wait after its failures (the connection is then
    /// refused, and counted for the log).
    pub fn check(&self, ip: IpAddr, now: Instant) -> Result<(), Duration> {
        let mut guard = lock(&self.peers);
        let peers = &mut *guard;
        let full = peers.by_ip.len() >= MAX_TRACKED_PEERS;
        let peer = match peers.by_ip.get_mut(&ip) {
            Some(p) => p,
            None if full => &mut peers.others,
            None => return Ok(()),
        };
        match peer.blocked_until {
            Some(until) if until > now => {
                peer.refused += 1;
                peer.failed_log.touch(now);
                Err(until - now)
            }
            _ => Ok(()),
        }
    }

    /// A handshake from `ip` failed for `why`: counts it, starts or lengthens the wait, and logs
    /// it if it is the first of a burst.
    pub fn failed(&self, ip: IpAddr, why: &str, now: Instant) {
        let mut guard = lock(&self.peers);
        let peers = &mut *guard;
        if !peers.by_ip.contains_key(&ip) && peers.by_ip.len() >= MAX_TRACKED_PEERS {
            self.prune(peers, now);
        }
        let (peer, key) = if peers.by_ip.len() < MAX_TRACKED_PEERS || peers.by_ip.contains_key(&ip)
        {
            (peers.by_ip.entry(ip).or_default(), Some(ip))
        } else {
            (&mut peers.others, None)
        };
        // A quiet address starts afresh.
        if peer
            .last_failure
            .is_some_and(|t| now.saturating_duration_since(t) > self.backoff_max)
        {
            peer.failures = 0;
        }
        peer.failures = peer.failures.saturating_add(1);
        peer.last_failure = Some(now);
        let mut wait = None;
        if peer.failures >= self.allowed {
            let doublings = (peer.failures - self.allowed).min(30);
            let w = self
                .backoff
                .saturating_mul(1u32 << doublings)
                .min(self.backoff_max);
            peer.blocked_until = Some(now + w);
            wait = Some(w);
        }
        if peer.failed_log.record(now) {
            tracing::warn!(
                peer = %who(key),
                reason = why,
                failures = peer.failures,
                wait_s = wait.map(|w| w.as_secs_f64()),
                "tcp client refused: authentication failed (further failures from this address \
                 are summed up every {} s)",
                LOG_WINDOW.as_secs()
            );
        }
    }

    /// `ip` sent the right token: its failures are forgotten (after logging their sum).
    pub fn succeeded(&self, ip: IpAddr, now: Instant) {
        let mut peers = lock(&self.peers);
        if let Some(mut peer) = peers.by_ip.remove(&ip) {
            Self::log_due(Some(ip), &mut peer, now, true);
        }
    }

    /// Logs the sums of the bursts whose window is over (all of them with `force`) and forgets
    /// addresses that are quiet; called by the accept loop a few times a second.
    pub fn flush(&self, now: Instant, force: bool) {
        let mut guard = lock(&self.peers);
        let peers = &mut *guard;
        for (ip, peer) in peers.by_ip.iter_mut() {
            Self::log_due(Some(*ip), peer, now, force);
        }
        Self::log_due(None, &mut peers.others, now, force);
        self.prune(peers, now);
    }

    fn log_due(ip: Option<IpAddr>, peer: &mut Peer, now: Instant, force: bool) {
        let Some((failed, span)) = peer.failed_log.due(now, force, peer.refused > 0) else {
            return;
        };
        let refused = std::mem::take(&mut peer.refused);
        let wait = peer
            .blocked_until
            .map_or(0.0, |t| t.saturating_duration_since(now).as_secs_f64());
        tracing::warn!(
            peer = %who(ip),
            failed,
            refused_while_waiting = refused,
            wait_s = wait,
            "authentication failed: {failed} more failed token attempts from {} in the last {:.0} s, \
             and {refused} connections refused while it had to wait",
            who(ip),
            span.as_secs_f64()
        );
    }

    /// Forgets the addresses with nothing left to wait for or to log.
    fn prune(&self, peers: &mut Peers, now: Instant) {
        let quiet = |p: &Peer| {
            p.failed_log.idle()
                && p.refused == 0
                && p.blocked_until.is_none_or(|t| t <= now)
                && p.last_failure
                    .is_none_or(|t| now.saturating_duration_since(t) > self.backoff_max)
        };
        peers.by_ip.retain(|_, p| !quiet(p));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::net::Ipv4Addr;

    fn throttle(allowed: u32) -> Throttle {
        let mut config = DaemonConfig::new("/nonexistent/socket");
        config.auth_failures_allowed = allowed;
        config.auth_backoff = Duration::from_secs(1);
        config.auth_backoff_max = Duration::from_secs(8);
        Throttle::new(&config)
    }

    fn ip(n: u32) -> IpAddr {
        IpAddr::V4(Ipv4Addr::from(0x7f00_0000 + n))
    }

    #[test]
    fn the_wait_doubles_up_to_its_maximum_and_a_success_ends_it() {
        let t = throttle(3);
        let t0 = Instant::now();
        let a = ip(1);
        for _ in 0..2 {
            t.failed(a, "wrong token", t0);
        }
        assert_eq!(t.check(a, t0), Ok(()));
        let mut waits = Vec::new();
        for _ in 0..6 {
            t.failed(a, "wrong token", t0);
            waits.push(t.check(a, t0).unwrap_err().as_secs());
        }
        assert_eq!(waits, [1, 2, 4, 8, 8, 8]);
        // Another address is not concerned.
        assert_eq!(t.check(ip(2), t0), Ok(()));
        // The wait ends, and a success forgets the failures.
        assert_eq!(t.check(a, t0 + Duration::from_secs(9)), Ok(()));
        t.succeeded(a, t0 + Duration::from_secs(9));
        t.failed(a, "wrong token", t0 + Duration::from_secs(10));
        assert_eq!(t.check(a, t0 + Duration::from_secs(10)), Ok(()));
    }

    #[test]
    fn a_quiet_address_starts_afresh() {
        let t = throttle(2);
        let t0 = Instant::now();
        t.failed(ip(1), "wrong token", t0);
        let later = t0 + Duration::from_secs(9);
        t.failed(ip(1), "wrong token", later);
        assert_eq!(t.check(ip(1), later), Ok(()));
        // The second failure is summed up; after a window with nothing in it the address goes.
        t.flush(later + Duration::from_secs(20), false);
        assert_eq!(lock(&t.peers).by_ip.len(), 1);
        t.flush(later + Duration::from_secs(40), false);
        assert!(lock(&t.peers).by_ip.is_empty());
    }

    #[test]
    fn a_flood_of_addresses_shares_one_entry_past_the_table_size() {
        let t = throttle(2);
        let t0 = Instant::now();
        let n = MAX_TRACKED_PEERS as u32 + 500;
        for i in 0..n {
            t.failed(ip(i), "wrong token", t0);
        }
        assert_eq!(lock(&t.peers).by_ip.len(), MAX_TRACKED_PEERS);
        // The 500 newcomers failed twice together: any new address now waits too.
        assert!(t.check(ip(n + 1), t0).is_err());
        assert_eq!(t.check(ip(0), t0), Ok(()));
        // Once they are quiet the table empties.
        t.flush(t0 + Duration::from_secs(60), true);
        assert!(lock(&t.peers).by_ip.is_empty());
        assert_eq!(t.check(ip(n + 1), t0 + Duration::from_secs(60)), Ok(()));
    }
}
