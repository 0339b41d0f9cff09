//! The scene as a ray-traced world: the scene's data plus its Embree scene,
//! and the map from Embree geometry ids back to meshes and lights.

use super::lights::Lights;
use glam::{Vec2, Vec3};
use penumbra_embree::{Device, EmbreeError, GeometryRole, SceneBuilder};
use penumbra_scene::{Light, Mesh, Scene};

/// What an Embree geometry id stands for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum GeomRef {
    Mesh(u32),
    Light(u32),
}

pub struct World<'d> {
    pub scene: Scene,
    /// `scene.lights` in every form the renderer reads, prepared once here;
    /// nothing changes a built world, so the two stay the same lights.
    pub lights: Lights,
    pub rt: penumbra_embree::Scene<'d>,
    pub geoms: Vec<GeomRef>,
    /// Per mesh, per triangle: what a hit needs from the triangle alone,
    /// computed once so that resolving a hit only interpolates.
    pub tris: Vec<Vec<TriFrame>>,
}

/// A triangle's own geometry: its unit face normal and the uv tangent
/// frame a normal map is applied in. `None` where the triangle is
/// degenerate (no area, or a uv mapping without area).
#[derive(Debug, Clone, Copy, Default)]
pub struct TriFrame {
    pub ng: Option<Vec3>,
    /// (dp/ds, dp/dt), present only with uvs of non-zero area.
    pub tangents: Option<(Vec3, Vec3)>,
}

impl TriFrame {
    fn new(mesh: &Mesh, tri: [u32; 3]) -> TriFrame {
        let [i0, i1, i2] = tri.map(|i| i as usize);
        let (Some(&p0), Some(&p1), Some(&p2)) = (
            mesh.positions.get(i0),
            mesh.positions.get(i1),
            mesh.positions.get(i2),
        ) else {
            return TriFrame::default();
        };
        let e1 = p1 - p0;
        let e2 = p2 - p0;
        let n = e1.cross(e2);
        // `normalize_or`'s test: the fallback is the hit's own direction.
        let rcp = n.length_recip();
        let ng = (rcp.is_finite() && rcp > 0.0).then(|| n * rcp);
        let tangents = mesh.uvs.as_ref().and_then(|t| {
            let (t0, t1, t2) = (*t.get(i0)?, *t.get(i1)?, *t.get(i2)?);
            uv_tangents(e1, e2, t1 - t0, t2 - t0)
        });
        TriFrame { ng, tangents }
    }
}

/// dp/ds and dp/dt of a triangle with edges `e1`, `e2` and uv edges `d1`,
/// `d2`; `None` on a degenerate uv mapping.
fn uv_tangents(e1: Vec3, e2: Vec3, d1: Vec2, d2: Vec2) -> Option<(Vec3, Vec3)> {
    let det = d1.x * d2.y - d2.x * d1.y;
    if det.abs() < 1e-12 || !det.is_finite() {
        return None;
    }
    let inv = 1.0 / det;
    let dpds = (e1 * d2.y - e2 * d1.y) * inv;
    let dpdt = (e2 * d1.x - e1 * d2.x) * inv;
    Some((dpds, dpdt))
}

impl<'d> World<'d> {
    /// Builds the acceleration structure. Meshes occlude shadow rays; lights
    /// are visible to camera rays only (they cast no shadows).
    pub fn build(device: &'d Device, scene: Scene) -> Result<World<'d>, EmbreeError> {
        let mut builder = SceneBuilder::new(device)?;
        let mut geoms = Vec::with_capacity(scene.meshes.len() + scene.lights.len());
        for (i, mesh) in scene.meshes.iter().enumerate() {
            let id =
                builder.add_triangles(&mesh.positions, &mesh.indices, GeometryRole::Occluder)?;
            debug_assert_eq!(id as usize, geoms.len());
            geoms.push(GeomRef::Mesh(i as u32));
        }
        for (i, light) in scene.lights.iter().enumerate() {
            let (positions, indices) = light_fan(light);
            let id = builder.add_triangles(&positions, &indices, GeometryRole::CameraOnly)?;
            debug_assert_eq!(id as usize, geoms.len());
            geoms.push(GeomRef::Light(i as u32));
        }
        let rt = builder.commit()?;
        let lights = Lights::new(&scene.lights);
        let tris = scene
            .meshes
            .iter()
            .map(|m| m.indices.iter().map(|&t| TriFrame::new(m, t)).collect())
            .collect();
        Ok(World {
            scene,
            lights,
            rt,
            geoms,
            tris,
        })
    }

    #[inline]
    pub fn geom(&self, geom_id: u32) -> Option<GeomRef> {
        self.geoms.get(geom_id as usize).copied()
    }
}

/// A convex polygon as a triangle fan around its first vertex.
fn light_fan(light: &Light) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let n = light.vertices.len() as u32;
    let indices = (1..n.saturating_sub(1)).map(|k| [0, k, k + 1]).collect();
    (light.vertices.clone(), indices)
}
