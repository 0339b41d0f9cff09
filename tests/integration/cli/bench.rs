//! `penumbra bench --quick --json`: the smoke run CI can afford, and the
//! reference cache behind every error figure.

use penumbra::embree::Device;
use penumbra::render::World;
use penumbra::report::reference::{cache_key, reference};
use penumbra::scene::Scene;
use serde_json::Value;
use std::path::Path;
use std::process::Command;

fn num(v: &Value, key: &str) -> f64 {
    let x = v[key]
        .as_f64()
        .unwrap_or_else(|| panic!("{key} is not a number in {v}"));
    assert!(x.is_finite(), "{key} = {x}");
    x
}

fn config<'a>(scene: &'a Value, label: &str, spp: u64) -> &'a Value {
    scene["configs"]
        .as_array()
        .unwrap()
        .iter()
        .find(|c| c["label"] == label && c["spp"] == spp)
        .unwrap_or_else(|| panic!("no {label} at {spp} spp"))
}

#[test]
fn quick_bench_writes_json_whose_figures_are_complete_and_sane() {
    let dir = tempfile::tempdir().unwrap();
    let json = dir.path().join("bench.json");
    let out = Command::new(env!("CARGO_BIN_EXE_penumbra"))
        .args(["bench", "--quick", "scenes/shadow-plane.toml", "--json"])
        .arg(&json)
        .arg("--cache")
        .arg(dir.path().join("cache"))
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let r: Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();

    assert_eq!(r["format"], 1);
    assert!(!r["git_revision"].as_str().unwrap().is_empty());
    assert!(num(&r["machine"], "cores") >= 1.0);
    assert!(!r["machine"]["cpu_model"].as_str().unwrap().is_empty());
    assert_eq!(r["settings"]["quick"], true);
    let (w, h) = (num(&r["settings"], "width"), num(&r["settings"], "height"));

    let s = &r["scenes"][0];
    assert_eq!(s["reference"]["reused"], false, "a fresh cache is empty");
    for c in s["configs"].as_array().unwrap() {
        let ms = &c["frame_ms"];
        let (lo, q1, mid, q3, hi) = (
            num(ms, "min"),
            num(ms, "q1"),
            num(ms, "median"),
            num(ms, "q3"),
            num(ms, "max"),
        );
        assert!(
            0.0 < lo && lo <= q1 && q1 <= mid && mid <= q3 && q3 <= hi,
            "{c}"
        );
        assert_eq!(num(c, "camera_rays"), w * h);
        assert!(num(c, "rel_mse") > 0.0 && num(c, "rel_mse_interior") > 0.0);
        assert!(num(c, "mrays_per_s") > 0.0);
        // At the full render scale the frame traces the ceiling's rays and
        // shades too: it cannot be faster. Below it (`50% res`) the frame
        // traces a fraction of the camera rays the ceiling counts, so the
        // ceiling bounds nothing there.
        if num(c, "render_scale") >= 1.0 {
            assert!(num(c, "over_ceiling") > 1.0, "{c}");
        }
        for stage in ["primary", "u", "shadow", "denoise", "composite"] {
            assert!(num(&c["stages_ms"], stage) >= 0.0);
        }
    }
    assert_eq!(num(config(s, "unshadowed", 0), "shadow_rays"), 0.0);
    for mode in ["ratio", "stochastic"] {
        let (one, four) = (config(s, mode, 1), config(s, mode, 4));
        assert!(
            num(four, "rel_mse") < num(one, "rel_mse"),
            "{mode}: more samples, less error"
        );
        assert!(num(four, "shadow_rays") > num(one, "shadow_rays"));
        let dn = config(s, &format!("{mode}+dn"), 1);
        assert!(num(dn, "rel_mse_first_frame") > 0.0);
    }

    let sc = &s["scaling"];
    assert_eq!(sc["threads"][0]["threads"], 1);
    assert!(num(sc, "thread_speedup") > 0.0 && num(sc, "per_pixel_ratio") > 0.0);
    assert_eq!(sc["resolution"].as_array().unwrap().len(), 2);
    // The equal-time curve of denoised `ratio` is its rows after one
    // warm-up frame (the long still-camera rows have a longer history):
    // an interpolated error lies within theirs.
    let curve: Vec<f64> = s["configs"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|c| c["mode"] == "ratio" && c["denoise"] == true)
        .filter(|c| c["visibility"] == "full" && num(c, "render_scale") == 1.0)
        .filter(|c| num(c, "warmup_frames") == 1.0)
        .map(|c| num(c, "rel_mse"))
        .collect();
    let (lo, hi) = curve
        .iter()
        .fold((f64::MAX, 0.0f64), |(lo, hi), &r| (lo.min(r), hi.max(r)));
    for e in s["equal_time"].as_array().unwrap() {
        assert!(num(e, "ratio_rel_mse") > 0.0 && num(e, "stochastic_rel_mse") > 0.0);
        let r = num(e, "ratio_rel_mse");
        assert!(lo <= r && r <= hi, "{e}: outside {lo}..{hi}");
    }
}

