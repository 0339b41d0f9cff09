//! The only place that knows how Embree 3 and Embree 4 differ in their query
//! calls: v3 takes an `RTCIntersectContext*` second, v4 takes optional
//! `RTCIntersectArguments*` / `RTCOccludedArguments*` last. The `rtcInit*`
//! helpers are header-inline (bindgen cannot export them), so they are
//! re-implemented here.
//!
//! Every function here is `unsafe`: the caller guarantees that `scene` is a
//! live, committed scene for the duration of the call.

use super::sys;

/// `RTC_INVALID_GEOMETRY_ID`, a cast macro bindgen does not export.
pub(crate) const INVALID_GEOMETRY_ID: u32 = u32::MAX;

/// Valid mask for an 8-lane query: -1 = trace, 0 = skip. Embree requires the
/// mask to be aligned like the packet (32 bytes for 8 lanes).
#[repr(C, align(32))]
pub(crate) struct Valid8(pub [i32; 8]);

/// Valid mask for a 16-lane query, 64-byte aligned as Embree requires.
#[repr(C, align(64))]
pub(crate) struct Valid16(pub [i32; 16]);

#[cfg(embree3)]
mod imp {
    use super::{INVALID_GEOMETRY_ID, Valid8, Valid16, sys};

    /// `rtcInitIntersectContext` plus the coherence hint.
    fn context(coherent: bool) -> sys::RTCIntersectContext {
        // Zeroing covers the optional fields (instStackSize, minWidthDistanceFactor)
        // that rtcInitIntersectContext sets to 0 when the build has them.
        let mut ctx = sys::RTCIntersectContext {
            flags: if coherent {
                sys::RTC_INTERSECT_CONTEXT_FLAG_COHERENT
            } else {
                sys::RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT
            },
            filter: None,
            ..Default::default()
        };
        ctx.instID.fill(INVALID_GEOMETRY_ID);
        ctx
    }

    pub(crate) unsafe fn intersect1(scene: sys::RTCScene, rh: &mut sys::RTCRayHit) {
        let mut ctx = context(false);
        // SAFETY: the caller guarantees `scene` is live and committed; `ctx`
        // and `rh` are exclusive borrows that outlive the call.
        unsafe { sys::rtcIntersect1(scene, &mut ctx, rh) }
    }

    pub(crate) unsafe fn occluded1(scene: sys::RTCScene, ray: &mut sys::RTCRay) {
        let mut ctx = context(false);
        // SAFETY: as in `intersect1`.
        unsafe { sys::rtcOccluded1(scene, &mut ctx, ray) }
    }

    pub(crate) unsafe fn intersect8(
        valid: &Valid8,
        scene: sys::RTCScene,
        rh: &mut sys::RTCRayHit8,
        coherent: bool,
    ) {
        let mut ctx = context(coherent);
        // SAFETY: `valid` and `rh` are 32-byte aligned by their types, the
        // caller guarantees `scene`; all pointers outlive the call.
        unsafe { sys::rtcIntersect8(valid.0.as_ptr(), scene, &mut ctx, rh) }
    }

    pub(crate) unsafe fn intersect16(
        valid: &Valid16,
        scene: sys::RTCScene,
        rh: &mut sys::RTCRayHit16,
        coherent: bool,
    ) {
        let mut ctx = context(coherent);
        // SAFETY: `valid` and `rh` are 64-byte aligned by their types, the
        // caller guarantees `scene`; all pointers outlive the call.
        unsafe { sys::rtcIntersect16(valid.0.as_ptr(), scene, &mut ctx, rh) }
    }

    pub(crate) unsafe fn occluded8(valid: &Valid8, scene: sys::RTCScene, ray: &mut sys::RTCRay8) {
        let mut ctx = context(false);
        // SAFETY: as in `intersect8`.
        unsafe { sys::rtcOccluded8(valid.0.as_ptr(), scene, &mut ctx, ray) }
    }

