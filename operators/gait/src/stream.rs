//! Causal, streaming trajectory filters for a live dataflow: one filter state per joint, driven
//! by the poses' own timestamps.
//!
//! A dataflow cannot look ahead, so the zero-lag Butterworth of [`crate::filter`] (a forward and
//! a backward pass) is an offline tool only. Live, the choice is between
//! - the **One-Euro** filter (Casiez et al. 2012): a first-order low-pass whose cut-off rises
//!   with the joint's speed, so a standing ankle is smoothed hard and a swinging one lags little;
//! - a **causal Butterworth** low-pass (cascaded second-order sections, [`Biquad`]): a fixed
//!   cut-off (6 Hz is the gait-lab habit for walking, Winter 2009 §3.4.4) and a fixed, known
//!   delay (≈ 37 ms at 6 Hz, order 2).
//!
//! # What resets a joint
//! Each joint's state is independent. It starts afresh (the first sample passes through
//! unfiltered) when the joint
//! - was missing from the previous pose ([`ResetReason::Missing`]),
//! - has a non-finite coordinate: the sample is rejected, never filtered, so a NaN can never
//!   enter a filter state and spread to later outputs ([`ResetReason::NonFinite`]),
//! - comes more than [`StreamParams::max_gap_secs`] after its previous sample
//!   ([`ResetReason::Gap`]): a filter bridging a tracker dropout would drag the joint across it,
//! - comes at or before its previous sample ([`ResetReason::TimeBackwards`]),
//! - (low-pass only) comes at less than half the sample interval the filter was designed for
//!   ([`ResetReason::RateChange`]).
//!
//! # Time
//! The low-pass needs a sample rate: it takes the first interval of a joint's run and follows
//! the intervals after it (a slow running average), redesigning its sections when the rate
//! moves by more than 5 %. A short gap of k intervals (below `max_gap_secs`, e.g. a dropped
//! aligned set) is filled with k − 1 samples interpolated linearly, so the filter keeps running
//! on its uniform grid instead of mistaking two intervals for one.

use std::collections::BTreeMap;
use std::fmt;

use nalgebra::{Point3, Vector3};
use serde::{Deserialize, Serialize};
use trigait_skeleton::Joint;

use crate::filter::{Biquad, OneEuro, OneEuroParams};
use crate::{Error, Result};

/// Parameters of the causal Butterworth low-pass.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct LowPassParams {
    /// −3 dB cut-off (Hz). Default 6 Hz: walking kinematics lie below it (Winter 2009,
    /// §3.4.4), Kinect jitter mostly above.
    pub cutoff_hz: f64,
    /// Filter order, 1–8. Default 2 (steeper orders lag more).
    pub order: usize,
}

impl Default for LowPassParams {
    fn default() -> Self {
        Self {
            cutoff_hz: 6.0,
            order: 2,
        }
    }
}

/// Which causal filter runs on the stream.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", tag = "kind")]
pub enum StreamFilter {
    /// Pass through (still rejects non-finite samples).
    None,
    /// The One-Euro filter (Casiez et al. 2012).
    OneEuro(OneEuroParams),
    /// Causal Butterworth low-pass.
    LowPass(LowPassParams),
}

impl Default for StreamFilter {
    fn default() -> Self {
        StreamFilter::OneEuro(OneEuroParams::default())
    }
}

impl fmt::Display for StreamFilter {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            StreamFilter::None => write!(f, "none"),
            StreamFilter::OneEuro(p) => write!(
                f,
                "one-euro (min cut-off {} Hz, beta {}, derivative cut-off {} Hz)",
                p.min_cutoff_hz, p.beta, p.derivative_cutoff_hz
            ),
            StreamFilter::LowPass(p) => {
                write!(
                    f,
                    "lowpass (causal Butterworth, {} Hz, order {})",
                    p.cutoff_hz, p.order
                )
            }
        }
    }
}

/// Parameters of a [`PoseFilter`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct StreamParams {
    /// The filter.
    pub filter: StreamFilter,
    /// A joint silent for longer than this (s) restarts. Default 0.2 s: six frames at 30 Hz,
    /// three thesis slot cycles of 60 ms; a longer dropout is a real gap, not jitter.
    pub max_gap_secs: f64,
}

impl Default for StreamParams {
    fn default() -> Self {
        Self {
            filter: StreamFilter::default(),
            max_gap_secs: 0.2,
        }
    }
}

