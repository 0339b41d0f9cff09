//! One frame of history: the temporally accumulated signals plus what the
//! next frame needs to validate a reprojection tap.
//!
//! The record is kept small (17 values with both signals): the normal is
//! octahedron-encoded. The colour resolve keeps the same metadata in
//! records of its own (`resolve::Records`).

use super::spatial::LANES;
#[cfg(test)]
use glam::{Vec2, Vec3};

/// The fields of one pixel's history, one `f32` plane each (`History`).
/// The encoded normal's two components are stored as the integers they
/// are, exactly.
pub(crate) mod field {
    pub const DEPTH: usize = 0;
    pub const PX: usize = 1;
    pub const PY: usize = 2;
    pub const PZ: usize = 3;
    pub const E0: usize = 4;
    pub const E1: usize = 5;
    pub const LEN: usize = 6;
    /// Accumulated first and second moments of the raw per-frame ratio
    /// (same blend as the signals), for the temporal noise estimate.
    pub const M1: usize = 7;
    pub const M2: usize = 8;
    pub const LU: usize = 9;
    pub const LU_DIFFUSE: usize = 10;
    pub const UR: usize = 11;
    pub const SR: usize = 14;
    pub const COUNT: usize = 17;
}

/// Values of one lane group's record: every field of the eight pixels of a
/// row that a lane group covers, field by field.
pub(crate) const GROUP: usize = field::COUNT * LANES;

/// One frame of history by lane groups: the eight pixels of a row that a
/// lane group covers keep their record as one block of `GROUP` values
/// (field `k` of the group's lane `l` at `k * LANES + l`), and image row `y`
/// is the row's groups in order. The temporal pass then reads the previous
/// frame and writes the next one as one stream each: a plane per field
/// would be 34 streams a row beside the pass's other planes, a layout that
/// at some frame widths (1280 among them) doubles the pass's time for the
/// same instructions (docs/performance.md). A lane group whose taps are
/// consecutive pixels of one row reads each field with one load (two where
/// they straddle groups). A pixel without a surface holds zeros: depth 0,
/// no history to give.
pub(crate) struct History {
    pub data: Vec<f32>,
    pub width: usize,
}

impl History {
    pub fn new(width: usize, height: usize) -> History {
        History {
            data: vec![0.0; width.div_ceil(LANES) * GROUP * height],
            width,
        }
    }

    /// Values of one image row of every field.
    #[inline(always)]
    pub fn row_len(&self) -> usize {
        self.width.div_ceil(LANES) * GROUP
    }

    /// Where pixel (x, y)'s field 0 sits; field `k` is `k * LANES` further.
    #[inline(always)]
    pub fn at(&self, x: usize, y: usize) -> usize {
        y * self.row_len() + x / LANES * GROUP + x % LANES
    }

    /// Field `k` of pixel (x, y).
    #[inline(always)]
    pub fn value(&self, k: usize, x: usize, y: usize) -> f32 {
        self.data[self.at(x, y) + k * LANES]
    }

    /// Field `k` of pixel `i` (row-major).
    #[inline(always)]
    pub fn get(&self, k: usize, i: usize) -> f32 {
        self.value(k, i % self.width, i / self.width)
    }

    /// Pixels held.
    pub fn len(&self) -> usize {
        self.data.len().checked_div(self.row_len()).unwrap_or(0) * self.width
    }

    /// Forget everything: every tap of the next reprojection fails its depth test.
    pub fn clear(&mut self) {
        self.data.fill(0.0);
    }
}

/// Octahedral normal encoding (Cigolle et al. 2014): about 1e-4 rad error,
/// far below the reprojection's normal tolerance. The passes encode in
/// lanes (`temporal::encode_normal_lanes`); this is the scalar reference
/// the tests hold them to.
#[cfg(test)]
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
/// compare angles with squared dots and avoid the square root. The scalar
/// reference of `temporal::decode_normal_lanes`.
#[cfg(test)]
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
#[cfg(test)]
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