#[test]
fn a_saved_report_is_drawn_as_a_chart_or_refused_clearly_without_a_font() {
    let dir = tempfile::tempdir().unwrap();
    let json = dir.path().join("bench.json");
    let quick = Command::new(env!("CARGO_BIN_EXE_penumbra"))
        .args([
            "bench", "--quick", "--width", "64", "--height", "36", "--json",
        ])
        .arg(&json)
        .arg("--cache")
        .arg(dir.path().join("cache"))
        .output()
        .unwrap();
    assert!(quick.status.success());
    let png = dir.path().join("chart.png");
    let plot = Command::new(env!("CARGO_BIN_EXE_penumbra"))
        .args(["bench", "--from-json"])
        .arg(&json)
        .arg("--plot")
        .arg(&png)
        .output()
        .unwrap();
    let font = Path::new("/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf").is_file()
        || Path::new("/usr/share/fonts/dejavu/DejaVuSans.ttf").is_file();
    if font {
        assert!(
            plot.status.success(),
            "{}",
            String::from_utf8_lossy(&plot.stderr)
        );
        let img = image::open(&png).unwrap().to_rgb8();
        assert!(img.width() > 100 && img.height() > 100);
        assert!(
            img.pixels().any(|p| p.0 != [255, 255, 255]),
            "something is drawn"
        );
    } else {
        assert!(!plot.status.success());
        let err = String::from_utf8_lossy(&plot.stderr);
        assert!(err.contains("fonts-dejavu-core"), "{err}");
    }
}

#[test]
fn reference_is_rendered_once_then_read_back_from_the_cache() {
    let dir = tempfile::tempdir().unwrap();
    let path = Path::new("scenes/shadow-plane.toml");
    let device = Device::new().unwrap();
    let world = World::build(&device, Scene::load(path).unwrap()).unwrap();
    let first = reference(&world, Some(path), 32, 18, 4, dir.path(), None).unwrap();
    let again = reference(&world, Some(path), 32, 18, 4, dir.path(), None).unwrap();
    assert!(!first.reused && again.reused);
    assert_eq!(first.file, again.file);
    assert_eq!(first.color, again.color);
}

#[test]
fn reference_cache_key_follows_scene_bytes_referenced_files_size_and_spp() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("s.toml");
    let text = std::fs::read_to_string("scenes/room.toml").unwrap();
    std::fs::write(&scene, &text).unwrap();
    let src = Path::new("scenes");
    for sub in ["textures", "meshes"] {
        std::fs::create_dir_all(dir.path().join(sub)).unwrap();
        for f in std::fs::read_dir(src.join(sub)).unwrap() {
            let f = f.unwrap().path();
            std::fs::copy(&f, dir.path().join(sub).join(f.file_name().unwrap())).unwrap();
        }
    }
    let key = || cache_key(Some(&scene), 64, 36, 16).unwrap();
    let base = key();
    assert_eq!(base, key(), "same inputs, same key");
    assert_ne!(base, cache_key(Some(&scene), 64, 37, 16).unwrap());
    assert_ne!(base, cache_key(Some(&scene), 64, 36, 32).unwrap());

    let mesh = dir.path().join("meshes/pedestal.obj");
    let obj = std::fs::read_to_string(&mesh).unwrap();
    std::fs::write(&mesh, format!("{obj}\n# touched\n")).unwrap();
    assert_ne!(base, key(), "a referenced mesh changed");
    std::fs::write(&mesh, &obj).unwrap();
    assert_eq!(base, key());

    std::fs::write(&scene, format!("{text}\n# touched\n")).unwrap();
    assert_ne!(base, key(), "the scene file changed");
}
