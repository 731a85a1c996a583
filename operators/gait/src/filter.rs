//! Trajectory filters: zero-lag Butterworth low-pass and the One-Euro filter.
//!
//! Kinect joint positions are noisy (≈ 1 cm jitter, occasional jumps); gait events from a noisy
//! ankle come out early or late by frames. The **Butterworth** filter is the gait-lab standard for
//! offline data (Winter 2009, §3.4.4): second order, run forwards and backwards so the phase lag
//! cancels, its cut-off corrected for the double pass, and the signal padded at both ends by a
//! point reflection so the start and end of a walk are not pulled towards zero. The **One-Euro**
//! filter (Casiez et al. 2012) is causal, for live use: a first-order low-pass whose cut-off rises
//! with the speed, so a still joint is smoothed hard and a swinging ankle lags little.
//!
//! Gaps stay gaps: each run of present samples is filtered on its own, and filter state never
//! crosses a gap.

use std::f64::consts::{PI, SQRT_2};
use std::str::FromStr;

use nalgebra::{Point3, Vector3};
use serde::{Deserialize, Serialize};
use trigait_skeleton::MotionClip;

use crate::{Error, Result};

/// Parameters of the One-Euro filter (Casiez et al. 2012).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct OneEuroParams {
    /// Cut-off at rest (Hz). Default 1.0 Hz.
    pub min_cutoff_hz: f64,
    /// Cut-off increase per unit speed (Hz per m/s). Default 2.0: a 4 m/s swinging ankle is
    /// filtered at 9 Hz, a standing one at 1 Hz.
    pub beta: f64,
    /// Cut-off of the speed estimate (Hz). Default 1.0 Hz, the paper's value.
    pub derivative_cutoff_hz: f64,
}

impl Default for OneEuroParams {
    fn default() -> Self {
        Self {
            min_cutoff_hz: 1.0,
            beta: 2.0,
            derivative_cutoff_hz: 1.0,
        }
    }
}

/// A trajectory filter, as chosen on the command line or in YAML.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", tag = "kind")]
pub enum Filter {
    /// No filtering.
    #[default]
    None,
    /// Zero-lag second-order Butterworth low-pass with this −3 dB cut-off (Hz).
    Butterworth {
        /// Cut-off of the whole forward-backward filter (Hz); 6 Hz is usual for walking.
        cutoff_hz: f64,
    },
    /// The causal One-Euro filter.
    OneEuro(OneEuroParams),
}

/// The filter `trigait gait` applies to skeleton streams (joint centres: Kinect SDK text,
/// trigait's own exports) unless told otherwise: a 6 Hz zero-lag Butterworth, after the cleaning.
///
/// Chosen from a sweep (`scripts/gait_filter_sweep.py`) of none, Butterworth 4, 6, 8 and 10 Hz
/// and One-Euro. On the CMU and OpenSim walks played through the simulated three-Kinect pipeline
/// (10 noise seeds each), unfiltered streams missed the tolerances (stride 3 cm, cadence 2 %,
/// width 2 cm) in 8 of 20 runs, 4 and 6 Hz in none (mean stride error 0.7 cm, cadence
/// 0.3–0.4 %), 8 Hz in 2, 10 Hz in 4, One-Euro in 2. On the real CHU Kinect log 6 Hz keeps only
/// walking strides and steps, as unfiltered; 4 and 10 Hz lose its one complete stride, and 8 Hz,
/// 10 Hz and One-Euro find a left step at 234–279 steps/min that only the travel check
/// ([`crate::MAX_TRAVEL_MISMATCH_M`]) keeps out of the figures.
/// 6 Hz is also the usual cut-off for walking (Winter 2009). Marker data is left unfiltered.
pub const SKELETON_FILTER: Filter = Filter::Butterworth { cutoff_hz: 6.0 };

