//! One frame of history: the temporally accumulated signals plus what the
//! next frame needs to validate a reprojection tap.
//!
//! At 1280x720 the denoiser is bound by memory traffic, not arithmetic, so
//! the record is kept small (64 bytes with both signals): the normal is octahedron-encoded.

use glam::{Vec2, Vec3};

/// Per-pixel history metadata, packed so one reprojection tap touches one
/// small record.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Meta {
    pub pos: Vec3,
    /// Octahedral encoding of the unit normal (see [`encode_normal`]).
    pub normal: [i16; 2],
    /// 0: no surface, the pixel has no history to give.
    pub depth: f32,
    /// Luminance of the analytic `U` this frame, and of its diffuse part
    /// (which a camera move cannot change), to detect light changes.
    pub lu: f32,
    pub lu_diffuse: f32,
    /// Accumulated first and second moments of the raw per-frame ratio
    /// (same blend as the signals), for the temporal noise estimate.
    pub m1: f32,
    pub m2: f32,
    /// Frames accumulated (capped); fractional after bilinear reprojection.
    pub len: f32,
}

/// One pixel's history: the metadata and both accumulated signals in one
/// cache line, so a reprojection tap is one bounds test and one line.
#[derive(Clone, Copy, Debug, Default)]
#[repr(C, align(64))]
pub(crate) struct Record {
    pub meta: Meta,
    pub un: Vec3,
    pub sn: Vec3,
}

const _: () = assert!(std::mem::size_of::<Record>() == 64);

pub(crate) struct History {
    pub rec: Vec<Record>,
}

impl History {
    pub fn new(n: usize) -> History {
        History {
            rec: vec![Record::default(); n],
        }
    }

    /// Forget everything: every tap of the next reprojection fails its depth test.
    pub fn clear(&mut self) {
        self.rec.fill(Record::default());
    }
}

/// Octahedral normal encoding (Cigolle et al. 2014): about 1e-4 rad error,
/// far below the reprojection's normal tolerance.
#[inline]
pub(crate) fn encode_normal(n: Vec3) -> [i16; 2] {
    let l1 = n.x.abs() + n.y.abs() + n.z.abs();
    if !(l1 > 0.0 && l1.is_finite()) {
        return [0, 0];
    }
    let mut p = Vec2::new(n.x, n.y) / l1;
    if n.z < 0.0 {
        p = (Vec2::ONE - Vec2::new(p.y.abs(), p.x.abs())) * sign(p);
    }
    // Round half away from zero by hand: `f32::round` is a libm call on
    // baseline x86-64.
    let q = |v: f32| (v * 32767.0 + 0.5f32.copysign(v)) as i16;
    [q(p.x), q(p.y)]
}

/// Decoded normal, not normalised (length within [1/sqrt(3), 1]): callers
/// compare angles with squared dots and avoid the square root.
#[inline(always)]
pub(crate) fn decode_normal(e: [i16; 2]) -> Vec3 {
    // A multiply, not a divide: this runs on every reprojection tap and the
    // last-bit difference is far below the normal tolerance.
    let mut p = Vec2::new(e[0] as f32, e[1] as f32) * (1.0 / 32767.0);
    let z = 1.0 - p.x.abs() - p.y.abs();
    if z < 0.0 {
        p = (Vec2::ONE - Vec2::new(p.y.abs(), p.x.abs())) * sign(p);
    }
    Vec3::new(p.x, p.y, z)
}

/// Sign with +1 at zero (octahedral wrap needs a definite side).
#[inline]
fn sign(p: Vec2) -> Vec2 {
    Vec2::new(
        if p.x >= 0.0 { 1.0 } else { -1.0 },
        if p.y >= 0.0 { 1.0 } else { -1.0 },
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn normal_encoding_round_trips() {
        for n in [
            Vec3::X,
            -Vec3::X,
            Vec3::Y,
            -Vec3::Y,
            Vec3::Z,
            -Vec3::Z,
            Vec3::new(0.3, -0.5, -0.8).normalize(),
            Vec3::new(-0.7, 0.1, 0.2).normalize(),
        ] {
            let d = decode_normal(encode_normal(n)).normalize();
            assert!(d.dot(n) > 0.99999, "{n} -> {d}");
        }
    }
}
