//! No NaN, ever: a seeded sweep over hostile but valid scenes (cameras inside
//! and outside geometry, in the floor's plane and grazing it, lights touching,
//! crossing and lying in surfaces, roughness 0 and 1, scenes at 1e-3 and 1e4
//! scale, degenerate normal maps) renders every mode, denoised and not, for
//! two frames with a moving camera, and checks that every pixel of every AOV
//! and of the G-buffer is finite.
//!
//! `color` passes through the renderer's `finite_or_zero` guard, so the
//! sweep's teeth are the unguarded buffers: `u`, `un`, `sn`, the ratio, the
//! albedo, normal and depth AOVs, and the G-buffer vectors.

use crate::support::rng::XorShift64 as Rng;
use glam::Vec3;
use image::{ImageFormat, Rgb32FImage};
use penumbra::embree::{self, Device};
use penumbra::output::Aov;
use penumbra::render::{Frame, Mode, RenderSettings, VisibilityRate, World};
use penumbra::scene::{Camera, Scene};
use std::fmt::Write;
use std::path::Path;

const WIDTH: u32 = 16;
const HEIGHT: u32 = 12;
/// Passes over every (camera, light) pair, each with fresh random scale,
/// materials, maps, field of view and radiance.
const ROUNDS: usize = 4;

#[derive(Clone, Copy, Debug)]
enum CameraKind {
    /// Above the floor, looking at the box.
    Outside,
    /// Inside the closed box.
    InsideBox,
    /// A hair above the floor, looking along it.
    Grazing,
    /// Exactly in the floor's plane.
    InFloorPlane,
    /// Right under the overhead light, looking up at it.
    AtTheLight,
    /// Inside the sphere.
    InsideSphere,
}

#[derive(Clone, Copy, Debug)]
enum LightKind {
    /// A quad above the scene, facing down.
    Overhead,
    /// A vertical quad whose bottom edge lies on the floor.
    TouchingFloor,
    /// A quad lying in the floor's plane, overlapping it.
    InFloorPlane,
    /// Below the floor, facing up into it.
    UnderFloor,
    /// A triangle with one corner on the box's top corner, two-sided.
    TouchingBox,
    /// A tiny polygon far away (a solid angle near zero).
    TinyAndFar,
}

const CAMERAS: [CameraKind; 6] = [
    CameraKind::Outside,
    CameraKind::InsideBox,
    CameraKind::Grazing,
    CameraKind::InFloorPlane,
    CameraKind::AtTheLight,
    CameraKind::InsideSphere,
];

const LIGHTS: [LightKind; 6] = [
    LightKind::Overhead,
    LightKind::TouchingFloor,
    LightKind::InFloorPlane,
    LightKind::UnderFloor,
    LightKind::TouchingBox,
    LightKind::TinyAndFar,
];

fn v(p: Vec3) -> String {
    format!("[{:e}, {:e}, {:e}]", p.x, p.y, p.z)
}

