//! The `reference` every error figure is measured against: rendered once
//! per scene, resolution and sample count, with a progress bar on stderr,
//! and cached on disk while its inputs are unchanged.
//!
//! The cache key hashes the scene file's bytes, the bytes of every file it
//! names (meshes, textures), the resolution, the sample count, the seed and
//! `FORMAT_VERSION`; bump the version when the reference estimator changes.

use crate::render::{Frame, Mode, RenderSettings, World};
use crate::scene::BUILTIN_SCENE_TOML;
use anyhow::{Context, Result, bail};
use glam::Vec3;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Bumped whenever the reference's pixels would change for the same inputs.
/// 2: no Schlick grazing term on materials with `specular = [0, 0, 0]`.
pub const FORMAT_VERSION: u32 = 2;
/// Seed of the reference's samples (the measured modes use seed 0).
pub const SEED: u32 = 0x5eed;
const MAGIC: &[u8; 8] = b"PNBRREF1";
/// Samples per progressive pass (one progress-bar step).
const PASS_SPP: u32 = 4;

/// A reference image and where it came from.
pub struct Reference {
    pub color: Vec<Vec3>,
    pub spp: u32,
    pub file: PathBuf,
    /// True when read from the cache rather than rendered now.
    pub reused: bool,
    /// Seconds spent rendering it (0 when reused).
    pub render_seconds: f64,
}

/// FNV-1a, 64 bit: stable across builds and platforms (std's hasher is not
/// promised to be).
struct Fnv(u64);

impl Fnv {
    fn new() -> Fnv {
        Fnv(0xcbf2_9ce4_8422_2325)
    }
    fn bytes(&mut self, b: &[u8]) {
        for &x in b {
            self.0 = (self.0 ^ x as u64).wrapping_mul(0x0000_0100_0000_01b3);
        }
    }
    /// A length-prefixed chunk, so concatenations cannot collide.
    fn chunk(&mut self, b: &[u8]) {
        self.bytes(&(b.len() as u64).to_le_bytes());
        self.bytes(b);
    }
}

/// The scene text: the file, or the compiled-in scene for `None`.
pub fn scene_text(scene_file: Option<&Path>) -> Result<String> {
    match scene_file {
        Some(p) => std::fs::read_to_string(p).with_context(|| format!("reading {}", p.display())),
        None => Ok(BUILTIN_SCENE_TOML.to_string()),
    }
}

/// Every string value in the scene that names an existing file relative to
/// the scene's folder, sorted.
fn referenced_files(text: &str, scene_file: &Path) -> Vec<PathBuf> {
    fn walk(v: &toml::Value, base: &Path, out: &mut Vec<PathBuf>) {
        match v {
            toml::Value::String(s) => {
                let p = base.join(s);
                if p.is_file() {
                    out.push(p);
                }
            }
            toml::Value::Array(a) => a.iter().for_each(|v| walk(v, base, out)),
            toml::Value::Table(t) => t.values().for_each(|v| walk(v, base, out)),
            _ => {}
        }
    }
    let base = scene_file.parent().unwrap_or(Path::new("."));
    let mut out = Vec::new();
    if let Ok(table) = text.parse::<toml::Table>() {
        table.values().for_each(|v| walk(v, base, &mut out));
    }
    out.sort();
    out.dedup();
    out
}

/// The cache key of a reference: see the module comment.
pub fn cache_key(scene_file: Option<&Path>, width: u32, height: u32, spp: u32) -> Result<u64> {
    let text = scene_text(scene_file)?;
    let mut h = Fnv::new();
    h.chunk(&FORMAT_VERSION.to_le_bytes());
    h.chunk(text.as_bytes());
    if let Some(path) = scene_file {
        for f in referenced_files(&text, path) {
            let bytes = std::fs::read(&f).with_context(|| format!("reading {}", f.display()))?;
            h.chunk(f.file_name().map_or(&[][..], |n| n.as_encoded_bytes()));
            h.chunk(&bytes);
        }
    }
    for v in [width, height, spp, SEED] {
        h.chunk(&v.to_le_bytes());
    }
    Ok(h.0)
}

