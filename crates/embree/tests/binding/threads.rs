//! Device and Scene are shared across rayon threads.

use crate::support::{Rng, triangle_soup};
use penumbra_embree::{
    Device, GeometryRole, Scene, SceneBuilder, Vec3, flush_denormals_enabled, thread_pool,
};
use rayon::prelude::*;

const fn assert_send_sync<T: Send + Sync>() {}
const _: () = assert_send_sync::<Device>();
const _: () = assert_send_sync::<Scene<'static>>();

#[test]
fn scene_answers_the_same_from_many_rayon_threads() {
    let device = Device::new().unwrap();
    let mut rng = Rng::new(7);
    let (p, i) = triangle_soup(&mut rng, 300, 0.3);
    let mut builder = SceneBuilder::new(&device).unwrap();
    builder
        .add_triangles(&p, &i, GeometryRole::Occluder)
        .unwrap();
    let scene = builder.commit().unwrap();
    let rays: Vec<(Vec3, Vec3)> = (0..20_000)
        .map(|_| (rng.vec3(-1.0, 1.0), rng.dir()))
        .collect();

    let serial: Vec<(Option<u32>, bool)> = rays
        .iter()
        .map(|&(o, d)| {
            (
                scene.intersect1(o, d, 0.0, 10.0).map(|h| h.prim_id),
                scene.occluded1(o, d, 0.0, 1.0),
            )
        })
        .collect();
    let pool = thread_pool(4).unwrap();
    let parallel: Vec<(Option<u32>, bool)> = pool.install(|| {
        rays.par_iter()
            .map(|&(o, d)| {
                (
                    scene.intersect1(o, d, 0.0, 10.0).map(|h| h.prim_id),
                    scene.occluded1(o, d, 0.0, 1.0),
                )
            })
            .collect()
    });
    assert_eq!(serial, parallel);
    assert!(serial.iter().any(|r| r.0.is_some()) && serial.iter().any(|r| r.0.is_none()));
}

#[test]
fn pool_threads_flush_denormals() {
    let pool = thread_pool(2).unwrap();
    let flags: Vec<bool> = pool.install(|| {
        (0..64)
            .into_par_iter()
            .map(|_| flush_denormals_enabled())
            .collect()
    });
    if cfg!(target_arch = "x86_64") {
        assert!(flags.iter().all(|&f| f));
        // And it really flushes: the smallest normal halved is a denormal.
        let tiny =
            pool.install(|| std::hint::black_box(f32::MIN_POSITIVE) * std::hint::black_box(0.5));
        assert_eq!(tiny, 0.0);
    }
}
