//! Quality of the denoised frame against `reference` (docs/denoiser.md, *Quality tests*):
//! accuracy after 16 static frames, shading detail on the mapped floor,
//! contact shadows, and temporal stability on an orbiting camera.
//!
//! References (256 spp: `reference` itself, and where the denoiser alone
//! is judged, the undenoised estimator at 256 spp) are rendered in-test and
//! shared between the tests of this file; the resolutions are small (160x90 and
//! 320x180) so the whole file stays a small part of `make test`.

use crate::support::{interior, load};
use glam::{Vec2, Vec3};
use penumbra::denoise::luminance;
use penumbra::embree::{self, Device};
use penumbra::render::{Frame, Mode, PixelKind, RenderSettings, World};
use penumbra::report::stats::{bilinear_taps, rel_mse_masked};
use penumbra::scene::{Camera, Scene};
use std::collections::HashMap;
use std::sync::{Arc, Mutex};

const REF_SPP: u32 = 256;
const THREADS: usize = 2;

/// Renders `cameras.len()` frames, one per camera, with one frame state (so
/// the denoiser's history carries over), calling `each` after every frame;
/// jitter and resolve (TAA) as `taa` says.
fn render_sequence(
    scene: &Scene,
    (w, h): (u32, u32),
    (mode, denoise, taa): (Mode, bool, bool),
    cameras: &[Camera],
    each: impl FnMut(usize, &mut Frame),
) -> Frame {
    render_sequence_seeded(scene, (w, h), (mode, denoise, taa), 1, cameras, each)
}

/// `render_sequence` with the sample stream `seed`.
fn render_sequence_seeded(
    scene: &Scene,
    (w, h): (u32, u32),
    (mode, denoise, taa): (Mode, bool, bool),
    seed: u32,
    cameras: &[Camera],
    mut each: impl FnMut(usize, &mut Frame),
) -> Frame {
    let device = Device::new().expect("Embree starts");
    let world = World::build(&device, scene.clone()).expect("scene builds");
    let pool = embree::thread_pool(THREADS).expect("thread pool");
    let settings = RenderSettings {
        mode,
        spp: 1,
        seed,
        denoise,
        taa,
        ..RenderSettings::default()
    };
    let mut frame = Frame::new(w, h);
    for (k, cam) in cameras.iter().enumerate() {
        pool.install(|| frame.render(&world, cam, &settings));
        each(k, &mut frame);
    }
    frame
}

/// `n` frames of the scene camera, TAA on (as shipped).
fn static_frames(scene: &Scene, size: (u32, u32), mode: Mode, denoise: bool, n: usize) -> Frame {
    render_sequence(
        scene,
        size,
        (mode, denoise, true),
        &vec![scene.camera; n],
        |_, _| {},
    )
}

fn orbit(scene: &Scene, deg_per_frame: f32, n: usize) -> Vec<Camera> {
    (0..n)
        .map(|k| scene.camera.orbit(deg_per_frame * k as f32))
        .collect()
}

/// `reference` colour of a shipped scene, its camera turned by `orbit_deg`.
fn reference(name: &str, size: (u32, u32), orbit_deg: f32) -> Arc<Vec<Vec3>> {
    converged(name, size, orbit_deg, Mode::Reference)
}

/// The colour `mode` converges to without denoising (`REF_SPP` samples in
/// one frame; `Mode::Reference`: the jittered ground truth), for a shipped
/// scene with its camera turned by `orbit_deg`; rendered once per test binary.
fn converged(name: &str, size: (u32, u32), orbit_deg: f32, mode: Mode) -> Arc<Vec<Vec3>> {
    static CACHE: Mutex<Option<HashMap<String, Arc<Vec<Vec3>>>>> = Mutex::new(None);
    let key = format!("{name} {}x{} {orbit_deg} {mode}", size.0, size.1);
    // Held while rendering: two tests wanting the same image wait for one render.
    let mut cache = CACHE.lock().unwrap_or_else(|e| e.into_inner());
    let map = cache.get_or_insert_with(HashMap::new);
    if let Some(r) = map.get(&key) {
        return r.clone();
    }
    let scene = load(name);
    let device = Device::new().expect("Embree starts");
    let world = World::build(&device, scene.clone()).expect("scene builds");
    let pool = embree::thread_pool(THREADS).expect("thread pool");
    let settings = RenderSettings {
        mode,
        spp: REF_SPP,
        seed: 0x5eed,
        denoise: false,
        taa: false,
        ..RenderSettings::default()
    };
    let mut frame = Frame::new(size.0, size.1);
    pool.install(|| frame.render(&world, &scene.camera.orbit(orbit_deg), &settings));
    let r = Arc::new(frame.color);
    map.insert(key, r.clone());
    r
}

fn material(scene: &Scene, name: &str) -> u32 {
    scene
        .materials
        .iter()
        .position(|m| m.name == name)
        .unwrap_or_else(|| panic!("no material {name}")) as u32
}

