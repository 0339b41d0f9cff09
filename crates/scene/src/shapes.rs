//! Triangle meshes for the built-in object types (quad, box, icosphere) and
//! the scale / rotate_y / translate transform shared by boxes and OBJ meshes.
//! Inputs are validated by the parser; nothing here can fail.

use super::Mesh;
use glam::{Mat3, Vec2, Vec3};
use std::collections::HashMap;
use std::hash::{BuildHasherDefault, Hasher};

/// Rotation about +Y by `degrees`, right-hand rule: 90 maps +X to -Z
/// (glam's `from_rotation_y` has exactly that sense).
pub fn rotation_y(degrees: f32) -> Mat3 {
    Mat3::from_rotation_y(degrees.to_radians())
}

/// Parallelogram with corners `center ± u ± v`, wound so its geometric normal
/// is `normalize(cross(u, v))`; (s, t) = (0, 0) at `center - u - v` and
/// (1, 1) at `center + u + v`, s along u, t along v.
pub fn quad(center: Vec3, u: Vec3, v: Vec3, material: u32) -> Mesh {
    let n = u.cross(v).normalize_or_zero();
    Mesh {
        positions: vec![
            center - u - v,
            center + u - v,
            center + u + v,
            center - u + v,
        ],
        normals: Some(vec![n; 4]),
        uvs: Some(vec![
            Vec2::new(0.0, 0.0),
            Vec2::new(1.0, 0.0),
            Vec2::new(1.0, 1.0),
            Vec2::new(0.0, 1.0),
        ]),
        indices: vec![[0, 1, 2], [0, 2, 3]],
        material,
    }
}

/// Appends `other` to `into` (same material), offsetting its indices.
fn append(into: &mut Mesh, other: Mesh) {
    let base = into.positions.len() as u32;
    into.positions.extend(other.positions);
    if let (Some(a), Some(b)) = (into.normals.as_mut(), other.normals) {
        a.extend(b);
    }
    if let (Some(a), Some(b)) = (into.uvs.as_mut(), other.uvs) {
        a.extend(b);
    }
    into.indices
        .extend(other.indices.iter().map(|t| t.map(|i| i + base)));
}

/// Box of full extents `size` centred on `center`, rotated about its own
/// centre by `rotate_y` degrees. Each face is its own quad (4 vertices, flat
/// outward normal, uvs 0..1) so that edges stay sharp: 24 vertices, 12
/// triangles. Side faces have t pointing up (+Y).
pub fn cuboid(center: Vec3, size: Vec3, rotate_y: f32, material: u32) -> Mesh {
    let h = size * 0.5;
    // (outward normal, u direction, v direction) with cross(u, v) = normal.
    let faces = [
        (Vec3::X, Vec3::NEG_Z, Vec3::Y),
        (Vec3::NEG_X, Vec3::Z, Vec3::Y),
        (Vec3::Z, Vec3::X, Vec3::Y),
        (Vec3::NEG_Z, Vec3::NEG_X, Vec3::Y),
        (Vec3::Y, Vec3::X, Vec3::NEG_Z),
        (Vec3::NEG_Y, Vec3::X, Vec3::Z),
    ];
    let mut mesh = Mesh {
        normals: Some(Vec::new()),
        uvs: Some(Vec::new()),
        material,
        ..Mesh::default()
    };
    for (n, du, dv) in faces {
        // Half-extent along a unit axis direction.
        let ext = |d: Vec3| d * d.abs().dot(h);
        append(&mut mesh, quad(ext(n), ext(du), ext(dv), material));
    }
    let r = rotation_y(rotate_y);
    for p in &mut mesh.positions {
        *p = center + r * *p;
    }
    if let Some(ns) = mesh.normals.as_mut() {
        for n in ns {
            *n = r * *n;
        }
    }
    mesh
}

/// Scale (per axis), then rotate about +Y, then translate.
#[derive(Debug, Clone, Copy)]
pub struct Transform {
    pub scale: Vec3,
    pub rotate_y: f32,
    pub translate: Vec3,
}

impl Transform {
    /// Applies the transform in place. Normals use the inverse transpose
    /// (for a diagonal scale and a rotation that is rotation * 1/scale) and
    /// are renormalised. A mirroring scale (odd number of negative factors)
    /// flips triangle winding so geometric and shading normals still agree.
    /// Scale factors must be non-zero (the parser refuses |s| < 1e-6).
    pub fn apply(&self, mesh: &mut Mesh) {
        let r = rotation_y(self.rotate_y);
        for p in &mut mesh.positions {
            *p = r * (*p * self.scale) + self.translate;
        }
        let inv = self.scale.recip();
        if let Some(ns) = mesh.normals.as_mut() {
            for n in ns {
                *n = (r * (*n * inv)).normalize_or_zero();
            }
        }
        if self.scale.x * self.scale.y * self.scale.z < 0.0 {
            for t in &mut mesh.indices {
                t.swap(1, 2);
            }
        }
    }
}

/// Hasher for packed edge keys: one multiply is plenty for distinct u64s
/// and keeps a level-8 sphere (millions of lookups) fast.
#[derive(Default)]
struct EdgeHasher(u64);

impl Hasher for EdgeHasher {
    fn finish(&self) -> u64 {
        self.0
    }
    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 = (self.0.rotate_left(5) ^ b as u64).wrapping_mul(0x517c_c1b7_2722_0a95);
        }
    }
    fn write_u64(&mut self, x: u64) {
        self.0 = (x ^ (x >> 29)).wrapping_mul(0x9e37_79b9_7f4a_7c15);
    }
}

