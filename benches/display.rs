//! The display transform of one 1280x720 frame, one thread: the per-channel
//! formula (`display_rgb8`: an `exp` and a `powf` each) against its table
//! (`DisplayMap`, built for the frame as the window and PNG output do).
//! The frame's radiance spans 2^-12 to 2^6, as a lit room's does.

use criterion::{Criterion, criterion_group, criterion_main};
use glam::Vec3;
use penumbra::display::{DisplayMap, display_rgb8};
use std::hint::black_box;

const PIXELS: usize = 1280 * 720;

fn frame() -> Vec<Vec3> {
    let mut z = 0x2545_F491_4F6C_DD1Du64;
    let mut next = || {
        z ^= z << 13;
        z ^= z >> 7;
        z ^= z << 17;
        // 2^-12 .. 2^6, uniform in stops.
        ((z >> 40) as f32 / (1u64 << 24) as f32 * 18.0 - 12.0).exp2()
    };
    (0..PIXELS)
        .map(|_| Vec3::new(next(), next(), next()))
        .collect()
}

fn bench(c: &mut Criterion) {
    let color = frame();
    let mut out = vec![[0u8; 3]; PIXELS];
    let mut group = c.benchmark_group("display 1280x720");
    group.bench_function("formula", |b| {
        b.iter(|| {
            for (o, c) in out.iter_mut().zip(&color) {
                *o = display_rgb8(*c, 1.0);
            }
            black_box(&out);
        })
    });
    group.bench_function("table", |b| {
        b.iter(|| {
            let map = DisplayMap::new(black_box(1.0));
            for (o, c) in out.iter_mut().zip(&color) {
                *o = map.rgb8(*c);
            }
            black_box(&out);
        })
    });
    group.bench_function("table build", |b| {
        b.iter(|| black_box(DisplayMap::new(black_box(1.0))))
    });
    group.finish();
}

#[path = "support/quiet.rs"]
mod quiet;

criterion_group! {
    name = benches;
    config = quiet::criterion();
    targets = bench
}
criterion_main!(benches);