/// After 16 static frames at 1 spp, interior relMSE of denoised `ratio`
/// and denoised `stochastic` (mean over the sample seeds asked for):
/// against `reference` with TAA on (jittered frames and the resolve: what
/// `render --frames 16` writes) and off (every frame at the pixel centres),
/// and, TAA off, against what each estimator converges to undenoised (the
/// error the denoiser leaves). `floor` is what the converged unbiased
/// estimator at the pixel centres scores against `reference`: `reference`
/// averages each pixel's area (jittered camera rays), so sub-pixel detail
/// (texture, the near-mirror's sharp reflections) leaves this much error in
/// any pixel-centred frame, however many samples it takes; only the jitter
/// and resolve go below it.
struct SixteenFrames {
    ratio_vs_reference: f64,
    stochastic_vs_reference: f64,
    ratio_vs_reference_no_taa: f64,
    stochastic_vs_reference_no_taa: f64,
    ratio_vs_converged: f64,
    stochastic_vs_converged: f64,
    floor: f64,
}

/// `measure_sixteen_frames`, computed once per test binary for each
/// (scene, size, seeds): several tests state different facts about one run.
fn sixteen_frames(name: &str, size: (u32, u32), seeds: &[u32]) -> Arc<SixteenFrames> {
    static CACHE: Mutex<Option<HashMap<String, Arc<SixteenFrames>>>> = Mutex::new(None);
    let key = format!("{name} {}x{} {seeds:?}", size.0, size.1);
    let mut cache = CACHE.lock().unwrap_or_else(|e| e.into_inner());
    let map = cache.get_or_insert_with(HashMap::new);
    if let Some(e) = map.get(&key) {
        return e.clone();
    }
    let e = Arc::new(measure_sixteen_frames(name, size, seeds));
    map.insert(key, e.clone());
    e
}

fn measure_sixteen_frames(name: &str, size: (u32, u32), seeds: &[u32]) -> SixteenFrames {
    let scene = load(name);
    let reference = reference(name, size, 0.0);
    let conv_ratio = converged(name, size, 0.0, Mode::Ratio);
    let conv_stochastic = converged(name, size, 0.0, Mode::Stochastic);
    let mut e = SixteenFrames {
        ratio_vs_reference: 0.0,
        stochastic_vs_reference: 0.0,
        ratio_vs_reference_no_taa: 0.0,
        stochastic_vs_reference_no_taa: 0.0,
        ratio_vs_converged: 0.0,
        stochastic_vs_converged: 0.0,
        floor: 0.0,
    };
    let n = seeds.len() as f64;
    for &seed in seeds {
        let frames = |mode, taa| {
            let cams = vec![scene.camera; 16];
            render_sequence_seeded(&scene, size, (mode, true, taa), seed, &cams, |_, _| {})
        };
        let ratio = frames(Mode::Ratio, true);
        let stochastic = frames(Mode::Stochastic, true);
        let ratio_centred = frames(Mode::Ratio, false);
        let stochastic_centred = frames(Mode::Stochastic, false);
        let inside = interior(&ratio_centred);
        let err = |x: &Frame, truth: &[Vec3]| rel_mse_masked(&x.color, truth, &inside) / n;
        e.ratio_vs_reference += err(&ratio, &reference);
        e.stochastic_vs_reference += err(&stochastic, &reference);
        e.ratio_vs_reference_no_taa += err(&ratio_centred, &reference);
        e.stochastic_vs_reference_no_taa += err(&stochastic_centred, &reference);
        e.ratio_vs_converged += err(&ratio_centred, &conv_ratio);
        e.stochastic_vs_converged += err(&stochastic_centred, &conv_stochastic);
        e.floor = rel_mse_masked(&conv_stochastic, &reference, &inside);
        // Where the error lives: per receiver material.
        println!("{name} seed {seed}, per material, interior relMSE:");
        for (id, m) in scene.materials.iter().enumerate() {
            let on: Vec<bool> = (0..ratio.pixel_count())
                .map(|k| {
                    inside[k]
                        && ratio_centred.gbuf[k].kind == PixelKind::Surface
                        && ratio_centred.gbuf[k].material == id as u32
                })
                .collect();
            let px = on.iter().filter(|&&b| b).count();
            if px > 0 {
                println!(
                    "  {:>10} ({px} px): vs reference, TAA: ratio {:.3e}, stochastic {:.3e}; no TAA: ratio {:.3e}, stochastic {:.3e}; converged stochastic (floor) {:.3e}; no TAA vs converged: ratio {:.3e}, stochastic {:.3e}",
                    m.name,
                    rel_mse_masked(&ratio.color, &reference, &on),
                    rel_mse_masked(&stochastic.color, &reference, &on),
                    rel_mse_masked(&ratio_centred.color, &reference, &on),
                    rel_mse_masked(&stochastic_centred.color, &reference, &on),
                    rel_mse_masked(&conv_stochastic, &reference, &on),
                    rel_mse_masked(&ratio_centred.color, &conv_ratio, &on),
                    rel_mse_masked(&stochastic_centred.color, &conv_stochastic, &on),
                );
            }
        }
    }
    println!(
        "{name} {}x{}, 16 frames at 1 spp, denoised, interior relMSE, mean over seeds {seeds:?}: vs reference with TAA: ratio {:.3e}, stochastic {:.3e} ({:.2}x); without TAA: ratio {:.3e}, stochastic {:.3e} ({:.2}x); floor (converged stochastic at pixel centres) {:.3e}; without TAA vs own {REF_SPP}-spp undenoised: ratio {:.3e}, stochastic {:.3e} ({:.2}x)",
        size.0,
        size.1,
        e.ratio_vs_reference,
        e.stochastic_vs_reference,
        e.stochastic_vs_reference / e.ratio_vs_reference,
        e.ratio_vs_reference_no_taa,
        e.stochastic_vs_reference_no_taa,
        e.stochastic_vs_reference_no_taa / e.ratio_vs_reference_no_taa,
        e.floor,
        e.ratio_vs_converged,
        e.stochastic_vs_converged,
        e.stochastic_vs_converged / e.ratio_vs_converged,
    );
    e
}