/// One scene of the sweep as TOML; `s` scales every length.
fn scene_text(cam: CameraKind, light: LightKind, s: f32, rng: &mut Rng, maps: bool) -> String {
    let mut t = String::new();
    let (eye, target, up) = match cam {
        CameraKind::Outside => (Vec3::new(0.3, 3.0, -7.0), Vec3::new(0.0, 0.5, 0.0), Vec3::Y),
        CameraKind::InsideBox => (Vec3::new(0.1, 0.5, 0.05), Vec3::new(1.0, 0.4, 0.3), Vec3::Y),
        CameraKind::Grazing => (
            Vec3::new(0.0, 1e-4, -3.9),
            Vec3::new(0.2, 1e-4, 3.0),
            Vec3::Y,
        ),
        CameraKind::InFloorPlane => (Vec3::new(0.0, 0.0, -3.0), Vec3::new(0.5, 0.0, 3.0), Vec3::Y),
        CameraKind::AtTheLight => (Vec3::new(0.0, 1.0, 0.0), Vec3::new(0.0, 3.0, 0.01), Vec3::Z),
        CameraKind::InsideSphere => (Vec3::new(-2.5, 1.0, 2.5), Vec3::new(0.0, 0.0, 0.0), Vec3::Y),
    };
    let any = rng.f32();
    let roughness = rng.pick(&[0.0, 1.0, any]);
    let specular = rng.pick(&[0.0, 1.0, 0.04]);
    let diffuse = rng.pick(&[0.0, 1.0, 0.5]);
    let fov = rng.pick(&[1.0, 45.0, 179.0]);
    writeln!(
        t,
        "[camera]\neye = {}\ntarget = {}\nup = {}\nfov_y = {fov}\n",
        v(eye * s),
        v(target * s),
        v(up)
    )
    .unwrap();
    writeln!(
        t,
        "[[material]]\nname = \"m\"\ndiffuse = [{diffuse}, {diffuse}, {diffuse}]\nspecular = [{specular}, {specular}, {specular}]\nroughness = {roughness}"
    )
    .unwrap();
    if maps {
        t.push_str("normal_map = \"normal.exr\"\nroughness_map = \"rough.exr\"\n");
    }
    writeln!(
        t,
        "\n[[material]]\nname = \"smooth\"\ndiffuse = [0.2, 0.2, 0.2]\nspecular = [1, 1, 1]\nroughness = 0\n"
    )
    .unwrap();
    let object = |t: &mut String, material: &str, ty: &str, body: String| {
        writeln!(
            t,
            "[[object]]\nmaterial = \"{material}\"\ntype = \"{ty}\"\n{body}"
        )
        .unwrap()
    };
    object(
        &mut t,
        "m",
        "quad",
        format!(
            "center = {}\nu = {}\nv = {}",
            v(Vec3::ZERO),
            v(Vec3::Z * 4.0 * s),
            v(Vec3::X * 4.0 * s)
        ),
    );
    object(
        &mut t,
        "smooth",
        "box",
        format!(
            "center = {}\nsize = {}\nrotate_y = {}",
            v(Vec3::new(0.5, 0.5, 0.5) * s),
            v(Vec3::ONE * s),
            rng.f32() * 90.0
        ),
    );
    object(
        &mut t,
        "m",
        "sphere",
        format!(
            "center = {}\nradius = {:e}\nsubdivisions = 1",
            v(Vec3::new(-2.5, 1.0, 2.5) * s),
            0.8 * s
        ),
    );
    let radiance = rng.pick(&[0.0, 1.0, 1e4]);
    let two_sided = rng.pick(&[true, false]);
    let emitter = |t: &mut String, body: String| {
        writeln!(
            t,
            "[[light]]\n{body}\nradiance = [{radiance}, {radiance}, {radiance}]\ntwo_sided = {two_sided}\n"
        )
        .unwrap()
    };
    let quad = |c: Vec3, u: Vec3, w: Vec3| {
        format!(
            "type = \"quad\"\ncenter = {}\nu = {}\nv = {}",
            v(c * s),
            v(u * s),
            v(w * s)
        )
    };
    let polygon = |pts: &[Vec3]| {
        let list: Vec<String> = pts.iter().map(|&p| v(p * s)).collect();
        format!("type = \"polygon\"\nvertices = [{}]", list.join(", "))
    };
    let body = match light {
        LightKind::Overhead => quad(Vec3::new(0.0, 3.0, 0.0), Vec3::X, Vec3::Z * 0.5),
        LightKind::TouchingFloor => quad(Vec3::new(-1.0, 0.5, 1.5), Vec3::X, Vec3::Y * 0.5),
        LightKind::InFloorPlane => quad(Vec3::new(1.5, 0.0, -1.0), Vec3::Z, Vec3::X),
        LightKind::UnderFloor => quad(Vec3::new(0.0, -0.5, 0.0), Vec3::Z, Vec3::X),
        LightKind::TouchingBox => polygon(&[
            Vec3::new(1.0, 1.0, 1.0),
            Vec3::new(2.0, 1.0, 1.0),
            Vec3::new(1.5, 2.0, 1.2),
        ]),
        LightKind::TinyAndFar => polygon(&[
            Vec3::new(0.0, 1e3, 0.0),
            Vec3::new(1e-2, 1e3, 0.0),
            Vec3::new(1e-2, 1e3, 1e-2),
            Vec3::new(0.0, 1e3, 1e-2),
        ]),
    };
    emitter(&mut t, body);
    t
}

