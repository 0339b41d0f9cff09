//! The scene as the renderer sees it: camera, materials, triangle meshes and
//! polygonal lights, all in world space. Files become this through `load`;
//! nothing downstream knows about TOML or OBJ.

mod camera;
pub mod color;
mod error;
mod fields;
mod lights;
mod obj;
mod parse;
mod shapes;
mod texture;

pub use camera::{Camera, CameraFrame};
pub use error::SceneError;
pub use lights::LightError;
pub use texture::{Encoding, TexelFootprint, Texture};

use glam::{Vec2, Vec3};
use std::path::{Path, PathBuf};

/// Default output size when the file has no `[output]` table.
pub const DEFAULT_WIDTH: u32 = 1280;
pub const DEFAULT_HEIGHT: u32 = 720;

#[derive(Debug, Clone)]
pub struct Material {
    pub name: String,
    /// Lambert albedo, linear RGB in [0, 1].
    pub diffuse: Vec3,
    /// Schlick F0, linear RGB in [0, 1]; zero means no specular lobe.
    pub specular: Vec3,
    /// Perceptual roughness in [0, 1]; GGX alpha = roughness^2.
    pub roughness: f32,
    /// sRGB image multiplying `diffuse` (decoded to linear on load).
    pub diffuse_map: Option<Texture>,
    /// Linear grey image replacing `roughness`.
    pub roughness_map: Option<Texture>,
    /// Tangent-space normal map, +Y up (OpenGL convention).
    pub normal_map: Option<Texture>,
}

/// A triangle mesh in world space. Every object type (quad, box, sphere, OBJ
/// mesh) becomes one of these.
#[derive(Debug, Clone, Default)]
pub struct Mesh {
    pub positions: Vec<Vec3>,
    /// Per-vertex shading normals (unit length), or `None` for face normals.
    pub normals: Option<Vec<Vec3>>,
    /// Per-vertex texture coordinates, or `None`.
    pub uvs: Option<Vec<Vec2>>,
    pub indices: Vec<[u32; 3]>,
    /// Index into `Scene::materials`.
    pub material: u32,
}

/// A planar convex polygonal area light with 3 to 8 vertices. The vertex
/// order is such that the emitting side is the right-hand-rule normal
/// (for a `quad`: center-u-v, center+u-v, center+u+v, center-u+v).
#[derive(Debug, Clone, PartialEq)]
pub struct Light {
    pub vertices: Vec<Vec3>,
    /// Emitted radiance, linear RGB, each channel >= 0.
    pub radiance: Vec3,
    pub two_sided: bool,
    /// Unit normal of the emitting side (right-hand rule of the vertex order).
    pub normal: Vec3,
    /// Area in scene units squared.
    pub area: f32,
    /// `Some((center, u, v))` when the light is a parallelogram given as a quad
    /// (corners center +- u +- v); lets samplers use rectangle methods.
    pub quad: Option<(Vec3, Vec3, Vec3)>,
}

#[derive(Debug, Clone)]
pub struct Scene {
    /// The file this scene came from (a pseudo path for the built-in scene).
    pub source: PathBuf,
    pub camera: Camera,
    pub width: u32,
    pub height: u32,
    pub materials: Vec<Material>,
    pub meshes: Vec<Mesh>,
    pub lights: Vec<Light>,
}

/// The built-in scene used when no file is given: `scenes/default.toml`,
/// compiled in together with the files it names, so it needs no files at run time.
pub const BUILTIN_SCENE_TOML: &str = include_str!("../../../scenes/default.toml");
/// The files `BUILTIN_SCENE_TOML` names, by the path it names them with.
pub const BUILTIN_FILES: &[(&str, &[u8])] = &[(
    "textures/showcase_normal.png",
    include_bytes!("../../../scenes/textures/showcase_normal.png"),
)];

impl Scene {
    /// Reads and validates a scene file; every problem is a `SceneError`
    /// naming file, line and key.
    pub fn load(path: &Path) -> Result<Scene, SceneError> {
        parse::load_file(path)
    }

    /// Parses scene text; `path` is used in messages and as the base for
    /// relative paths inside the file.
    pub fn parse(text: &str, path: &Path) -> Result<Scene, SceneError> {
        parse::parse_text(text, path)
    }

    /// The built-in default scene.
    pub fn builtin() -> Scene {
        parse::parse_text_with(
            BUILTIN_SCENE_TOML,
            Path::new("<builtin>/default.toml"),
            BUILTIN_FILES,
        )
        .expect("the built-in scene is valid (checked by a test)")
    }

    pub fn triangle_count(&self) -> usize {
        self.meshes.iter().map(|m| m.indices.len()).sum()
    }
}

/// The same size limits the `[output]` table obeys, for sizes given on the
/// command line.
pub fn check_resolution(width: u32, height: u32) -> Result<(), String> {
    let (w, h) = (width as i64, height as i64);
    if !(1..=parse::MAX_SIDE).contains(&w) || !(1..=parse::MAX_SIDE).contains(&h) {
        return Err(format!(
            "resolution {width}x{height}: each side must be in 1..={}",
            parse::MAX_SIDE
        ));
    }
    if w * h > parse::MAX_PIXELS {
        return Err(format!(
            "resolution {width}x{height} = {} pixels exceeds the limit of {} (64 Mpixel)",
            w * h,
            parse::MAX_PIXELS
        ));
    }
    Ok(())
}