impl StreamParams {
    /// Checks every parameter.
    ///
    /// # Errors
    /// [`Error::BadParameter`] naming the first bad one.
    pub fn validate(&self) -> Result<()> {
        if !(self.max_gap_secs.is_finite() && self.max_gap_secs > 0.0) {
            return Err(Error::BadParameter {
                name: "max_gap_secs",
                value: self.max_gap_secs,
                expected: "a positive number of seconds",
            });
        }
        match self.filter {
            StreamFilter::None => Ok(()),
            StreamFilter::OneEuro(p) => OneEuro::new(p).map(|_| ()),
            StreamFilter::LowPass(p) => {
                if !(p.cutoff_hz.is_finite() && p.cutoff_hz > 0.0) {
                    return Err(Error::BadParameter {
                        name: "cutoff_hz",
                        value: p.cutoff_hz,
                        expected: "a positive cut-off (Hz)",
                    });
                }
                // The order is checked by the design at any legal rate.
                Biquad::causal_butterworth(p.cutoff_hz, p.cutoff_hz * 10.0, p.order).map(|_| ())
            }
        }
    }
}

/// Why a joint's filter started afresh.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ResetReason {
    /// The joint was not in the previous pose.
    Missing,
    /// The sample had a NaN or infinite coordinate (rejected).
    NonFinite,
    /// Longer than `max_gap_secs` since the joint's previous sample.
    Gap,
    /// The stamp was not after the joint's previous one.
    TimeBackwards,
    /// The interval dropped below half the one the low-pass was designed for.
    RateChange,
    /// The low-pass could not be designed for the observed rate (cut-off too close to Nyquist);
    /// the joint passes through unfiltered.
    CannotDesign,
}

impl ResetReason {
    /// Name used in logs and JSON.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            ResetReason::Missing => "missing",
            ResetReason::NonFinite => "non_finite",
            ResetReason::Gap => "gap",
            ResetReason::TimeBackwards => "time_backwards",
            ResetReason::RateChange => "rate_change",
            ResetReason::CannotDesign => "cannot_design",
        }
    }
}

/// What happened to one joint of a pose.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum JointOutcome {
    /// Filtered position.
    Filtered(Point3<f64>),
    /// The filter (re)started here; the position is the input, unfiltered.
    Started(Point3<f64>),
    /// A non-finite sample: dropped, the joint's state is cleared.
    NonFinite,
}

impl JointOutcome {
    /// The position to send on, if any.
    #[must_use]
    pub fn position(self) -> Option<Point3<f64>> {
        match self {
            JointOutcome::Filtered(p) | JointOutcome::Started(p) => Some(p),
            JointOutcome::NonFinite => None,
        }
    }
}

/// Running counts of a [`PoseFilter`].
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct StreamCounts {
    /// Poses seen.
    pub poses: u64,
    /// Joint samples filtered (state carried over from the previous sample).
    pub filtered: u64,
    /// Joint samples that (re)started a filter and passed through.
    pub started: u64,
    /// Restarts by reason (the first sample of a joint is not a restart).
    pub resets: BTreeMap<ResetReason, u64>,
}

#[derive(Debug, Clone)]
enum State {
    None,
    OneEuro(OneEuro),
    LowPass(LowPass),
}

#[derive(Debug, Clone)]
struct LowPass {
    params: LowPassParams,
    /// Sample interval the sections were designed for (ns) and its running estimate.
    design_nanos: f64,
    period_nanos: f64,
    sections: Vec<Biquad>,
    /// Per axis, per section.
    z: [Vec<[f64; 2]>; 3],
}

impl LowPass {
    fn design(params: LowPassParams, period_nanos: f64, start: &Vector3<f64>) -> Result<Self> {
        let sections =
            Biquad::causal_butterworth(params.cutoff_hz, 1e9 / period_nanos, params.order)?;
        let z = std::array::from_fn(|axis| {
            sections
                .iter()
                .map(|s| s.steady_state(start[axis]))
                .collect()
        });
        Ok(Self {
            params,
            design_nanos: period_nanos,
            period_nanos,
            sections,
            z,
        })
    }

    fn step(&mut self, x: &Vector3<f64>) -> Vector3<f64> {
        let mut y = *x;
        for axis in 0..3 {
            let mut v = x[axis];
            for (s, z) in self.sections.iter().zip(self.z[axis].iter_mut()) {
                v = s.step(v, z);
            }
            y[axis] = v;
        }
        y
    }

