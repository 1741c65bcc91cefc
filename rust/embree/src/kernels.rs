//! Embree's batch query calls on a slice of rays: 8- and 16-wide packets (`rtcOccluded8/16`,
//! `rtcIntersect8/16`, SoA rays with an aligned valid mask, the last partial packet masked off)
//! and the stream call (`rtcOccluded1M` / `rtcIntersect1M`), each with the coherent or
//! incoherent context flag.
//!
//! The stream call is the AoS `1M` form rather than `rtcOccludedNp`: it takes the same `RTCRay`
//! as `rtcOccluded1`, and in Embree 3.13 both forms end in the same `RayStreamFilter` (octant
//! sorting for incoherent occlusion, packets otherwise), so `Np` would only add a SoA copy.

use antumbra_core::geometry::Ray;
use embree3::sys::{
    rtcIntersect16, rtcIntersect1M, rtcIntersect8, rtcOccluded16, rtcOccluded1M, rtcOccluded8,
    RTCHit, RTCIntersectContext, RTCIntersectContextFlags, RTCRay, RTCRayHit,
};

use crate::{check, rtc_ray, EmbreeScene, INVALID_ID};

/// Which Embree call traces a batch of rays.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum EmbreeKernel {
    /// `rtcOccluded1` / `rtcIntersect1`, one ray per call.
    Single,
    /// `rtcOccluded8` / `rtcIntersect8`: SoA packets of 8 rays.
    Packet8,
    /// `rtcOccluded16` / `rtcIntersect16`: SoA packets of 16 rays.
    Packet16,
    /// `rtcOccluded1M` / `rtcIntersect1M`: the batch as one stream of AoS rays.
    Stream,
}

impl EmbreeKernel {
    pub const ALL: [EmbreeKernel; 4] = [
        EmbreeKernel::Single,
        EmbreeKernel::Packet8,
        EmbreeKernel::Packet16,
        EmbreeKernel::Stream,
    ];

    /// Embree's name of the any-hit call, e.g. `rtcOccluded16`.
    pub fn occluded_name(self) -> &'static str {
        match self {
            EmbreeKernel::Single => "rtcOccluded1",
            EmbreeKernel::Packet8 => "rtcOccluded8",
            EmbreeKernel::Packet16 => "rtcOccluded16",
            EmbreeKernel::Stream => "rtcOccluded1M",
        }
    }

    /// Embree's name of the closest-hit call, e.g. `rtcIntersect16`.
    pub fn intersect_name(self) -> &'static str {
        match self {
            EmbreeKernel::Single => "rtcIntersect1",
            EmbreeKernel::Packet8 => "rtcIntersect8",
            EmbreeKernel::Packet16 => "rtcIntersect16",
            EmbreeKernel::Stream => "rtcIntersect1M",
        }
    }
}

/// The context flag Embree is given: a promise about the rays of one call, not a request.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Coherence {
    /// `RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT` (what `rtcInitIntersectContext` sets).
    Incoherent,
    /// `RTC_INTERSECT_CONTEXT_FLAG_COHERENT`: the rays of a call start and point alike.
    Coherent,
}

impl Coherence {
    pub fn name(self) -> &'static str {
        match self {
            Coherence::Incoherent => "incoherent",
            Coherence::Coherent => "coherent",
        }
    }
}

/// What fills the unused slots of a stream buffer (never handed to Embree).
const IDLE: Ray = Ray {
    origin: glam::Vec3::ZERO,
    direction: glam::Vec3::Z,
    t_min: 0.0,
    t_max: 0.0,
};

/// Rays per stream call: a bound for the stack buffer (Embree cuts streams into 32 anyway).
const STREAM: usize = 256;

pub(crate) fn context(coherence: Coherence) -> RTCIntersectContext {
    // What `rtcInitIntersectContext` (an inline C function, absent from the bindings) does.
    RTCIntersectContext {
        flags: match coherence {
            Coherence::Incoherent => RTCIntersectContextFlags::INCOHERENT,
            Coherence::Coherent => RTCIntersectContextFlags::COHERENT,
        },
        filter: None,
        instID: [INVALID_ID],
    }
}

