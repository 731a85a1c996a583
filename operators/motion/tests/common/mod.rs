//! Gait measurements shared by the integration tests: stance detection from ankle speed, foot
//! placements, step length, cadence and speed measured back from joint trajectories.
#![allow(dead_code, missing_docs)]

use nalgebra::Point3;
use trigait_motion::{Joint, MotionClip};

/// A period with the ankle (nearly) still: the foot is on the floor.
#[derive(Debug, Clone, Copy)]
pub struct Stance {
    pub first: usize,
    pub last: usize,
    /// Mean ankle position over the period.
    pub ankle: Point3<f64>,
}

/// Horizontal ankle speed per frame (central differences), m/s; `None` across gaps.
pub fn horizontal_speed(clip: &MotionClip, joint: Joint) -> Vec<Option<f64>> {
    let n = clip.frame_count();
    (0..n)
        .map(|f| {
            let a = clip.position(f.saturating_sub(1), joint)?;
            let b = clip.position((f + 1).min(n - 1), joint)?;
            let dt = ((f + 1).min(n - 1) - f.saturating_sub(1)) as f64 / clip.rate_hz();
            Some(((b.x - a.x).powi(2) + (b.y - a.y).powi(2)).sqrt() / dt)
        })
        .collect()
}

/// Stance periods of `joint`: runs of at least `min_frames` frames with horizontal speed below
/// `threshold` m/s. Runs touching the clip's ends are kept (they are still foot placements).
pub fn stances(clip: &MotionClip, joint: Joint, threshold: f64, min_frames: usize) -> Vec<Stance> {
    let speed = horizontal_speed(clip, joint);
    // Runs of still frames; runs split by a brief blip (marker noise) are merged.
    let mut runs: Vec<(usize, usize)> = Vec::new();
    let mut start = None;
    for f in 0..=speed.len() {
        let still = f < speed.len() && speed[f].is_some_and(|s| s < threshold);
        match (still, start) {
            (true, None) => start = Some(f),
            (false, Some(s)) => {
                match runs.last_mut() {
                    Some(last) if s - last.1 <= min_frames / 2 + 1 => last.1 = f - 1,
                    _ => runs.push((s, f - 1)),
                }
                start = None;
            }
            _ => {}
        }
    }
    runs.into_iter()
        .filter(|(a, b)| b + 1 - a >= min_frames)
        .map(|(first, last)| {
            let points: Vec<Point3<f64>> = (first..=last)
                .filter_map(|i| clip.position(i, joint))
                .collect();
            let mean = points
                .iter()
                .fold(nalgebra::Vector3::zeros(), |acc, p| acc + p.coords)
                / points.len() as f64;
            Stance {
                first,
                last,
                ankle: Point3::from(mean),
            }
        })
        .collect()
}

/// Gait numbers measured from a clip.
#[derive(Debug, Clone)]
pub struct GaitMeasures {
    /// Mean forward distance between consecutive foot placements of opposite feet, m.
    pub step_length_m: f64,
    /// Steps per minute from the mid-stance times of alternating feet.
    pub cadence_steps_per_min: f64,
    /// Mean forward speed of the pelvis (SpineBase), m/s.
    pub speed_m_per_s: f64,
    /// Number of steps used.
    pub steps: usize,
}

/// Measures step length, cadence and speed from the ankles and the pelvis.
///
/// Only stances fully inside the clip (not touching either end) count for timing.
pub fn measure(clip: &MotionClip, threshold: f64) -> GaitMeasures {
    let min_frames = (0.1 * clip.rate_hz()) as usize;
    let mut all: Vec<(usize, Stance)> = Vec::new();
    for (side, joint) in [(0, Joint::AnkleLeft), (1, Joint::AnkleRight)] {
        for s in stances(clip, joint, threshold, min_frames) {
            all.push((side, s));
        }
    }
    all.sort_by_key(|(_, s)| s.first);
    let n = clip.frame_count();
    let mut lengths = Vec::new();
    let mut onsets = Vec::new();
    for w in all.windows(2) {
        let ((sa, a), (sb, b)) = (w[0], w[1]);
        if sa != sb {
            lengths.push(b.ankle.x - a.ankle.x);
            if a.first > 0 && b.first > 0 && a.last + 1 < n && b.last + 1 < n {
                // Mid-stance to mid-stance: less sensitive to the speed threshold than onsets.
                onsets.push((b.first + b.last - a.first - a.last) as f64 / 2.0 / clip.rate_hz());
            }
        }
    }
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len().max(1) as f64;
    let first = (0..n).find_map(|f| clip.position(f, Joint::SpineBase).map(|p| (f, p)));
    let last = (0..n)
        .rev()
        .find_map(|f| clip.position(f, Joint::SpineBase).map(|p| (f, p)));
    let speed = match (first, last) {
        (Some((f0, p0)), Some((f1, p1))) if f1 > f0 => {
            (p1.x - p0.x) / ((f1 - f0) as f64 / clip.rate_hz())
        }
        _ => f64::NAN,
    };
    GaitMeasures {
        step_length_m: mean(&lengths),
        cadence_steps_per_min: 60.0 / mean(&onsets),
        speed_m_per_s: speed,
        steps: lengths.len(),
    }
}

/// (min, max) of a slice.
pub fn range(values: &[f64]) -> (f64, f64) {
    values
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
            (lo.min(*v), hi.max(*v))
        })
}

/// Standard deviation of a slice.
pub fn std_dev(values: &[f64]) -> f64 {
    let m = values.iter().sum::<f64>() / values.len() as f64;
    (values.iter().map(|v| (v - m).powi(2)).sum::<f64>() / values.len() as f64).sqrt()
}

/// Distances between two joints over all frames where both exist.
pub fn segment_lengths(clip: &MotionClip, a: Joint, b: Joint) -> Vec<f64> {
    (0..clip.frame_count())
        .filter_map(|f| Some((clip.position(f, a)? - clip.position(f, b)?).norm()))
        .collect()
}

/// A unique path in the temp directory for this test process.
pub fn temp_path(name: &str) -> std::path::PathBuf {
    std::env::temp_dir().join(format!("trigait-motion-{}-{name}", std::process::id()))
}