/// shadow-plane is judged over three seeds: its error sits in a few hundred
/// glossy and near-mirror pixels, and a single seed's figure moves by 2x
/// (the stochastic/ratio gap measured 3.1x, 2.2x and 2.4x for seeds 1-3).
const SHADOW_PLANE_SEEDS: [u32; 3] = [1, 2, 3];

/// relMSE of the denoised ratio against `reference` on shadow-plane, seeds 1-3.
const SHADOW_PLANE_MAX_REL_MSE: f64 = 5e-3;
/// relMSE of the denoised ratio against `reference` on room, seed 1.
const ROOM_MAX_REL_MSE: f64 = 3e-3;
/// The 4x goal of docs/denoiser.md: denoised stochastic's relMSE against
/// `reference` over the denoised ratio's, with TAA, on room.
const ROOM_MIN_GAIN_VS_REFERENCE: f64 = 4.0;
/// The denoised ratio's relMSE against `reference` as a share of the
/// pixel-centred floor, with TAA, on room.
const ROOM_MAX_SHARE_OF_FLOOR: f64 = 0.5;
/// The 4x goal against each mode's own converged estimator, on room
/// (22x when last measured).
const ROOM_MIN_GAIN_VS_CONVERGED: f64 = 4.0;
/// Stochastic's error over the ratio's against their converged estimators on
/// shadow-plane: what holds there (2.6x over seeds 1-3, docs/denoiser.md).
const SHADOW_PLANE_MIN_GAIN_VS_CONVERGED: f64 = 2.2;
/// The denoised ratio's relMSE against its converged value on shadow-plane
/// (2.1e-3 over seeds 1-3 when last measured).
const SHADOW_PLANE_MAX_REL_MSE_VS_CONVERGED: f64 = 2.8e-3;
/// How far the high-pass energy of the denoised floor may be from the
/// truth's, as a fraction of it (25 %).
const FLOOR_DETAIL_MAX_ENERGY_ERROR: f64 = 0.25;
/// How far the share of the true floor detail kept may be from all of it.
const FLOOR_DETAIL_MAX_KEPT_ERROR: f64 = 0.1;
/// Below this share of the true floor detail kept, the detail is lost.
const FLOOR_DETAIL_LOST_BELOW: f64 = 0.6;
/// relMSE of the denoised ratio against `reference` in the box's contact band.
const CONTACT_BAND_MAX_REL_MSE: f64 = 1e-2;
/// RMS change of the denoised ratio a frame in penumbrae on an orbit.
/// Undenoised, the same pixels change by ~0.5 a frame (0.49 at 320x180 in
/// examples/denoise_table.rs). On the glossy-floor room: 0.070 when last
/// measured without TAA; 0.091 while the history was judged on the whole
/// `U`, whose specular part slides with the camera (see
/// `temporal::light_changed`).
const PENUMBRA_MAX_FLICKER: f64 = 0.08;

#[test]
fn after_16_frames_denoised_ratio_is_close_to_reference_on_shadow_plane() {
    let e = sixteen_frames("shadow-plane.toml", (160, 90), &SHADOW_PLANE_SEEDS);
    assert!(
        e.ratio_vs_reference < SHADOW_PLANE_MAX_REL_MSE,
        "ratio relMSE {}",
        e.ratio_vs_reference
    );
}

#[test]
fn after_16_frames_denoised_ratio_is_close_to_reference_on_room() {
    let e = sixteen_frames("room.toml", (320, 180), &[1]);
    assert!(
        e.ratio_vs_reference < ROOM_MAX_REL_MSE,
        "ratio relMSE {}",
        e.ratio_vs_reference
    );
}

/// The 4x goal against `reference`, which needs TAA: without it the
/// pixel-centred floor (7.4e-4 here) is above a quarter of denoised
/// stochastic and at most 1.25x is possible.
#[test]
fn after_16_frames_with_taa_denoised_ratio_is_much_closer_to_reference_than_stochastic_on_room() {
    let e = sixteen_frames("room.toml", (320, 180), &[1]);
    assert!(
        e.stochastic_vs_reference > ROOM_MIN_GAIN_VS_REFERENCE * e.ratio_vs_reference,
        "ratio {} vs stochastic {}",
        e.ratio_vs_reference,
        e.stochastic_vs_reference
    );
}

/// Jitter and resolve average each pixel's area as `reference` does: the
/// denoised ratio goes well below what any pixel-centred frame can reach.
#[test]
fn after_16_frames_with_taa_denoised_ratio_is_well_below_the_pixel_centred_floor_on_room() {
    let e = sixteen_frames("room.toml", (320, 180), &[1]);
    assert!(
        e.ratio_vs_reference < ROOM_MAX_SHARE_OF_FLOOR * e.floor,
        "ratio {} vs floor {}",
        e.ratio_vs_reference,
        e.floor
    );
}

