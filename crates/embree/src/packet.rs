//! 8- and 16-wide ray packets (structure of arrays) and their queries.
//!
//! The public types are plain arrays with no alignment demands; each query
//! copies them into Embree's aligned `RTCRay*` layouts on the stack. The copy
//! is a few hundred bytes, small next to a BVH traversal.

use super::context::{self, INVALID_GEOMETRY_ID, Valid8, Valid16};
use super::scene::{RAY_MASK_ALL, Scene};
use super::sys;

/// Geometry id of a missed or inactive lane (`RTC_INVALID_GEOMETRY_ID`).
pub const INVALID_ID: u32 = INVALID_GEOMETRY_ID;

macro_rules! packet_types {
    ($n:literal, $Rays:ident, $Hits:ident, $Active:ty) => {
        #[doc = concat!($n, " rays, structure of arrays. Only lanes whose bit is set in `active` are traced.")]
        #[derive(Clone, Copy, Debug)]
        pub struct $Rays {
            pub ox: [f32; $n],
            pub oy: [f32; $n],
            pub oz: [f32; $n],
            pub dx: [f32; $n],
            pub dy: [f32; $n],
            pub dz: [f32; $n],
            pub tnear: [f32; $n],
            pub tfar: [f32; $n],
            /// Bit i set = lane i is traced.
            pub active: $Active,
        }

        impl $Rays {
            /// All lanes inactive, `tnear = 0`, `tfar = inf`.
            pub fn new() -> Self {
                Self {
                    ox: [0.0; $n],
                    oy: [0.0; $n],
                    oz: [0.0; $n],
                    dx: [0.0; $n],
                    dy: [0.0; $n],
                    dz: [0.0; $n],
                    tnear: [0.0; $n],
                    tfar: [f32::INFINITY; $n],
                    active: 0,
                }
            }

            /// Sets lane `i` (and marks it active).
            pub fn set(&mut self, i: usize, org: glam::Vec3, dir: glam::Vec3, tnear: f32, tfar: f32) {
                self.ox[i] = org.x;
                self.oy[i] = org.y;
                self.oz[i] = org.z;
                self.dx[i] = dir.x;
                self.dy[i] = dir.y;
                self.dz[i] = dir.z;
                self.tnear[i] = tnear;
                self.tfar[i] = tfar;
                self.active |= 1 << i;
            }

            /// Whether lane `i` is traced.
            pub fn is_active(&self, i: usize) -> bool {
                self.active >> i & 1 == 1
            }
        }

        impl Default for $Rays {
            fn default() -> Self {
                Self::new()
            }
        }

        #[doc = concat!("Results of an ", $n, "-wide intersect: per lane `t = f32::INFINITY` and `geom_id = INVALID_ID` where missed or inactive.")]
        #[derive(Clone, Copy, Debug)]
        pub struct $Hits {
            pub t: [f32; $n],
            pub geom_id: [u32; $n],
            pub prim_id: [u32; $n],
            pub u: [f32; $n],
            pub v: [f32; $n],
            /// Embree's unnormalised geometric normal.
            pub ngx: [f32; $n],
            pub ngy: [f32; $n],
            pub ngz: [f32; $n],
        }

        impl $Hits {
            /// Every lane a miss.
            pub fn new() -> Self {
                Self {
                    t: [f32::INFINITY; $n],
                    geom_id: [INVALID_ID; $n],
                    prim_id: [INVALID_ID; $n],
                    u: [0.0; $n],
                    v: [0.0; $n],
                    ngx: [0.0; $n],
                    ngy: [0.0; $n],
                    ngz: [0.0; $n],
                }
            }

            /// Whether lane `i` hit something.
            pub fn is_hit(&self, i: usize) -> bool {
                self.geom_id[i] != INVALID_ID
            }
        }

        impl Default for $Hits {
            fn default() -> Self {
                Self::new()
            }
        }
    };
}

packet_types!(16, Rays16, Hits16, u16);
packet_types!(8, Rays8, Hits8, u8);

/// Fills an Embree packet ray from ours. Inactive lanes are copied as they
/// are: the valid mask already makes Embree ignore them.
macro_rules! fill_ray {
    ($dst:expr, $rays:expr, $mask:expr) => {{
        let dst = &mut $dst;
        let rays = $rays;
        dst.org_x = rays.ox;
        dst.org_y = rays.oy;
        dst.org_z = rays.oz;
        dst.dir_x = rays.dx;
        dst.dir_y = rays.dy;
        dst.dir_z = rays.dz;
        dst.tnear = rays.tnear;
        dst.tfar = rays.tfar;
        dst.mask.fill($mask);
        dst.time.fill(0.0);
        dst.id.fill(0);
        dst.flags.fill(0);
    }};
}

macro_rules! valid_mask {
    ($Valid:ident, $n:literal, $active:expr) => {{
        let active = $active;
        $Valid(std::array::from_fn::<i32, $n, _>(|i| {
            if active >> i & 1 == 1 { -1 } else { 0 }
        }))
    }};
}