/// The filter for a skeleton stream sampled at `rate_hz`: [`SKELETON_FILTER`], or none where
/// the rate is too low for its cut-off (under about 16 Hz, as for a Kinect log read at
/// `--rate 10`; such a stream holds little above 6 Hz to remove).
#[must_use]
pub fn skeleton_filter(rate_hz: f64) -> Filter {
    SKELETON_FILTER.or_none_at(rate_hz)
}

const FILTER_FORMS: &str = "none, butterworth, butterworth:<cut-off>hz (e.g. butterworth:6hz), \
                            one-euro or one-euro:<min cut-off>hz:<beta> (e.g. one-euro:1hz:2)";

fn parse_hz(text: &str) -> Option<f64> {
    let t = text.trim().to_ascii_lowercase();
    let t = t.strip_suffix("hz").unwrap_or(&t);
    t.trim()
        .parse::<f64>()
        .ok()
        .filter(|v| v.is_finite() && *v > 0.0)
}

impl FromStr for Filter {
    type Err = Error;

    /// Parses `none`, `butterworth[:<f>hz]` (default 6 Hz) or
    /// `one-euro[:<min cut-off>hz[:<beta>]]`.
    fn from_str(spec: &str) -> Result<Self> {
        let bad = || Error::BadFilterSpec {
            spec: spec.to_owned(),
            expected: FILTER_FORMS,
        };
        let lower = spec.trim().to_ascii_lowercase();
        let mut parts = lower.split(':');
        let kind = parts.next().unwrap_or_default();
        let args: Vec<&str> = parts.collect();
        match kind {
            "none" | "off" if args.is_empty() => Ok(Filter::None),
            "butterworth" | "butter" => match args.as_slice() {
                [] => Ok(Filter::Butterworth { cutoff_hz: 6.0 }),
                [hz] => parse_hz(hz)
                    .map(|cutoff_hz| Filter::Butterworth { cutoff_hz })
                    .ok_or_else(bad),
                _ => Err(bad()),
            },
            "one-euro" | "oneeuro" | "one_euro" | "1euro" => {
                let mut p = OneEuroParams::default();
                match args.as_slice() {
                    [] => {}
                    [hz] => p.min_cutoff_hz = parse_hz(hz).ok_or_else(bad)?,
                    [hz, beta] => {
                        p.min_cutoff_hz = parse_hz(hz).ok_or_else(bad)?;
                        p.beta = beta
                            .trim()
                            .parse::<f64>()
                            .ok()
                            .filter(|b| b.is_finite() && *b >= 0.0)
                            .ok_or_else(bad)?;
                    }
                    _ => return Err(bad()),
                }
                Ok(Filter::OneEuro(p))
            }
            _ => Err(bad()),
        }
    }
}

impl std::fmt::Display for Filter {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Filter::None => write!(f, "none"),
            Filter::Butterworth { cutoff_hz } => write!(f, "butterworth:{cutoff_hz}hz"),
            Filter::OneEuro(p) => write!(f, "one-euro:{}hz:{}", p.min_cutoff_hz, p.beta),
        }
    }
}

impl Filter {
    /// Filters every joint trajectory of `clip`, each coordinate and each gap-free run apart.
    ///
    /// # Errors
    /// [`Error::BadParameter`] for a cut-off at or above the Nyquist frequency (after the
    /// double-pass correction) or non-positive parameters.
    pub fn apply(&self, clip: &MotionClip) -> Result<MotionClip> {
        let rate = clip.rate_hz();
        let joints = clip.joints().to_vec();
        let n = clip.frame_count();
        let mut columns: Vec<Vec<Option<Point3<f64>>>> = Vec::with_capacity(joints.len());
        for joint in &joints {
            let track: Vec<Option<Point3<f64>>> =
                (0..n).map(|f| clip.position(f, *joint)).collect();
            columns.push(self.apply_track(&track, rate)?);
        }
        let frames = (0..n)
            .map(|f| {
                columns
                    .iter()
                    .map(|c| c.get(f).copied().flatten())
                    .collect()
            })
            .collect();
        Ok(MotionClip::new(clip.name(), rate, joints, frames)?)
    }

