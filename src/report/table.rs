//! The text form of a benchmark report.

use super::results::{BenchReport, SceneReport};
use std::fmt::Write;

pub fn format_report(r: &BenchReport) -> String {
    let mut out = String::new();
    let m = &r.machine;
    let _ = writeln!(
        out,
        "penumbra {} ({}) on {} cores, {} ({}); {}x{}, {} threads, median of {} frames after {} warm-up",
        r.penumbra_version,
        short(&r.git_revision),
        m.cores,
        m.cpu_model,
        m.isa,
        r.settings.width,
        r.settings.height,
        r.settings.threads,
        r.settings.measured_frames,
        r.settings.warmup_frames
    );
    let _ = writeln!(out, "error: {}", r.settings.error_method);
    for s in &r.scenes {
        scene(&mut out, s);
    }
    out
}

fn short(rev: &str) -> &str {
    &rev[..rev.len().min(10)]
}

fn scene(out: &mut String, s: &SceneReport) {
    let rf = &s.reference;
    let _ = writeln!(
        out,
        "\nscene {}: {} triangles, {} lights; reference {} spp ({} {})",
        s.scene,
        s.triangles,
        s.lights,
        rf.spp,
        if rf.reused {
            "cached".to_string()
        } else {
            format!("rendered in {:.0} s, stored", rf.render_seconds)
        },
        rf.cache_file
    );
    let _ = writeln!(
        out,
        "{:<14} {:>3} {:>8} {:>17} {:>6} {:>7} {:>7} {:>7} {:>7} {:>7} {:>7} {:>7} {:>8} {:>10} {:>10} {:>10}",
        "config",
        "spp",
        "ms",
        "(min-max)",
        "fps",
        "primary",
        "U",
        "shadow",
        "denoise",
        "compose",
        "resolve",
        "Mrays/s",
        "/ceiling",
        "relMSE",
        "interior",
        "1st frame"
    );
    for c in &s.configs {
        let st = &c.stages_ms;
        let _ = writeln!(
            out,
            "{:<14} {:>3} {:>8.1} {:>17} {:>6.2} {:>7.1} {:>7.1} {:>7.1} {:>7.1} {:>7.1} {:>7.1} {:>7.2} {:>8.2} {:>10.3e} {:>10.3e} {:>10}",
            c.label,
            c.spp,
            c.frame_ms.median,
            format!("({:.1}-{:.1})", c.frame_ms.min, c.frame_ms.max),
            c.fps,
            st.primary,
            st.u,
            st.shadow,
            st.denoise,
            st.composite,
            st.resolve,
            c.mrays_per_s,
            c.over_ceiling,
            c.rel_mse,
            c.rel_mse_interior,
            c.rel_mse_first_frame
                .map_or("-".to_string(), |e| format!("{e:.3e}"))
        );
    }
    stage_split(out, s);
    for c in &s.ceilings {
        let _ = writeln!(
            out,
            "ceiling, {} thread(s), {} spp: {:.1} ms (primary {:.1}, shadow {:.1}): Embree alone, {} camera + {} shadow rays, 16-wide packets",
            c.threads,
            c.spp,
            c.total_ms.median,
            c.primary_ms,
            c.shadow_ms,
            c.camera_rays,
            c.shadow_rays
        );
    }
    let sc = &s.scaling;
    let threads: Vec<String> = sc
        .threads
        .iter()
        .map(|t| format!("{} thread(s) {:.1} ms", t.threads, t.frame_ms.median))
        .collect();
    let _ = writeln!(
        out,
        "threads ({}): {}: speed-up {:.2}x (Embree alone {:.2}x)",
        sc.config,
        threads.join(", "),
        sc.thread_speedup,
        sc.ceiling_speedup
    );
    let res: Vec<String> = sc
        .resolution
        .iter()
        .map(|p| format!("{}x{} {:.0} ns/pixel", p.width, p.height, p.ns_per_pixel))
        .collect();
    let _ = writeln!(
        out,
        "cost per pixel ({}): {}: smaller/larger {:.2}",
        sc.config,
        res.join(", "),
        sc.per_pixel_ratio
    );
    if s.equal_time.is_empty() {
        let _ = writeln!(
            out,
            "equal time: the denoised ratio and stochastic curves do not overlap in ms per frame"
        );
    }
    for e in &s.equal_time {
        let _ = writeln!(
            out,
            "equal time at {:.1} ms ({}): relMSE ratio+dn {:.3e}, stochastic+dn {:.3e} ({:.2}x)",
            e.ms, e.anchor, e.ratio_rel_mse, e.stochastic_rel_mse, e.stochastic_over_ratio
        );
    }
}

/// Each stage's cost in ns per pixel (thread time over the thread count;
/// the denoiser, upsampling and resolve are wall time), beside what Embree
/// alone takes for the same rays: its camera rays, and the ceiling's shadow
/// rays scaled to the number this configuration traced.
fn stage_split(out: &mut String, s: &SceneReport) {
    let Some(ceiling) = s
        .ceilings
        .iter()
        .find(|c| c.spp == 1)
        .or(s.ceilings.first())
    else {
        return;
    };
    let pixels = ceiling.camera_rays.max(1) as f64;
    let ns = |ms: f64| ms * 1e6 / pixels;
    let _ = writeln!(
        out,
        "\nstage split, ns per pixel ({:.0} pixels); lights: U's lights per surface pixel, both lobes + Lambert only; Embree alone: camera rays {:.1}, shadow rays (as many as the row traced) in brackets",
        pixels,
        ns(ceiling.primary_ms)
    );
    let _ = writeln!(
        out,
        "{:<18} {:>7} {:>7} {:>9} {:>15} {:>7} {:>8} {:>7} {:>7} {:>7}",
        "config",
        "primary",
        "U",
        "lights",
        "shadow (Embree)",
        "denoise",
        "upsample",
        "compose",
        "resolve",
        "frame"
    );
    for c in &s.configs {
        let st = &c.stages_ms;
        let per_ray = if ceiling.shadow_rays > 0 {
            ceiling.shadow_ms / ceiling.shadow_rays as f64
        } else {
            0.0
        };
        let embree_shadow = ns(per_ray * c.shadow_rays as f64);
        let _ = writeln!(
            out,
            "{:<18} {:>7.1} {:>7.1} {:>9} {:>15} {:>7.1} {:>8.1} {:>7.1} {:>7.1} {:>7.1}",
            format!("{} {}spp", c.label, c.spp),
            ns(st.primary),
            ns(st.u),
            format!("{:.1}+{:.1}", c.u_lights[0], c.u_lights[1]),
            format!("{:.1} ({:.1})", ns(st.shadow), embree_shadow),
            ns(st.denoise),
            ns(st.upsample),
            ns(st.composite),
            ns(st.resolve),
            ns(c.frame_ms.median)
        );
    }
}