macro_rules! read_hits {
    ($rh:expr, $rays:expr, $Hits:ident) => {{
        let rh = &$rh;
        let mut out = $Hits::new();
        for i in 0..out.t.len() {
            if $rays.is_active(i) && rh.hit.geomID[i] != INVALID_GEOMETRY_ID {
                out.t[i] = rh.ray.tfar[i];
                out.geom_id[i] = rh.hit.geomID[i];
                out.prim_id[i] = rh.hit.primID[i];
                out.u[i] = rh.hit.u[i];
                out.v[i] = rh.hit.v[i];
                out.ngx[i] = rh.hit.Ng_x[i];
                out.ngy[i] = rh.hit.Ng_y[i];
                out.ngz[i] = rh.hit.Ng_z[i];
            }
        }
        out
    }};
}

/// Embree marks an occluded lane with tfar = -inf; a lane that came in with
/// tfar = -inf is an empty interval, not a hit.
macro_rules! read_occluded {
    ($ray:expr, $rays:expr, $Bits:ty) => {{
        let mut bits: $Bits = 0;
        for i in 0..$rays.tfar.len() {
            if $rays.is_active(i)
                && $ray.tfar[i] == f32::NEG_INFINITY
                && $rays.tfar[i] != f32::NEG_INFINITY
            {
                bits |= 1 << i;
            }
        }
        bits
    }};
}

impl Scene<'_> {
    /// Closest hits of up to 16 rays. `coherent` hints that the rays are
    /// neighbours (primary rays of a 4x4 pixel block); never set it for
    /// shadow or bounce rays.
    pub fn intersect16(&self, rays: &Rays16, coherent: bool) -> Hits16 {
        if rays.active == 0 {
            return Hits16::new();
        }
        let valid = valid_mask!(Valid16, 16, rays.active);
        let mut rh = sys::RTCRayHit16::default();
        fill_ray!(rh.ray, rays, RAY_MASK_ALL);
        rh.hit.geomID.fill(INVALID_GEOMETRY_ID);
        for level in rh.hit.instID.iter_mut() {
            level.fill(INVALID_GEOMETRY_ID);
        }
        // SAFETY: the camera-ray scene is committed and lives as long as `self`.
        unsafe { context::intersect16(&valid, self.raw_all(), &mut rh, coherent) };
        read_hits!(rh, rays, Hits16)
    }

    /// 8-wide [`Scene::intersect16`].
    pub fn intersect8(&self, rays: &Rays8, coherent: bool) -> Hits8 {
        if rays.active == 0 {
            return Hits8::new();
        }
        let valid = valid_mask!(Valid8, 8, rays.active);
        let mut rh = sys::RTCRayHit8::default();
        fill_ray!(rh.ray, rays, RAY_MASK_ALL);
        rh.hit.geomID.fill(INVALID_GEOMETRY_ID);
        for level in rh.hit.instID.iter_mut() {
            level.fill(INVALID_GEOMETRY_ID);
        }
        // SAFETY: the camera-ray scene is committed and lives as long as `self`.
        unsafe { context::intersect8(&valid, self.raw_all(), &mut rh, coherent) };
        read_hits!(rh, rays, Hits8)
    }

    /// Shadow rays: bit i set = lane i is occluded. Inactive lanes are 0.
    /// `CameraOnly` meshes never occlude.
    pub fn occluded16(&self, rays: &Rays16) -> u16 {
        if rays.active == 0 {
            return 0;
        }
        let (scene, mask) = self.raw_shadow();
        let valid = valid_mask!(Valid16, 16, rays.active);
        let mut ray = sys::RTCRay16::default();
        fill_ray!(ray, rays, mask);
        // SAFETY: the shadow-ray scene is committed and lives as long as `self`.
        unsafe { context::occluded16(&valid, scene, &mut ray) };
        read_occluded!(ray, rays, u16)
    }

    /// 8-wide [`Scene::occluded16`].
    pub fn occluded8(&self, rays: &Rays8) -> u8 {
        if rays.active == 0 {
            return 0;
        }
        let (scene, mask) = self.raw_shadow();
        let valid = valid_mask!(Valid8, 8, rays.active);
        let mut ray = sys::RTCRay8::default();
        fill_ray!(ray, rays, mask);
        // SAFETY: the shadow-ray scene is committed and lives as long as `self`.
        unsafe { context::occluded8(&valid, scene, &mut ray) };
        read_occluded!(ray, rays, u8)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::mem::align_of;

    #[test]
    fn embree_packet_layouts_carry_the_alignment_embree_requires() {
        // Embree: 8-wide packets 32-byte aligned, 16-wide 64-byte aligned,
        // valid masks aligned like their packet.
        assert!(align_of::<sys::RTCRay8>() >= 32);
        assert!(align_of::<sys::RTCRayHit8>() >= 32);
        assert!(align_of::<Valid8>() >= 32);
        assert!(align_of::<sys::RTCRay16>() >= 64);
        assert!(align_of::<sys::RTCRayHit16>() >= 64);
        assert!(align_of::<Valid16>() >= 64);
    }

    #[test]
    fn public_packets_have_no_alignment_demand_of_their_own() {
        // Plain f32 arrays: any place Rust can put one is fine, because the
        // query copies it into the aligned Embree layout.
        assert_eq!(align_of::<Rays16>(), align_of::<f32>());
        assert_eq!(align_of::<Rays8>(), align_of::<f32>());
    }
}
