//! Embree 3 as an independent oracle and speed reference for antumbra's traversal.
//!
//! [`EmbreeScene`] owns an Embree device and one committed scene holding a single triangle
//! geometry (triangle id = primitive id = index in the input slice). It is driven through the
//! raw `embree3::sys` FFI: the safe wrapper of the `embree3` crate has no build-quality setter
//! and ties scenes to lifetimes we do not need here.
//!
//! [`EmbreeScene::occluded`] and [`EmbreeScene::intersect`] are the single-ray calls
//! (`rtcOccluded1` / `rtcIntersect1`, incoherent context), the oracle. [`EmbreeScene::occluded_with`]
//! and [`EmbreeScene::intersect_with`] trace a batch with any of Embree's calls ([`EmbreeKernel`]:
//! 8- and 16-wide packets, the stream) and either context flag ([`Coherence`]), for speed
//! comparisons. The incoherent forms are tested ray for ray against the single-ray calls; the
//! coherent ones are only a promise about the rays, so `bench` counts their disagreements instead
//! (an earlier report of wrong coherent answers for rays leaving a surface is not reproduced by
//! the CLI's `embree_coherence` example).
//!
//! # Ray segment
//!
//! antumbra's segment is (t_min, t_max]; Embree's is documented as [tnear, tfar]. We map
//! tnear = t_min and tfar = t_max unchanged, so the two can only disagree about a hit at exactly
//! t = t_min (antumbra rejects it; Embree may accept it). The tests count such cases.
//! Measured on Embree 3.13.5 (Debian, AVX-512 kernels): in robust mode (which runs the
//! Pluecker triangle test, `TriangleMvIntersector1Pluecker`) the segment really is closed at
//! both ends, [tnear, tfar]; without robust mode a hit at exactly tnear is rejected, i.e.
//! (tnear, tfar] like antumbra. Either way t is Embree's own f32 estimate, which need not
//! equal antumbra's bit for bit: on AMD EPYC a hit at exact t = 1 reports 1 - 2^-24, and
//! robust mode decides the ends on that estimate, the default mode on the exact t
//! (`segment_ends_exactly_at_a_hit`).
//!
//! Embree requires 0 <= tnear, non-NaN tfar and |origin|, |direction| components <= 1.844e18
//! (`FLT_LARGE`); Debian's build keeps its internal asserts, so such a ray would abort the
//! process. [`EmbreeScene::occluded`] and [`EmbreeScene::intersect`] panic on such rays instead;
//! use [`embree_accepts`] to filter first.
//!
//! # Robust mode
//!
//! Scenes are built with `RTC_SCENE_FLAG_ROBUST` by default: it makes Embree avoid the
//! optimisations that reduce arithmetic accuracy (in traversal and triangle tests). antumbra
//! compares answers exactly, so robust is the fair setting; `robust = false` is available
//! through [`EmbreeScene::with_options`] for raw-speed comparisons.

mod kernels;

pub use kernels::{Coherence, EmbreeKernel};

use std::ffi::CString;
use std::os::raw::c_void;
use std::ptr;
use std::time::Instant;

use antumbra_core::geometry::Ray;
use embree3::sys::{
    rtcAttachGeometry, rtcCommitGeometry, rtcCommitScene, rtcGetDeviceError, rtcGetDeviceProperty,
    rtcIntersect1, rtcNewDevice, rtcNewGeometry, rtcNewScene, rtcOccluded1, rtcReleaseDevice,
    rtcReleaseGeometry, rtcReleaseScene, rtcSetGeometryBuildQuality, rtcSetNewGeometryBuffer,
    rtcSetSceneBuildQuality, rtcSetSceneFlags, RTCBufferType, RTCBuildQuality, RTCDevice,
    RTCDeviceProperty, RTCError, RTCFormat, RTCGeometryType, RTCRay, RTCRayHit, RTCScene,
    RTCSceneFlags,
};
use glam::Vec3;

