//! Temporal reprojection: history follows the camera exactly on whole-pixel
//! shifts, and is dropped on disocclusion and on a big change of U (judged on
//! U's diffuse part where it has one: a camera move slides glossy highlights).

use crate::support::denoise::{Frame, Rng};
use glam::{Vec2, Vec3};
use penumbra::denoise::{DenoiseSettings, Denoiser, Lobe};

const W: u32 = 40;
const H: u32 = 30;

fn temporal_only() -> DenoiseSettings {
    DenoiseSettings {
        spatial: false,
        ..DenoiseSettings::default()
    }
}

fn random(rng: &mut Rng, n: usize) -> (Vec<Vec3>, Vec<Vec3>) {
    let un: Vec<Vec3> = (0..n)
        .map(|_| Vec3::new(rng.f32(), rng.f32(), rng.f32()) + 0.1)
        .collect();
    let sn = un.iter().map(|u| *u * rng.f32()).collect();
    (un, sn)
}

fn close(a: Vec3, b: Vec3) -> bool {
    (a - b).abs().max_element() <= 1e-6 * a.abs().max_element().max(1.0)
}

#[test]
fn whole_pixel_shift_carries_history_exactly() {
    assert_shift_carries_history(W, H, (3, -2));
}

/// A history is kept by groups of eight pixels of a row; a shift by any
/// number of columns reads taps that straddle two groups in every way, and
/// a width that is no multiple of eight ends each row in a partial group.
#[test]
fn every_shift_within_a_lane_group_carries_history_exactly() {
    for dx in -9..=9 {
        assert_shift_carries_history(43, 7, (dx, 1));
    }
}

/// The camera moves so that the world point seen at (x, y) in frame 1 is
/// seen at (x + dx, y + dy) in frame 2 (same plane, guides shifted): every
/// pixel still on screen blends its own history exactly, every pixel that
/// entered the screen starts one.
fn assert_shift_carries_history(w: u32, h: u32, (dx, dy): (i32, i32)) {
    let f1 = Frame::plane(w, h);
    let mut f2 = Frame::plane(w, h);
    let (wi, hi) = (w as i32, h as i32);
    let source = |x: i32, y: i32| {
        let (sx, sy) = (x - dx, y - dy);
        (sx >= 0 && sy >= 0 && sx < wi && sy < hi).then_some((sy * wi + sx) as usize)
    };
    for y in 0..hi {
        for x in 0..wi {
            let i = (y * wi + x) as usize;
            f2.prev_pixel[i] = Vec2::new((x - dx) as f32 + 0.5, (y - dy) as f32 + 0.5);
            if let Some(j) = source(x, y) {
                f2.pos[i] = f1.pos[j];
                f2.depth[i] = f1.depth[j];
            }
        }
    }
    let mut rng = Rng::new(1);
    let (a_un, a_sn) = random(&mut rng, f1.n());
    let (b_un, b_sn) = random(&mut rng, f1.n());
    let mut d = Denoiser::new(w, h);
    let (mut un, mut sn) = (a_un.clone(), a_sn.clone());
    d.denoise(&f1.guide(), &mut un, &mut sn, &temporal_only());
    let (mut un, mut sn) = (b_un.clone(), b_sn.clone());
    d.denoise(&f2.guide(), &mut un, &mut sn, &temporal_only());
    let len = d.history_len();
    let (mut carried, mut fresh) = (0, 0);
    for y in 0..hi {
        for x in 0..wi {
            let i = (y * wi + x) as usize;
            let at = format!("{x},{y} shifted by {dx},{dy}");
            if let Some(j) = source(x, y) {
                assert!(close(un[i], (a_un[j] + b_un[i]) * 0.5), "U_N at {at}");
                assert!(close(sn[i], (a_sn[j] + b_sn[i]) * 0.5), "S_N at {at}");
                assert_eq!(len[i], 2.0, "history length at {at}");
                carried += 1;
            } else {
                // Entered the screen this frame: no history, the input itself.
                assert_eq!((un[i], sn[i]), (b_un[i], b_sn[i]), "new pixel {at}");
                assert_eq!(len[i], 1.0, "history length at {at}");
                fresh += 1;
            }
        }
    }
    assert!(carried > 0 && fresh > 0);
}

/// Two frames on a static plane; `edit` changes the second frame's guides in
/// the region x < 10. Returns (output, inputs of frame 2, history lengths).
fn two_frames(edit: impl Fn(&mut Frame, usize)) -> (Vec<Vec3>, Vec<Vec3>, Vec<f32>) {
    two_frames_from(Frame::plane(W, H), edit)
}