    /// This filter where a stream sampled at `rate_hz` can carry it ([`Filter::validate`]),
    /// otherwise none.
    #[must_use]
    pub fn or_none_at(self, rate_hz: f64) -> Filter {
        if self.validate(rate_hz).is_ok() {
            self
        } else {
            Filter::None
        }
    }

    /// Whether the filter can run on data sampled at `rate_hz` (a Butterworth cut-off must lie
    /// below 0.76 × the Nyquist frequency).
    ///
    /// # Errors
    /// [`Error::BadParameter`] naming what does not fit.
    pub fn validate(&self, rate_hz: f64) -> Result<()> {
        match self {
            Filter::None => Ok(()),
            Filter::Butterworth { cutoff_hz } => {
                Biquad::zero_lag_lowpass(*cutoff_hz, rate_hz).map(|_| ())
            }
            Filter::OneEuro(params) => OneEuro::new(*params).map(|_| ()),
        }
    }

    /// Filters one trajectory sampled at `rate_hz`; `None` samples are gaps and stay gaps.
    ///
    /// # Errors
    /// As [`Filter::apply`].
    pub fn apply_track(
        &self,
        track: &[Option<Point3<f64>>],
        rate_hz: f64,
    ) -> Result<Vec<Option<Point3<f64>>>> {
        let mut out = track.to_vec();
        let runs = runs(track);
        match self {
            Filter::None => {}
            Filter::Butterworth { cutoff_hz } => {
                let biquad = Biquad::zero_lag_lowpass(*cutoff_hz, rate_hz)?;
                for (a, b) in runs {
                    for axis in 0..3 {
                        let x: Vec<f64> = track[a..b]
                            .iter()
                            .map(|p| p.map_or(0.0, |p| p[axis]))
                            .collect();
                        let y = biquad.filtfilt(&x, cutoff_hz_pad(*cutoff_hz, rate_hz));
                        for (k, v) in y.into_iter().enumerate() {
                            if let Some(Some(p)) = out.get_mut(a + k) {
                                p[axis] = v;
                            }
                        }
                    }
                }
            }
            Filter::OneEuro(params) => {
                for (a, b) in runs {
                    let mut filter = OneEuro::new(*params)?;
                    for (k, p) in track[a..b].iter().enumerate() {
                        if let Some(p) = p {
                            let t = (a + k) as f64 / rate_hz;
                            out[a + k] = Some(Point3::from(filter.filter(t, &p.coords)));
                        }
                    }
                }
            }
        }
        Ok(out)
    }
}

/// Half-open ranges of consecutive present samples.
fn runs(track: &[Option<Point3<f64>>]) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    let mut i = 0;
    while i < track.len() {
        if track[i].is_none() {
            i += 1;
            continue;
        }
        let start = i;
        while i < track.len() && track[i].is_some() {
            i += 1;
        }
        out.push((start, i));
    }
    out
}

/// Padding at each end: one period of the cut-off, enough for the transient to decay.
fn cutoff_hz_pad(cutoff_hz: f64, rate_hz: f64) -> usize {
    (rate_hz / cutoff_hz).ceil().max(6.0) as usize
}

/// A second-order IIR section, `a0` normalised to 1.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Biquad {
    b: [f64; 3],
    a: [f64; 2],
}

/// Winter's correction for a second-order filter run twice: each pass is designed with its
/// cut-off raised by 1 / (2^(1/2) − 1)^(1/4) ≈ 1/0.802 so that the −3 dB point of the cascade
/// lands on the requested cut-off (Winter 2009, §3.4.4.3).
const DOUBLE_PASS_CORRECTION: f64 = 0.802_419_7;