/// Embree's `RTC_INVALID_GEOMETRY_ID`.
pub(crate) const INVALID_ID: u32 = u32::MAX;

/// Embree's `FLT_LARGE`: the largest origin/direction component magnitude a ray may have.
const FLT_LARGE: f32 = 1.844e18;

/// True if Embree accepts the ray: `t_min >= 0`, `t_max` not NaN (infinity is fine) and every
/// origin and direction component finite with magnitude <= 1.844e18. Embree asserts this
/// (`RayK::valid` and `tnear >= 0`), and Debian's library aborts when the assert fails.
#[inline]
pub fn embree_accepts(ray: &Ray) -> bool {
    let small = |v: Vec3| v.abs().max_element() <= FLT_LARGE && !v.is_nan();
    ray.t_min >= 0.0 && !ray.t_max.is_nan() && small(ray.origin) && small(ray.direction)
}

#[inline(always)]
pub(crate) fn check(ray: &Ray) {
    assert!(
        embree_accepts(ray),
        "ray not accepted by Embree (needs t_min >= 0, t_max not NaN, |components| <= 1.844e18): \
         {ray:?}"
    );
}

/// BVH build quality (`RTC_BUILD_QUALITY_LOW/MEDIUM/HIGH`). Embree's default is `Medium`;
/// `High` enables spatial splits.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum EmbreeQuality {
    Low,
    Medium,
    High,
}

impl EmbreeQuality {
    fn raw(self) -> RTCBuildQuality {
        match self {
            EmbreeQuality::Low => RTCBuildQuality::LOW,
            EmbreeQuality::Medium => RTCBuildQuality::MEDIUM,
            EmbreeQuality::High => RTCBuildQuality::HIGH,
        }
    }
}

/// An Embree device plus one committed scene of one triangle geometry.
#[derive(Debug)]
pub struct EmbreeScene {
    device: RTCDevice,
    pub(crate) scene: RTCScene,
    build_ms: f64,
    triangle_count: usize,
    robust: bool,
}

// SAFETY: the handles are owned exclusively by this struct (no other Rust value holds them) and
// Embree reference-counts its objects atomically, so moving the owner to another thread and
// releasing it there is fine. After `rtcCommitScene` the scene is never modified again; Embree
// documents ray queries (`rtcIntersect1`, `rtcOccluded1`) on a committed scene as thread-safe
// and they write only to the caller's ray/hit/context structures, which live on the caller's
// stack. Hence `&EmbreeScene` may be shared between threads.
unsafe impl Send for EmbreeScene {}
unsafe impl Sync for EmbreeScene {}

/// The first error recorded for `device` on this thread (clears it), as a message.
fn take_error(device: RTCDevice, what: &str) -> Result<(), String> {
    // SAFETY: `device` is a valid device handle or null (null reads the global error).
    match unsafe { rtcGetDeviceError(device) } {
        RTCError::NONE => Ok(()),
        e => Err(format!("embree: {what} failed: {e:?}")),
    }
}

impl EmbreeScene {
    /// Builds from triangles given as `[[Vec3; 3]]` (triangle id = index), in robust mode.
    /// `threads` sets Embree's worker-thread count (`threads=N`; `None` = Embree's default).
    /// The build time (`rtcCommitScene` only) is available from [`build_ms`].
    ///
    /// Embree skips triangles with non-finite vertices during the build; zero-area ones are
    /// never hit.
    ///
    /// [`build_ms`]: EmbreeScene::build_ms
    pub fn new(
        triangles: &[[Vec3; 3]],
        quality: EmbreeQuality,
        threads: Option<usize>,
    ) -> Result<Self, String> {
        Self::with_options(triangles, quality, threads, true)
    }