/// Normal and roughness maps with the worst texels: a tangent normal of
/// exactly zero (0.5 grey in a float image), one lying in the surface, one
/// pointing straight down, next to sane ones; roughness 0 and 1.
fn write_hostile_maps(dir: &Path) {
    let mut n = Rgb32FImage::new(2, 2);
    n.put_pixel(0, 0, image::Rgb([0.5, 0.5, 0.5]));
    n.put_pixel(1, 0, image::Rgb([1.0, 0.5, 0.5]));
    n.put_pixel(0, 1, image::Rgb([0.5, 0.5, 0.0]));
    n.put_pixel(1, 1, image::Rgb([0.5, 0.5, 1.0]));
    n.save_with_format(dir.join("normal.exr"), ImageFormat::OpenExr)
        .unwrap();
    let mut r = Rgb32FImage::new(2, 1);
    r.put_pixel(0, 0, image::Rgb([0.0; 3]));
    r.put_pixel(1, 0, image::Rgb([1.0; 3]));
    r.save_with_format(dir.join("rough.exr"), ImageFormat::OpenExr)
        .unwrap();
}

/// The first non-finite value among the frame's buffers, named.
fn first_non_finite(frame: &Frame) -> Option<String> {
    let mut buffers: Vec<(&str, Vec<Vec3>)> = vec![("color", frame.color.clone())];
    for aov in Aov::ALL {
        buffers.push((aov.name(), aov.values(frame)));
    }
    let g = &frame.gbuf;
    buffers.push(("gbuf.position", g.iter().map(|s| s.position).collect()));
    buffers.push(("gbuf.ng", g.iter().map(|s| s.ng).collect()));
    buffers.push(("gbuf.ns", g.iter().map(|s| s.ns).collect()));
    buffers.push(("gbuf.wo", g.iter().map(|s| s.wo).collect()));
    buffers.push(("gbuf.emission", g.iter().map(|s| s.emission).collect()));
    buffers.push((
        "gbuf.uv,prev_pixel",
        g.iter()
            .map(|s| Vec3::new(s.uv.x + s.uv.y, s.prev_pixel.x, s.prev_pixel.y))
            .collect(),
    ));
    for (name, values) in buffers {
        if let Some(k) = values.iter().position(|c| !c.is_finite()) {
            return Some(format!(
                "{name} at pixel ({}, {}) = {}",
                k % WIDTH as usize,
                k / WIDTH as usize,
                values[k]
            ));
        }
    }
    None
}

/// Renders two frames of every mode, denoised and not, the second from a
/// slightly moved camera (reprojection and history at work); returns every
/// non-finite finding.
/// Returns how many pixels saw a lit surface (`U > 0`), so a sweep of black
/// frames cannot pass for a sweep of lit ones.
fn sweep_scene(scene: &Scene, what: &str, findings: &mut Vec<String>) -> usize {
    let mut lit = 0;
    let device = Device::new().expect("Embree starts");
    let world = World::build(&device, scene.clone()).expect("scene builds");
    let pool = embree::thread_pool(2).expect("thread pool");
    let cam = scene.camera;
    let step = (cam.target - cam.eye) * 0.01;
    let moved = Camera {
        eye: cam.eye + step,
        target: cam.target + step + step.cross(cam.up) * 0.5,
        ..cam
    };
    let plans = Mode::ALL.into_iter().flat_map(|mode| {
        // The rate matters only where samples are denoised into a ratio.
        let rated = matches!(mode, Mode::Ratio | Mode::SoftShadow);
        [(false, VisibilityRate::Full), (true, VisibilityRate::Full)]
            .into_iter()
            .chain(rated.then_some((true, VisibilityRate::Quarter)))
            .map(move |(denoise, rate)| (mode, denoise, rate))
    });
    for (mode, denoise, rate) in plans {
        {
            let settings = RenderSettings {
                mode,
                spp: 2,
                seed: 7,
                denoise,
                visibility: rate,
                ..RenderSettings::default()
            };
            let mut frame = Frame::new(WIDTH, HEIGHT);
            for (i, c) in [cam, moved].iter().enumerate() {
                pool.install(|| frame.render(&world, c, &settings));
                if let Some(bad) = first_non_finite(&frame) {
                    findings.push(format!(
                        "{what}, {mode}, denoise {denoise}, visibility {rate}, frame {i}: {bad}"
                    ));
                }
                lit += frame.u.iter().filter(|u| u.max_element() > 0.0).count();
            }
        }
    }
    lit
}