type EdgeMap = HashMap<u64, u32, BuildHasherDefault<EdgeHasher>>;

/// Unit icosahedron: 12 vertices, 20 faces wound outward.
fn icosahedron() -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let p = (1.0 + 5f32.sqrt()) * 0.5;
    let verts: Vec<Vec3> = [
        (-1.0, p, 0.0),
        (1.0, p, 0.0),
        (-1.0, -p, 0.0),
        (1.0, -p, 0.0),
        (0.0, -1.0, p),
        (0.0, 1.0, p),
        (0.0, -1.0, -p),
        (0.0, 1.0, -p),
        (p, 0.0, -1.0),
        (p, 0.0, 1.0),
        (-p, 0.0, -1.0),
        (-p, 0.0, 1.0),
    ]
    .iter()
    .map(|&(x, y, z)| Vec3::new(x, y, z).normalize())
    .collect();
    let mut faces: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    // Enforce outward winding rather than trust the table by eye.
    for f in &mut faces {
        let [a, b, c] = f.map(|i| verts[i as usize]);
        if (b - a).cross(c - a).dot(a + b + c) < 0.0 {
            f.swap(1, 2);
        }
    }
    (verts, faces)
}

/// Unit-sphere directions and faces of an icosphere at `level` (each level
/// splits every triangle into 4 through cached edge midpoints).
fn unit_icosphere(level: u32) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let (mut verts, mut faces) = icosahedron();
    for _ in 0..level {
        let mut next = Vec::with_capacity(faces.len() * 4);
        let mut cache = EdgeMap::default();
        cache.reserve(faces.len() * 3 / 2);
        verts.reserve(faces.len() * 3 / 2);
        let mut midpoint = |a: u32, b: u32, verts: &mut Vec<Vec3>| -> u32 {
            let key = ((a.min(b) as u64) << 32) | a.max(b) as u64;
            *cache.entry(key).or_insert_with(|| {
                let m = (verts[a as usize] + verts[b as usize]).normalize();
                verts.push(m);
                (verts.len() - 1) as u32
            })
        };
        for &[a, b, c] in &faces {
            let ab = midpoint(a, b, &mut verts);
            let bc = midpoint(b, c, &mut verts);
            let ca = midpoint(c, a, &mut verts);
            next.extend_from_slice(&[[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        faces = next;
    }
    (verts, faces)
}

/// Spherical (s, t) of a unit direction: s grows towards +X seen from +Z
/// (so textures are not mirrored from outside), seam at -Z; t = 0 at the
/// south pole (-Y), 1 at the north pole.
fn spherical_uv(d: Vec3) -> Vec2 {
    let s = 0.5 + d.x.atan2(d.z) / std::f32::consts::TAU;
    let t = 0.5 + d.y.clamp(-1.0, 1.0).asin() / std::f32::consts::PI;
    Vec2::new(s, t)
}

/// Icosphere at `level` (20 * 4^level triangles) with radial normals and
/// spherical uvs. Triangles straddling the seam get duplicated vertices with
/// s + 1 (textures repeat, so s + 1 samples the same texel), and each
/// triangle touching a pole gets its own pole vertex with the mean s of its
/// other corners: otherwise those triangles would smear the whole texture.
pub fn icosphere(center: Vec3, radius: f32, level: u32, material: u32) -> Mesh {
    let (dirs, mut faces) = unit_icosphere(level);
    let mut normals = dirs;
    let mut uvs: Vec<Vec2> = normals.iter().map(|&d| spherical_uv(d)).collect();
    let is_pole = |d: Vec3| d.x * d.x + d.z * d.z < 1e-10;
    let mut seam_copy: HashMap<u32, u32> = HashMap::new();
    for f in &mut faces {
        // Poles sit at any s; leave them out of the straddle test.
        let (mut lo, mut hi) = (f32::MAX, f32::MIN);
        for &i in f.iter() {
            if !is_pole(normals[i as usize]) {
                lo = lo.min(uvs[i as usize].x);
                hi = hi.max(uvs[i as usize].x);
            }
        }
        let straddles = hi - lo > 0.5;
        if straddles {
            for i in f.iter_mut() {
                if !is_pole(normals[*i as usize]) && uvs[*i as usize].x < 0.5 {
                    *i = *seam_copy.entry(*i).or_insert_with(|| {
                        let uv = uvs[*i as usize] + Vec2::X;
                        normals.push(normals[*i as usize]);
                        uvs.push(uv);
                        (normals.len() - 1) as u32
                    });
                }
            }
        }
        for k in 0..3 {
            let i = f[k] as usize;
            if is_pole(normals[i]) {
                let others = [f[(k + 1) % 3], f[(k + 2) % 3]];
                let s = 0.5 * (uvs[others[0] as usize].x + uvs[others[1] as usize].x);
                let t = uvs[i].y;
                normals.push(normals[i]);
                uvs.push(Vec2::new(s, t));
                f[k] = (normals.len() - 1) as u32;
            }
        }
    }
    let positions = normals.iter().map(|&d| center + d * radius).collect();
    Mesh {
        positions,
        normals: Some(normals),
        uvs: Some(uvs),
        indices: faces,
        material,
    }
}
