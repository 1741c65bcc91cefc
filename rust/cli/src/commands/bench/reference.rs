//! Embree on the same triangles and rays, for `--compare embree`: its build time and its two
//! queries, called directly so its timed loops have no dynamic dispatch either.

use antumbra_core::geometry::Ray;
#[cfg(not(feature = "embree"))]
use anyhow::bail;
use anyhow::Result;

/// Embree on the same triangles, for `--compare embree`: its build time, and its two queries
/// called directly (no dynamic dispatch in its timed loops either).
#[cfg(feature = "embree")]
pub(super) struct Reference {
    pub(super) build_ms: f64,
    scene: antumbra_embree::EmbreeScene,
}

#[cfg(feature = "embree")]
fn embree_quality(quality: &str) -> Result<antumbra_embree::EmbreeQuality> {
    use antumbra_embree::EmbreeQuality;
    match quality {
        "medium" => Ok(EmbreeQuality::Medium),
        "high" => Ok(EmbreeQuality::High),
        other => anyhow::bail!("--embree-quality: '{other}' is not medium or high"),
    }
}

#[cfg(feature = "embree")]
impl Reference {
    /// The best of `repeat` builds (commits) with `threads` threads.
    pub(super) fn build(
        quality: &str,
        tris: &[[glam::Vec3; 3]],
        threads: usize,
        repeat: u32,
    ) -> Result<Self> {
        use antumbra_embree::EmbreeScene;
        let quality = embree_quality(quality)?;
        let mut build_ms = f64::INFINITY;
        let mut scene = None;
        for _ in 0..repeat.max(1) {
            let s = EmbreeScene::new(tris, quality, Some(threads))
                .map_err(|e| anyhow::anyhow!("embree: {e}"))?;
            build_ms = build_ms.min(s.build_ms());
            scene = Some(s);
        }
        // Embree's TBB workers spin for a moment after a commit; let them settle before timing.
        std::thread::sleep(std::time::Duration::from_millis(300));
        Ok(Reference {
            build_ms,
            scene: scene.expect("built at least once"),
        })
    }

    /// One build (commit) with `threads` threads; its time in ms.
    pub(super) fn build_only(
        quality: &str,
        tris: &[[glam::Vec3; 3]],
        threads: usize,
    ) -> Result<f64> {
        let quality = embree_quality(quality)?;
        antumbra_embree::EmbreeScene::new(tris, quality, Some(threads))
            .map(|s| s.build_ms())
            .map_err(|e| anyhow::anyhow!("embree: {e}"))
    }

    #[inline]
    pub(super) fn intersect(&self, ray: &Ray) {
        std::hint::black_box(self.scene.intersect(ray));
    }

    #[inline]
    pub(super) fn occluded(&self, ray: &Ray) -> bool {
        self.scene.occluded(ray)
    }
}

/// Without the `embree` feature `run` refuses `--compare` before any is built.
#[cfg(not(feature = "embree"))]
pub(super) struct Reference {
    pub(super) build_ms: f64,
    never: std::convert::Infallible,
}

#[cfg(not(feature = "embree"))]
impl Reference {
    pub(super) fn build(_: &str, _: &[[glam::Vec3; 3]], _: usize, _: u32) -> Result<Self> {
        bail!("built without the 'embree' feature")
    }
    pub(super) fn build_only(_: &str, _: &[[glam::Vec3; 3]], _: usize) -> Result<f64> {
        bail!("built without the 'embree' feature")
    }
    pub(super) fn intersect(&self, _: &Ray) {
        match self.never {}
    }
    pub(super) fn occluded(&self, _: &Ray) -> bool {
        match self.never {}
    }
}
