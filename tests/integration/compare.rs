//! `penumbra compare` and `penumbra::compare`: the figures on images whose
//! answer is known, the exit status as a gate, and clear refusals.
use glam::Vec3;
use penumbra::compare::{self, CompareError, Image, Limits};
use penumbra::output::write_exr;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

const W: u32 = 24;
const H: u32 = 16;

/// A smooth linear test image with values from 0 to about 1.2.
fn gradient() -> Vec<Vec3> {
    (0..W * H)
        .map(|k| {
            let (x, y) = ((k % W) as f32 / W as f32, (k / W) as f32 / H as f32);
            Vec3::new(x, y, 1.2 * x * y)
        })
        .collect()
}

fn exr(dir: &Path, name: &str, w: u32, h: u32, px: &[Vec3]) -> PathBuf {
    let p = dir.join(name);
    write_exr(&p, w, h, px).unwrap();
    p
}

fn penumbra(args: &[&Path]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_penumbra"))
        .arg("compare")
        .args(args)
        .output()
        .unwrap()
}

fn flag(s: &str) -> &Path {
    Path::new(s)
}

#[test]
fn identical_images_give_zero_on_every_figure() {
    let a = Image::linear(W, H, gradient(), "a");
    let c = compare::compare(&a, &a.clone()).unwrap();
    assert_eq!(c.rel_mse, 0.0);
    assert_eq!(c.mean_flip, 0.0);
    assert_eq!(c.max_abs, 0.0);
}

#[test]
fn one_perturbed_channel_gives_its_relmse_and_is_the_worst_pixel() {
    let reference = gradient();
    let (x, y, d) = (7u32, 5u32, 0.25f32);
    let k = (y * W + x) as usize;
    let mut test = reference.clone();
    test[k].y += d;
    let r = f64::from(reference[k].y);
    // One channel of W * H * 3 differs by d; the others add exactly 0.
    let expected = f64::from(d) * f64::from(d) / (r * r + 1e-2) / f64::from(W * H * 3);
    let c = compare::compare(
        &Image::linear(W, H, test.clone(), "test"),
        &Image::linear(W, H, reference.clone(), "ref"),
    )
    .unwrap();
    // The sum is over f32 values widened to f64: the only rounding is d's
    // own (f32 addition and subtraction around reference[k].y).
    const RELATIVE_TOLERANCE: f64 = 1e-6;
    assert!(
        (c.rel_mse - expected).abs() <= RELATIVE_TOLERANCE * expected,
        "{} against {expected}",
        c.rel_mse
    );
    assert!((c.max_abs - d).abs() < 1e-6, "{}", c.max_abs);
    assert_eq!((c.worst.x, c.worst.y), (x, y));
    assert_eq!(c.worst.test, test[k]);
    assert_eq!(c.worst.reference, reference[k]);
    assert!(c.mean_flip > 0.0, "a visible change has FLIP 0");
}

#[test]
fn relmse_weighs_an_error_against_the_reference_not_the_test_image() {
    let dark = vec![Vec3::splat(0.1); 4];
    let bright = vec![Vec3::splat(1.0); 4];
    let im = |p: &Vec<Vec3>| Image::linear(2, 2, p.clone(), "x");
    let on_dark = compare::compare(&im(&bright), &im(&dark)).unwrap().rel_mse;
    let on_bright = compare::compare(&im(&dark), &im(&bright)).unwrap().rel_mse;
    assert!((on_dark - 0.81 / 0.02).abs() < 1e-4, "{on_dark}");
    assert!((on_bright - 0.81 / 1.01).abs() < 1e-6, "{on_bright}");
}

#[test]
fn limits_pass_at_the_value_and_fail_above_it() {
    let a = Image::linear(W, H, gradient(), "a");
    let mut px = gradient();
    px[3] += Vec3::splat(0.5);
    let c = compare::compare(&Image::linear(W, H, px, "b"), &a).unwrap();
    let at = Limits {
        max_rel_mse: Some(c.rel_mse),
        max_flip: Some(c.mean_flip),
    };
    assert!(at.exceeded(&c).is_empty());
    let below = Limits {
        max_rel_mse: Some(c.rel_mse * 0.99),
        max_flip: None,
    };
    assert_eq!(below.exceeded(&c).len(), 1);
    let flip_below = Limits {
        max_rel_mse: None,
        max_flip: Some(c.mean_flip * 0.99),
    };
    assert!(flip_below.exceeded(&c)[0].contains("FLIP"));
}