/// What the denoiser is responsible for: each mode's error against its own
/// converged estimator (22x when last measured).
#[test]
fn after_16_frames_the_denoiser_leaves_much_less_error_on_ratio_than_on_stochastic_on_room() {
    let e = sixteen_frames("room.toml", (320, 180), &[1]);
    assert!(
        e.stochastic_vs_converged > ROOM_MIN_GAIN_VS_CONVERGED * e.ratio_vs_converged,
        "ratio {} vs stochastic {}",
        e.ratio_vs_converged,
        e.stochastic_vs_converged
    );
}

/// On shadow-plane the 4x goal is NOT met, not even against the converged
/// estimators (2.6x over seeds 1-3, docs/denoiser.md): on the glossy and
/// near-mirror strips the error is the visibility seen through the lobe,
/// which both estimators share sample for sample; the ratio cancels only the
/// BRDF and light variance, which MIS leaves small there. The pixels whose
/// lobe straddles the bar's reflected edge hold 96 % of the ratio's error
/// here, with stochastic only 1.63x above it on them
/// (`cargo run --release --example denoise_strips`; docs/denoiser.md). What holds is kept from regressing.
#[test]
fn after_16_frames_the_denoised_ratio_has_less_error_than_stochastic_on_shadow_plane() {
    let e = sixteen_frames("shadow-plane.toml", (160, 90), &SHADOW_PLANE_SEEDS);
    assert!(
        e.stochastic_vs_converged > SHADOW_PLANE_MIN_GAIN_VS_CONVERGED * e.ratio_vs_converged,
        "ratio {} vs stochastic {}",
        e.ratio_vs_converged,
        e.stochastic_vs_converged
    );
}

/// The sharp shadow seen in the glossy and near-mirror strips is not blurred
/// by the spatial levels (the lobe guide): 2.1e-3 over seeds 1-3 when last
/// measured (seed 1: 2.4e-3, and 3.2e-3 without the guide).
#[test]
fn after_16_frames_the_denoised_ratio_is_close_to_its_converged_value_on_shadow_plane() {
    let e = sixteen_frames("shadow-plane.toml", (160, 90), &SHADOW_PLANE_SEEDS);
    assert!(
        e.ratio_vs_converged < SHADOW_PLANE_MAX_REL_MSE_VS_CONVERGED,
        "ratio relMSE vs converged {}",
        e.ratio_vs_converged
    );
}

/// Laplacian of the luminance at the floor pixels whose 4 neighbours are
/// floor too (away from edges), in the lower half of the image where the
/// floor is near and its texture is larger than a pixel.
fn floor_laplacian(colors: &[Vec3], window: &[usize], w: usize) -> Vec<f64> {
    let l = |k: usize| luminance(colors[k]) as f64;
    window
        .iter()
        .map(|&k| 4.0 * l(k) - l(k - 1) - l(k + 1) - l(k - w) - l(k + w))
        .collect()
}

/// The ratio's floor matches the truth's high-frequency energy; denoised
/// stochastic does not. On the dark glossy floor (since the roomfig scene)
/// stochastic no longer loses the detail (it keeps 1.09 of it after one
/// frame; 0.57 on the earlier white floor): the lobe and `U` edge-stopping
/// keep its taps apart, so its noise stays, and the high-pass energy is 3x
/// the truth's. Either way it does not match; the test asks exactly that.
#[test]
fn floor_detail_survives_in_ratio_and_stochastic_does_not_match_it() {
    let size = (320u32, 180u32);
    let scene = load("room.toml");
    // The detail a pixel-centred renderer should show: `stochastic` at
    // REF_SPP samples, undenoised (the jittered `reference` box-filters the
    // texture and has less high-frequency energy than any pixel-centred frame).
    let truth = converged("room.toml", size, 0.0, Mode::Stochastic);
    let tiles = material(&scene, "tiles");
    let first = static_frames(&scene, size, Mode::Unshadowed, false, 1);
    let inside = interior(&first);
    let w = size.0 as usize;
    let floor = |k: usize| inside[k] && first.gbuf[k].material == tiles;
    let window: Vec<usize> = (w * (size.1 as usize / 2)..w * (size.1 as usize - 1))
        .filter(|&k| floor(k) && floor(k - 1) && floor(k + 1) && floor(k - w) && floor(k + w))
        .collect();
    assert!(
        window.len() > 2000,
        "floor window of {} pixels",
        window.len()
    );
    let hp_truth = floor_laplacian(&truth, &window, w);
    let energy = |hp: &[f64]| hp.iter().map(|v| v * v).sum::<f64>();
    // Share of the true detail present in x: the projection of x's
    // high-pass onto the truth's (noise in x does not count as detail).
    let kept =
        |hp: &[f64]| hp.iter().zip(&hp_truth).map(|(a, b)| a * b).sum::<f64>() / energy(&hp_truth);
    // One frame (what a moving camera gets) is where the two part ways; by
    // 16 static frames stochastic has averaged its noise away and keeps the
    // detail too (printed, not asserted).
    let mut at = Vec::new();
    for frames in [1usize, 16] {
        let ratio = static_frames(&scene, size, Mode::Ratio, true, frames);
        let stochastic = static_frames(&scene, size, Mode::Stochastic, true, frames);
        let hp_ratio = floor_laplacian(&ratio.color, &window, w);
        let hp_stochastic = floor_laplacian(&stochastic.color, &window, w);
        let e_truth = energy(&hp_truth);
        let m = (
            energy(&hp_ratio) / e_truth,
            kept(&hp_ratio),
            energy(&hp_stochastic) / e_truth,
            kept(&hp_stochastic),
        );
        println!(
            "room floor ({} px), {frames} frame(s) at 1 spp, denoised: high-pass energy / truth: ratio {:.3} (detail kept {:.3}), stochastic {:.3} (detail kept {:.3})",
            window.len(),
            m.0,
            m.1,
            m.2,
            m.3
        );
        at.push(m);
    }
    let (ratio_energy, ratio_kept, stochastic_energy, stochastic_kept) = at[0];
    assert!(
        (ratio_energy - 1.0).abs() < FLOOR_DETAIL_MAX_ENERGY_ERROR,
        "ratio energy {ratio_energy}"
    );
    assert!(
        (ratio_kept - 1.0).abs() < FLOOR_DETAIL_MAX_KEPT_ERROR,
        "ratio keeps {ratio_kept}"
    );
    // Not matched: detail lost or buried in noise.
    assert!(
        stochastic_kept < FLOOR_DETAIL_LOST_BELOW
            || (stochastic_energy - 1.0).abs() > FLOOR_DETAIL_MAX_ENERGY_ERROR,
        "stochastic keeps {stochastic_kept}, energy {stochastic_energy}"
    );
}