    /// Redesigns for the current interval estimate, keeping the section states (the change
    /// is under 5 %, so the states stay close to what the new sections would hold).
    fn follow_rate(&mut self) {
        if (self.period_nanos / self.design_nanos - 1.0).abs() > 0.05
            && let Ok(sections) = Biquad::causal_butterworth(
                self.params.cutoff_hz,
                1e9 / self.period_nanos,
                self.params.order,
            )
        {
            self.sections = sections;
            self.design_nanos = self.period_nanos;
        }
    }
}

#[derive(Debug, Clone)]
struct JointState {
    origin_nanos: i64,
    last_nanos: i64,
    last_input: Vector3<f64>,
    state: State,
}

/// Per-joint causal filtering of a stream of poses.
///
/// Positions only: a pose's covariance is the covariance of that instant's *measurement*, and
/// this type leaves it to the caller to pass it through unchanged. After filtering it is a
/// conservative bound on the random part of the error (a low-pass averages several
/// measurements, so the filtered noise is smaller) and says nothing about the lag the filter
/// adds when the joint moves fast.
#[derive(Debug, Clone)]
pub struct PoseFilter {
    params: StreamParams,
    joints: BTreeMap<Joint, JointState>,
    counts: StreamCounts,
}

impl PoseFilter {
    /// A filter with no history.
    ///
    /// # Errors
    /// As [`StreamParams::validate`].
    pub fn new(params: StreamParams) -> Result<Self> {
        params.validate()?;
        Ok(Self {
            params,
            joints: BTreeMap::new(),
            counts: StreamCounts::default(),
        })
    }

    /// The parameters.
    #[must_use]
    pub fn params(&self) -> &StreamParams {
        &self.params
    }

    /// Running counts.
    #[must_use]
    pub fn counts(&self) -> &StreamCounts {
        &self.counts
    }

    fn reset(&mut self, joint: Joint, reason: ResetReason) {
        if self.joints.remove(&joint).is_some() || reason == ResetReason::NonFinite {
            *self.counts.resets.entry(reason).or_default() += 1;
        }
    }

    /// Filters the joints of the pose at `stamp_nanos`. A joint the filter held before and
    /// that is absent now is reset ([`ResetReason::Missing`]).
    pub fn push<'a>(
        &mut self,
        stamp_nanos: i64,
        joints: impl IntoIterator<Item = (Joint, &'a Point3<f64>)>,
    ) -> BTreeMap<Joint, JointOutcome> {
        self.counts.poses += 1;
        let mut out = BTreeMap::new();
        for (joint, p) in joints {
            out.insert(joint, self.push_joint(joint, stamp_nanos, &p.coords));
        }
        let absent: Vec<Joint> = self
            .joints
            .keys()
            .filter(|j| !out.contains_key(j))
            .copied()
            .collect();
        for joint in absent {
            self.reset(joint, ResetReason::Missing);
        }
        out
    }

    fn start(&mut self, joint: Joint, t: i64, x: &Vector3<f64>) -> JointOutcome {
        let state = match self.params.filter {
            StreamFilter::None => State::None,
            StreamFilter::OneEuro(p) => match OneEuro::new(p) {
                Ok(mut f) => {
                    let _ = f.filter(0.0, x);
                    State::OneEuro(f)
                }
                Err(_) => State::None,
            },
            // Designed at the second sample, when the interval is known.
            StreamFilter::LowPass(_) => State::None,
        };
        self.joints.insert(
            joint,
            JointState {
                origin_nanos: t,
                last_nanos: t,
                last_input: *x,
                state,
            },
        );
        self.counts.started += 1;
        JointOutcome::Started(Point3::from(*x))
    }

