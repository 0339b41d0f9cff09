//! TOML scene text to `Scene`, following docs/scene-format.md to the letter.
//!
//! The document is parsed with `toml`'s span-preserving `DeTable` so every
//! key keeps its line; each section is then read through `fields::Section`,
//! which refuses unknown keys, wrong types, wrong lengths and non-finite
//! numbers. Range and geometry rules are checked here, next to the key they
//! belong to.

use super::fields::{
    Ctx, Field, MAX_MAGNITUDE, Result, Section, entries_in_order, fmt_num, fmt_vec3,
};
use super::texture::{Encoding, Texture};
use super::{Camera, DEFAULT_HEIGHT, DEFAULT_WIDTH, Light, Material, Mesh, Scene, SceneError};
use super::{lights, obj, shapes};
use glam::Vec3;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use toml::de::{DeTable, DeValue};

/// Largest accepted image side, and largest pixel count (64 Mpixel): keeps
/// the frame buffers of one frame within a few GiB.
pub const MAX_SIDE: i64 = 16384;
pub const MAX_PIXELS: i64 = 64 * 1024 * 1024;
/// Smallest magnitude of a mesh scale factor.
pub const MIN_SCALE: f32 = 1e-6;
/// Icosphere levels accepted: level 9 is already 5.2 M triangles.
pub const MAX_SUBDIVISIONS: i64 = 9;

pub fn load_file(path: &Path) -> std::result::Result<Scene, SceneError> {
    let bytes = std::fs::read(path).map_err(|e| SceneError {
        file: path.to_path_buf(),
        line: 0,
        message: format!("cannot read: {e}"),
    })?;
    let text = String::from_utf8(bytes).map_err(|e| SceneError {
        file: path.to_path_buf(),
        line: 1 + e.as_bytes()[..e.utf8_error().valid_up_to()]
            .iter()
            .filter(|&&b| b == b'\n')
            .count(),
        message: "the file is not UTF-8 text".into(),
    })?;
    parse_text(&text, path)
}

/// A top-level table key (`[camera]`, `[output]`) with its header line.
fn single_table<'a, 'i>(ctx: &Ctx, f: &Field<'a, 'i>) -> Result<(usize, &'a DeTable<'i>)> {
    match f.value {
        DeValue::Table(t) => Ok((f.line, t)),
        other => Err(ctx.error(
            f.line,
            format!(
                "{} must be a table ([{}]), found {}",
                f.key,
                f.key,
                other.type_str()
            ),
        )),
    }
}

/// A top-level array of tables (`[[material]]` ...), each with its header line.
fn table_list<'a, 'i>(ctx: &Ctx, f: &Field<'a, 'i>) -> Result<Vec<(usize, &'a DeTable<'i>)>> {
    let bad = |found: &str| {
        ctx.error(
            f.line,
            format!(
                "{} must be an array of tables ([[{}]]), found {found}",
                f.key, f.key
            ),
        )
    };
    let DeValue::Array(items) = f.value else {
        return Err(bad(f.value.type_str()));
    };
    items
        .iter()
        .map(|item| match item.get_ref() {
            DeValue::Table(t) => Ok((ctx.line_of(item.span().start), t)),
            other => Err(bad(&format!("an array containing {}", other.type_str()))),
        })
        .collect()
}

pub fn parse_text(text: &str, path: &Path) -> std::result::Result<Scene, SceneError> {
    parse_text_with(text, path, &[])
}