#[test]
fn contact_shadow_of_the_box_on_the_floor_stays_sharp() {
    let size = (320u32, 180u32);
    let scene = load("room.toml");
    let reference = reference("room.toml", size, 0.0);
    let ratio = static_frames(&scene, size, Mode::Ratio, true, 16);
    let tiles = material(&scene, "tiles");
    let inside = interior(&ratio);
    // The red box: centre (-1.3, 0.5, 1.5), 1 x 1 x 1, turned 25 degrees
    // about +Y. Distance of a floor point to the box's footprint, in the
    // box's own frame (the inverse rotation).
    let (c, (s, co)) = (Vec2::new(-1.3, 1.5), 25f32.to_radians().sin_cos());
    let footprint_distance = |p: Vec3| {
        let d = Vec2::new(p.x, p.z) - c;
        let local = Vec2::new(d.x * co - d.y * s, d.x * s + d.y * co);
        (local.abs() - Vec2::splat(0.5)).max(Vec2::ZERO).length()
    };
    // The band: floor within 0.25 of the contact line, where the reference
    // is shadowed (below 95 % of U).
    let band: Vec<bool> = (0..ratio.pixel_count())
        .map(|k| {
            let g = &ratio.gbuf[k];
            let d = footprint_distance(g.position);
            inside[k]
                && g.kind == PixelKind::Surface
                && g.material == tiles
                && d > 0.0
                && d <= 0.25
                && luminance(reference[k]) < 0.95 * luminance(ratio.u[k])
        })
        .collect();
    let n = band.iter().filter(|&&b| b).count();
    assert!(n >= 50, "contact band of {n} pixels");
    let e = rel_mse_masked(&ratio.color, &reference, &band);
    let raw = static_frames(&scene, size, Mode::Ratio, false, 1);
    let e_raw = rel_mse_masked(&raw.color, &reference, &band);
    println!(
        "contact band ({n} px): relMSE denoised ratio, 16 frames {e:.3e}; undenoised, 1 frame {e_raw:.3e}"
    );
    assert!(e < CONTACT_BAND_MAX_REL_MSE, "contact band relMSE {e}");
}

/// Pixels no occluder touches, per frame of an orbit: an undenoised twin
/// with the same samples (and the same jitter) marks where S_N != U_N, i.e.
/// an occluder blocked a sample. Every such point, seen in any frame so far,
/// is projected into the current frame and its 20-pixel surroundings (the
/// filter reaches 15, reprojection 1 more) are marked.
fn near_occluders(scene: &Scene, size: (u32, u32), cams: &[Camera], taa: bool) -> Vec<Vec<bool>> {
    let (w, h) = (size.0 as i64, size.1 as i64);
    let mut touched: Vec<Vec3> = Vec::new();
    let mut masks = Vec::new();
    render_sequence(scene, size, (Mode::Ratio, false, taa), cams, |t, f| {
        for k in 0..f.pixel_count() {
            if f.gbuf[k].kind == PixelKind::Surface && f.sn[k] != f.un[k] {
                touched.push(f.gbuf[k].position);
            }
        }
        let cam = cams[t].frame(size.0, size.1);
        let mut near = vec![false; f.pixel_count()];
        for p in &touched {
            if let Some((px, py)) = cam.project(*p) {
                let (cx, cy) = (px as i64, py as i64);
                for y in (cy - 20).max(0)..(cy + 21).min(h) {
                    for x in (cx - 20).max(0)..(cx + 21).min(w) {
                        near[(y * w + x) as usize] = true;
                    }
                }
            }
        }
        masks.push(near);
    });
    masks
}

