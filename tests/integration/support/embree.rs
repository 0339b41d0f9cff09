//! Shared helpers for the Embree tests: a tiny deterministic RNG and scenes.

use penumbra::embree::Vec3;

pub use super::rng::XorShift64Star as Rng;

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