impl Biquad {
    /// Second-order Butterworth low-pass for a forward-backward pass whose combined −3 dB point is
    /// `cutoff_hz`, by the bilinear transform with pre-warping and Winter's double-pass correction.
    ///
    /// # Errors
    /// [`Error::BadParameter`] unless 0 < corrected cut-off < Nyquist.
    pub fn zero_lag_lowpass(cutoff_hz: f64, rate_hz: f64) -> Result<Self> {
        if !(rate_hz.is_finite() && rate_hz > 0.0) {
            return Err(Error::BadParameter {
                name: "rate_hz",
                value: rate_hz,
                expected: "a positive sample rate",
            });
        }
        let nyquist = rate_hz / 2.0;
        if !(cutoff_hz.is_finite()
            && cutoff_hz > 0.0
            && cutoff_hz / DOUBLE_PASS_CORRECTION < 0.95 * nyquist)
        {
            return Err(Error::BadParameter {
                name: "cutoff_hz",
                value: cutoff_hz,
                expected: "a cut-off above 0 and below 0.76 × the Nyquist frequency",
            });
        }
        let k = (PI * cutoff_hz / rate_hz).tan() / DOUBLE_PASS_CORRECTION;
        let norm = 1.0 / (1.0 + SQRT_2 * k + k * k);
        let b0 = k * k * norm;
        Ok(Self {
            b: [b0, 2.0 * b0, b0],
            a: [
                2.0 * (k * k - 1.0) * norm,
                (1.0 - SQRT_2 * k + k * k) * norm,
            ],
        })
    }

    /// A causal Butterworth low-pass of `order` (1–8) with its −3 dB point at `cutoff_hz`, as a
    /// cascade of second-order sections (one first-order section for an odd order), by the
    /// bilinear transform with pre-warping. The analogue prototype's poles lie on the unit
    /// circle at angles π(2k + n − 1)/(2n); each conjugate pair becomes one section
    /// 1 / (s² + 2 sin(π(2k − 1)/(2n)) s + 1). Unlike [`Biquad::zero_lag_lowpass`] this is
    /// run once, forwards, so it has phase lag (≈ 1/(2π f_c) × √2 s at low frequencies for
    /// order 2, e.g. 37 ms at 6 Hz) and no double-pass correction; it is what a live
    /// dataflow can do, since it cannot see the future.
    ///
    /// # Errors
    /// [`Error::BadParameter`] for an order outside 1–8, a non-positive rate or a cut-off not
    /// below 0.45 × the sample rate (0.9 × Nyquist).
    pub fn causal_butterworth(cutoff_hz: f64, rate_hz: f64, order: usize) -> Result<Vec<Self>> {
        if !(1..=8).contains(&order) {
            return Err(Error::BadParameter {
                name: "order",
                value: order as f64,
                expected: "a filter order from 1 to 8",
            });
        }
        if !(rate_hz.is_finite() && rate_hz > 0.0) {
            return Err(Error::BadParameter {
                name: "rate_hz",
                value: rate_hz,
                expected: "a positive sample rate",
            });
        }
        if !(cutoff_hz.is_finite() && cutoff_hz > 0.0 && cutoff_hz < 0.45 * rate_hz) {
            return Err(Error::BadParameter {
                name: "cutoff_hz",
                value: cutoff_hz,
                expected: "a cut-off above 0 and below 0.9 × the Nyquist frequency",
            });
        }
        let k = (PI * cutoff_hz / rate_hz).tan();
        let n = order as f64;
        let mut sections = Vec::with_capacity(order.div_ceil(2));
        for i in 1..=order / 2 {
            let damping = 2.0 * (PI * (2.0 * i as f64 - 1.0) / (2.0 * n)).sin();
            let norm = 1.0 / (1.0 + damping * k + k * k);
            let b0 = k * k * norm;
            sections.push(Self {
                b: [b0, 2.0 * b0, b0],
                a: [
                    2.0 * (k * k - 1.0) * norm,
                    (1.0 - damping * k + k * k) * norm,
                ],
            });
        }
        if order % 2 == 1 {
            let norm = 1.0 / (1.0 + k);
            sections.push(Self {
                b: [k * norm, k * norm, 0.0],
                a: [(k - 1.0) * norm, 0.0],
            });
        }
        Ok(sections)
    }