/// Colour of every frame of `unshadowed` along `cams` (TAA as asked).
fn unshadowed_frames(
    scene: &Scene,
    size: (u32, u32),
    cams: &[Camera],
    taa: bool,
) -> Vec<Vec<Vec3>> {
    let mut out = Vec::new();
    render_sequence(scene, size, (Mode::Unshadowed, false, taa), cams, |_, f| {
        out.push(f.color.clone())
    });
    out
}

#[test]
fn on_an_orbit_pixels_no_occluder_touches_are_exactly_u_every_frame() {
    let scene = load("room.toml");
    let size = (160u32, 90u32);
    let cams = orbit(&scene, 1.0, 16);
    let masks = near_occluders(&scene, size, &cams, false);
    let mut checked = 0;
    render_sequence(&scene, size, (Mode::Ratio, true, false), &cams, |t, f| {
        for (k, &near) in masks[t].iter().enumerate() {
            if f.gbuf[k].kind == PixelKind::Surface && !near {
                let analytic = f.gbuf[k].emission + f.u[k];
                assert_eq!(f.color[k], analytic, "frame {t}, pixel {k}");
                checked += 1;
            }
        }
    });
    println!("{checked} pixel-frames equal to U exactly");
    assert!(checked > 16 * 1000, "only {checked} pixel-frames untouched");
}

/// With TAA the frame is no longer this frame's `U` but the resolve of the
/// jittered `U`s: exactly what `unshadowed` with TAA shows, bit for bit (the
/// resolve never sees the ratio's noise; the denoised ratio multiplies it).
#[test]
fn with_taa_on_an_orbit_pixels_no_occluder_touches_are_exactly_the_resolve_of_u() {
    let scene = load("room.toml");
    let size = (160u32, 90u32);
    let cams = orbit(&scene, 1.0, 16);
    let masks = near_occluders(&scene, size, &cams, true);
    let unshadowed = unshadowed_frames(&scene, size, &cams, true);
    let mut checked = 0;
    render_sequence(&scene, size, (Mode::Ratio, true, true), &cams, |t, f| {
        for (k, &near) in masks[t].iter().enumerate() {
            if f.gbuf[k].kind == PixelKind::Surface && !near {
                assert_eq!(f.color[k], unshadowed[t][k], "frame {t}, pixel {k}");
                checked += 1;
            }
        }
        // The resolve did something: frames after the first differ from
        // this frame's own U somewhere.
        if t > 0 {
            assert!((0..f.pixel_count()).any(|k| unshadowed[t][k] != f.gbuf[k].emission + f.u[k]));
        }
    });
    println!("{checked} pixel-frames equal to the resolve of U exactly");
    assert!(checked > 16 * 1000, "only {checked} pixel-frames untouched");
}

/// Root mean square frame-to-frame change of the ratio in penumbrae
/// (0.05 < ratio < 0.95), comparing each pixel with where its surface point
/// was in the previous frame (bilinear, all four taps on the same surface).
/// The ratio is colour over the `unshadowed` colour of the same frame (same
/// camera, same jitter, same resolve): colour / `U` without TAA, and with it
/// the denoised ratio alone, not the jitter's sub-pixel shading detail.
fn penumbra_flicker(scene: &Scene, cams: &[Camera], taa: bool) -> (f64, usize) {
    let size = (160u32, 90u32);
    let w = size.0 as usize;
    let unshadowed = unshadowed_frames(scene, size, cams, taa);
    let mut prev: Option<(Vec<Option<f32>>, Vec<Vec3>)> = None;
    let (mut sum, mut n) = (0.0f64, 0usize);
    render_sequence(scene, size, (Mode::Ratio, true, taa), cams, |t, f| {
        let (s0, n0) = (sum, n);
        let r: Vec<Option<f32>> = (0..f.pixel_count())
            .map(|k| {
                let lu = luminance(unshadowed[t][k]);
                (f.gbuf[k].kind == PixelKind::Surface && lu > 1e-3)
                    .then(|| luminance(f.color[k]) / lu)
            })
            .collect();
        let pos: Vec<Vec3> = f.gbuf.iter().map(|g| g.position).collect();
        if let Some((pr, pp)) = &prev {
            for (k, rk) in r.iter().enumerate() {
                let g = &f.gbuf[k];
                let Some(rk) = rk.filter(|v| *v > 0.05 && *v < 0.95) else {
                    continue;
                };
                if !g.prev_valid {
                    continue;
                }
                let Some(taps) = bilinear_taps(g.prev_pixel, w, size.1 as usize) else {
                    continue;
                };
                let same_surface = taps
                    .iter()
                    .all(|&(t, _)| pr[t].is_some() && pp[t].distance(g.position) < 0.05 * g.depth);
                if !same_surface {
                    continue;
                }
                let before: f32 = taps.iter().map(|&(t, wt)| pr[t].unwrap() * wt).sum();
                sum += ((rk - before) as f64).powi(2);
                n += 1;
            }
        }
        prev = Some((r, pos));
        if n > n0 {
            println!(
                "  frame {t}: flicker {:.4} over {}",
                ((sum - s0) / (n - n0) as f64).sqrt(),
                n - n0
            );
        }
    });
    ((sum / n.max(1) as f64).sqrt(), n)
}

