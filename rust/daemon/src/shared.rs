//! What every session, the spool and the accept loop share: the configuration, the mesh cache,
//! the render slots, the counters and the stop flag.

use std::collections::HashMap;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Instant;

use antumbra_protocol::DaemonStats;
use antumbra_session::MeshCache;

use crate::config::DaemonConfig;
use crate::gate::Gate;
use crate::listen::Conn;
use crate::slots::RenderSlots;
use crate::throttle::Throttle;

#[derive(Default)]
pub(crate) struct Counters {
    pub sessions_live: AtomicU64,
    pub sessions_total: AtomicU64,
    pub renders_done: AtomicU64,
    pub renders_cancelled: AtomicU64,
    pub renders_failed: AtomicU64,
}

pub(crate) fn bump(c: &AtomicU64) {
    c.fetch_add(1, Ordering::Relaxed);
}

/// What every session, the spool and the accept loop share.
pub(crate) struct Shared {
    pub config: DaemonConfig,
    /// Every session's meshes (each session holds its working set in its `SessionState`).
    pub cache: Arc<MeshCache>,
    pub slots: RenderSlots,
    pub counters: Counters,
    /// Set by `Shutdown`, a signal or [`DaemonHandle::stop`]; everything winds down once set.
    pub stop: Arc<AtomicBool>,
    pub started: Instant,
    /// A clone of each live session's connection, to wake its reader when the daemon stops.
    pub sessions: Mutex<HashMap<u64, Conn>>,
    /// The TCP connections in their handshake.
    pub gate: Gate,
    /// The back-off of addresses after failed TCP handshakes.
    pub throttle: Throttle,
}

impl Shared {
    pub fn new(config: DaemonConfig) -> Self {
        Shared {
            cache: Arc::new(MeshCache::new(config.memory_budget)),
            slots: RenderSlots::new(config.max_renders),
            counters: Counters::default(),
            stop: Arc::new(AtomicBool::new(false)),
            started: Instant::now(),
            sessions: Mutex::new(HashMap::new()),
            gate: Gate::default(),
            throttle: Throttle::new(&config),
            config,
        }
    }

    pub fn stopping(&self) -> bool {
        self.stop.load(Ordering::Relaxed)
    }

    pub fn request_stop(&self) {
        self.stop.store(true, Ordering::Relaxed);
    }

    pub fn daemon_stats(&self) -> DaemonStats {
        let c = &self.counters;
        let cache = self.cache.stats();
        let get = |a: &AtomicU64| a.load(Ordering::Relaxed);
        DaemonStats {
            sessions: get(&c.sessions_live) as u32,
            sessions_total: get(&c.sessions_total),
            meshes_cached: cache.meshes,
            bytes_cached: cache.bytes,
            renders_done: get(&c.renders_done),
            renders_cancelled: get(&c.renders_cancelled),
            renders_failed: get(&c.renders_failed),
            uptime_s: self.started.elapsed().as_secs_f64(),
            meshes_evicted: cache.evicted,
            images_cached: cache.images,
            images_evicted: cache.images_evicted,
        }
    }
}