    /// The state (transposed direct form II) in which a constant input `x0` gives output `x0`
    /// (the DC gain of a low-pass section is 1), so a filter starts without a transient.
    #[must_use]
    pub(crate) fn steady_state(&self, x0: f64) -> [f64; 2] {
        let z2 = (self.b[2] - self.a[1]) * x0;
        [(self.b[1] - self.a[0]) * x0 + z2, z2]
    }

    /// One causal step (transposed direct form II) with the section state `z`.
    pub(crate) fn step(&self, x: f64, z: &mut [f64; 2]) -> f64 {
        let y = self.b[0] * x + z[0];
        z[0] = self.b[1] * x - self.a[0] * y + z[1];
        z[1] = self.b[2] * x - self.a[1] * y;
        y
    }

    /// One causal pass (transposed direct form II), started in the steady state of `x[0]`.
    fn pass(&self, x: &[f64]) -> Vec<f64> {
        let [b0, b1, b2] = self.b;
        let [a1, a2] = self.a;
        let x0 = x.first().copied().unwrap_or(0.0);
        // Steady state for a constant input x0 (DC gain is 1).
        let mut z2 = (b2 - a2) * x0;
        let mut z1 = (b1 - a1) * x0 + z2;
        x.iter()
            .map(|&xi| {
                let y = b0 * xi + z1;
                z1 = b1 * xi - a1 * y + z2;
                z2 = b2 * xi - a2 * y;
                y
            })
            .collect()
    }

    /// Forward-backward filtering with `pad` samples of odd reflection at each end
    /// (x[-k] = 2·x[0] − x[k]), which continues a linear trend through the ends.
    #[must_use]
    pub fn filtfilt(&self, x: &[f64], pad: usize) -> Vec<f64> {
        let n = x.len();
        if n < 2 {
            return x.to_vec();
        }
        let pad = pad.min(n - 1);
        let (first, last) = (x[0], x[n - 1]);
        let mut ext = Vec::with_capacity(n + 2 * pad);
        ext.extend((1..=pad).rev().map(|k| 2.0 * first - x[k]));
        ext.extend_from_slice(x);
        ext.extend((1..=pad).map(|k| 2.0 * last - x[n - 1 - k]));
        let forward = self.pass(&ext);
        let mut backward: Vec<f64> = forward.into_iter().rev().collect();
        backward = self.pass(&backward);
        backward.reverse();
        backward[pad..pad + n].to_vec()
    }
}

/// Streaming One-Euro filter of a 3-D position (Casiez et al. 2012).
///
/// The speed that sets the cut-off is the norm of the filtered velocity vector, so all three
/// coordinates share one cut-off and the joint's path is not distorted axis by axis.
#[derive(Debug, Clone, PartialEq)]
pub struct OneEuro {
    params: OneEuroParams,
    last: Option<(f64, Vector3<f64>, Vector3<f64>)>,
}

impl OneEuro {
    /// A filter with no history.
    ///
    /// # Errors
    /// [`Error::BadParameter`] for non-positive cut-offs or a negative beta.
    pub fn new(params: OneEuroParams) -> Result<Self> {
        for (name, value, ok) in [
            (
                "min_cutoff_hz",
                params.min_cutoff_hz,
                params.min_cutoff_hz > 0.0,
            ),
            ("beta", params.beta, params.beta >= 0.0),
            (
                "derivative_cutoff_hz",
                params.derivative_cutoff_hz,
                params.derivative_cutoff_hz > 0.0,
            ),
        ] {
            if !(value.is_finite() && ok) {
                return Err(Error::BadParameter {
                    name,
                    value,
                    expected: "positive cut-offs and a non-negative beta",
                });
            }
        }
        Ok(Self { params, last: None })
    }

    /// Smoothing factor of a first-order low-pass with `cutoff_hz` over `dt` seconds.
    fn alpha(cutoff_hz: f64, dt: f64) -> f64 {
        let tau = 1.0 / (2.0 * PI * cutoff_hz);
        1.0 / (1.0 + tau / dt)
    }