#[test]
fn on_an_orbit_penumbrae_flicker_little() {
    let scene = load("room.toml");
    let cams = orbit(&scene, 1.0, 16);
    for taa in [false, true] {
        let (denoised, n) = penumbra_flicker(&scene, &cams, taa);
        println!(
            "room 160x90, orbit 1 deg/frame, 16 frames, TAA {taa}: penumbra flicker (rms change of the ratio) denoised {denoised:.4} over {n} pixel-frames"
        );
        assert!(n > 1000, "only {n} penumbra pixel-frames");
        assert!(
            denoised < PENUMBRA_MAX_FLICKER,
            "TAA {taa}: flicker {denoised}"
        );
    }
}

/// Interior pixels at camera `b` that camera `a` did not see (hidden behind
/// something nearer, or outside its view), judged on one frame of each.
fn disoccluded(scene: &Scene, size: (u32, u32), a: Camera, b: Camera) -> Vec<bool> {
    let (w, h) = (size.0 as usize, size.1 as usize);
    let before = render_sequence(
        scene,
        size,
        (Mode::Unshadowed, false, false),
        &[a],
        |_, _| {},
    );
    let after = render_sequence(
        scene,
        size,
        (Mode::Unshadowed, false, false),
        &[b],
        |_, _| {},
    );
    let cam_a = a.frame(size.0, size.1);
    let inside = interior(&after);
    (0..after.pixel_count())
        .map(|k| {
            let g = &after.gbuf[k];
            if !inside[k] || g.kind != PixelKind::Surface {
                return false;
            }
            match cam_a.project(g.position) {
                None => true,
                Some((px, py)) if px < 0.0 || py < 0.0 || px >= w as f32 || py >= h as f32 => true,
                Some((px, py)) => {
                    let seen = &before.gbuf[py as usize * w + px as usize];
                    let dist = g.position.distance(cam_a.eye);
                    seen.kind == PixelKind::Surface && seen.depth < dist * 0.95
                }
            }
        })
        .collect()
}

/// 8 frames at the scene camera, an 8-degree turn, 8 frames there; error of
/// the disoccluded pixels against `truth` on each frame after the turn, with
/// the history kept and with it dropped at the turn (a fresh start with the
/// same light samples). Returns (pixels, with history, fresh).
fn disocclusion_recovery(taa: bool, truth: &[Vec3]) -> (usize, Vec<f64>, Vec<f64>) {
    let scene = load("room.toml");
    let size = (160u32, 90u32);
    let (a, b) = (scene.camera, scene.camera.orbit(8.0));
    let region = disoccluded(&scene, size, a, b);
    let mut cams = vec![a; 8];
    cams.extend(std::iter::repeat_n(b, 8));
    let (mut hist, mut fresh) = (Vec::new(), Vec::new());
    render_sequence(&scene, size, (Mode::Ratio, true, taa), &cams, |t, f| {
        if t >= 8 {
            hist.push(rel_mse_masked(&f.color, truth, &region));
        }
    });
    render_sequence(&scene, size, (Mode::Ratio, true, taa), &cams, |t, f| {
        if t == 7 {
            f.reset_history();
        } else if t >= 8 {
            fresh.push(rel_mse_masked(&f.color, truth, &region));
        }
    });
    let n = region.iter().filter(|&&r| r).count();
    println!("room 160x90, turn 8 deg after 8 frames, TAA {taa}: {n} disoccluded pixels");
    for k in 0..hist.len() {
        println!(
            "  frame {} after the turn: relMSE with history {:.3e}, fresh start {:.3e}",
            k + 1,
            hist[k],
            fresh[k]
        );
    }
    (n, hist, fresh)
}

/// No ghost: with the same samples, the disoccluded pixels are within 1.5x
/// of a fresh start (which has no history to leak) on every frame (a leaked
/// history of the occluder would carry its ratio, not this surface's), and
/// after 4 frames within 2x of the error a fresh start has after 8.
fn assert_no_ghost(n: usize, hist: &[f64], fresh: &[f64]) {
    assert!(n >= 100, "only {n} disoccluded pixels");
    for k in 0..hist.len() {
        assert!(
            hist[k] <= 1.5 * fresh[k],
            "frame {}: {} vs fresh {}",
            k + 1,
            hist[k],
            fresh[k]
        );
    }
    assert!(
        hist[3] <= 2.0 * fresh[fresh.len() - 1],
        "after 4 frames {} vs fresh start after 8 {}",
        hist[3],
        fresh[fresh.len() - 1]
    );
}

#[test]
fn after_a_disocclusion_the_error_recovers_without_a_ghost_trail() {
    // Against the ratio's own converged value at the turned camera: on room
    // the pixel-footprint floor would otherwise hide the noise and any ghost.
    let truth = converged("room.toml", (160, 90), 8.0, Mode::Ratio);
    let (n, hist, fresh) = disocclusion_recovery(false, &truth);
    assert_no_ghost(n, &hist, &fresh);
}