    /// As [`new`](EmbreeScene::new), choosing whether to set `RTC_SCENE_FLAG_ROBUST`.
    pub fn with_options(
        triangles: &[[Vec3; 3]],
        quality: EmbreeQuality,
        threads: Option<usize>,
        robust: bool,
    ) -> Result<Self, String> {
        let n = triangles.len();
        if n > u32::MAX as usize / 3 {
            return Err(format!("embree: too many triangles ({n})"));
        }
        let config = match threads {
            Some(0) => return Err("embree: threads must be at least 1".into()),
            Some(t) => format!("threads={t},verbose=0"),
            None => "verbose=0".to_string(),
        };
        let config = CString::new(config).expect("no interior NUL");

        // SAFETY: plain FFI calls on handles created here; every handle is checked for null
        // before use, and the partially built `EmbreeScene` releases whatever was created if
        // a later step fails (its `Drop` tolerates a null scene).
        unsafe {
            let device = rtcNewDevice(config.as_ptr());
            if device.is_null() {
                let e = rtcGetDeviceError(ptr::null_mut());
                return Err(format!("embree: rtcNewDevice failed: {e:?}"));
            }
            let mut this = EmbreeScene {
                device,
                scene: ptr::null_mut(),
                build_ms: 0.0,
                triangle_count: n,
                robust,
            };
            if rtcGetDeviceProperty(device, RTCDeviceProperty::BACKFACE_CULLING_ENABLED) != 0 {
                return Err(
                    "embree: library built with backface culling; antumbra counts \
                            both faces"
                        .into(),
                );
            }

            let scene = rtcNewScene(device);
            take_error(device, "rtcNewScene")?;
            if scene.is_null() {
                return Err("embree: rtcNewScene returned null".into());
            }
            this.scene = scene;
            let flags = if robust {
                RTCSceneFlags::ROBUST
            } else {
                RTCSceneFlags::NONE
            };
            rtcSetSceneFlags(scene, flags);
            rtcSetSceneBuildQuality(scene, quality.raw());

            if n > 0 {
                let geom = rtcNewGeometry(device, RTCGeometryType::TRIANGLE);
                take_error(device, "rtcNewGeometry")?;
                if geom.is_null() {
                    return Err("embree: rtcNewGeometry returned null".into());
                }
                let result = fill_geometry(device, geom, triangles, quality);
                if result.is_ok() {
                    rtcAttachGeometry(scene, geom);
                }
                // The scene holds its own reference once attached.
                rtcReleaseGeometry(geom);
                result?;
                take_error(device, "rtcAttachGeometry")?;
            }

            let start = Instant::now();
            rtcCommitScene(scene);
            this.build_ms = start.elapsed().as_secs_f64() * 1e3;
            take_error(device, "rtcCommitScene")?;
            Ok(this)
        }
    }

    /// Duration of `rtcCommitScene` (the BVH build), in milliseconds.
    ///
    /// Embree's TBB workers keep spinning for a moment after the commit; on few cores, time
    /// queries only after letting them settle (~200 ms sleep) or they can appear twice as slow.
    pub fn build_ms(&self) -> f64 {
        self.build_ms
    }

    /// Number of triangles given to [`new`](EmbreeScene::new).
    pub fn triangle_count(&self) -> usize {
        self.triangle_count
    }

    /// Whether the scene was built with `RTC_SCENE_FLAG_ROBUST`.
    pub fn robust(&self) -> bool {
        self.robust
    }

    /// True if any triangle is hit in the segment (`rtcOccluded1`).
    ///
    /// # Panics
    /// If [`embree_accepts`] rejects the ray.
    #[inline]
    pub fn occluded(&self, ray: &Ray) -> bool {
        check(ray);
        let mut context = kernels::context(Coherence::Incoherent);
        let mut r = rtc_ray(ray);
        // SAFETY: `scene` is committed and never modified afterwards; `context` and `r` are
        // valid, properly aligned locals.
        unsafe { rtcOccluded1(self.scene, &mut context, &mut r) };
        // Embree marks an occluded ray by setting tfar to -inf.
        r.tfar == f32::NEG_INFINITY
    }