#[test]
fn cli_exit_status_is_0_within_the_limits_1_above_them() {
    let dir = tempfile::tempdir().unwrap();
    let reference = exr(dir.path(), "ref.exr", W, H, &gradient());
    let mut px = gradient();
    px[40] += Vec3::new(0.3, 0.0, 0.0);
    let test = exr(dir.path(), "test.exr", W, H, &px);
    let expected = compare::compare(
        &Image::load(&test).unwrap(),
        &Image::load(&reference).unwrap(),
    )
    .unwrap();

    let plain = penumbra(&[&test, &reference]);
    let out = String::from_utf8_lossy(&plain.stdout);
    assert_eq!(plain.status.code(), Some(0), "{out}");
    assert!(
        out.contains(&format!("relMSE     {:.6e}", expected.rel_mse)),
        "{out}"
    );
    assert!(out.contains("pixel (16, 1)"), "{out}");

    let above = format!("{:e}", expected.rel_mse * 0.5);
    let gated = penumbra(&[&test, &reference, flag("--max-relmse"), flag(&above)]);
    assert_eq!(gated.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&gated.stderr).contains("relMSE"));

    let loose = format!("{:e}", expected.rel_mse * 2.0);
    let passed = penumbra(&[&test, &reference, flag("--max-relmse"), flag(&loose)]);
    assert_eq!(passed.status.code(), Some(0));

    let flip = penumbra(&[&test, &reference, flag("--max-flip"), flag("0")]);
    assert_eq!(flip.status.code(), Some(1));
    let same = penumbra(&[&reference, &reference, flag("--max-flip"), flag("0")]);
    assert_eq!(same.status.code(), Some(0));
}

#[test]
fn heatmap_is_a_png_of_the_images_size_brightest_where_they_differ() {
    let dir = tempfile::tempdir().unwrap();
    let reference = exr(dir.path(), "ref.exr", W, H, &gradient());
    let mut px = gradient();
    let k = (8 * W + 12) as usize;
    px[k] = Vec3::splat(1.0);
    let test = exr(dir.path(), "test.exr", W, H, &px);
    let map = dir.path().join("map.png");
    let run = penumbra(&[&test, &reference, flag("--heatmap"), &map]);
    assert_eq!(run.status.code(), Some(0));
    let img = image::open(&map).unwrap().into_rgb8();
    assert_eq!(img.dimensions(), (W, H));
    let sum = |x: u32, y: u32| {
        img.get_pixel(x, y)
            .0
            .iter()
            .map(|&v| u32::from(v))
            .sum::<u32>()
    };
    assert!(sum(12, 8) > sum(0, 0), "{} vs {}", sum(12, 8), sum(0, 0));
}

#[test]
fn images_of_different_sizes_are_refused_naming_both() {
    let dir = tempfile::tempdir().unwrap();
    let a = exr(dir.path(), "a.exr", W, H, &gradient());
    let b = exr(dir.path(), "b.exr", 2, 2, &[Vec3::ONE; 4]);
    let e = compare::compare(&Image::load(&a).unwrap(), &Image::load(&b).unwrap()).unwrap_err();
    assert!(matches!(e, CompareError::Size { .. }), "{e}");
    let run = penumbra(&[&a, &b]);
    let err = String::from_utf8_lossy(&run.stderr);
    assert_eq!(run.status.code(), Some(2), "{err}");
    for needle in ["a.exr", "24x16", "b.exr", "2x2"] {
        assert!(err.contains(needle), "lacks {needle}: {err}");
    }
    assert!(!err.contains("panicked"), "{err}");
}

#[test]
fn unreadable_or_unknown_files_are_refused_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let good = exr(dir.path(), "good.exr", W, H, &gradient());
    let missing = dir.path().join("missing.exr");
    let garbage = dir.path().join("garbage.exr");
    std::fs::write(&garbage, b"not an image").unwrap();
    let text = dir.path().join("notes.txt");
    std::fs::write(&text, b"hello").unwrap();
    for (bad, needle) in [
        (&missing, "missing.exr"),
        (&garbage, "garbage.exr"),
        (&text, "not a .png or .exr"),
    ] {
        for args in [[bad, &good], [&good, bad]] {
            let run = penumbra(&[args[0], args[1]]);
            let err = String::from_utf8_lossy(&run.stderr);
            assert_eq!(run.status.code(), Some(2), "{err}");
            assert!(err.contains(needle), "lacks {needle}: {err}");
            assert_eq!(err.trim_end().lines().count(), 1, "not one message: {err}");
            assert!(!err.contains("panicked"), "{err}");
        }
    }
}

#[test]
fn an_exr_and_a_png_are_not_compared() {
    let dir = tempfile::tempdir().unwrap();
    let a = exr(dir.path(), "a.exr", W, H, &gradient());
    let b = dir.path().join("b.png");
    penumbra::output::write_png(&b, W, H, &gradient(), 0.0).unwrap();
    let run = penumbra(&[&a, &b]);
    let err = String::from_utf8_lossy(&run.stderr);
    assert_eq!(run.status.code(), Some(2), "{err}");
    assert!(err.contains("EXR") && err.contains("PNG"), "{err}");
}

#[test]
fn png_images_compare_as_their_stored_values() {
    let dir = tempfile::tempdir().unwrap();
    let (a, b) = (dir.path().join("a.png"), dir.path().join("b.png"));
    let grey = |v: u8| image::RgbImage::from_pixel(4, 4, image::Rgb([v, v, v]));
    grey(128).save(&a).unwrap();
    grey(64).save(&b).unwrap();
    let c = compare::compare(&Image::load(&a).unwrap(), &Image::load(&b).unwrap()).unwrap();
    let (x, r) = (128.0 / 255.0, 64.0 / 255.0);
    let expected = (x - r) * (x - r) / (r * r + 1e-2);
    assert!(
        (c.rel_mse - expected).abs() < 1e-6 * expected,
        "{}",
        c.rel_mse
    );
    assert!(c.mean_flip > 0.0);
}