    pub(crate) unsafe fn occluded16(
        valid: &Valid16,
        scene: sys::RTCScene,
        ray: &mut sys::RTCRay16,
    ) {
        let mut ctx = context(false);
        // SAFETY: as in `intersect16`.
        unsafe { sys::rtcOccluded16(valid.0.as_ptr(), scene, &mut ctx, ray) }
    }
}

#[cfg(embree4)]
mod imp {
    use super::{Valid8, Valid16, sys};

    fn flags(coherent: bool) -> sys::RTCRayQueryFlags {
        if coherent {
            sys::RTC_RAY_QUERY_FLAG_COHERENT
        } else {
            sys::RTC_RAY_QUERY_FLAG_INCOHERENT
        }
    }

    /// `rtcInitIntersectArguments` plus the coherence hint. Zeroing covers the
    /// null context/filter/intersect pointers and optional fields.
    fn intersect_args(coherent: bool) -> sys::RTCIntersectArguments {
        sys::RTCIntersectArguments {
            flags: flags(coherent),
            feature_mask: sys::RTC_FEATURE_FLAG_ALL,
            ..Default::default()
        }
    }

    /// `rtcInitOccludedArguments`; shadow rays are never coherent.
    fn occluded_args() -> sys::RTCOccludedArguments {
        sys::RTCOccludedArguments {
            flags: flags(false),
            feature_mask: sys::RTC_FEATURE_FLAG_ALL,
            ..Default::default()
        }
    }

    pub(crate) unsafe fn intersect1(scene: sys::RTCScene, rh: &mut sys::RTCRayHit) {
        let mut args = intersect_args(false);
        // SAFETY: the caller guarantees `scene` is live and committed; `args`
        // and `rh` are exclusive borrows that outlive the call.
        unsafe { sys::rtcIntersect1(scene, rh, &mut args) }
    }

    pub(crate) unsafe fn occluded1(scene: sys::RTCScene, ray: &mut sys::RTCRay) {
        let mut args = occluded_args();
        // SAFETY: as in `intersect1`.
        unsafe { sys::rtcOccluded1(scene, ray, &mut args) }
    }

    pub(crate) unsafe fn intersect8(
        valid: &Valid8,
        scene: sys::RTCScene,
        rh: &mut sys::RTCRayHit8,
        coherent: bool,
    ) {
        let mut args = intersect_args(coherent);
        // SAFETY: `valid` and `rh` are 32-byte aligned by their types, the
        // caller guarantees `scene`; all pointers outlive the call.
        unsafe { sys::rtcIntersect8(valid.0.as_ptr(), scene, rh, &mut args) }
    }

    pub(crate) unsafe fn intersect16(
        valid: &Valid16,
        scene: sys::RTCScene,
        rh: &mut sys::RTCRayHit16,
        coherent: bool,
    ) {
        let mut args = intersect_args(coherent);
        // SAFETY: `valid` and `rh` are 64-byte aligned by their types, the
        // caller guarantees `scene`; all pointers outlive the call.
        unsafe { sys::rtcIntersect16(valid.0.as_ptr(), scene, rh, &mut args) }
    }

    pub(crate) unsafe fn occluded8(valid: &Valid8, scene: sys::RTCScene, ray: &mut sys::RTCRay8) {
        let mut args = occluded_args();
        // SAFETY: as in `intersect8`.
        unsafe { sys::rtcOccluded8(valid.0.as_ptr(), scene, ray, &mut args) }
    }

    pub(crate) unsafe fn occluded16(
        valid: &Valid16,
        scene: sys::RTCScene,
        ray: &mut sys::RTCRay16,
    ) {
        let mut args = occluded_args();
        // SAFETY: as in `intersect16`.
        unsafe { sys::rtcOccluded16(valid.0.as_ptr(), scene, ray, &mut args) }
    }
}

pub(crate) use imp::{intersect1, intersect8, intersect16, occluded1, occluded8, occluded16};
