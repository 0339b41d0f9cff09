//! Wavefront OBJ meshes via tobj.
//!
//! tobj reports errors without a line number and trusts some of its input
//! (NaN coordinates, zero normals), so the file is first checked line by
//! line here; tobj then only ever sees well-formed text. Materials (`mtllib`)
//! are ignored: the scene file assigns the material.

use super::Mesh;
use super::fields::MAX_MAGNITUDE;
use glam::{DVec3, Vec2, Vec3};
use std::path::Path;

/// Why an OBJ was refused: the message and, where it applies, the OBJ line.
#[derive(Debug)]
pub struct ObjError {
    pub line: Option<usize>,
    pub message: String,
}

fn at(line: usize, message: impl Into<String>) -> ObjError {
    ObjError {
        line: Some(line),
        message: message.into(),
    }
}

fn whole(message: impl Into<String>) -> ObjError {
    ObjError {
        line: None,
        message: message.into(),
    }
}

/// Parses `n` leading floats of a statement, each finite.
fn floats(words: &[&str], n: usize, what: &str, line: usize) -> Result<Vec<f32>, ObjError> {
    if words.len() < n {
        return Err(at(
            line,
            format!("{what} needs {n} numbers, found {}", words.len()),
        ));
    }
    words[..n]
        .iter()
        .map(|w| match w.parse::<f32>() {
            Ok(x) if x.is_finite() => Ok(x),
            Ok(x) => Err(at(line, format!("{what} has a non-finite value {x}"))),
            Err(_) => Err(at(line, format!("{what} has a non-number `{w}`"))),
        })
        .collect()
}

/// The unit vector along (x, y, z), computed in f64 so that any finite,
/// non-zero f32 normal normalises; zero when the normal is zero.
fn unit_normal(x: f32, y: f32, z: f32) -> Vec3 {
    DVec3::new(x as f64, y as f64, z as f64)
        .normalize_or_zero()
        .as_vec3()
}

/// Resolves one OBJ index (1-based, or negative = relative to the elements
/// defined so far) and checks it against the element count.
fn check_index(
    text: &str,
    so_far: usize,
    total: usize,
    what: &str,
    line: usize,
) -> Result<(), ObjError> {
    let i: i64 = text
        .parse()
        .map_err(|_| at(line, format!("face has a malformed {what} index `{text}`")))?;
    let ok = match i {
        0 => false,
        i if i > 0 => (i as u64) <= total as u64,
        i => i.unsigned_abs() <= so_far as u64,
    };
    if ok {
        Ok(())
    } else {
        Err(at(
            line,
            format!(
                "face {what} index {i} is out of range ({so_far} defined so far, {total} in the file)"
            ),
        ))
    }
}