impl EmbreeScene {
    /// `out[i]` = whether any triangle blocks `rays[i]`, traced by `kernel` with `coherence`;
    /// packets and streams are cut from `rays` in order, the last partial packet masked off.
    ///
    /// # Panics
    /// If the slices differ in length or [`crate::embree_accepts`] rejects a ray.
    pub fn occluded_with(
        &self,
        kernel: EmbreeKernel,
        coherence: Coherence,
        rays: &[Ray],
        out: &mut [bool],
    ) {
        assert_eq!(rays.len(), out.len(), "rays and out differ in length");
        match kernel {
            EmbreeKernel::Single => {
                for (r, o) in rays.iter().zip(out) {
                    *o = self.occluded(r);
                }
            }
            EmbreeKernel::Packet8 => packet8::occluded(self, coherence, rays, out),
            EmbreeKernel::Packet16 => packet16::occluded(self, coherence, rays, out),
            EmbreeKernel::Stream => stream::occluded(self, coherence, rays, out),
        }
    }

    /// `out[i]` = the closest hit of `rays[i]` as (t, triangle id), as
    /// [`EmbreeScene::intersect`] gives it, traced by `kernel` with `coherence`.
    ///
    /// # Panics
    /// If the slices differ in length or [`crate::embree_accepts`] rejects a ray.
    pub fn intersect_with(
        &self,
        kernel: EmbreeKernel,
        coherence: Coherence,
        rays: &[Ray],
        out: &mut [Option<(f32, u32)>],
    ) {
        assert_eq!(rays.len(), out.len(), "rays and out differ in length");
        match kernel {
            EmbreeKernel::Single => {
                for (r, o) in rays.iter().zip(out) {
                    *o = self.intersect(r);
                }
            }
            EmbreeKernel::Packet8 => packet8::intersect(self, coherence, rays, out),
            EmbreeKernel::Packet16 => packet16::intersect(self, coherence, rays, out),
            EmbreeKernel::Stream => stream::intersect(self, coherence, rays, out),
        }
    }
}

/// One packet width in a module of its own: its SoA structs, its aligned mask and its calls.
macro_rules! packet_width {
    ($name:ident, $k:literal, $align:literal, $ray:ident, $hit:ident, $rayhit:ident, $occ:ident, $isect:ident) => {
        pub(crate) mod $name {
            use super::*;
            use embree3::sys::{$hit, $ray, $rayhit};

            /// A valid mask with the alignment Embree requires of it (the packet's own).
            #[repr(C, align($align))]
            struct Valid([i32; $k]);

            /// The SoA packet of up to K rays; lanes past `rays.len()` stay masked off and hold
            /// an empty segment, so no lane carries garbage.
            fn packet(rays: &[Ray]) -> (Valid, $ray) {
                let mut valid = Valid([0; $k]);
                let mut p = $ray {
                    org_x: [0.0; $k],
                    org_y: [0.0; $k],
                    org_z: [0.0; $k],
                    tnear: [0.0; $k],
                    dir_x: [0.0; $k],
                    dir_y: [0.0; $k],
                    dir_z: [1.0; $k],
                    time: [0.0; $k],
                    tfar: [f32::NEG_INFINITY; $k],
                    mask: [u32::MAX; $k],
                    id: [0; $k],
                    flags: [0; $k],
                };
                for (i, r) in rays.iter().enumerate() {
                    check(r);
                    valid.0[i] = -1;
                    p.org_x[i] = r.origin.x;
                    p.org_y[i] = r.origin.y;
                    p.org_z[i] = r.origin.z;
                    p.tnear[i] = r.t_min;
                    p.dir_x[i] = r.direction.x;
                    p.dir_y[i] = r.direction.y;
                    p.dir_z[i] = r.direction.z;
                    p.tfar[i] = r.t_max;
                }
                (valid, p)
            }

            pub(crate) fn occluded(
                scene: &EmbreeScene,
                coherence: Coherence,
                rays: &[Ray],
                out: &mut [bool],
            ) {
                let mut ctx = context(coherence);
                for (rays, out) in rays.chunks($k).zip(out.chunks_mut($k)) {
                    let (valid, mut p) = packet(rays);
                    // SAFETY: the scene is committed; mask and packet are aligned locals of the
                    // layout Embree expects for this width.
                    unsafe { $occ(valid.0.as_ptr(), scene.scene, &mut ctx, &mut p) };
                    for (i, o) in out.iter_mut().enumerate() {
                        // Embree marks an occluded ray by setting tfar to -inf.
                        *o = p.tfar[i] == f32::NEG_INFINITY;
                    }
                }
            }

            pub(crate) fn intersect(
                scene: &EmbreeScene,
                coherence: Coherence,
                rays: &[Ray],
                out: &mut [Option<(f32, u32)>],
            ) {
                let mut ctx = context(coherence);
                for (rays, out) in rays.chunks($k).zip(out.chunks_mut($k)) {
                    let (valid, ray) = packet(rays);
                    let mut rh = $rayhit {
                        ray,
                        hit: $hit {
                            Ng_x: [0.0; $k],
                            Ng_y: [0.0; $k],
                            Ng_z: [0.0; $k],
                            u: [0.0; $k],
                            v: [0.0; $k],
                            primID: [INVALID_ID; $k],
                            geomID: [INVALID_ID; $k],
                            instID: [[INVALID_ID; $k]],
                        },
                    };
                    // SAFETY: as in `occluded`.
                    unsafe { $isect(valid.0.as_ptr(), scene.scene, &mut ctx, &mut rh) };
                    for (i, o) in out.iter_mut().enumerate() {
                        *o = (rh.hit.geomID[i] != INVALID_ID)
                            .then_some((rh.ray.tfar[i], rh.hit.primID[i]));
                    }
                }
            }
        }
    };
}