fn read_cached(file: &Path, width: u32, height: u32, spp: u32) -> Option<Vec<Vec3>> {
    let bytes = std::fs::read(file).ok()?;
    let n = width as usize * height as usize;
    let header = MAGIC.len() + 12;
    if bytes.len() != header + n * 12 || &bytes[..8] != MAGIC {
        return None;
    }
    let word = |i: usize| u32::from_le_bytes(bytes[i..i + 4].try_into().unwrap());
    if (word(8), word(12), word(16)) != (width, height, spp) {
        return None;
    }
    let f = |i: usize| f32::from_bits(word(header + 4 * i));
    let color: Vec<Vec3> = (0..n)
        .map(|k| Vec3::new(f(3 * k), f(3 * k + 1), f(3 * k + 2)))
        .collect();
    color.iter().all(|c| c.is_finite()).then_some(color)
}

fn write_cached(file: &Path, width: u32, height: u32, spp: u32, color: &[Vec3]) -> Result<()> {
    let mut bytes = Vec::with_capacity(20 + color.len() * 12);
    bytes.extend_from_slice(MAGIC);
    for v in [width, height, spp] {
        bytes.extend_from_slice(&v.to_le_bytes());
    }
    for c in color {
        for x in c.to_array() {
            bytes.extend_from_slice(&x.to_le_bytes());
        }
    }
    if let Some(dir) = file.parent() {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    // Write beside, then rename: an interrupted run leaves no torn file.
    let tmp = file.with_extension("tmp");
    std::fs::write(&tmp, bytes).with_context(|| format!("writing {}", tmp.display()))?;
    std::fs::rename(&tmp, file).with_context(|| format!("writing {}", file.display()))?;
    Ok(())
}

/// The reference of `scene_file` (with only the lights `subset` when
/// given: `world` holds those) at this size and sample count: read from
/// `cache_dir` when present and valid, else rendered on the current rayon
/// pool (progress on stderr) and stored there.
pub fn reference(
    world: &World,
    scene_file: Option<&Path>,
    width: u32,
    height: u32,
    spp: u32,
    cache_dir: &Path,
    subset: Option<&[usize]>,
) -> Result<Reference> {
    if spp == 0 {
        bail!("the reference needs at least 1 sample per pixel");
    }
    let mut key = cache_key(scene_file, width, height, spp)?;
    if let Some(kept) = subset {
        // Fewer lights than the file's: another scene.
        let mut h = Fnv(key);
        for &i in kept {
            h.chunk(&(i as u64).to_le_bytes());
        }
        key = h.0;
    }
    let file = cache_dir.join(format!("reference-{key:016x}.bin"));
    if let Some(color) = read_cached(&file, width, height, spp) {
        return Ok(Reference {
            color,
            spp,
            file,
            reused: true,
            render_seconds: 0.0,
        });
    }
    let name = scene_file.map_or("<builtin>".into(), |p| p.display().to_string());
    let camera = world.scene.camera;
    let mut frame = Frame::new(width, height);
    let start = Instant::now();
    let mut done = 0;
    let bar = super::progress::bar(
        u64::from(spp),
        format!("reference {name} {width}x{height}"),
        "spp",
    );
    while done < spp {
        let pass = PASS_SPP.min(spp - done);
        let settings = RenderSettings {
            mode: Mode::Reference,
            spp: pass,
            seed: SEED,
            denoise: false,
            ..RenderSettings::default()
        };
        frame.render(world, &camera, &settings);
        done += pass;
        bar.set_position(u64::from(done));
    }
    bar.finish_and_clear();
    let render_seconds = start.elapsed().as_secs_f64();
    write_cached(&file, width, height, spp, &frame.color)?;
    Ok(Reference {
        color: frame.color,
        spp,
        file,
        reused: false,
        render_seconds,
    })
}
