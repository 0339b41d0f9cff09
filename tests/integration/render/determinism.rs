//! A frame is a pure function of scene, camera, settings and seed.

use crate::support::{Job, color_bytes, render};
use penumbra::scene::Scene;

#[test]
fn same_seed_gives_the_same_bytes() {
    let scene = Scene::builtin();
    let a = render(&scene, &Job::default());
    let b = render(&scene, &Job::default());
    assert_eq!(color_bytes(&a), color_bytes(&b));
}

#[test]
fn one_and_two_threads_give_the_same_bytes() {
    let scene = Scene::builtin();
    let one = render(&scene, &Job::default());
    let two = render(
        &scene,
        &Job {
            threads: 2,
            ..Job::default()
        },
    );
    assert_eq!(color_bytes(&one), color_bytes(&two));
}

#[test]
fn builtin_scene_renders_lit_pixels() {
    let frame = render(&Scene::builtin(), &Job::default());
    let lit = frame
        .color
        .iter()
        .filter(|c| c.max_element() > 1e-3)
        .count();
    assert!(lit > frame.color.len() / 4, "only {lit} lit pixels");
    assert!(frame.color.iter().all(|c| c.is_finite()));
}
