//! Whether pairs of linear EXR frames agree, for renders of one scene, mode
//! and seed by two builds (Embree 3 and Embree 4, `scripts/embree4-test.sh`):
//! `cargo run --release --example embree_agree -- A.exr B.exr [A2.exr B2.exr ...]`
//!
//! Per pair it prints relMSE (DESIGN.md's formula, B as the reference), the
//! fraction of pixels whose value differs and the largest relative
//! difference, and exits 1 when any pair exceeds the bounds or holds a
//! non-finite value. `--max-relmse X` and `--max-differing F` override the
//! bounds; `--expect-disagree` inverts the verdict (the caller checks that
//! the check can fail, on renders with different seeds).

use anyhow::{Context, Result, bail};
use glam::Vec3;
use penumbra::report::stats::rel_mse;
use std::path::Path;
use std::process::ExitCode;

/// Bound on relMSE between the two builds' frames. Same seeds give the same
/// rays, so only hits that two BVHs resolve differently (rays grazing a
/// shared edge or a silhouette) may differ. At 160x90 one pixel changed
/// entirely adds 1/14400 = 6.9e-5, so this admits about one; the builds
/// measured 0 on every pair, two seeds of one build 1.4e-4 and more
/// (docs/embree.md).
const MAX_RELMSE: f64 = 1e-4;
/// Bound on the fraction of pixels that differ at all (see `DIFFERS`):
/// 72 pixels at 160x90, room for a few flipped hits and the denoiser's
/// spreading of them; two seeds of one build differ in 2 % and more
/// (docs/embree.md).
const MAX_DIFFERING: f64 = 0.005;
/// A pixel differs when a channel's difference exceeds this share of the
/// pixel's magnitude (plus the 0.1 floor of relMSE's denominator): above the
/// rounding of f32 sums taken in a different order, far below a changed sample.
const DIFFERS: f32 = 1e-4;

struct Agreement {
    rel_mse: f64,
    differing: f64,
    max_rel: f32,
}

fn load(path: &Path) -> Result<(u32, u32, Vec<Vec3>)> {
    let img = image::open(path)
        .with_context(|| format!("{}: cannot read the image", path.display()))?
        .into_rgb32f();
    let (w, h) = img.dimensions();
    let px = img.pixels().map(|p| Vec3::from_array(p.0)).collect();
    Ok((w, h, px))
}

fn compare(a: &Path, b: &Path) -> Result<Agreement> {
    let (wa, ha, pa) = load(a)?;
    let (wb, hb, pb) = load(b)?;
    if (wa, ha) != (wb, hb) {
        bail!(
            "{} is {wa}x{ha} but {} is {wb}x{hb}",
            a.display(),
            b.display()
        );
    }
    for (path, px) in [(a, &pa), (b, &pb)] {
        if let Some(k) = px.iter().position(|p| !p.is_finite()) {
            bail!(
                "{}: pixel ({}, {}) is not finite",
                path.display(),
                k as u32 % wa,
                k as u32 / wa
            );
        }
    }
    let mut differing = 0usize;
    let mut max_rel = 0.0f32;
    for (x, r) in pa.iter().zip(&pb) {
        let scale = x.abs().max(r.abs()) + Vec3::splat(0.1);
        let rel = ((*x - *r).abs() / scale).max_element();
        max_rel = max_rel.max(rel);
        if rel > DIFFERS {
            differing += 1;
        }
    }
    Ok(Agreement {
        rel_mse: rel_mse(&pa, &pb),
        differing: differing as f64 / pa.len().max(1) as f64,
        max_rel,
    })
}

fn main() -> ExitCode {
    match run() {
        Ok(true) => ExitCode::SUCCESS,
        Ok(false) => ExitCode::FAILURE,
        Err(e) => {
            eprintln!("embree_agree: {e:#}");
            ExitCode::from(2)
        }
    }
}

fn run() -> Result<bool> {
    let mut max_relmse = MAX_RELMSE;
    let mut max_differing = MAX_DIFFERING;
    let mut expect_disagree = false;
    let mut files = Vec::new();
    let mut args = std::env::args().skip(1);
    while let Some(arg) = args.next() {
        let mut value = |name: &str| -> Result<f64> {
            let v = args
                .next()
                .with_context(|| format!("{name} needs a value"))?;
            v.parse()
                .with_context(|| format!("{name} {v}: not a number"))
        };
        match arg.as_str() {
            "--max-relmse" => max_relmse = value("--max-relmse")?,
            "--max-differing" => max_differing = value("--max-differing")?,
            "--expect-disagree" => expect_disagree = true,
            _ => files.push(arg),
        }
    }
    if files.is_empty() || files.len() % 2 != 0 {
        bail!(
            "usage: embree_agree [--max-relmse X] [--max-differing F] [--expect-disagree] A.exr B.exr [A2.exr B2.exr ...]"
        );
    }
    let mut agreeing = 0usize;
    for pair in files.chunks(2) {
        let (a, b) = (Path::new(&pair[0]), Path::new(&pair[1]));
        let g = compare(a, b)?;
        let agree = g.rel_mse <= max_relmse && g.differing <= max_differing;
        agreeing += usize::from(agree);
        println!(
            "{} {} vs {}: relMSE {:.3e} (max {max_relmse:.0e}), differing pixels {:.4} (max {max_differing}), largest relative difference {:.3e}",
            if agree { "agree   " } else { "DISAGREE" },
            a.display(),
            b.display(),
            g.rel_mse,
            g.differing,
            g.max_rel,
        );
    }
    let pairs = files.len() / 2;
    println!("embree_agree: {agreeing} of {pairs} pairs agree");
    Ok(if expect_disagree {
        agreeing == 0
    } else {
        agreeing == pairs
    })
}