    /// Filters the sample `x` taken at `t_secs`; a sample not later than the previous one
    /// restarts the filter.
    pub fn filter(&mut self, t_secs: f64, x: &Vector3<f64>) -> Vector3<f64> {
        let Some((t0, x0, dx0)) = self.last else {
            self.last = Some((t_secs, *x, Vector3::zeros()));
            return *x;
        };
        let dt = t_secs - t0;
        if !(dt.is_finite() && dt > 0.0) {
            self.last = Some((t_secs, *x, Vector3::zeros()));
            return *x;
        }
        let dx = (x - x0) / dt;
        let dx_hat = dx0.lerp(&dx, Self::alpha(self.params.derivative_cutoff_hz, dt));
        let cutoff = self.params.min_cutoff_hz + self.params.beta * dx_hat.norm();
        let x_hat = x0.lerp(x, Self::alpha(cutoff, dt));
        self.last = Some((t_secs, x_hat, dx_hat));
        x_hat
    }

    /// Forgets the history (e.g. after a gap).
    pub fn reset(&mut self) {
        self.last = None;
    }
}

#[cfg(test)]
mod tests {
    use approx::assert_relative_eq;

    use super::*;

    /// Skeletons get 6 Hz where the rate allows it, and nothing where it does not.
    #[test]
    fn skeleton_filter_fits_the_rate() {
        assert_eq!(skeleton_filter(30.0), SKELETON_FILTER);
        assert_eq!(skeleton_filter(100.0), SKELETON_FILTER);
        assert_eq!(skeleton_filter(10.0), Filter::None);
        assert!(matches!(skeleton_filter(15.0), Filter::None));
    }

    fn sine(freq_hz: f64, rate_hz: f64, secs: f64) -> Vec<f64> {
        let n = (secs * rate_hz) as usize;
        (0..n)
            .map(|i| (2.0 * PI * freq_hz * i as f64 / rate_hz).sin())
            .collect()
    }

    fn amplitude(x: &[f64]) -> f64 {
        // RMS over the middle half, times √2.
        let m = &x[x.len() / 4..3 * x.len() / 4];
        (m.iter().map(|v| v * v).sum::<f64>() / m.len() as f64).sqrt() * SQRT_2
    }

    /// The forward-backward filter is −3 dB at the requested cut-off (Winter's correction),
    /// passes low frequencies and stops high ones.
    #[test]
    fn butterworth_gain() {
        let f = Biquad::zero_lag_lowpass(6.0, 120.0).unwrap();
        let at = |hz| amplitude(&f.filtfilt(&sine(hz, 120.0, 10.0), 20));
        assert_relative_eq!(at(6.0), 0.5f64.sqrt(), epsilon = 0.02);
        assert!(at(1.0) > 0.99);
        assert!(at(30.0) < 0.01);
    }

    /// Zero lag: a filtered low-frequency sine has its peaks where the input has them.
    #[test]
    fn butterworth_has_no_lag() {
        let f = Biquad::zero_lag_lowpass(6.0, 100.0).unwrap();
        let x = sine(1.0, 100.0, 4.0);
        let y = f.filtfilt(&x, 17);
        let argmax = |v: &[f64]| (0..100).max_by(|a, b| v[*a].total_cmp(&v[*b])).unwrap_or(0);
        assert_eq!(argmax(&y), argmax(&x));
    }

    /// Odd padding keeps a linear trend at both ends (within 1 mm here, the start-up transient
    /// decaying inside the padding), where zero padding would pull the ends 1.5 m towards zero.
    #[test]
    fn butterworth_edges_follow_trends() {
        let f = Biquad::zero_lag_lowpass(4.0, 100.0).unwrap();
        let x: Vec<f64> = (0..80).map(|i| 1.5 + 0.02 * f64::from(i)).collect();
        let y = f.filtfilt(&x, 25);
        for (a, b) in x.iter().zip(&y) {
            assert_relative_eq!(a, b, epsilon = 1e-3);
        }
    }