/// `parse_text` with `embedded` files in place of files on disk.
pub fn parse_text_with(
    text: &str,
    path: &Path,
    embedded: Embedded,
) -> std::result::Result<Scene, SceneError> {
    let ctx = Ctx::new(text, path);
    let doc = DeTable::parse(text).map_err(|e| {
        let line = e.span().map_or(1, |s| ctx.line_of(s.start));
        ctx.error(line, format!("invalid TOML: {}", e.message().trim()))
    })?;
    let root = doc.get_ref();

    let mut camera = None;
    let mut output = None;
    let (mut materials, mut objects, mut lights) = (Vec::new(), Vec::new(), Vec::new());
    for f in entries_in_order(&ctx, root) {
        match f.key {
            "camera" => camera = Some(single_table(&ctx, &f)?),
            "output" => output = Some(single_table(&ctx, &f)?),
            "material" => materials = table_list(&ctx, &f)?,
            "object" => objects = table_list(&ctx, &f)?,
            "light" => lights = table_list(&ctx, &f)?,
            other => {
                return Err(ctx.error(
                    f.line,
                    format!(
                        "unknown top-level key `{other}` (allowed: camera, output, material, object, light)"
                    ),
                ));
            }
        }
    }

    let Some((cam_line, cam_table)) = camera else {
        return Err(ctx.error(1, "missing required table [camera]"));
    };
    let camera = parse_camera(&Section::new(&ctx, "camera".into(), cam_line, cam_table))?;
    let (width, height) = match output {
        Some((line, t)) => parse_output(&Section::new(&ctx, "output".into(), line, t))?,
        None => (DEFAULT_WIDTH, DEFAULT_HEIGHT),
    };

    let mut textures = TextureCache {
        loaded: HashMap::new(),
        embedded,
    };
    let mut by_name: HashMap<String, (u32, usize)> = HashMap::new();
    let mut mats = Vec::with_capacity(materials.len());
    for (i, (line, t)) in materials.iter().enumerate() {
        let sec = Section::new(&ctx, format!("material {}", i + 1), *line, t);
        let (m, name_line) = parse_material(sec, &mut textures)?;
        if let Some((first, first_line)) = by_name.get(&m.name) {
            return Err(ctx.error(
                name_line,
                format!(
                    "material \"{}\": name = \"{}\" is already used by material {} (line {first_line})",
                    m.name,
                    m.name,
                    first + 1
                ),
            ));
        }
        by_name.insert(m.name.clone(), (i as u32, name_line));
        mats.push(m);
    }

    let mut meshes = Vec::with_capacity(objects.len());
    for (i, (line, t)) in objects.iter().enumerate() {
        let sec = Section::new(&ctx, format!("object {}", i + 1), *line, t);
        meshes.push(parse_object(sec, &by_name)?);
    }

    let mut out_lights = Vec::with_capacity(lights.len());
    for (i, (line, t)) in lights.iter().enumerate() {
        let sec = Section::new(&ctx, format!("light {}", i + 1), *line, t);
        out_lights.push(parse_light(sec)?);
    }

    Ok(Scene {
        source: path.to_path_buf(),
        camera,
        width,
        height,
        materials: mats,
        meshes,
        lights: out_lights,
    })
}

fn parse_camera(sec: &Section) -> Result<Camera> {
    sec.allow_only(&["eye", "target", "up", "fov_y"])?;
    let (eye, _) = sec.vec3("eye")?;
    let (target, target_line) = sec.vec3("target")?;
    let up = sec.opt_vec3("up")?;
    let (fov_y, fov_line) = sec.number("fov_y")?;
    if !(fov_y > 0.0 && fov_y < 180.0) {
        return Err(sec.err(
            fov_line,
            format!("fov_y = {} is outside (0, 180)", fmt_num(fov_y)),
        ));
    }
    let forward = (target - eye).as_dvec3();
    let scale = eye.abs().max(target.abs()).max_element().max(1.0) as f64;
    if forward.length() <= 1e-6 * scale {
        return Err(sec.err(
            target_line,
            format!(
                "target = {} equals eye (no view direction)",
                fmt_vec3(target)
            ),
        ));
    }
    let (up_vec, up_line, given) = match up {
        Some((u, l)) => (u, l, true),
        None => (Vec3::Y, target_line, false),
    };
    let up_d = up_vec.as_dvec3();
    // Checked in f64 for the angle and in f32 for what the renderer will do
    // with it (a denormal up would give a NaN frame).
    let parallel = up_d.length() == 0.0
        || forward.normalize().cross(up_d.normalize()).length() < 1e-4
        || (target - eye).cross(up_vec).try_normalize().is_none();
    if parallel {
        let what = if given {
            format!("up = {}", fmt_vec3(up_vec))
        } else {
            "up (default [0, 1, 0])".to_string()
        };
        return Err(sec.err(
            up_line,
            format!("{what} is zero or parallel to target - eye; give an up that is not"),
        ));
    }
    Ok(Camera {
        eye,
        target,
        up: up_vec,
        fov_y,
    })
}

fn parse_output(sec: &Section) -> Result<(u32, u32)> {
    sec.allow_only(&["width", "height"])?;
    let w = sec.opt_int("width", 1, MAX_SIDE)?;
    let h = sec.opt_int("height", 1, MAX_SIDE)?;
    let (wv, hv) = (
        w.map_or(DEFAULT_WIDTH as i64, |x| x.0),
        h.map_or(DEFAULT_HEIGHT as i64, |x| x.0),
    );
    if wv * hv > MAX_PIXELS {
        let line = h.or(w).map_or(sec.line, |x| x.1);
        return Err(sec.err(
            line,
            format!(
                "width x height = {wv} x {hv} = {} pixels exceeds the limit of {MAX_PIXELS} (64 Mpixel)",
                wv * hv
            ),
        ));
    }
    Ok((wv as u32, hv as u32))
}