#[test]
fn a_non_finite_pixel_is_refused_with_its_position() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("nan.exr");
    // write_exr never writes a NaN; the image crate does.
    let mut data = vec![0.5f32; (W * H * 3) as usize];
    data[(3 * W as usize + 5) * 3 + 1] = f32::NAN;
    image::Rgb32FImage::from_raw(W, H, data)
        .unwrap()
        .save_with_format(&p, image::ImageFormat::OpenExr)
        .unwrap();
    let e = Image::load(&p).unwrap_err().to_string();
    assert!(e.contains("nan.exr") && e.contains("(5, 3)"), "{e}");
}

#[test]
fn bad_limits_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let a = exr(dir.path(), "a.exr", W, H, &gradient());
    for v in ["-1", "NaN", "inf"] {
        let run = penumbra(&[&a, &a, flag("--max-relmse"), flag(v)]);
        assert_eq!(run.status.code(), Some(2), "{v}");
    }
}

/// A flat grey reference: every interior pixel lit and smooth.
fn flat(v: f32) -> Vec<Vec3> {
    vec![Vec3::splat(v); (W * H) as usize]
}

#[test]
fn an_isolated_pixel_off_by_more_than_twice_is_a_speckle_either_way() {
    let reference = flat(0.5);
    let mut test = reference.clone();
    // Just inside the factor: no speckle.
    test[(5 * W + 5) as usize] = Vec3::splat(0.5 * compare::SPECKLE_FACTOR * 0.99);
    test[(5 * W + 9) as usize] = Vec3::splat(0.5 / compare::SPECKLE_FACTOR * 1.01);
    // Beyond it, one bright and one dark.
    test[(9 * W + 5) as usize] = Vec3::splat(0.5 * compare::SPECKLE_FACTOR * 1.01);
    test[(9 * W + 9) as usize] = Vec3::splat(0.5 / compare::SPECKLE_FACTOR * 0.99);
    let c = compare::compare(
        &Image::linear(W, H, test, "test"),
        &Image::linear(W, H, reference, "reference"),
    )
    .unwrap();
    assert_eq!((c.speckles.dark, c.speckles.bright), (1, 1));
    // Every pixel but the frame's border is smooth in the reference.
    assert_eq!(c.speckles.lit, ((W - 2) * (H - 2)) as usize);
    assert_eq!(c.speckles.fraction(), 2.0 / c.speckles.lit as f64);
}

#[test]
fn speckles_are_not_counted_on_geometric_edges_or_dark_reference_pixels() {
    let mut reference = flat(0.5);
    // A dark reference pixel: a 0 in the test there is no speckle.
    reference[(4 * W + 4) as usize] = Vec3::splat(compare::SPECKLE_LIT * 0.5);
    let mut test = reference.clone();
    test[(4 * W + 4) as usize] = Vec3::ZERO;
    // A pixel on a depth step, off by 4x.
    let (ex, ey) = (12u32, 8u32);
    test[(ey * W + ex) as usize] = Vec3::splat(2.0);
    let depth: Vec<Vec3> = (0..W * H)
        .map(|k| Vec3::splat(if k % W > ex { 3.0 } else { 1.0 }))
        .collect();
    let depth = Image::linear(W, H, depth, "depth");
    let reference = Image::linear(W, H, reference, "reference");
    let mask = compare::away_from_depth_edges(&depth, &reference).unwrap();
    assert!(!mask[(ey * W + ex) as usize] && !mask[(ey * W + ex + 1) as usize]);
    let s = compare::speckles(W, &test, &reference.pixels, Some(&mask));
    assert_eq!((s.dark, s.bright), (0, 0));
    // Without the depth edge the same pixel counts.
    let all = vec![true; (W * H) as usize];
    let s = compare::speckles(W, &test, &reference.pixels, Some(&all));
    assert_eq!((s.dark, s.bright), (0, 1));
}

#[test]
fn the_cli_prints_the_speckle_count_against_the_depth_edges() {
    let dir = std::env::temp_dir().join(format!("penumbra-speckle-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let reference = flat(0.5);
    let mut test = reference.clone();
    test[(6 * W + 6) as usize] = Vec3::splat(0.1);
    let t = exr(&dir, "t.exr", W, H, &test);
    let r = exr(&dir, "r.exr", W, H, &reference);
    let d = exr(&dir, "d.exr", W, H, &flat(1.0));
    let out = penumbra(&[&t, &r, flag("--depth"), &d]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{text}");
    assert!(
        text.contains("(1 dark, 0 bright"),
        "speckle line missing or wrong: {text}"
    );
    std::fs::remove_dir_all(&dir).ok();
}