/// The same with jitter and the colour resolve (its history reprojected,
/// tested and clamped), against `reference`, which the resolve converges to.
/// The fresh start restarts the jitter sequence with its history, so single
/// frames of the two runs see different sub-pixel positions (two-frame
/// averages differ by 1.6x either way at frame 2); a ghost would last for
/// the history's length, so the 8 frames after the turn are judged
/// together, and the recovery as above.
#[test]
fn with_taa_after_a_disocclusion_the_error_recovers_without_a_ghost_trail() {
    let truth = reference("room.toml", (160, 90), 8.0);
    let (n, hist, fresh) = disocclusion_recovery(true, &truth);
    assert!(n >= 100, "only {n} disoccluded pixels");
    let (sum_hist, sum_fresh) = (hist.iter().sum::<f64>(), fresh.iter().sum::<f64>());
    assert!(
        sum_hist <= 1.25 * sum_fresh,
        "8 frames after the turn: {sum_hist} vs fresh {sum_fresh}"
    );
    assert!(
        hist[3] <= 2.0 * fresh[fresh.len() - 1],
        "after 4 frames {} vs fresh start after 8 {}",
        hist[3],
        fresh[fresh.len() - 1]
    );
}

/// Speckles (`compare::speckles`: lit pixels away from geometric edges whose
/// luminance is off `reference`'s by more than 2x either way) after `n`
/// static frames at 1 spp, TAA on, denoised or not, seed 1.
fn speckles_after(name: &str, size: (u32, u32), n: usize, denoise: bool) -> f64 {
    let scene = load(name);
    let truth = reference(name, size, 0.0);
    let frame = static_frames(&scene, size, Mode::Ratio, denoise, n);
    let s = penumbra::compare::speckles(size.0, &frame.color, &truth, Some(&interior(&frame)));
    println!(
        "{name} {}x{}, {n} frames, denoise {denoise}: speckles {:.3} % ({} dark, {} bright of {} lit)",
        size.0,
        size.1,
        s.fraction() * 100.0,
        s.dark,
        s.bright,
        s.lit
    );
    s.fraction()
}

/// The speckle goal after 16 frames (docs/first-frame.md), met on room
/// (0.05 % at 320x180, seed 1, when last measured).
const ROOM_MAX_SPECKLES_16_FRAMES: f64 = 1e-3;
/// On the built-in scene the goal is NOT met: the converged ratio
/// estimator itself leaves about 0.4 % of its lit pixels over 2x off
/// `reference` on the glossy strips (there `U` differs from the true
/// unshadowed integral by that much; docs/first-frame.md). What holds: the
/// denoised 16th frame has at most this share of the undenoised one's
/// (1.47 % against 3.43 % at 320x180, seed 1, when last measured).
const BUILT_IN_MAX_SPECKLE_SHARE_OF_UNDENOISED: f64 = 0.5;

#[test]
fn after_16_frames_under_one_pixel_in_a_thousand_is_a_speckle_on_room() {
    let s = speckles_after("room.toml", (320, 180), 16, true);
    assert!(s <= ROOM_MAX_SPECKLES_16_FRAMES, "speckles {s}");
}

#[test]
fn after_16_frames_the_denoiser_removes_most_speckles_on_the_built_in_scene() {
    let dn = speckles_after("default.toml", (320, 180), 16, true);
    let raw = speckles_after("default.toml", (320, 180), 16, false);
    assert!(
        dn <= BUILT_IN_MAX_SPECKLE_SHARE_OF_UNDENOISED * raw,
        "denoised {dn} vs undenoised {raw}"
    );
}

/// Interior relMSE against `reference` of the 4th frame after the eye jumps
/// by `jump_deg` about the target, after 16 frames of the scene camera,
/// and of the 4th frame of a fresh start at the same view; TAA on, seed 1.
fn after_a_jump(name: &str, size: (u32, u32), jump_deg: f32) -> (f64, f64) {
    let scene = load(name);
    let truth = reference(name, size, jump_deg);
    let to = scene.camera.orbit(jump_deg);
    let mut cams = vec![scene.camera; 16];
    cams.extend([to; 4]);
    let jumped = render_sequence(&scene, size, (Mode::Ratio, true, true), &cams, |_, _| {});
    let fresh = render_sequence(&scene, size, (Mode::Ratio, true, true), &[to; 4], |_, _| {});
    let inside = interior(&fresh);
    let (a, b) = (
        rel_mse_masked(&jumped.color, &truth, &inside),
        rel_mse_masked(&fresh.color, &truth, &inside),
    );
    println!(
        "{name} {}x{}: 4 frames after a {jump_deg} degree jump {a:.3e}, fresh {b:.3e}",
        size.0, size.1
    );
    (a, b)
}

/// Four frames after a camera jump, the error is at most this many times a
/// fresh start's at the same view (the history of the old view either
/// reprojects onto the same surfaces or is dropped, never a ghost): 1.10x
/// on room when last measured. NOT met on shadow-plane (2.7x after a 30
/// degree jump, docs/first-frame.md); part of it is the old view's
/// reflected visibility kept on the glossy strips (dropping the history
/// where the specular part of `U` moved brought it to 2.0x, and broke the
/// orbit's flicker bound).
const JUMP_MAX_ERROR_OVER_FRESH: f64 = 1.5;

#[test]
fn four_frames_after_a_camera_jump_the_error_is_close_to_a_fresh_start_on_room() {
    let (jumped, fresh) = after_a_jump("room.toml", (320, 180), 30.0);
    assert!(
        jumped <= JUMP_MAX_ERROR_OVER_FRESH * fresh,
        "after the jump {jumped}, fresh {fresh}"
    );
}
