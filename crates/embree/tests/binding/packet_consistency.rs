//! Single rays, 8-packets and 16-packets give the same answers on 10^4
//! random rays through a random triangle soup, with partial active masks.

use crate::support::{Rng, triangle_soup};
use penumbra_embree::{Device, GeometryRole, INVALID_ID, Rays8, Rays16, Scene, SceneBuilder, Vec3};

const RAYS: usize = 10_000;

struct Ray {
    org: Vec3,
    dir: Vec3,
    tnear: f32,
    tfar: f32,
}

fn setup(device: &Device) -> (Scene<'_>, Vec<Ray>) {
    let mut rng = Rng::new(0x5EED_1234);
    let (p, i) = triangle_soup(&mut rng, 400, 0.25);
    let mut builder = SceneBuilder::new(device).unwrap();
    // Split the soup in two meshes so geometry ids are exercised too.
    builder
        .add_triangles(&p, &i[..200], GeometryRole::Occluder)
        .unwrap();
    builder
        .add_triangles(&p, &i[200..], GeometryRole::Occluder)
        .unwrap();
    let scene = builder.commit().unwrap();
    let rays = (0..RAYS)
        .map(|_| Ray {
            org: rng.vec3(-1.0, 1.0),
            dir: rng.dir() * rng.range(0.5, 2.0), // non-unit on purpose
            tnear: if rng.f32() < 0.3 {
                rng.range(0.0, 0.2)
            } else {
                0.0
            },
            tfar: if rng.f32() < 0.5 {
                rng.range(0.1, 1.5)
            } else {
                f32::INFINITY
            },
        })
        .collect();
    (scene, rays)
}

/// Random mask with roughly 3/4 of lanes on, and every 7th packet full.
fn active_mask(rng: &mut Rng, packet: usize, lanes: usize) -> u32 {
    let all = (1u32 << lanes) - 1;
    if packet.is_multiple_of(7) {
        all
    } else {
        (rng.next_u64() as u32 | rng.next_u64() as u32) & all
    }
}

#[derive(Debug, PartialEq, Clone, Copy)]
struct Answer {
    t: f32,
    geom: u32,
    prim: u32,
}

const MISS: Answer = Answer {
    t: f32::INFINITY,
    geom: INVALID_ID,
    prim: INVALID_ID,
};

fn same(a: Answer, b: Answer) -> bool {
    a.geom == b.geom && a.prim == b.prim && (a.t == b.t || (a.t - b.t).abs() <= 1e-5 * a.t.abs())
}

#[test]
fn intersect_single_8_and_16_agree() {
    let device = Device::new().unwrap();
    let (scene, rays) = setup(&device);
    let single: Vec<Answer> = rays
        .iter()
        .map(|r| {
            scene
                .intersect1(r.org, r.dir, r.tnear, r.tfar)
                .map_or(MISS, |h| Answer {
                    t: h.t,
                    geom: h.geom_id,
                    prim: h.prim_id,
                })
        })
        .collect();
    let hits = single.iter().filter(|a| a.geom != INVALID_ID).count();
    assert!(
        hits > RAYS / 10 && hits < RAYS * 9 / 10,
        "test scene too empty or full: {hits}"
    );
    assert!(single.iter().any(|a| a.geom == 1) && single.iter().any(|a| a.geom == 0));

    let mut rng = Rng::new(99);
    let mut compared = 0;
    for (k, chunk) in rays.chunks(16).enumerate() {
        let mut p = Rays16::new();
        for (i, r) in chunk.iter().enumerate() {
            p.set(i, r.org, r.dir, r.tnear, r.tfar);
        }
        p.active &= active_mask(&mut rng, k, 16) as u16;
        let h = scene.intersect16(&p, k.is_multiple_of(2));
        for i in 0..16 {
            let got = Answer {
                t: h.t[i],
                geom: h.geom_id[i],
                prim: h.prim_id[i],
            };
            if p.is_active(i) {
                let want = single[k * 16 + i];
                assert!(
                    same(got, want),
                    "16-packet ray {}: {got:?} vs single {want:?}",
                    k * 16 + i
                );
                compared += 1;
            } else {
                assert_eq!(got, MISS, "inactive lane {i} of packet {k}");
            }
        }
    }
    for (k, chunk) in rays.chunks(8).enumerate() {
        let mut p = Rays8::new();
        for (i, r) in chunk.iter().enumerate() {
            p.set(i, r.org, r.dir, r.tnear, r.tfar);
        }
        p.active &= active_mask(&mut rng, k, 8) as u8;
        let h = scene.intersect8(&p, !k.is_multiple_of(2));
        for i in 0..8 {
            let got = Answer {
                t: h.t[i],
                geom: h.geom_id[i],
                prim: h.prim_id[i],
            };
            if p.is_active(i) {
                let want = single[k * 8 + i];
                assert!(
                    same(got, want),
                    "8-packet ray {}: {got:?} vs single {want:?}",
                    k * 8 + i
                );
                compared += 1;
            } else {
                assert_eq!(got, MISS, "inactive lane {i} of packet {k}");
            }
        }
    }
    assert!(compared > RAYS, "masks left too few lanes: {compared}");
}

#[test]
fn occluded_single_8_and_16_agree() {
    let device = Device::new().unwrap();
    let (scene, rays) = setup(&device);
    let single: Vec<bool> = rays
        .iter()
        .map(|r| scene.occluded1(r.org, r.dir, r.tnear, r.tfar))
        .collect();
    let blocked = single.iter().filter(|&&b| b).count();
    assert!(
        blocked > RAYS / 10 && blocked < RAYS * 9 / 10,
        "test scene too empty or full: {blocked}"
    );
    // occluded agrees with intersect: blocked iff there is a hit in [tnear, tfar].
    for (r, &b) in rays.iter().zip(&single) {
        assert_eq!(b, scene.intersect1(r.org, r.dir, r.tnear, r.tfar).is_some());
    }

    let mut rng = Rng::new(1234);
    for (k, chunk) in rays.chunks(16).enumerate() {
        let mut p = Rays16::new();
        for (i, r) in chunk.iter().enumerate() {
            p.set(i, r.org, r.dir, r.tnear, r.tfar);
        }
        p.active &= active_mask(&mut rng, k, 16) as u16;
        let got = scene.occluded16(&p);
        let want = (0..16)
            .filter(|&i| p.is_active(i) && single[k * 16 + i])
            .fold(0u16, |m, i| m | 1 << i);
        assert_eq!(got, want, "16-packet {k}: {got:016b} vs {want:016b}");
    }
    for (k, chunk) in rays.chunks(8).enumerate() {
        let mut p = Rays8::new();
        for (i, r) in chunk.iter().enumerate() {
            p.set(i, r.org, r.dir, r.tnear, r.tfar);
        }
        p.active &= active_mask(&mut rng, k, 8) as u8;
        let got = scene.occluded8(&p);
        let want = (0..8)
            .filter(|&i| p.is_active(i) && single[k * 8 + i])
            .fold(0u8, |m, i| m | 1 << i);
        assert_eq!(got, want, "8-packet {k}: {got:08b} vs {want:08b}");
    }
}
