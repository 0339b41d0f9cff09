//! How many lights a many-light scene really needs per pixel, and how close
//! the culling bounds come to what they bound: with every light's `U` known
//! at every pixel (tolerance 0), the lights that hold 99 % and 95 % of each
//! pixel's `U`, the lights whose GGX lobe the shipped culling's GGX budget
//! (0.8 of `LIGHT_TOLERANCE` of `U`) cannot leave out, and the bound over
//! the computed value per (4-pixel run,
//! light). docs/frame-design.md (*Many lights*) quotes its figures.
//!
//! `cargo run --release --example light_oracle -- scenes/hall.toml 640 360`

use penumbra::color::luminance;
use penumbra::embree::Device;
use penumbra::render::estimate::surface_point;
use penumbra::render::{Frame, LIGHT_TOLERANCE, Mode, PixelKind, RenderSettings, World};
use penumbra::scene::Scene;
use penumbra::shading::SurfacePoint;
use penumbra::shading::light_bound::PointGroup;
use penumbra::shading::u_batch::{LANES, LaneLobes, PixelBatch, lobes_batch};

/// The share of `U` the shipped culling lets left-out GGX lobes take.
const GGX_BUDGET: f32 = 0.8 * LIGHT_TOLERANCE;

/// The lights, largest first, whose values sum to `share` of the total.
fn needed(values: &mut [f32], share: f32) -> usize {
    values.sort_by(|a, b| b.total_cmp(a));
    let total: f32 = values.iter().sum();
    let mut acc = 0.0;
    for (j, v) in values.iter().enumerate() {
        acc += v;
        if acc >= share * total {
            return j + 1;
        }
    }
    values.len()
}

fn quantiles(v: &mut [f32]) -> String {
    v.sort_by(|a, b| a.total_cmp(b));
    let q = |p: f64| v[((v.len() - 1) as f64 * p) as usize];
    format!(
        "p10 {:.2}, median {:.2}, p90 {:.2}, p99 {:.2}",
        q(0.1),
        q(0.5),
        q(0.9),
        q(0.99)
    )
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let path = args.get(1).map_or("scenes/hall.toml", String::as_str);
    let width: u32 = args.get(2).and_then(|a| a.parse().ok()).unwrap_or(640);
    let height: u32 = args.get(3).and_then(|a| a.parse().ok()).unwrap_or(360);
    let scene = Scene::load(std::path::Path::new(path)).unwrap_or_else(|e| panic!("{e}"));
    let camera = scene.camera;
    let device = Device::new().expect("Embree starts");
    let world = World::build(&device, scene).expect("scene builds");
    let mut frame = Frame::new(width, height);
    let settings = RenderSettings {
        mode: Mode::Unshadowed,
        light_tolerance: 0.0,
        ..RenderSettings::default()
    };
    frame.render(&world, &camera, &settings);
    let n = world.lights.len();
    let (mut n99, mut n95, mut spec_needed, mut pixels) = (0, 0, 0, 0);
    let (mut spec_sum, mut u_sum) = (0.0f64, 0.0f64);
    let (mut over_d, mut over_s) = (Vec::new(), Vec::new());
    let mut lobes = LaneLobes::default();
    for run in frame.gbuf.chunks(LANES) {
        let lane: [Option<SurfacePoint>; LANES] = std::array::from_fn(|l| {
            run.get(l)
                .filter(|g| g.kind == PixelKind::Surface)
                .map(surface_point)
        });
        let points: Vec<SurfacePoint> = lane.iter().flatten().copied().collect();
        let Some(group) = PointGroup::new(&points) else {
            continue;
        };
        let batch = PixelBatch::new(&lane);
        // (Lambert, GGX) luminance per light and lane.
        let mut values = vec![[(0.0f32, 0.0f32); LANES]; n];
        for (i, light) in world.lights.batch().iter().enumerate() {
            lobes_batch(&batch, light, &mut lobes);
            let bound = group.bound(&world.lights.extents()[i]);
            let (mut most_d, mut most_s) = (0.0f32, 0.0f32);
            for (l, v) in values[i].iter_mut().enumerate() {
                if lane[l].is_some() {
                    let (d, s) = lobes.lane(l);
                    *v = (luminance(d), luminance(s));
                    most_d = most_d.max(v.0);
                    most_s = most_s.max(v.1);
                }
            }
            if bound.diffuse.is_finite() && most_d > 1e-7 {
                over_d.push(bound.diffuse / most_d);
            }
            if bound.specular.is_finite() && most_s > 1e-7 {
                over_s.push(bound.specular / most_s);
            }
        }
        for (l, sp) in lane.iter().enumerate() {
            if sp.is_none() {
                continue;
            }
            let mut total: Vec<f32> = values.iter().map(|v| v[l].0 + v[l].1).collect();
            let u: f32 = total.iter().sum();
            if u <= 0.0 {
                continue;
            }
            let mut spec: Vec<f32> = values.iter().map(|v| v[l].1).collect();
            let s: f32 = spec.iter().sum();
            spec_sum += f64::from(s);
            u_sum += f64::from(u);
            n99 += needed(&mut total.clone(), 0.99);
            n95 += needed(&mut total, 0.95);
            // Lobes left out smallest first while they stay within the budget.
            spec.sort_by(|a, b| a.total_cmp(b));
            let mut left = 0.0;
            let droppable = spec
                .iter()
                .take_while(|&&x| {
                    left += x;
                    left <= GGX_BUDGET * u
                })
                .count();
            spec_needed += n - droppable;
            pixels += 1;
        }
    }
    let per = |x: usize| x as f64 / pixels.max(1) as f64;
    println!("{path} at {width}x{height}, {n} lights, {pixels} lit surface pixels");
    println!(
        "lights per pixel holding 99 % of U: {:.2}; 95 %: {:.2}",
        per(n99),
        per(n95)
    );
    println!(
        "lights per pixel whose GGX lobe a budget of {:.1} % of U cannot leave out: {:.2}",
        GGX_BUDGET * 100.0,
        per(spec_needed)
    );
    println!("GGX share of U: {:.3}", spec_sum / u_sum.max(1e-30));
    println!("bound / computed, Lambert: {}", quantiles(&mut over_d));
    println!("bound / computed, GGX: {}", quantiles(&mut over_s));
}