packet_width!(
    packet8,
    8,
    32,
    RTCRay8,
    RTCHit8,
    RTCRayHit8,
    rtcOccluded8,
    rtcIntersect8
);
packet_width!(
    packet16,
    16,
    64,
    RTCRay16,
    RTCHit16,
    RTCRayHit16,
    rtcOccluded16,
    rtcIntersect16
);

/// The stream calls, on stack buffers of up to [`STREAM`] AoS rays per call.
pub(crate) mod stream {
    use super::*;

    pub(crate) fn occluded(
        scene: &EmbreeScene,
        coherence: Coherence,
        rays: &[Ray],
        out: &mut [bool],
    ) {
        let mut ctx = context(coherence);
        let mut buffer = [rtc_ray(&IDLE); STREAM];
        for (rays, out) in rays.chunks(STREAM).zip(out.chunks_mut(STREAM)) {
            for (b, r) in buffer.iter_mut().zip(rays) {
                check(r);
                *b = rtc_ray(r);
            }
            // SAFETY: the scene is committed; `buffer` holds `rays.len()` valid RTCRays
            // (16-byte aligned, as their type is) at a stride of one RTCRay.
            unsafe {
                rtcOccluded1M(
                    scene.scene,
                    &mut ctx,
                    buffer.as_mut_ptr(),
                    rays.len() as u32,
                    size_of::<RTCRay>(),
                )
            };
            for (o, b) in out.iter_mut().zip(&buffer) {
                *o = b.tfar == f32::NEG_INFINITY;
            }
        }
    }

    pub(crate) fn intersect(
        scene: &EmbreeScene,
        coherence: Coherence,
        rays: &[Ray],
        out: &mut [Option<(f32, u32)>],
    ) {
        let mut ctx = context(coherence);
        let empty = RTCRayHit {
            ray: rtc_ray(&IDLE),
            hit: empty_hit(),
        };
        let mut buffer = [empty; STREAM];
        for (rays, out) in rays.chunks(STREAM).zip(out.chunks_mut(STREAM)) {
            for (b, r) in buffer.iter_mut().zip(rays) {
                check(r);
                *b = RTCRayHit {
                    ray: rtc_ray(r),
                    hit: empty_hit(),
                };
            }
            // SAFETY: as in `occluded`, with RTCRayHits.
            unsafe {
                rtcIntersect1M(
                    scene.scene,
                    &mut ctx,
                    buffer.as_mut_ptr(),
                    rays.len() as u32,
                    size_of::<RTCRayHit>(),
                )
            };
            for (o, b) in out.iter_mut().zip(&buffer) {
                *o = (b.hit.geomID != INVALID_ID).then_some((b.ray.tfar, b.hit.primID));
            }
        }
    }
}

pub(crate) fn empty_hit() -> RTCHit {
    RTCHit {
        Ng_x: 0.0,
        Ng_y: 0.0,
        Ng_z: 0.0,
        u: 0.0,
        v: 0.0,
        primID: INVALID_ID,
        geomID: INVALID_ID,
        instID: [INVALID_ID],
    }
}
