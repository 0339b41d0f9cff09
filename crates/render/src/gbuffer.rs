//! The G-buffer: what the camera ray of each pixel found, with the material
//! already resolved (textures looked up, normal map applied), so that later
//! stages never touch meshes or textures.

use super::world::{GeomRef, World};
use glam::{Vec2, Vec3};
use penumbra_scene::CameraFrame;
use penumbra_scene::{TexelFootprint, Texture};

#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum PixelKind {
    /// The camera ray left the scene.
    #[default]
    Miss,
    /// A receiver surface (mesh).
    Surface,
    /// A light's emitting side, or its dark back side.
    Light,
}

/// One pixel of the G-buffer.
#[derive(Debug, Clone, Copy, Default)]
pub struct GSample {
    pub kind: PixelKind,
    /// World-space hit point, interpolated from the triangle's vertices (more
    /// precise than eye + t * dir far from the eye).
    pub position: Vec3,
    /// Unit geometric normal, flipped to face the camera.
    pub ng: Vec3,
    /// Unit shading normal (interpolated, normal-mapped), on the camera's side of `ng`.
    pub ns: Vec3,
    /// Unit direction from the hit toward the eye.
    pub wo: Vec3,
    /// Distance from the eye along the unit camera ray; 0 on a miss.
    pub depth: f32,
    pub uv: Vec2,
    /// Index of the material (surfaces) or light (lights).
    pub material: u32,
    /// Resolved material parameters (maps applied).
    pub diffuse: Vec3,
    pub specular: Vec3,
    pub roughness: f32,
    /// Radiance the camera sees directly (light pixels only).
    pub emission: Vec3,
    /// Where this point was in the previous frame's camera, in continuous
    /// pixel coordinates (the current camera stands in for the first frame).
    pub prev_pixel: Vec2,
    /// False when the point was behind the previous camera (no history).
    pub prev_valid: bool,
}

/// Resolves an Embree hit into the G-buffer sample `out`, written in place
/// (inlined into the per-ISA primary kernel, `primary::trace_rows`).
/// `prev` is the previous frame's camera, for the motion vector; `None`
/// where the camera did not move (the hit's history is its own pixel's,
/// which the caller writes).
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub fn resolve_hit(
    world: &World,
    geom_id: u32,
    prim_id: u32,
    b1: f32,
    b2: f32,
    t: f32,
    dir: Vec3,
    prev: Option<&CameraFrame>,
    out: &mut GSample,
) {
    let Some(geom) = world.geom(geom_id) else {
        *out = GSample::default();
        return;
    };
    match geom {
        GeomRef::Light(li) => {
            let light = &world.lights.declared()[li as usize];
            let position = world.scene.camera.eye + dir * t;
            let mut ng = light.normal;
            let front = ng.dot(dir) < 0.0;
            if !front {
                ng = -ng;
            }
            let emission = if front || light.two_sided {
                light.radiance
            } else {
                Vec3::ZERO
            };
            *out = GSample {
                kind: PixelKind::Light,
                position,
                ng,
                ns: ng,
                wo: -dir,
                depth: t,
                material: li,
                emission,
                ..GSample::default()
            };
            set_motion(out, prev);
        }
        GeomRef::Mesh(mi) => {
            let mesh = &world.scene.meshes[mi as usize];
            let (Some(tri), Some(frame)) = (
                mesh.indices.get(prim_id as usize),
                world
                    .tris
                    .get(mi as usize)
                    .and_then(|f| f.get(prim_id as usize)),
            ) else {
                *out = GSample::default();
                return;
            };
            let [i0, i1, i2] = tri.map(|i| i as usize);
            let (p0, p1, p2) = (mesh.positions[i0], mesh.positions[i1], mesh.positions[i2]);
            let b0 = 1.0 - b1 - b2;
            let position = b0 * p0 + b1 * p1 + b2 * p2;
            let mut ng = frame.ng.unwrap_or(-dir);
            let mut ns = match &mesh.normals {
                Some(n) => (b0 * n[i0] + b1 * n[i1] + b2 * n[i2]).normalize_or(ng),
                None => ng,
            };
            // Two-sided surfaces: both normals turn to the camera's side.
            if ng.dot(dir) > 0.0 {
                ng = -ng;
            }
            if ns.dot(ng) < 0.0 {
                ns = -ns;
            }
            let uv = match &mesh.uvs {
                Some(t) => b0 * t[i0] + b1 * t[i1] + b2 * t[i2],
                None => Vec2::new(b1, b2),
            };
            let mat = &world.scene.materials[mesh.material as usize];
            // A material's maps usually share one size: their texel
            // footprint at `uv` is then worked out once (`sample_map`).
            let mut last: Option<((u32, u32), TexelFootprint)> = None;
            let mut diffuse = mat.diffuse;
            if let Some(map) = &mat.diffuse_map {
                let texel = sample_map(map, uv, &mut last);
                diffuse *= Vec3::new(texel[0], texel[1], texel[2]);
            }
            let roughness = match &mat.roughness_map {
                Some(map) => sample_map(map, uv, &mut last)[0].clamp(0.0, 1.0),
                None => mat.roughness,
            };
            if let (Some(map), Some((dpds, dpdt))) = (&mat.normal_map, frame.tangents) {
                let texel = sample_map(map, uv, &mut last);
                let local = Vec3::new(texel[0], texel[1], texel[2]) * 2.0 - Vec3::ONE;
                ns = apply_normal_map(ns, dpds, dpdt, local);
            }
            *out = GSample {
                kind: PixelKind::Surface,
                position,
                ng,
                ns,
                wo: -dir,
                depth: t,
                uv,
                material: mesh.material,
                diffuse,
                specular: mat.specular,
                roughness,
                ..GSample::default()
            };
            set_motion(out, prev);
        }
    }
}

/// `map` at `uv`, through the footprint in `last` when it was made for a
/// map of this size. Inlined into the per-ISA primary kernel.
#[inline(always)]
fn sample_map(
    map: &Texture,
    uv: Vec2,
    last: &mut Option<((u32, u32), TexelFootprint)>,
) -> [f32; 4] {
    let size = (map.width, map.height);
    let fp = match *last {
        Some((s, fp)) if s == size => fp,
        _ => {
            let fp = map.footprint(uv);
            *last = Some((size, fp));
            fp
        }
    };
    fp.sample(map)
}

/// Tangent-space normal `local` (+Y along increasing t, OpenGL convention)
/// to world space, in the tangent frame (`dpds`, `dpdt`) of the triangle's
/// uv parameterisation (`TriFrame`; absent on degenerate uvs, where the
/// normal stays unperturbed).
#[inline]
fn apply_normal_map(ns: Vec3, dpds: Vec3, dpdt: Vec3, local: Vec3) -> Vec3 {
    // Gram-Schmidt against the (possibly flipped) shading normal; the
    // bitangent keeps the handedness the uv mapping has.
    let Some(t) = (dpds - ns * ns.dot(dpds)).try_normalize() else {
        return ns;
    };
    let mut b = ns.cross(t);
    if b.dot(dpdt) < 0.0 {
        b = -b;
    }
    (t * local.x + b * local.y + ns * local.z.max(0.0)).normalize_or(ns)
}

#[inline]
fn set_motion(s: &mut GSample, prev: Option<&CameraFrame>) {
    match prev {
        Some(prev) => {
            if let Some((x, y)) = prev.project(s.position) {
                s.prev_pixel = Vec2::new(x, y);
                s.prev_valid = true;
            }
        }
        None => s.prev_valid = true,
    }
}
