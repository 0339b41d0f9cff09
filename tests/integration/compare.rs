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
