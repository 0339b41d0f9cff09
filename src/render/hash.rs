//! Stateless hashing to [0,1) numbers: any pixel, sample and seed gets its
//! own value without shared state, so frames are the same at any thread count.

use glam::Vec2;

/// A well-mixed 32-bit hash (lowbias32 structure: xor-shift-multiply rounds).
#[inline]
pub fn mix(mut x: u32) -> u32 {
    x ^= x >> 16;
    x = x.wrapping_mul(0x7feb_352d);
    x ^= x >> 15;
    x = x.wrapping_mul(0x846c_a68b);
    x ^= x >> 16;
    x
}

#[inline]
pub fn hash3(a: u32, b: u32, c: u32) -> u32 {
    mix(a ^ mix(b ^ mix(c)))
}

/// A number in [0, 1) from the top 24 bits of a hash.
#[inline]
pub fn unit(h: u32) -> f32 {
    (h >> 8) as f32 * (1.0 / 16_777_216.0)
}

#[inline]
pub fn unit2(a: u32, b: u32, c: u32) -> Vec2 {
    let h = hash3(a, b, c);
    Vec2::new(unit(h), unit(mix(h ^ 0x9e37_79b9)))
}