/// Line-by-line check of everything the mesh will use.
fn validate(text: &str) -> Result<(), ObjError> {
    let lines: Vec<Vec<&str>> = text
        .lines()
        .map(|l| {
            l.split('#')
                .next()
                .unwrap_or("")
                .split_whitespace()
                .collect()
        })
        .collect();
    let count = |kw: &str| lines.iter().filter(|w| w.first() == Some(&kw)).count();
    let (nv, nvt, nvn) = (count("v"), count("vt"), count("vn"));
    let (mut sv, mut svt, mut svn, mut faces) = (0, 0, 0, 0);
    for (i, words) in lines.iter().enumerate() {
        let line = i + 1;
        let Some((&kw, args)) = words.split_first() else {
            continue;
        };
        match kw {
            "v" => {
                let p = floats(args, 3, "vertex position", line)?;
                // The same bound as every coordinate in the scene file: past
                // it, f32 positions lose the precision shadow-ray offsets need
                // and a transform can overflow to infinity.
                if let Some(c) = p.iter().find(|c| c.abs() as f64 > MAX_MAGNITUDE) {
                    return Err(at(
                        line,
                        format!("vertex coordinate {c:e} exceeds the scene limit of 1e8"),
                    ));
                }
                match args.len() {
                    3 | 6 => {}
                    4 => {
                        let w = floats(&args[3..], 1, "vertex weight w", line)?[0];
                        if w == 0.0 || p.iter().any(|c| !(c / w).is_finite()) {
                            return Err(at(line, format!("vertex weight w = {w} is not usable")));
                        }
                    }
                    n => {
                        return Err(at(
                            line,
                            format!("vertex has {n} numbers (expected x y z [w] or x y z r g b)"),
                        ));
                    }
                }
                if args.len() == 6 {
                    floats(&args[3..], 3, "vertex colour", line)?;
                }
                sv += 1;
            }
            "vt" => {
                floats(args, 2, "texture coordinate", line)?;
                svt += 1;
            }
            "vn" => {
                let n = floats(args, 3, "normal", line)?;
                // In f64: f32 squares of finite normals can underflow to 0 or
                // overflow to infinity.
                if unit_normal(n[0], n[1], n[2]) == Vec3::ZERO {
                    return Err(at(line, "normal has zero length"));
                }
                svn += 1;
            }
            "f" => {
                if args.len() < 3 {
                    return Err(at(
                        line,
                        format!("face has {} vertices, needs at least 3", args.len()),
                    ));
                }
                for a in args {
                    let parts: Vec<&str> = a.split('/').collect();
                    if parts.len() > 3 || parts[0].is_empty() {
                        return Err(at(line, format!("malformed face vertex `{a}`")));
                    }
                    check_index(parts[0], sv, nv, "vertex", line)?;
                    if let Some(t) = parts.get(1).filter(|t| !t.is_empty()) {
                        check_index(t, svt, nvt, "texture coordinate", line)?;
                    }
                    if let Some(n) = parts.get(2) {
                        if n.is_empty() {
                            return Err(at(line, format!("malformed face vertex `{a}`")));
                        }
                        check_index(n, svn, nvn, "normal", line)?;
                    }
                }
                faces += 1;
            }
            // Everything else (groups, materials, smoothing, points, lines,
            // free-form statements) does not contribute triangles; tobj
            // skips it too.
            _ => {}
        }
    }
    if faces == 0 {
        return Err(whole("has no faces"));
    }
    Ok(())
}

/// Loads an OBJ file as one mesh in object space (all groups merged).
/// Polygons are triangulated. Normals and uvs are kept only when every
/// vertex has them; otherwise `None` (face normals, no texture coordinates).
pub fn load(path: &Path, material: u32) -> Result<Mesh, ObjError> {
    let bytes = std::fs::read(path).map_err(|e| whole(format!("cannot read: {e}")))?;
    let text =
        String::from_utf8(bytes).map_err(|_| whole("is not UTF-8 text (not an OBJ file?)"))?;
    validate(&text)?;
    let opts = tobj::LoadOptions {
        triangulate: true,
        single_index: true,
        ignore_points: true,
        ignore_lines: true,
    };
    let (models, _) = tobj::load_obj_buf(&mut text.as_bytes(), &opts, |_| {
        Err(tobj::LoadError::GenericFailure)
    })
    .map_err(|e| whole(format!("rejected by the OBJ reader: {e}")))?;

    let mut mesh = Mesh {
        normals: Some(Vec::new()),
        uvs: Some(Vec::new()),
        material,
        ..Mesh::default()
    };
    for model in models {
        let m = model.mesh;
        let nverts = m.positions.len() / 3;
        let base = mesh.positions.len();
        mesh.positions.extend(
            m.positions
                .chunks_exact(3)
                .map(|p| Vec3::new(p[0], p[1], p[2])),
        );
        match mesh.normals.as_mut() {
            Some(ns) if m.normals.len() == nverts * 3 => ns.extend(
                m.normals
                    .chunks_exact(3)
                    .map(|n| unit_normal(n[0], n[1], n[2])),
            ),
            _ => mesh.normals = None,
        }
        match mesh.uvs.as_mut() {
            Some(uvs) if m.texcoords.len() == nverts * 2 => {
                uvs.extend(m.texcoords.chunks_exact(2).map(|t| Vec2::new(t[0], t[1])))
            }
            _ => mesh.uvs = None,
        }
        for tri in m.indices.chunks_exact(3) {
            let t = [tri[0], tri[1], tri[2]];
            if t.iter().any(|&i| i as usize >= nverts) {
                return Err(whole("face index out of range after triangulation"));
            }
            mesh.indices.push(t.map(|i| i + base as u32));
        }
    }
    if mesh.indices.is_empty() {
        return Err(whole("has no faces"));
    }
    Ok(mesh)
}
