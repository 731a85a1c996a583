//! All five depth metrics on 30 simulated 512×424 frames (the goal: ≤ 50 ms on one core), with a
//! same-run baseline — one plain read pass summing the same 30 frames — so the printed ratio
//! does not depend on how busy the shared machine is.
//!
//! Run: `cargo bench -p trigait-depth --bench metrics` (add `-- --quick` for a short run).

// Test helpers outside `#[test]` functions panic on failure by design.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::hint::black_box;
use std::time::{Duration, Instant};

use criterion::{BatchSize, Criterion};
use trigait_depth::sim::{Scene, Shape, SimParams, Simulator};
use trigait_depth::{DepthFrame, MetricsParams, SequenceAnalyzer};

const FRAMES: usize = 30;

fn frames() -> Vec<DepthFrame> {
    let mut scene = Scene::wall(2.5);
    scene.shapes.push(Shape::Disc {
        x_m: -0.3,
        y_m: 0.0,
        radius_m: 0.25,
        distance_m: 1.2,
    });
    let params = SimParams {
        noise_sd_mm: 1.5,
        ring_amplitude_mm: 2.0,
        ring_period_px: 40.0,
        edge_dropout_px: 2.0,
        ..SimParams::default()
    };
    let Ok(mut sim) = Simulator::new(&scene, params) else {
        panic!("simulator parameters are valid");
    };
    (0..FRAMES).map(|_| sim.next_frame()).collect()
}

/// The five metrics over a 30-frame sequence: accuracy and entropy on every frame, resolution
/// and edge noise on the first, structural noise on the mean frame (the defaults). The analyzer
/// (camera rays and cone, computed once per sensor) is reused via `reset`, as a node would.
fn five_metrics(analyzer: &mut SequenceAnalyzer, frames: &[DepthFrame]) -> usize {
    analyzer.reset();
    for f in frames {
        analyzer.push(f);
    }
    match analyzer.report() {
        Ok(r) => r.frames,
        Err(e) => panic!("metrics failed: {e}"),
    }
}

/// Baseline: read every pixel of every frame once.
fn read_pass(frames: &[DepthFrame]) -> u64 {
    frames
        .iter()
        .map(|f| f.as_mm().iter().map(|&z| u64::from(z)).sum::<u64>())
        .sum()
}

fn median_time(mut f: impl FnMut(), runs: usize) -> Duration {
    let mut t: Vec<Duration> = (0..runs)
        .map(|_| {
            let start = Instant::now();
            f();
            start.elapsed()
        })
        .collect();
    t.sort();
    t[runs / 2]
}

fn main() {
    let frames = frames();
    let params = MetricsParams::default();
    let mut c = Criterion::default()
        .configure_from_args()
        .sample_size(10)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(3));
    let mut analyzer = SequenceAnalyzer::new(params, None);
    c.bench_function("five_metrics_30_frames", |b| {
        b.iter(|| black_box(five_metrics(&mut analyzer, black_box(&frames))));
    });
    c.bench_function("analyzer_setup", |b| {
        b.iter(|| black_box(SequenceAnalyzer::new(params, None)));
    });
    c.bench_function("baseline_read_pass_30_frames", |b| {
        b.iter(|| black_box(read_pass(black_box(&frames))));
    });
    c.bench_function("push_one_frame", |b| {
        b.iter_batched(
            || {
                SequenceAnalyzer::new(
                    MetricsParams {
                        frame_metric_stride: 1,
                        ..params
                    },
                    None,
                )
            },
            |mut a| {
                a.push(black_box(&frames[0]));
                a
            },
            BatchSize::LargeInput,
        );
    });
    c.final_summary();

    let metrics = median_time(|| _ = black_box(five_metrics(&mut analyzer, &frames)), 21);
    let baseline = median_time(|| _ = black_box(read_pass(&frames)), 21);
    let mut every = SequenceAnalyzer::new(
        MetricsParams {
            frame_metric_stride: 1,
            ..params
        },
        None,
    );
    let every_frame = median_time(|| _ = black_box(five_metrics(&mut every, &frames)), 5);
    let ms = |d: Duration| d.as_secs_f64() * 1e3;
    let verdict = if metrics <= Duration::from_millis(50) {
        "met"
    } else {
        "MISSED"
    };
    println!(
        "five metrics on {FRAMES} frames: {:.1} ms (median of 21); baseline read pass: {:.2} ms; \
         ratio {:.0}x; budget 50 ms: {verdict}",
        ms(metrics),
        ms(baseline),
        metrics.as_secs_f64() / baseline.as_secs_f64(),
    );
    println!(
        "with resolution and edge noise on every frame (the CLI default): {:.1} ms",
        ms(every_frame)
    );
}
