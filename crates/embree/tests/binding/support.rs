//! Shared helpers for the Embree tests: a tiny deterministic RNG and scenes.

use penumbra_embree::Vec3;

/// xorshift64* (seed 0 becomes 1): the stream these tests were tuned on,
/// so it may not change a bit.
pub struct Rng(u64);

/// `count` independent triangles of edge ~`size` scattered in [-1, 1]^3.
pub fn triangle_soup(rng: &mut Rng, count: usize, size: f32) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let mut positions = Vec::with_capacity(count * 3);
    let mut indices = Vec::with_capacity(count);
    for i in 0..count {
        let c = rng.vec3(-1.0, 1.0);
        for _ in 0..3 {
            positions.push(c + rng.vec3(-size, size));
        }
        let b = (3 * i) as u32;
        indices.push([b, b + 1, b + 2]);
    }
    (positions, indices)
}

/// A square in the plane z = `z`, spanning [-1, 1]^2, normal +z (counter-clockwise from +z).
pub fn square(z: f32) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    (
        vec![
            Vec3::new(-1.0, -1.0, z),
            Vec3::new(1.0, -1.0, z),
            Vec3::new(1.0, 1.0, z),
            Vec3::new(-1.0, 1.0, z),
        ],
        vec![[0, 1, 2], [0, 2, 3]],
    )
}

impl Rng {
    pub fn new(seed: u64) -> Self {
        Rng(seed.max(1))
    }
    pub fn next_u64(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }
    /// Uniform in [0, 1).
    pub fn f32(&mut self) -> f32 {
        (self.next_u64() >> 40) as f32 / (1u64 << 24) as f32
    }
    pub fn range(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.f32()
    }
    pub fn vec3(&mut self, lo: f32, hi: f32) -> Vec3 {
        Vec3::new(self.range(lo, hi), self.range(lo, hi), self.range(lo, hi))
    }
    /// Uniform direction on the unit sphere.
    pub fn dir(&mut self) -> Vec3 {
        loop {
            let v = self.vec3(-1.0, 1.0);
            let l = v.length_squared();
            if l > 1e-4 && l <= 1.0 {
                return v / l.sqrt();
            }
        }
    }
}
