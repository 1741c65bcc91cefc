//! The mesh cache behind sessions (a daemon's, shared by all its sessions; a `LocalSession`'s
//! own, with no budget): meshes by content hash, as `Arc<Mesh>` so every session and every
//! frame that uses a mesh shares one copy (and the renderers see the same `Arc`, which is how
//! they know the geometry did not change).
//!
//! Alpha images (issue 38) live here too, by their own content hash, under the same budget and
//! the same eviction rule: one budget for everything uploaded.
//!
//! Memory is bounded by a budget: when the cached bytes exceed it, meshes that nothing but the
//! cache holds (no live session has them in its working set, no renderer keeps them) are dropped,
//! least recently used first. Meshes in use are never dropped, so a budget smaller than the
//! meshes in use is exceeded rather than breaking a session.

use std::collections::HashMap;
use std::sync::{Arc, Mutex};

use antumbra_core::alpha::AlphaImage;
use antumbra_core::scene::Mesh;

use crate::lock;

struct Entry<T> {
    mesh: Arc<T>,
    bytes: u64,
    last_used: u64,
}

#[derive(Default)]
struct Inner {
    map: HashMap<u64, Entry<Mesh>>,
    images: HashMap<u64, Entry<AlphaImage>>,
    bytes: u64,
    tick: u64,
    evicted: u64,
    evicted_bytes: u64,
    images_evicted: u64,
}

/// Counts for `DaemonStats`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct CacheStats {
    pub meshes: u64,
    pub bytes: u64,
    pub evicted: u64,
    pub evicted_bytes: u64,
    pub images: u64,
    pub images_evicted: u64,
}

pub struct MeshCache {
    inner: Mutex<Inner>,
    budget: u64,
}

/// Bytes a mesh holds: 12 per vertex, 12 per triangle, and its normals, slots and UV maps.
pub fn mesh_bytes(mesh: &Mesh) -> u64 {
    let corners: u64 = mesh.uv_maps.iter().map(|m| m.corners.len() as u64).sum();
    (mesh.positions.len() as u64 + mesh.triangles.len() as u64) * 12
        + mesh.normals.len() as u64 * 36
        + mesh.material_slots.len() as u64 * 4
        + corners * 24
}

/// Bytes an alpha image holds: 4 per texel.
pub fn image_bytes(image: &AlphaImage) -> u64 {
    image.texels.len() as u64 * 4
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

    /// The alpha image with this hash, marked as just used.
    pub fn image(&self, hash: u64) -> Option<Arc<AlphaImage>> {
        let mut inner = lock(&self.inner);
        inner.tick += 1;
        let tick = inner.tick;
        inner.images.get_mut(&hash).map(|e| {
            e.last_used = tick;
            e.mesh.clone()
        })
    }

    pub fn contains_image(&self, hash: u64) -> bool {
        lock(&self.inner).images.contains_key(&hash)
    }

    /// Stores an alpha image under its hash, as [`insert`](Self::insert) stores a mesh.
    pub fn insert_image(&self, hash: u64, image: AlphaImage) -> Arc<AlphaImage> {
        let mut inner = lock(&self.inner);
        inner.tick += 1;
        let tick = inner.tick;
        if let Some(e) = inner.images.get_mut(&hash) {
            e.last_used = tick;
            return e.mesh.clone();
        }
        let bytes = image_bytes(&image);
        let image = Arc::new(image);
        inner.images.insert(
            hash,
            Entry {
                mesh: image.clone(),
                bytes,
                last_used: tick,
            },
        );
        inner.bytes += bytes;
        self.evict(&mut inner);
        image
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
        // (last used, is an image, hash, bytes): meshes and images compete for one budget.
        let mut unused: Vec<(u64, bool, u64, u64)> = inner
            .map
            .iter()
            .filter(|(_, e)| Arc::strong_count(&e.mesh) == 1)
            .map(|(&h, e)| (e.last_used, false, h, e.bytes))
            .chain(
                inner
                    .images
                    .iter()
                    .filter(|(_, e)| Arc::strong_count(&e.mesh) == 1)
                    .map(|(&h, e)| (e.last_used, true, h, e.bytes)),
            )
            .collect();
        unused.sort_unstable();
        for (_, is_image, hash, bytes) in unused {
            if inner.bytes <= self.budget {
                break;
            }
            if is_image {
                if inner.images.remove(&hash).is_some() {
                    inner.bytes -= bytes;
                    inner.images_evicted += 1;
                    inner.evicted_bytes += bytes;
                    tracing::info!(
                        image = format!("{hash:#018x}"),
                        bytes,
                        cached_bytes = inner.bytes,
                        budget = self.budget,
                        "evicted alpha image from cache"
                    );
                }
                continue;
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
            images: inner.images.len() as u64,
            images_evicted: inner.images_evicted,
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
    fn images_share_the_budget_and_the_eviction_rule() {
        // A 48-byte mesh and a 48-byte image (12 texels); budget for one of them.
        let cache = MeshCache::new(60);
        let image = |v: f32| AlphaImage {
            width: 4,
            height: 3,
            texels: vec![v; 12],
        };
        let held = cache.insert_image(1, image(0.5));
        drop(cache.insert(2, mesh(1, 1)));
        // The image is in use: the unused mesh goes (at the next trim: a mesh being inserted is
        // in use by its inserter).
        cache.trim();
        assert!(cache.contains_image(1) && !cache.contains(2));
        drop(held);
        drop(cache.insert_image(3, image(0.25)));
        let s = cache.stats();
        assert_eq!((s.images, s.images_evicted, s.meshes), (1, 1, 0));
        assert!(cache.contains_image(3));
        assert!(Arc::ptr_eq(
            &cache.insert_image(3, image(0.25)),
            &cache.image(3).unwrap()
        ));
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