#[test]
fn every_aov_of_every_mode_is_finite_on_hostile_scenes() {
    let dir = tempfile::tempdir().unwrap();
    write_hostile_maps(dir.path());
    let mut rng = Rng::new(0x5eed_cafe_f00d_0001);
    let mut findings = Vec::new();
    let (mut scenes, mut lit) = (0, 0);
    for (cam, light) in (0..ROUNDS).flat_map(|_| {
        CAMERAS
            .into_iter()
            .flat_map(|c| LIGHTS.into_iter().map(move |l| (c, l)))
    }) {
        {
            let s = rng.pick(&[1e-3, 1.0, 1e4]);
            let maps = rng.pick(&[false, true]);
            let text = scene_text(cam, light, s, &mut rng, maps);
            let path = dir.path().join("sweep.toml");
            std::fs::write(&path, &text).unwrap();
            let scene =
                Scene::load(&path).unwrap_or_else(|e| panic!("sweep scene refused: {e}\n{text}"));
            let what = format!("camera {cam:?}, light {light:?}, scale {s:e}, maps {maps}");
            lit += sweep_scene(&scene, &what, &mut findings);
            scenes += 1;
        }
    }
    assert_eq!(scenes, ROUNDS * CAMERAS.len() * LIGHTS.len());
    assert!(lit > 10_000, "only {lit} lit pixels over the sweep");
    assert!(
        findings.is_empty(),
        "{} non-finite findings:\n{}",
        findings.len(),
        findings.join("\n")
    );
}

#[test]
fn scenes_without_objects_or_lights_render_finite() {
    let camera = "[camera]\neye = [0, 1, -3]\ntarget = [0, 0, 0]\nfov_y = 60\n";
    let floor = "[[material]]\nname = \"m\"\ndiffuse = [1, 1, 1]\nspecular = [1, 1, 1]\nroughness = 0\n[[object]]\nmaterial = \"m\"\ntype = \"quad\"\ncenter = [0, 0, 0]\nu = [0, 0, 2]\nv = [2, 0, 0]\n";
    let light = "[[light]]\ntype = \"quad\"\ncenter = [0, 2, 0]\nu = [1, 0, 0]\nv = [0, 0, 1]\nradiance = [1, 1, 1]\n";
    let mut findings = Vec::new();
    for (what, text) in [
        ("empty", camera.to_string()),
        ("no lights", format!("{camera}{floor}")),
        ("only a light", format!("{camera}{light}")),
    ] {
        let scene = Scene::parse(&text, Path::new("inline.toml")).unwrap();
        sweep_scene(&scene, what, &mut findings);
    }
    assert!(findings.is_empty(), "{}", findings.join("\n"));
}

#[test]
fn the_check_finds_a_nan_in_an_unguarded_buffer() {
    let mut frame = Frame::new(WIDTH, HEIGHT);
    assert_eq!(first_non_finite(&frame), None);
    frame.sn[WIDTH as usize + 3] = Vec3::new(0.0, f32::NAN, 0.0);
    let found = first_non_finite(&frame).expect("found");
    assert!(found.starts_with("sn at pixel (3, 1)"), "{found}");
}