    /// A cut-off at or beyond Nyquist is a typed error.
    #[test]
    fn butterworth_rejects_bad_cutoff() {
        assert!(matches!(
            Biquad::zero_lag_lowpass(50.0, 100.0),
            Err(Error::BadParameter {
                name: "cutoff_hz",
                ..
            })
        ));
        assert!(Biquad::zero_lag_lowpass(-1.0, 100.0).is_err());
        assert!(Biquad::zero_lag_lowpass(6.0, 0.0).is_err());
    }

    /// One-Euro smooths jitter at rest and follows a fast move with little lag.
    #[test]
    fn one_euro_adapts_to_speed() {
        let mut f = OneEuro::new(OneEuroParams::default()).unwrap();
        let rate = 30.0;
        // At rest with ±1 cm alternating jitter.
        let mut still = Vec::new();
        for i in 0..60 {
            let j = if i % 2 == 0 { 0.01 } else { -0.01 };
            still.push(f.filter(f64::from(i) / rate, &Vector3::new(j, 0.0, 0.0)).x);
        }
        let jitter = still[30..].iter().fold(0.0f64, |m, v| m.max(v.abs()));
        assert!(jitter < 0.002, "residual jitter {jitter}");
        // Then a 3 m/s move: after 0.5 s the lag is a few centimetres, not the 0.5 m a 1 Hz
        // fixed low-pass would leave.
        let mut last = 0.0;
        for i in 60..75 {
            let t = f64::from(i) / rate;
            let x = 3.0 * (t - 2.0);
            last = x - f.filter(t, &Vector3::new(x, 0.0, 0.0)).x;
        }
        assert!(last > 0.0 && last < 0.12, "lag {last} m");
    }

    /// Filter specs parse and print back; nonsense is a typed error naming the accepted forms.
    #[test]
    fn filter_specs() {
        assert_eq!("none".parse::<Filter>().unwrap(), Filter::None);
        assert_eq!(
            "butterworth:6hz".parse::<Filter>().unwrap(),
            Filter::Butterworth { cutoff_hz: 6.0 }
        );
        assert_eq!(
            "Butterworth:4.5Hz".parse::<Filter>().unwrap(),
            Filter::Butterworth { cutoff_hz: 4.5 }
        );
        assert_eq!(
            "one-euro".parse::<Filter>().unwrap(),
            Filter::OneEuro(OneEuroParams::default())
        );
        let Filter::OneEuro(p) = "one-euro:1.5hz:0.7".parse::<Filter>().unwrap() else {
            panic!("not one-euro");
        };
        assert_relative_eq!(p.min_cutoff_hz, 1.5);
        assert_relative_eq!(p.beta, 0.7);
        for bad in [
            "kalman",
            "butterworth:fast",
            "butterworth:-3hz",
            "one-euro:1hz:2:3",
        ] {
            let err = bad.parse::<Filter>().unwrap_err();
            assert!(err.to_string().contains("butterworth:6hz"), "{err}");
        }
        let spec = Filter::Butterworth { cutoff_hz: 6.0 }.to_string();
        assert_eq!(
            spec.parse::<Filter>().unwrap(),
            Filter::Butterworth { cutoff_hz: 6.0 }
        );
    }

    /// Gaps stay gaps and the runs on either side are filtered independently.
    #[test]
    fn gaps_are_kept() {
        let mut track: Vec<Option<Point3<f64>>> = (0..40)
            .map(|i| Some(Point3::new(f64::from(i) * 0.01, 1.0, 0.5)))
            .collect();
        track[20] = None;
        for filter in [
            Filter::Butterworth { cutoff_hz: 6.0 },
            Filter::OneEuro(OneEuroParams::default()),
        ] {
            let out = filter.apply_track(&track, 100.0).unwrap();
            assert!(out[20].is_none());
            assert_eq!(out.iter().filter(|p| p.is_none()).count(), 1);
            assert_relative_eq!(out[39].unwrap().y, 1.0, epsilon = 1e-9);
        }
    }
}
