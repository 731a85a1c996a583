//! Per-frame cost of the `freenect2` backend's work on a capture — 512×424 depth and IR floats
//! rounded to whole units, encoded as Arrow `depth_frame` and `ir_frame` messages, and their buffers copied
//! once into a fresh contiguous buffer, as dora's `send_output` copies them into a shared-memory
//! sample — against a same-run baseline, a plain copy of the same two float frames (what moving
//! them at all costs), so the printed ratio does not depend on how busy the machine is.
//! Budget: 2 ms per frame. Not included: dora's own bookkeeping of the send (no daemon here).
//!
//! Run: `cargo bench --release --workspace --bench backend` (add `-- --quick` for a short run).

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::hint::black_box;
use std::time::{Duration, Instant};

use criterion::Criterion;
use trigait_freenect2::capture::{Capture, CaptureConfig, Captured, Event, Selector};
use trigait_freenect2::fake::{FakeDriver, FakeKinect};
use trigait_schema::{Array, ArrayRef, Message};

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
    send_copy(&a).len() + send_copy(&b).len()
}

/// Every buffer of `array` (children included) copied into one new buffer: the copy dora's
/// send makes into a shared-memory sample.
fn send_copy(array: &ArrayRef) -> Vec<u8> {
    let data = array.to_data();
    let mut out = Vec::with_capacity(data.get_slice_memory_size().unwrap_or(0));
    let mut stack = vec![data];
    while let Some(d) = stack.pop() {
        for b in d.buffers() {
            out.extend_from_slice(b.as_slice());
        }
        stack.extend(d.child_data().iter().cloned());
    }
    out
}

fn plain_copy(c: &Captured) -> usize {
    let a = c.depth.as_f32().to_vec();
    let b = c.ir.as_ref().expect("IR captured").as_f32().to_vec();
    a.len() + b.len()
}

/// Median and mean of `runs` timed calls (the mean shows what a busy machine adds).
fn times(mut f: impl FnMut(), runs: usize) -> (Duration, Duration) {
    let mut t: Vec<Duration> = (0..runs)
        .map(|_| {
            let start = Instant::now();
            f();
            start.elapsed()
        })
        .collect();
    t.sort();
    let mean = t.iter().sum::<Duration>() / u32::try_from(runs).unwrap();
    (t[runs / 2], mean)
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
    let (ours, ours_mean) = times(|| _ = black_box(backend(&captured)), 101);
    let (base, base_mean) = times(|| _ = black_box(plain_copy(&captured)), 101);
    let ms = |d: Duration| d.as_secs_f64() * 1e3;
    let verdict = if ours <= Duration::from_millis(2) {
        "met"
    } else {
        "MISSED"
    };
    println!(
        "depth+IR 512x424 -> Arrow -> send copy: {:.3} ms per frame (median of 101; mean \
         {:.3} ms); plain copy of both frames: {:.3} ms (mean {:.3} ms); ratio {:.1}x; \
         budget 2 ms (median): {verdict}",
        ms(ours),
        ms(ours_mean),
        ms(base),
        ms(base_mean),
        ours.as_secs_f64() / base.as_secs_f64()
    );
}
