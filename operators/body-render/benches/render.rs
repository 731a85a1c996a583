//! Frames per second of the body renderer against a plain copy of a depth frame (the baseline
//! measured in the same run): a live stream needs ≥ 30 frames/s per sensor.
#![allow(missing_docs)]

use criterion::{Criterion, criterion_group, criterion_main};
use nalgebra::Isometry3;
use trigait_body_render::{BodyShape, RenderParams, Renderer, Room};
use trigait_motion::{WalkerParams, walker};
use trigait_rig::Rig;

fn bench(c: &mut Criterion) {
    let Some(rig) = Rig::builtin("thesis") else {
        return;
    };
    let Ok(clip) = walker(&WalkerParams::default(), 2.0, 30.0) else {
        return;
    };
    let clip = clip.transformed(&Isometry3::translation(-1.2, 0.0, 0.0));
    let Ok(mut r) = Renderer::new(
        RenderParams::default(),
        &rig.sensors[0].world_from_kinect,
        &Room::default(),
    ) else {
        return;
    };
    let shape = BodyShape::default();
    let frame = trigait_depth::DepthFrame::zeros();
    c.bench_function("copy_frame", |b| {
        b.iter(|| std::hint::black_box(frame.clone()))
    });
    let mut f = 0;
    c.bench_function("render_frame", |b| {
        b.iter(|| {
            f = (f + 1) % clip.frame_count();
            std::hint::black_box(r.render_pose(&shape, |j| clip.position(f, j)).ok())
        });
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
