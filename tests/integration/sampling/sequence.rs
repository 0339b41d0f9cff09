use glam::Vec2;
use penumbra::sampling::{Pcg32, hash_u32, sample_1d, sample_2d};

#[test]
fn values_lie_in_unit_interval() {
    for pixel in [0, 1, 77, 1_000_003, u32::MAX] {
        for i in (0..4096).chain([u32::MAX - 1, u32::MAX]) {
            for dim in 0..3 {
                let p = sample_2d(pixel, i, dim, 12345);
                assert!(
                    (0.0..1.0).contains(&p.x) && (0.0..1.0).contains(&p.y),
                    "{p}"
                );
                let x = sample_1d(pixel, i, dim, 12345);
                assert!((0.0..1.0).contains(&x), "{x}");
            }
        }
    }
}

/// Cell index of a point in an nx × ny grid.
fn cell(p: Vec2, nx: u32, ny: u32) -> u32 {
    (p.x * nx as f32) as u32 + nx * (p.y * ny as f32) as u32
}

#[test]
fn first_16_points_fill_every_cell_of_4x4_and_other_elementary_grids() {
    for pixel in 0..200 {
        for dim in 0..4 {
            let pts: Vec<Vec2> = (0..16).map(|i| sample_2d(pixel, i, dim, 9)).collect();
            for (nx, ny) in [(4, 4), (16, 1), (1, 16), (8, 2), (2, 8)] {
                let mut seen = [false; 16];
                for p in &pts {
                    seen[cell(*p, nx, ny) as usize] = true;
                }
                assert!(
                    seen.iter().all(|s| *s),
                    "pixel {pixel} dim {dim} grid {nx}x{ny}"
                );
            }
        }
    }
}

#[test]
fn every_power_of_two_block_of_256_is_a_net() {
    for pixel in [3, 4000] {
        for block in 0..4 {
            let mut seen = [false; 256];
            for i in 0..256 {
                seen[cell(sample_2d(pixel, block * 256 + i, 1, 5), 16, 16) as usize] = true;
            }
            assert!(seen.iter().all(|s| *s));
        }
    }
}

#[test]
fn first_8_values_of_1d_fill_8_strata() {
    for pixel in 0..500 {
        let mut seen = [false; 8];
        for i in 0..8 {
            seen[(sample_1d(pixel, i, 2, 1) * 8.0) as usize] = true;
        }
        assert!(seen.iter().all(|s| *s), "pixel {pixel}");
    }
}

#[test]
fn different_pixels_frames_and_dimensions_give_different_points() {
    let base = sample_2d(10, 0, 0, 1);
    assert_ne!(base, sample_2d(11, 0, 0, 1), "pixel");
    assert_ne!(base, sample_2d(10, 0, 0, 2), "seed / frame");
    assert_ne!(base, sample_2d(10, 0, 1, 1), "dimension");
    // Across many pixels the first point is spread over the square, not shared.
    let mut cells = std::collections::HashSet::new();
    for pixel in 0..1000 {
        cells.insert(cell(sample_2d(pixel, 0, 0, 1), 16, 16));
    }
    assert!(cells.len() > 200, "{} distinct cells of 256", cells.len());
}

#[test]
fn two_dimensions_of_one_pixel_are_uncorrelated() {
    // Pair dimension 0's x with dimension 1's x over many pixels and indices.
    let (mut sxy, mut sx, mut sy, mut sxx, mut syy) = (0f64, 0f64, 0f64, 0f64, 0f64);
    let mut n = 0f64;
    for pixel in 0..200 {
        for i in 0..64 {
            let a = sample_2d(pixel, i, 0, 3).x as f64;
            let b = sample_2d(pixel, i, 1, 3).x as f64;
            sxy += a * b;
            sx += a;
            sy += b;
            sxx += a * a;
            syy += b * b;
            n += 1.0;
        }
    }
    let cov = sxy / n - sx / n * sy / n;
    let corr = cov / ((sxx / n - (sx / n).powi(2)) * (syy / n - (sy / n).powi(2))).sqrt();
    // 12800 pairs: independent streams give |corr| ~ 0.009.
    assert!(corr.abs() < 0.05, "correlation {corr}");
}

#[test]
fn hash_changes_about_half_the_bits_for_a_one_bit_change() {
    let mut flips = 0u64;
    for x in 0..10_000u32 {
        flips += (hash_u32(x) ^ hash_u32(x ^ 1)).count_ones() as u64;
    }
    let mean = flips as f64 / 10_000.0;
    assert!((mean - 16.0).abs() < 0.5, "{mean}");
}

#[test]
fn pcg_is_uniform_and_stream_dependent() {
    let mut r = Pcg32::new(42, 0);
    let mut bins = [0u32; 10];
    for _ in 0..100_000 {
        let x = r.next_f32();
        assert!((0.0..1.0).contains(&x));
        bins[(x * 10.0) as usize] += 1;
    }
    for b in bins {
        assert!((b as i32 - 10_000).abs() < 500, "{bins:?}");
    }
    assert_ne!(Pcg32::new(42, 0).next_u32(), Pcg32::new(42, 1).next_u32());
}

/// The band pass hashes its pixels' streams in lanes (`StreamBatch`, run
/// at the active ISA level); the pixel replay hashes one pixel at a time:
/// both must give the same bits, for runs that are not whole lane groups.
#[test]
fn batched_streams_are_the_per_pixel_values() {
    use penumbra::isa;
    use penumbra::sampling::{STREAM_LANES, StreamBatch};
    let mut rng = Pcg32::new(3, 4);
    for n in [1, 7, STREAM_LANES, STREAM_LANES + 5, 3 * STREAM_LANES] {
        let pixels: Vec<u32> = (0..n).map(|_| rng.next_u32()).collect();
        let (index, seed) = (rng.next_u32(), rng.next_u32());
        let dims = [0, 1, 0x7fff_fff0];
        let mut o: Vec<Vec<f32>> = vec![vec![0.0; n]; 5];
        let [a, b, c, x, y] = o.as_mut_slice() else {
            unreachable!()
        };
        isa::run(StreamBatch {
            pixels: &pixels,
            sample_index: index,
            seed,
            dims_1d: dims,
            out_1d: [a, b, c],
            dim_2d: 3,
            out_2d: [x, y],
        });
        for (j, &p) in pixels.iter().enumerate() {
            for (d, &dim) in dims.iter().enumerate() {
                assert_eq!(o[d][j].to_bits(), sample_1d(p, index, dim, seed).to_bits());
            }
            let v = sample_2d(p, index, 3, seed);
            assert_eq!(
                (o[3][j].to_bits(), o[4][j].to_bits()),
                (v.x.to_bits(), v.y.to_bits())
            );
        }
    }
}