    /// The closest hit in the segment as (t, triangle id), via `rtcIntersect1`. t is Embree's
    /// hit distance in units of the (unnormalised) direction.
    ///
    /// # Panics
    /// If [`embree_accepts`] rejects the ray.
    #[inline]
    pub fn intersect(&self, ray: &Ray) -> Option<(f32, u32)> {
        check(ray);
        let mut context = kernels::context(Coherence::Incoherent);
        let mut rh = RTCRayHit {
            ray: rtc_ray(ray),
            hit: kernels::empty_hit(),
        };
        // SAFETY: as in `occluded`.
        unsafe { rtcIntersect1(self.scene, &mut context, &mut rh) };
        (rh.hit.geomID != INVALID_ID).then_some((rh.ray.tfar, rh.hit.primID))
    }

    /// `out[i] = self.occluded(&rays[i])`, one `rtcOccluded1` per ray on the calling thread.
    ///
    /// # Panics
    /// If the slices differ in length or a ray is rejected by [`embree_accepts`].
    pub fn occluded_many(&self, rays: &[Ray], out: &mut [bool]) {
        assert_eq!(rays.len(), out.len(), "rays and out differ in length");
        for (ray, o) in rays.iter().zip(out.iter_mut()) {
            *o = self.occluded(ray);
        }
    }
}

impl Drop for EmbreeScene {
    fn drop(&mut self) {
        // SAFETY: the handles were created by `with_options` and are released exactly once.
        unsafe {
            if !self.scene.is_null() {
                rtcReleaseScene(self.scene);
            }
            rtcReleaseDevice(self.device);
        }
    }
}

/// Copies the triangles into Embree-owned vertex/index buffers (vertices unshared: triangle i
/// uses vertices 3i, 3i+1, 3i+2) and commits the geometry.
///
/// # Safety
/// `device` and `geom` must be valid handles.
unsafe fn fill_geometry(
    device: RTCDevice,
    geom: embree3::sys::RTCGeometry,
    triangles: &[[Vec3; 3]],
    quality: EmbreeQuality,
) -> Result<(), String> {
    let n = triangles.len();
    rtcSetGeometryBuildQuality(geom, quality.raw());
    // Embree pads buffers it allocates itself so that its 16-byte loads stay in bounds.
    let vb: *mut c_void =
        rtcSetNewGeometryBuffer(geom, RTCBufferType::VERTEX, 0, RTCFormat::FLOAT3, 12, 3 * n);
    take_error(device, "vertex buffer")?;
    let ib: *mut c_void =
        rtcSetNewGeometryBuffer(geom, RTCBufferType::INDEX, 0, RTCFormat::UINT3, 12, n);
    take_error(device, "index buffer")?;
    if vb.is_null() || ib.is_null() {
        return Err("embree: geometry buffer allocation returned null".into());
    }
    // SAFETY: Embree returned buffers of 3n float3 and n uint3 items, 4-byte aligned at least.
    let verts = std::slice::from_raw_parts_mut(vb as *mut [f32; 3], 3 * n);
    let idx = std::slice::from_raw_parts_mut(ib as *mut [u32; 3], n);
    for (i, tri) in triangles.iter().enumerate() {
        for (k, v) in tri.iter().enumerate() {
            verts[3 * i + k] = v.to_array();
        }
        let b = 3 * i as u32;
        idx[i] = [b, b + 1, b + 2];
    }
    rtcCommitGeometry(geom);
    take_error(device, "rtcCommitGeometry")
}

#[inline(always)]
pub(crate) fn rtc_ray(ray: &Ray) -> RTCRay {
    RTCRay {
        org_x: ray.origin.x,
        org_y: ray.origin.y,
        org_z: ray.origin.z,
        tnear: ray.t_min,
        dir_x: ray.direction.x,
        dir_y: ray.direction.y,
        dir_z: ray.direction.z,
        time: 0.0,
        tfar: ray.t_max,
        mask: u32::MAX,
        id: 0,
        flags: 0,
    }
}