/// Files held in memory, by the path a scene names them with (the built-in
/// scene's textures): looked up before the file system.
pub type Embedded<'e> = &'e [(&'e str, &'e [u8])];

/// Textures by (resolved path, encoding): a map shared by materials loads once.
struct TextureCache<'e> {
    loaded: HashMap<(PathBuf, Encoding), Texture>,
    embedded: Embedded<'e>,
}

impl TextureCache<'_> {
    fn get(&mut self, sec: &Section, key: &str, enc: Encoding) -> Result<Option<Texture>> {
        let Some((rel, line)) = sec.opt_string(key)? else {
            return Ok(None);
        };
        let path = sec.ctx.resolve(rel);
        if let Some(t) = self.loaded.get(&(path.clone(), enc)) {
            return Ok(Some(t.clone()));
        }
        let tex = match self.embedded.iter().find(|(name, _)| *name == rel) {
            Some((_, bytes)) => Texture::from_bytes(bytes, &path, enc),
            None => Texture::load(&path, enc),
        }
        .map_err(|msg| sec.err(line, format!("{key} = \"{rel}\": {msg}")))?;
        self.loaded.insert((path, enc), tex.clone());
        Ok(Some(tex))
    }
}

/// A material and the line of its `name` key.
fn parse_material(mut sec: Section, textures: &mut TextureCache) -> Result<(Material, usize)> {
    sec.allow_only(&[
        "name",
        "diffuse",
        "specular",
        "roughness",
        "diffuse_map",
        "roughness_map",
        "normal_map",
    ])?;
    let (name, name_line) = sec.string("name")?;
    if name.is_empty() {
        return Err(sec.err(name_line, "name must not be empty"));
    }
    sec.label = format!("material \"{name}\"");
    let (diffuse, _) = sec.unit_rgb("diffuse")?;
    let (specular, _) = sec.unit_rgb("specular")?;
    let (roughness, r_line) = sec.number("roughness")?;
    if !(0.0..=1.0).contains(&roughness) {
        return Err(sec.err(
            r_line,
            format!("roughness = {} is outside [0, 1]", fmt_num(roughness)),
        ));
    }
    let material = Material {
        name: name.to_string(),
        diffuse,
        specular,
        roughness,
        diffuse_map: textures.get(&sec, "diffuse_map", Encoding::Srgb)?,
        roughness_map: textures.get(&sec, "roughness_map", Encoding::Linear)?,
        normal_map: textures.get(&sec, "normal_map", Encoding::Linear)?,
    };
    Ok((material, name_line))
}

/// The `type` key of an object or light, refused unless one of `allowed`.
fn type_of<'a>(sec: &Section<'a, '_>, allowed: &[&str]) -> Result<(&'a str, usize)> {
    let (ty, line) = sec.string("type")?;
    if !allowed.contains(&ty) {
        return Err(sec.err(
            line,
            format!("type = \"{ty}\" is not one of {}", allowed.join(", ")),
        ));
    }
    Ok((ty, line))
}

/// `u` and `v` of a quad (object or light), refused when they span no area.
fn quad_frame(sec: &Section) -> Result<(Vec3, Vec3, Vec3)> {
    let (center, _) = sec.vec3("center")?;
    let (u, _) = sec.vec3("u")?;
    let (v, v_line) = sec.vec3("v")?;
    if lights::parallelogram_degenerate(u, v) {
        return Err(sec.err(
            v_line,
            format!(
                "u = {} and v = {} span zero area (u x v = 0: a zero or parallel edge)",
                fmt_vec3(u),
                fmt_vec3(v)
            ),
        ));
    }
    Ok((center, u, v))
}

