//! Frames per second of the leg tracker against a plain copy of the same depth frame, measured
//! in the same run: three sensors at 30 Hz on one core need ≥ 100 frames/s.
#![allow(missing_docs)]

use criterion::{Criterion, criterion_group, criterion_main};
use trigait_body_render::{BodyShape, RenderParams, Renderer, Room};
use trigait_leg_tracker::{Floor, LegTracker, TrackerConfig};
use trigait_motion::{WalkerParams, there_and_back, walker};
use trigait_rig::Rig;

fn bench(c: &mut Criterion) {
    let Some(rig) = Rig::builtin("thesis") else {
        return;
    };
    let Some(lap) = walker(&WalkerParams::default(), 3.0, 30.0)
        .ok()
        .and_then(|w| there_and_back(&w.placed_on_walkway()).ok())
    else {
        return;
    };
    let pose = rig.sensors[0].world_from_kinect;
    let Ok(mut renderer) = Renderer::new(RenderParams::default(), &pose, &Room::default()) else {
        return;
    };
    let frames: Vec<_> = (0..lap.frame_count())
        .filter_map(|f| {
            renderer
                .render_pose(&BodyShape::default(), |j| lap.position(f, j))
                .ok()
                .map(|r| r.depth)
        })
        .collect();
    if frames.is_empty() {
        return;
    }
    let config = TrackerConfig {
        floor: Floor::from_pose(&pose),
        ..TrackerConfig::default()
    };
    let Ok(mut tracker) = LegTracker::new(config) else {
        return;
    };
    c.bench_function("copy_frame", |b| {
        b.iter(|| std::hint::black_box(frames[0].clone()));
    });
    let mut i = 0;
    c.bench_function("track_frame", |b| {
        b.iter(|| {
            i = (i + 1) % frames.len();
            std::hint::black_box(tracker.track(&frames[i]).joints.len())
        });
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