/// `two_frames`, both frames starting as `f1`.
fn two_frames_from(
    f1: Frame,
    edit: impl Fn(&mut Frame, usize),
) -> (Vec<Vec3>, Vec<Vec3>, Vec<f32>) {
    let mut f2 = Frame {
        pos: f1.pos.clone(),
        normal: f1.normal.clone(),
        depth: f1.depth.clone(),
        prev_pixel: f1.prev_pixel.clone(),
        prev_valid: f1.prev_valid.clone(),
        u: f1.u.clone(),
        lobe: f1.lobe.clone(),
        ..f1
    };
    for i in 0..f2.n() {
        if (i as u32 % W) < 10 {
            edit(&mut f2, i);
        }
    }
    let mut rng = Rng::new(2);
    let (mut un, mut sn) = random(&mut rng, f1.n());
    let mut d = Denoiser::new(W, H);
    d.denoise(&f1.guide(), &mut un, &mut sn, &temporal_only());
    let (b_un, b_sn) = random(&mut rng, f1.n());
    let (mut un, mut sn) = (b_un.clone(), b_sn.clone());
    d.denoise(&f2.guide(), &mut un, &mut sn, &temporal_only());
    let _ = sn;
    (un, b_un, d.history_len())
}

fn assert_reset_left_only(out: &[Vec3], input: &[Vec3], len: &[f32]) {
    for i in 0..out.len() {
        if (i as u32 % W) < 10 {
            assert_eq!(
                out[i], input[i],
                "pixel {i}: history should have been dropped"
            );
            assert_eq!(len[i], 1.0);
        } else {
            assert_ne!(out[i], input[i], "pixel {i}: history should have been kept");
            assert_eq!(len[i], 2.0);
        }
    }
}

#[test]
fn occluder_in_front_drops_history() {
    // Something now stands in front of the plane at x < 10.
    let (out, input, len) = two_frames(|f, i| {
        f.pos[i] *= 0.5;
        f.depth[i] *= 0.5;
    });
    assert_reset_left_only(&out, &input, &len);
}

#[test]
fn depth_mismatch_alone_drops_history() {
    // Only the depth disagrees (positions kept): the depth test must catch it.
    let (out, input, len) = two_frames(|f, i| f.depth[i] *= 1.5);
    assert_reset_left_only(&out, &input, &len);
}

#[test]
fn normal_mismatch_alone_drops_history() {
    // Same point, turned 60 degrees: a different surface.
    let (out, input, len) = two_frames(|f, i| f.normal[i] = Vec3::new(0.866, 0.0, 0.5));
    assert_reset_left_only(&out, &input, &len);
}

#[test]
fn big_change_of_u_drops_history() {
    // A light moved: U doubled at x < 10, geometry unchanged.
    let (out, input, len) = two_frames(|f, i| f.u[i] *= 2.0);
    assert_reset_left_only(&out, &input, &len);
}

#[test]
fn small_change_of_u_keeps_history() {
    // 5 % is shading drift, not a light change.
    let (_, _, len) = two_frames(|f, i| f.u[i] *= 1.05);
    assert!(len.iter().all(|&l| l == 2.0));
}

#[test]
fn invalid_reprojection_drops_history() {
    let (out, input, len) = two_frames(|f, i| f.prev_valid[i] = false);
    assert_reset_left_only(&out, &input, &len);
}

/// A plane whose `U` is `u` everywhere, a `share` of it in the specular lobe.
fn glossy_plane(u: f32, share: f32) -> Frame {
    let mut f = Frame::plane(W, H);
    f.u = vec![Vec3::splat(u); f.n()];
    f.lobe = vec![Lobe::new(Vec3::Z, Vec3::Z, 0.3, share); f.n()];
    f
}

/// Sets pixel i's `U` to a diffuse part `d` plus a specular part `s`.
fn set_u(f: &mut Frame, i: usize, d: f32, s: f32) {
    f.u[i] = Vec3::splat(d + s);
    f.lobe[i] = Lobe::new(Vec3::Z, Vec3::Z, 0.3, s / (d + s));
}

#[test]
fn a_glossy_highlight_sliding_under_a_camera_move_keeps_history() {
    // U = 0.4 diffuse + 0.6 specular; the camera moved and the specular part
    // doubled (U up 60 %), the diffuse part (the light's witness) did not.
    let (_, _, len) = two_frames_from(glossy_plane(1.0, 0.6), |f, i| set_u(f, i, 0.4, 1.2));
    assert!(len.iter().all(|&l| l == 2.0));
}

#[test]
fn a_light_change_on_a_glossy_surface_drops_history() {
    // The light doubled: both parts of U doubled.
    let (out, input, len) = two_frames_from(glossy_plane(1.0, 0.6), |f, i| set_u(f, i, 0.8, 1.2));
    assert_reset_left_only(&out, &input, &len);
}

#[test]
fn on_a_near_mirror_the_whole_u_is_judged() {
    // 1 % diffuse is too small a witness: a 50 % change of U drops the
    // history even though the diffuse part stayed.
    let (out, input, len) =
        two_frames_from(glossy_plane(1.0, 0.99), |f, i| set_u(f, i, 0.01, 1.49));
    assert_reset_left_only(&out, &input, &len);
}