    fn push_joint(&mut self, joint: Joint, t: i64, x: &Vector3<f64>) -> JointOutcome {
        if !x.iter().all(|v| v.is_finite()) {
            self.reset(joint, ResetReason::NonFinite);
            return JointOutcome::NonFinite;
        }
        let max_gap_nanos = self.params.max_gap_secs * 1e9;
        let filter = self.params.filter;
        let Some(js) = self.joints.get_mut(&joint) else {
            return self.start(joint, t, x);
        };
        let dt = t.saturating_sub(js.last_nanos) as f64;
        if dt <= 0.0 {
            self.reset(joint, ResetReason::TimeBackwards);
            return self.start(joint, t, x);
        }
        if dt > max_gap_nanos {
            self.reset(joint, ResetReason::Gap);
            return self.start(joint, t, x);
        }
        let y = match (&mut js.state, filter) {
            (State::OneEuro(f), _) => f.filter((t - js.origin_nanos) as f64 * 1e-9, x),
            (State::LowPass(lp), _) => {
                let steps = (dt / lp.period_nanos).round();
                if steps < 1.0 {
                    self.reset(joint, ResetReason::RateChange);
                    return self.start(joint, t, x);
                }
                if steps == 1.0 {
                    lp.period_nanos += 0.05 * (dt - lp.period_nanos);
                    lp.follow_rate();
                }
                // Fill a short gap of k intervals with k − 1 interpolated samples.
                let k = steps as usize;
                for i in 1..k {
                    let f = i as f64 / k as f64;
                    let _ = lp.step(&js.last_input.lerp(x, f));
                }
                lp.step(x)
            }
            (State::None, StreamFilter::LowPass(p)) => {
                match LowPass::design(p, dt, &js.last_input) {
                    Ok(mut lp) => {
                        let y = lp.step(x);
                        js.state = State::LowPass(lp);
                        y
                    }
                    Err(_) => {
                        // Leave the state empty: the next sample tries again.
                        *self
                            .counts
                            .resets
                            .entry(ResetReason::CannotDesign)
                            .or_default() += 1;
                        js.last_nanos = t;
                        js.last_input = *x;
                        return JointOutcome::Started(Point3::from(*x));
                    }
                }
            }
            (State::None, _) => *x,
        };
        js.last_nanos = t;
        js.last_input = *x;
        self.counts.filtered += 1;
        JointOutcome::Filtered(Point3::from(y))
    }
}

#[cfg(test)]
mod tests {
    use std::f64::consts::PI;

    use approx::assert_relative_eq;

    use super::*;

    const PERIOD: i64 = 33_333_333;

    fn lowpass(cutoff_hz: f64, order: usize) -> StreamParams {
        StreamParams {
            filter: StreamFilter::LowPass(LowPassParams { cutoff_hz, order }),
            ..StreamParams::default()
        }
    }

    fn all_filters() -> Vec<StreamParams> {
        let v = vec![
            StreamParams::default(),
            lowpass(6.0, 2),
            lowpass(4.0, 3),
            StreamParams {
                filter: StreamFilter::None,
                ..StreamParams::default()
            },
        ];
        assert!(v.len() >= 3);
        v
    }

    /// Deterministic pseudo-noise in [−1, 1] (no RNG dependency needed).
    fn noise(i: u64) -> f64 {
        let x = (i.wrapping_mul(0x9E37_79B9_7F4A_7C15) >> 11) as f64 / (1u64 << 53) as f64;
        2.0 * x - 1.0
    }

    fn run(f: &mut PoseFilter, joint: Joint, samples: &[(i64, Point3<f64>)]) -> Vec<JointOutcome> {
        samples
            .iter()
            .map(|(t, p)| f.push(*t, [(joint, p)])[&joint])
            .collect()
    }

    /// Second-difference RMS, the frame-to-frame jerkiness a viewer sees.
    fn accel_rms(x: &[f64]) -> f64 {
        let d: Vec<f64> = x.windows(3).map(|w| w[2] - 2.0 * w[1] + w[0]).collect();
        (d.iter().map(|v| v * v).sum::<f64>() / d.len() as f64).sqrt()
    }

    /// The causal sections are −3 dB at the cut-off, pass DC and stop high frequencies, for
    /// even and odd orders, and a step settles to exactly 1 (unit DC gain).
    #[test]
    fn causal_butterworth_gain() {
        for order in [1, 2, 3, 4] {
            let sections = Biquad::causal_butterworth(6.0, 120.0, order).unwrap();
            assert_eq!(sections.len(), order.div_ceil(2));
            let gain = |hz: f64| {
                let n = 2400;
                let mut z = vec![[0.0; 2]; sections.len()];
                let y: Vec<f64> = (0..n)
                    .map(|i| {
                        let mut v = (2.0 * PI * hz * i as f64 / 120.0).sin();
                        for (s, z) in sections.iter().zip(z.iter_mut()) {
                            v = s.step(v, z);
                        }
                        v
                    })
                    .collect();
                let m = &y[n / 2..];
                (m.iter().map(|v| v * v).sum::<f64>() / m.len() as f64).sqrt() * 2f64.sqrt()
            };
            assert_relative_eq!(gain(6.0), 0.5f64.sqrt(), epsilon = 0.01);
            assert!(gain(0.5) > 0.99, "order {order}");
            assert!(
                gain(40.0) < 0.35f64.powi(order as i32),
                "order {order}: {}",
                gain(40.0)
            );
        }
        assert!(Biquad::causal_butterworth(6.0, 120.0, 9).is_err());
        assert!(Biquad::causal_butterworth(6.0, 120.0, 0).is_err());
        assert!(Biquad::causal_butterworth(14.0, 30.0, 2).is_err());
    }

