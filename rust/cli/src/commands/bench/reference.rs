//! Embree on the same triangles and rays, for `--compare embree`: its build time, its two
//! single-ray queries called directly (no dynamic dispatch in its timed loops either) and its
//! packet and stream calls ([`Kernel`]).

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
    pub(super) fn occluded(&self, ray: &Ray) -> bool {
        self.scene.occluded(ray)
    }

    pub(super) fn occluded_with(&self, k: Kernel, rays: &[Ray], out: &mut [bool]) {
        self.scene.occluded_with(k.0, k.1, rays, out);
    }

    pub(super) fn intersect_with(&self, k: Kernel, rays: &[Ray], out: &mut [Option<(f32, u32)>]) {
        self.scene.intersect_with(k.0, k.1, rays, out);
    }
}

/// One of Embree's calls with its context flag.
#[cfg(feature = "embree")]
#[derive(Clone, Copy, Debug)]
pub(super) struct Kernel(antumbra_embree::EmbreeKernel, antumbra_embree::Coherence);

#[cfg(feature = "embree")]
impl Kernel {
    /// Every call the bench times: each incoherent, then the batch calls coherent (one ray per
    /// call has nothing to be coherent with; Embree's single-ray path ignores the flag).
    pub(super) fn all() -> Vec<Kernel> {
        use antumbra_embree::{Coherence, EmbreeKernel};
        let batch = EmbreeKernel::ALL
            .into_iter()
            .filter(|k| *k != EmbreeKernel::Single);
        EmbreeKernel::ALL
            .into_iter()
            .map(|k| Kernel(k, Coherence::Incoherent))
            .chain(batch.map(|k| Kernel(k, Coherence::Coherent)))
            .collect()
    }

    pub(super) fn occluded_name(&self) -> &'static str {
        self.0.occluded_name()
    }

    pub(super) fn intersect_name(&self) -> &'static str {
        self.0.intersect_name()
    }

    pub(super) fn context(&self) -> &'static str {
        self.1.name()
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
    pub(super) fn occluded(&self, _: &Ray) -> bool {
        match self.never {}
    }
    pub(super) fn occluded_with(&self, k: Kernel, _: &[Ray], _: &mut [bool]) {
        match k {}
    }
    pub(super) fn intersect_with(&self, k: Kernel, _: &[Ray], _: &mut [Option<(f32, u32)>]) {
        match k {}
    }
}

/// Without the `embree` feature there is no call to time.
#[cfg(not(feature = "embree"))]
#[derive(Clone, Copy, Debug)]
pub(super) enum Kernel {}

#[cfg(not(feature = "embree"))]
impl Kernel {
    pub(super) fn all() -> Vec<Kernel> {
        Vec::new()
    }
    pub(super) fn occluded_name(&self) -> &'static str {
        match *self {}
    }
    pub(super) fn intersect_name(&self) -> &'static str {
        match *self {}
    }
    pub(super) fn context(&self) -> &'static str {
        match *self {}
    }
}