fn parse_object(mut sec: Section, materials: &HashMap<String, (u32, usize)>) -> Result<Mesh> {
    let (ty, _) = type_of(&sec, &["quad", "box", "sphere", "mesh"])?;
    sec.label = format!("{} ({ty})", sec.label);
    let keys: &[&str] = match ty {
        "quad" => &["material", "type", "center", "u", "v"],
        "box" => &["material", "type", "center", "size", "rotate_y"],
        "sphere" => &["material", "type", "center", "radius", "subdivisions"],
        _ => &["material", "type", "path", "translate", "scale", "rotate_y"],
    };
    sec.allow_only(keys)?;
    let (mat_name, mat_line) = sec.string("material")?;
    let Some(&(material, _)) = materials.get(mat_name) else {
        return Err(sec.err(
            mat_line,
            format!("material = \"{mat_name}\" is not defined by any [[material]]"),
        ));
    };
    let rotate_y = sec.opt_number("rotate_y")?.map_or(0.0, |x| x.0);
    match ty {
        "quad" => {
            let (c, u, v) = quad_frame(&sec)?;
            Ok(shapes::quad(c, u, v, material))
        }
        "box" => {
            let (center, _) = sec.vec3("center")?;
            let (size, line) = sec.vec3("size")?;
            if size.min_element() <= 0.0 {
                return Err(sec.err(
                    line,
                    format!("size = {}: every extent must be > 0", fmt_vec3(size)),
                ));
            }
            Ok(shapes::cuboid(center, size, rotate_y, material))
        }
        "sphere" => {
            let (center, _) = sec.vec3("center")?;
            let (radius, line) = sec.number("radius")?;
            if radius <= 0.0 {
                return Err(sec.err(line, format!("radius = {} must be > 0", fmt_num(radius))));
            }
            let level = sec
                .opt_int("subdivisions", 0, MAX_SUBDIVISIONS)?
                .map_or(3, |x| x.0);
            Ok(shapes::icosphere(center, radius, level as u32, material))
        }
        _ => parse_mesh(&sec, material, rotate_y),
    }
}

fn parse_mesh(sec: &Section, material: u32, rotate_y: f32) -> Result<Mesh> {
    let (rel, path_line) = sec.string("path")?;
    let translate = sec.opt_vec3("translate")?.map_or(Vec3::ZERO, |x| x.0);
    let scale = match sec.field("scale") {
        None => Vec3::ONE,
        Some(f) => {
            let s = match f.value {
                DeValue::Array(_) => sec.vec3_of(&f)?,
                _ => Vec3::splat(sec.number_of(&f)?),
            };
            // Tiny factors would flatten the mesh and overflow the inverse
            // scale applied to normals.
            if s.abs().min_element() < MIN_SCALE {
                return Err(sec.err(
                    f.line,
                    format!(
                        "scale = {} has a zero factor or one smaller than {MIN_SCALE:e} in magnitude",
                        fmt_vec3(s)
                    ),
                ));
            }
            s
        }
    };
    let path = sec.ctx.resolve(rel);
    let mut mesh = obj::load(&path, material).map_err(|e| {
        let at = e.line.map(|l| format!(":{l}")).unwrap_or_default();
        sec.err(
            path_line,
            format!("path = \"{rel}\": {}{at}: {}", path.display(), e.message),
        )
    })?;
    shapes::Transform {
        scale,
        rotate_y,
        translate,
    }
    .apply(&mut mesh);
    // Scale times the OBJ's coordinates can leave the range every scene
    // coordinate must stay in (or overflow f32 altogether).
    if let Some(p) = mesh
        .positions
        .iter()
        .find(|p| !(p.is_finite() && p.abs().max_element() as f64 <= MAX_MAGNITUDE))
    {
        return Err(sec.err(
            path_line,
            format!(
                "path = \"{rel}\": {}: after scale, rotate_y and translate a vertex lies at {}, beyond the scene limit of 1e8",
                path.display(),
                fmt_vec3(*p)
            ),
        ));
    }
    Ok(mesh)
}

fn parse_light(mut sec: Section) -> Result<Light> {
    let (ty, _) = type_of(&sec, &["quad", "polygon"])?;
    sec.label = format!("{} ({ty})", sec.label);
    let keys: &[&str] = match ty {
        "quad" => &["type", "center", "u", "v", "radiance", "two_sided"],
        _ => &["type", "vertices", "radiance", "two_sided"],
    };
    sec.allow_only(keys)?;
    let (radiance, rad_line) = sec.vec3("radiance")?;
    if radiance.min_element() < 0.0 {
        return Err(sec.err(
            rad_line,
            format!("radiance = {} has a negative channel", fmt_vec3(radiance)),
        ));
    }
    let two_sided = sec.opt_bool("two_sided")?.is_some_and(|x| x.0);
    // The radiance is checked before the geometry keys are read, so a table
    // with several problems reports the first one in key order.
    let light = if ty == "quad" {
        let (c, u, v) = quad_frame(&sec)?;
        Light::quad(c, u, v, radiance).map_err(|e| sec.err(sec.line, e))?
    } else {
        let f = sec.require("vertices")?;
        let items = sec.array_of(&f)?;
        let vertices = items
            .iter()
            .enumerate()
            .map(|(i, v)| sec.vec3_elem(&f, i, v))
            .collect::<Result<Vec<Vec3>>>()?;
        Light::polygon(vertices, radiance).map_err(|e| sec.err(f.line, e))?
    };
    Ok(light.with_two_sided(two_sided))
}