    /// A knee-like swing (±0.3 m at 0.9 Hz, up to 1.7 m/s) with ±1 cm noise at 30 Hz: each
    /// filter's delay is the shift that best aligns its output with the truth; the noise left
    /// is the frame-to-frame jerkiness (second difference) of the output minus the delayed
    /// truth. The 6 Hz order-2 low-pass delays by its group delay √2 / (2π f_c) ≈ 37 ms
    /// (within 12 ms) and cuts the noise jerkiness at least 3-fold, the One-Euro at least
    /// 2-fold with a delay under 60 ms; `none` changes nothing.
    #[test]
    fn smooths_noise_with_bounded_lag() {
        let truth = |t: f64| 0.3 * (2.0 * PI * 0.9 * t).sin();
        let time = |i: usize| i as f64 * PERIOD as f64 * 1e-9;
        let samples: Vec<(i64, Point3<f64>)> = (0..600_usize)
            .map(|i| {
                let p = Point3::new(truth(time(i)) + 0.01 * noise(i as u64), 0.0, 1.0);
                (i as i64 * PERIOD, p)
            })
            .collect();
        let raw_noise: Vec<f64> = samples
            .iter()
            .enumerate()
            .map(|(i, (_, p))| p.x - truth(time(i)))
            .collect();
        for params in all_filters() {
            let mut f = PoseFilter::new(params).unwrap();
            let out: Vec<f64> = run(&mut f, Joint::KneeLeft, &samples)
                .into_iter()
                .map(|o| o.position().unwrap().x)
                .collect();
            let residual = |lag_ms: i32| -> Vec<f64> {
                (60..600)
                    .map(|i| out[i] - truth(time(i) - f64::from(lag_ms) * 1e-3))
                    .collect()
            };
            let lag_ms = (0_i32..=200)
                .min_by(|a, b| {
                    let e = |ms| residual(ms).iter().map(|v| v * v).sum::<f64>();
                    e(*a).total_cmp(&e(*b))
                })
                .unwrap_or(0);
            let ratio = accel_rms(&residual(lag_ms)) / accel_rms(&raw_noise[60..]);
            match params.filter {
                StreamFilter::None => {
                    assert_eq!(lag_ms, 0);
                    assert_relative_eq!(ratio, 1.0, epsilon = 1e-9);
                }
                StreamFilter::LowPass(LowPassParams { order: 2, .. }) => {
                    assert!((lag_ms - 37).abs() <= 12, "lag {lag_ms} ms");
                    assert!(ratio < 0.33, "noise jerk ratio {ratio}");
                }
                StreamFilter::LowPass(_) => assert!(ratio < 0.33, "noise jerk ratio {ratio}"),
                StreamFilter::OneEuro(_) => {
                    assert!(lag_ms < 60, "lag {lag_ms} ms");
                    assert!(ratio < 0.5, "noise jerk ratio {ratio}");
                }
            }
            eprintln!(
                "{}: lag {lag_ms} ms, noise jerk ratio {ratio:.3}",
                params.filter
            );
        }
    }

