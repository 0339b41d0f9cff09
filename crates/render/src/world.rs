//! The scene as a ray-traced world: the scene's data plus its Embree scene,
//! and the map from Embree geometry ids back to meshes and lights.

use super::lights::Lights;
use glam::Vec3;
use penumbra_embree::{Device, EmbreeError, GeometryRole, SceneBuilder};
use penumbra_scene::{Light, Scene};

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
        Ok(World {
            scene,
            lights,
            rt,
            geoms,
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
