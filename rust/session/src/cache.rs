//! The mesh cache behind sessions (a daemon's, shared by all its sessions; a `LocalSession`'s
//! own, with no budget): meshes by content hash, as `Arc<Mesh>` so every session and every
//! frame that uses a mesh shares one copy (and the renderers see the same `Arc`, which is how
//! they know the geometry did not change).
//!
//! Memory is bounded by a budget: when the cached bytes exceed it, meshes that nothing but the
//! cache holds (no live session has them in its working set, no renderer keeps them) are dropped,
//! least recently used first. Meshes in use are never dropped, so a budget smaller than the
//! meshes in use is exceeded rather than breaking a session.

use std::collections::HashMap;
use std::sync::{Arc, Mutex};

use antumbra_core::scene::Mesh;

use crate::lock;

struct Entry {
    mesh: Arc<Mesh>,
    bytes: u64,
    last_used: u64,
}

#[derive(Default)]
struct Inner {
    map: HashMap<u64, Entry>,
    bytes: u64,
    tick: u64,
    evicted: u64,
    evicted_bytes: u64,
}

/// Counts for `DaemonStats`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct CacheStats {
    pub meshes: u64,
    pub bytes: u64,
    pub evicted: u64,
    pub evicted_bytes: u64,
}

pub struct MeshCache {
    inner: Mutex<Inner>,
    budget: u64,
}

/// Bytes a mesh holds: 12 per vertex, 12 per triangle (what was uploaded).
pub fn mesh_bytes(mesh: &Mesh) -> u64 {
    (mesh.positions.len() as u64 + mesh.triangles.len() as u64) * 12
}

impl MeshCache {
    pub fn new(budget: u64) -> Self {
        MeshCache {
            inner: Mutex::new(Inner::default()),
            budget,
        }
    }

    /// The mesh with this hash, marked as just used.
    pub fn get(&self, hash: u64) -> Option<Arc<Mesh>> {
        let mut inner = lock(&self.inner);
        inner.tick += 1;
        let tick = inner.tick;
        inner.map.get_mut(&hash).map(|e| {
            e.last_used = tick;
            e.mesh.clone()
        })
    }

    pub fn contains(&self, hash: u64) -> bool {
        lock(&self.inner).map.contains_key(&hash)
    }

    /// Stores a mesh under its hash and returns the cached `Arc`: the existing one if the hash
    /// is already cached (so the renderers keep recognising it), else the new one. Then evicts
    /// unused meshes while the cache is over budget.
    pub fn insert(&self, hash: u64, mesh: Mesh) -> Arc<Mesh> {
        let mut inner = lock(&self.inner);
        inner.tick += 1;
        let tick = inner.tick;
        if let Some(e) = inner.map.get_mut(&hash) {
            e.last_used = tick;
            return e.mesh.clone();
        }
        let bytes = mesh_bytes(&mesh);
        let mesh = Arc::new(mesh);
        inner.map.insert(
            hash,
            Entry {
                mesh: mesh.clone(),
                bytes,
                last_used: tick,
            },
        );
        inner.bytes += bytes;
        self.evict(&mut inner);
        mesh
    }

    /// Evicts unused meshes while over budget (call after sessions released meshes).
    pub fn trim(&self) {
        let mut inner = lock(&self.inner);
        self.evict(&mut inner);
    }

    fn evict(&self, inner: &mut Inner) {
        if inner.bytes <= self.budget {
            return;
        }
        // Only the cache holds an Arc whose strong count is 1. Every other holder got its Arc
        // from the cache under this lock or cloned one it held, so the count cannot rise while
        // we decide.
        let mut unused: Vec<(u64, u64, u64)> = inner
            .map
            .iter()
            .filter(|(_, e)| Arc::strong_count(&e.mesh) == 1)
            .map(|(&h, e)| (e.last_used, h, e.bytes))
            .collect();
        unused.sort_unstable();
        for (_, hash, bytes) in unused {
            if inner.bytes <= self.budget {
                break;
            }
            if let Some(e) = inner.map.remove(&hash) {
                inner.bytes -= bytes;
                inner.evicted += 1;
                inner.evicted_bytes += bytes;
                tracing::info!(
                    mesh = %e.mesh.name,
                    hash = format!("{hash:#018x}"),
                    bytes,
                    cached_bytes = inner.bytes,
                    budget = self.budget,
                    "evicted mesh from cache"
                );
            }
        }
        if inner.bytes > self.budget {
            tracing::debug!(
                cached_bytes = inner.bytes,
                budget = self.budget,
                "mesh cache over budget: the rest is in use"
            );
        }
    }

    pub fn stats(&self) -> CacheStats {
        let inner = lock(&self.inner);
        CacheStats {
            meshes: inner.map.len() as u64,
            bytes: inner.bytes,
            evicted: inner.evicted,
            evicted_bytes: inner.evicted_bytes,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A mesh of `n` triangles (3n vertices) with distinct content per `seed`.
    fn mesh(seed: u32, n: u32) -> Mesh {
        let mut m = Mesh {
            name: format!("m{seed}"),
            ..Mesh::default()
        };
        for t in 0..n {
            for k in 0..3 {
                let v = (seed * 1000 + t * 3 + k) as f32;
                m.positions.push([v, k as f32, 0.0].into());
            }
            m.triangles.push([3 * t, 3 * t + 1, 3 * t + 2]);
        }
        m
    }

    #[test]
    fn evicts_unused_least_recently_used_first() {
        // Each mesh: 3 vertices + 1 triangle = 48 bytes; budget for two.
        let cache = MeshCache::new(100);
        let a = mesh(1, 1);
        let (ha, hb, hc) = (
            a.content_hash(),
            mesh(2, 1).content_hash(),
            mesh(3, 1).content_hash(),
        );
        drop(cache.insert(ha, a));
        let held_b = cache.insert(hb, mesh(2, 1));
        // Touch a, so b would be older, but b is held by a "session".
        let _ = cache.get(ha);
        drop(cache.insert(hc, mesh(3, 1)));
        // 144 bytes > 100: a is the only unused mesh older than c... a was touched after b, and
        // b is in use, so the oldest unused is a.
        let s = cache.stats();
        assert_eq!(s.evicted, 1);
        assert!(!cache.contains(ha));
        assert!(cache.contains(hb));
        assert!(cache.contains(hc));
        // Releasing b and trimming does nothing: 96 bytes fit.
        drop(held_b);
        cache.trim();
        assert_eq!(cache.stats().meshes, 2);
    }

    #[test]
    fn in_use_meshes_are_never_evicted() {
        let cache = MeshCache::new(10);
        let held: Vec<_> = (0..3)
            .map(|i| {
                let m = mesh(i, 2);
                cache.insert(m.content_hash(), m)
            })
            .collect();
        assert_eq!(cache.stats().meshes, 3);
        assert_eq!(cache.stats().evicted, 0);
        drop(held);
        cache.trim();
        assert_eq!(cache.stats().meshes, 0);
        assert_eq!(cache.stats().evicted, 3);
    }

    #[test]
    fn insert_of_a_cached_hash_returns_the_same_arc() {
        let cache = MeshCache::new(1 << 20);
        let m = mesh(7, 3);
        let h = m.content_hash();
        let a = cache.insert(h, m.clone());
        let b = cache.insert(h, m);
        assert!(Arc::ptr_eq(&a, &b));
    }
}