    /// NaN is rejected and never reaches a later output; a missing joint, a long gap and a
    /// stamp going backwards restart the joint (the restarting sample passes through) and are
    /// counted; no panic on any of it.
    #[test]
    fn bad_input_resets_and_is_counted() {
        for params in all_filters() {
            let mut f = PoseFilter::new(params).unwrap();
            let p = |x: f64| Point3::new(x, 0.2, 0.9);
            let knee = Joint::KneeLeft;
            let hip = Joint::HipLeft;
            for i in 0..10 {
                let _ = f.push(i * PERIOD, [(knee, &p(0.1 * i as f64)), (hip, &p(0.0))]);
            }
            // NaN knee: rejected, hip filtered on.
            let nan = Point3::new(f64::NAN, 0.0, 0.0);
            let o = f.push(10 * PERIOD, [(knee, &nan), (hip, &p(0.0))]);
            assert_eq!(o[&knee], JointOutcome::NonFinite);
            assert!(matches!(o[&hip], JointOutcome::Filtered(_)));
            // Next knee restarts from scratch: no NaN inside.
            let o = f.push(11 * PERIOD, [(knee, &p(1.1)), (hip, &p(0.0))]);
            assert_eq!(o[&knee], JointOutcome::Started(p(1.1)));
            for i in 12..20 {
                let o = f.push(i * PERIOD, [(knee, &p(0.1 * i as f64)), (hip, &p(0.0))]);
                assert!(o[&knee].position().unwrap().x.is_finite());
            }
            // Hip missing once, then back: restarted.
            let _ = f.push(20 * PERIOD, [(knee, &p(2.0))]);
            let o = f.push(21 * PERIOD, [(knee, &p(2.1)), (hip, &p(0.5))]);
            assert_eq!(o[&hip], JointOutcome::Started(p(0.5)));
            // A 1 s gap: restarted at the new place.
            let o = f.push(51 * PERIOD, [(knee, &p(5.0)), (hip, &p(0.5))]);
            assert_eq!(o[&knee], JointOutcome::Started(p(5.0)));
            // Time backwards.
            let o = f.push(40 * PERIOD, [(knee, &p(5.0)), (hip, &p(0.5))]);
            assert_eq!(o[&knee], JointOutcome::Started(p(5.0)));
            let r = &f.counts().resets;
            assert_eq!(r.get(&ResetReason::NonFinite), Some(&1), "{r:?}");
            assert_eq!(r.get(&ResetReason::Missing), Some(&1), "{r:?}");
            assert_eq!(r.get(&ResetReason::Gap), Some(&2), "{r:?}");
            assert_eq!(r.get(&ResetReason::TimeBackwards), Some(&2), "{r:?}");
            assert_eq!(f.counts().poses, 24);
        }
    }

    /// A dropped pose (two intervals in one step) is bridged on the low-pass's grid: the
    /// output after it matches an uninterrupted run of a ramp within 1 mm, where treating the
    /// double interval as one would put the filter 3 cm behind.
    #[test]
    fn lowpass_bridges_a_dropped_pose() {
        let ramp = |i: i64| Point3::new(0.03 * i as f64, 0.0, 1.0);
        let mut full = PoseFilter::new(lowpass(6.0, 2)).unwrap();
        let mut holed = PoseFilter::new(lowpass(6.0, 2)).unwrap();
        let mut last = (0.0, 0.0);
        for i in 0..40 {
            let a = full.push(i * PERIOD, [(Joint::AnkleLeft, &ramp(i))]);
            if i == 20 {
                continue;
            }
            let b = holed.push(i * PERIOD, [(Joint::AnkleLeft, &ramp(i))]);
            last = (
                a[&Joint::AnkleLeft].position().unwrap().x,
                b[&Joint::AnkleLeft].position().unwrap().x,
            );
        }
        assert_relative_eq!(last.0, last.1, epsilon = 1e-3);
        assert!(holed.counts().resets.is_empty(), "{:?}", holed.counts());
    }

    /// A cut-off too high for the observed rate never panics: the joint passes through and
    /// the failure is counted.
    #[test]
    fn lowpass_too_fast_for_the_rate_passes_through() {
        let mut f = PoseFilter::new(lowpass(20.0, 2)).unwrap();
        for i in 0..5 {
            let p = Point3::new(i as f64, 0.0, 0.0);
            let o = f.push(i * PERIOD, [(Joint::KneeRight, &p)]);
            assert_eq!(o[&Joint::KneeRight].position(), Some(p));
        }
        assert_eq!(f.counts().resets.get(&ResetReason::CannotDesign), Some(&4));
    }

    /// Bad parameters are typed errors naming the parameter.
    #[test]
    fn rejects_bad_parameters() {
        let bad = [
            StreamParams {
                max_gap_secs: 0.0,
                ..StreamParams::default()
            },
            lowpass(-1.0, 2),
            lowpass(6.0, 0),
            StreamParams {
                filter: StreamFilter::OneEuro(OneEuroParams {
                    beta: -1.0,
                    ..OneEuroParams::default()
                }),
                ..StreamParams::default()
            },
        ];
        for p in bad {
            assert!(
                matches!(PoseFilter::new(p), Err(Error::BadParameter { .. })),
                "{p:?}"
            );
        }
    }
}
