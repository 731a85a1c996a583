//! Per-frame cost of the `freenect2` backend's work on a capture — 512×424 depth and IR floats
//! rounded to whole units and encoded as two Arrow `depth_frame` messages — against a same-run
//! baseline, a plain copy of the same two float frames (what moving them at all costs), so the
//! printed ratio does not depend on how busy the machine is. Budget: 2 ms per frame. dora's own
//! send (one copy into shared memory) is not included; the baseline is the size of that copy.
//!
//! Run: `cargo bench -p trigait-freenect2 --bench backend` (add `-- --quick` for a short run).

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::hint::black_box;
use std::time::{Duration, Instant};

use criterion::Criterion;
use trigait_freenect2::capture::{Capture, CaptureConfig, Captured, Event, Selector};
use trigait_freenect2::fake::{FakeDriver, FakeKinect};
use trigait_schema::Message;

fn one_capture() -> Captured {
    // A wall with a ramp and holes: realistic values, nothing constant-folds.
    let depth: Vec<f32> = (0..512 * 424)
        .map(|i| {
            if i % 53 == 0 {
                0.0
            } else {
                1800.0 + (i % 911) as f32 * 0.37
            }
        })
        .collect();
    let driver = FakeDriver::new(vec![FakeKinect::new("BENCH", vec![depth])]);
    let mut capture = Capture::new(CaptureConfig::new(Selector::Index(0)), Box::new(driver));
    loop {
        if let Some(Event::Frame(f)) = capture.poll(Duration::from_millis(200)) {
            return *f;
        }
    }
}

fn backend(c: &Captured) -> usize {
    let (depth, ir) = c.messages("k1", 7);
    let a = depth.encode().unwrap();
    let b = ir.expect("IR captured").encode().unwrap();
    a.len() + b.len()
}

fn plain_copy(c: &Captured) -> usize {
    let a = c.depth.as_f32().to_vec();
    let b = c.ir.as_ref().expect("IR captured").as_f32().to_vec();
    a.len() + b.len()
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
    let captured = one_capture();
    let mut c = Criterion::default()
        .configure_from_args()
        .sample_size(20)
        .warm_up_time(Duration::from_millis(300))
        .measurement_time(Duration::from_secs(2));
    c.bench_function("backend_depth_ir_to_arrow", |b| {
        b.iter(|| black_box(backend(black_box(&captured))));
    });
    c.bench_function("baseline_plain_copy_depth_ir", |b| {
        b.iter(|| black_box(plain_copy(black_box(&captured))));
    });
    c.final_summary();
    let ours = median_time(|| _ = black_box(backend(&captured)), 101);
    let base = median_time(|| _ = black_box(plain_copy(&captured)), 101);
    let ms = |d: Duration| d.as_secs_f64() * 1e3;
    let verdict = if ours <= Duration::from_millis(2) {
        "met"
    } else {
        "MISSED"
    };
    println!(
        "depth+IR 512x424 -> Arrow: {:.3} ms per frame (median of 101); plain copy of both: \
         {:.3} ms; ratio {:.1}x; budget 2 ms: {verdict}",
        ms(ours),
        ms(base),
        ours.as_secs_f64() / base.as_secs_f64()
    );
}
