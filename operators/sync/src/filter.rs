//! Per-sensor clock filter: offset **and drift** from a window of NTP samples.
//!
//! The thesis (§6.4.1) takes one exchange at a time and trusts it to ±d/2. A Kinect PC's quartz
//! drifts by tens of ppm (100 ppm = 0.1 ms per second), so an offset measured once is stale within
//! seconds, and a single exchange that met a busy switch is off by milliseconds. This filter
//! therefore, like NTP's clock filter:
//!
//! 1. keeps the last [`ClockFilterParams::window_len`] accepted samples;
//! 2. uses only the lowest-delay fraction of them ([`ClockFilterParams::keep_fraction`]): low delay
//!    means a tight eq. 6.3 bound, high delay usually means queueing on one leg only;
//! 3. fits `offset(t) = a + b·(t − t_ref)` by weighted least squares (weights 1/(d/2)²), where `b`
//!    is the drift (dimensionless; ×10⁶ = ppm), falling back to the previous drift when the window
//!    spans too little time to fit one;
//! 4. maps a sensor-local stamp to server time by inverting that line, with an uncertainty made of
//!    the tightest eq. 6.3 bound among the samples used plus three standard deviations of the fitted
//!    line at that instant (which grows with the distance from the samples: extrapolation error);
//! 5. under sustained load, when every exchange so far took longer than
//!    [`ClockFilterParams::max_delay_nanos`], falls back to the over-limit samples once a whole
//!    window ([`ClockFilterParams::window_len`]) of them is in: a sensor then synchronises with
//!    an honest, wide uncertainty (their d/2) instead of never; the first sample within the limit
//!    replaces them. Not sooner: at start-up, while every process is still launching, round trips
//!    of hundreds of milliseconds are common for a second or two, and a fallback on those (tried
//!    with `min_used` samples) mapped frames with errors of up to 190 ms at 16 sensors;
//! 6. detects a clock **step** (someone set the sensor's clock, an NTP daemon slewed it): a sample
//!    whose offset is outside every error bound is held back; [`ClockFilterParams::step_confirm_samples`]
//!    such samples agreeing with each other reset the window to them and are reported as a step,
//!    with the number of exchanges from the first that disagreed through the one that confirmed
//!    it (how long, in exchanges, frames were mapped with the stale estimate).
//!
//! Offsets are "sensor clock minus server clock" (see [`crate::ntp`]).

use std::collections::VecDeque;

use crate::ntp::{NtpMeasurement, NtpSample, Rejection};
use crate::{Error, Result};

/// Tuning of a [`ClockFilter`]. Defaults suit a LAN (delays well under 1 ms, thesis §6.4.1) with
/// one exchange every 0.5 s.
#[derive(Debug, Clone, PartialEq)]
pub struct ClockFilterParams {
    /// Accepted samples kept (default 32: 16 s at 2 exchanges per second).
    pub window_len: usize,
    /// Fraction of the window, lowest delay first, used in the fit (default 0.5).
    pub keep_fraction: f64,
    /// Fewest samples used in a fit, if the window has them (default 4). Also the samples a
    /// filter needs before its first fit: until then it maps nothing (the sensor is not
    /// synchronised). One start-up exchange that met a busy core is off by up to its d/2 —
    /// 5 ms has been seen — and would map the first frames with that error; among four, the
    /// fastest carries the fit.
    pub min_used: usize,
    /// Time the used samples must span before drift is fitted rather than carried over
    /// (default 2 s).
    pub min_drift_span_nanos: i64,
    /// Samples with a larger round-trip delay are rejected while the window holds any sample
    /// within it (default 20 ms); see the module docs, point 5, for the fallback.
    pub max_delay_nanos: i64,
    /// A fitted drift beyond this is treated as a failed fit (default 500 ppm; quartz is ≤ 100).
    pub max_drift_ppm: f64,
    /// Floor on the d/2 used as a weight, so a zero-delay sample does not get infinite weight
    /// (default 10 µs).
    pub delay_floor_nanos: i64,
    /// Extra margin beyond the error bounds before a sample counts as inconsistent (default 1 ms).
    pub step_threshold_nanos: i64,
    /// Consecutive mutually consistent inconsistent samples that make a step (default 3).
    pub step_confirm_samples: usize,
}

impl Default for ClockFilterParams {
    fn default() -> Self {
        ClockFilterParams {
            window_len: 32,
            keep_fraction: 0.5,
            min_used: 4,
            min_drift_span_nanos: 2_000_000_000,
            max_delay_nanos: 20_000_000,
            max_drift_ppm: 500.0,
            delay_floor_nanos: 10_000,
            step_threshold_nanos: 1_000_000,
            step_confirm_samples: 3,
        }
    }
}

impl ClockFilterParams {
    /// Sets [`Self::window_len`].
    #[must_use]
    pub fn with_window_len(mut self, window_len: usize) -> Self {
        self.window_len = window_len;
        self
    }

    /// Sets [`Self::keep_fraction`].
    #[must_use]
    pub fn with_keep_fraction(mut self, keep_fraction: f64) -> Self {
        self.keep_fraction = keep_fraction;
        self
    }

    /// Sets [`Self::max_delay_nanos`].
    #[must_use]
    pub fn with_max_delay_nanos(mut self, max_delay_nanos: i64) -> Self {
        self.max_delay_nanos = max_delay_nanos;
        self
    }

    /// Sets [`Self::step_threshold_nanos`].
    #[must_use]
    pub fn with_step_threshold_nanos(mut self, step_threshold_nanos: i64) -> Self {
        self.step_threshold_nanos = step_threshold_nanos;
        self
    }

    /// Sets [`Self::step_confirm_samples`].
    #[must_use]
    pub fn with_step_confirm_samples(mut self, step_confirm_samples: usize) -> Self {
        self.step_confirm_samples = step_confirm_samples;
        self
    }

    /// Checks every field; the error names the first bad one.
    pub fn validate(&self) -> Result<()> {
        let bad = |param: &'static str, value: String, expected: &'static str| {
            Err(Error::InvalidParam {
                param,
                value,
                expected,
            })
        };
        if self.window_len < 1 {
            return bad(
                "clock.window_len",
                self.window_len.to_string(),
                "at least 1",
            );
        }
        if !(self.keep_fraction > 0.0 && self.keep_fraction <= 1.0) {
            return bad(
                "clock.keep_fraction",
                self.keep_fraction.to_string(),
                "in (0, 1]",
            );
        }
        if self.min_used < 1 {
            return bad("clock.min_used", self.min_used.to_string(), "at least 1");
        }
        if self.min_drift_span_nanos < 1 {
            return bad(
                "clock.min_drift_span_nanos",
                self.min_drift_span_nanos.to_string(),
                "positive",
            );
        }
        if self.max_delay_nanos < 0 {
            return bad(
                "clock.max_delay_nanos",
                self.max_delay_nanos.to_string(),
                "non-negative",
            );
        }
        if !(self.max_drift_ppm.is_finite() && self.max_drift_ppm > 0.0) {
            return bad(
                "clock.max_drift_ppm",
                self.max_drift_ppm.to_string(),
                "positive and finite",
            );
        }
        if self.delay_floor_nanos < 1 {
            return bad(
                "clock.delay_floor_nanos",
                self.delay_floor_nanos.to_string(),
                "positive",
            );
        }
        if self.step_threshold_nanos < 0 {
            return bad(
                "clock.step_threshold_nanos",
                self.step_threshold_nanos.to_string(),
                "non-negative",
            );
        }
        if self.step_confirm_samples < 1 {
            return bad(
                "clock.step_confirm_samples",
                self.step_confirm_samples.to_string(),
                "at least 1",
            );
        }
        Ok(())
    }
}

/// What [`ClockFilter::push`] did with a sample.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SampleOutcome {
    /// Added to the window; the estimate was refitted.
    Accepted(NtpMeasurement),
    /// Not used, with the reason.
    Rejected(Rejection),
    /// The sensor clock stepped: the window was reset to the samples that showed it.
    Step {
        /// How far the sensor clock jumped (positive: forward), nanoseconds.
        step_nanos: i64,
        /// Server time of the newest sample that confirmed the step.
        at_server_nanos: i64,
        /// Server time of the newest exchange that still agreed with the previous estimate:
        /// the clock stepped after it, so frames captured between it and `at_server_nanos`
        /// may have been mapped with the old estimate.
        agreed_server_nanos: i64,
        /// Exchanges from the first that disagreed with the previous estimate through this
        /// one, rejected ones included (at least [`ClockFilterParams::step_confirm_samples`]):
        /// until this exchange, frames were mapped with the estimate from before the step.
        exchanges: u64,
    },
}

/// A sensor-local instant mapped to server time.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct ServerTime {
    /// The instant on the server clock, nanoseconds.
    pub server_nanos: i64,
    /// Half-width of the interval the true server time is expected in, nanoseconds.
    pub uncertainty_nanos: i64,
}

/// The current offset/drift estimate of one sensor clock, for reports and plots.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ClockEstimate {
    /// Sensor clock minus server clock at [`Self::at_server_nanos`], nanoseconds.
    pub offset_nanos: i64,
    /// Server time of the newest sample in the window.
    pub at_server_nanos: i64,
    /// Sensor clock rate minus server clock rate, ppm (positive: sensor runs fast).
    pub drift_ppm: f64,
    /// Whether the drift was fitted from this window (`false`: carried over or assumed 0).
    pub drift_fitted: bool,
    /// Uncertainty of the offset at [`Self::at_server_nanos`], nanoseconds.
    pub uncertainty_nanos: i64,
    /// Samples the fit used.
    pub samples_used: usize,
    /// Samples in the window.
    pub samples_in_window: usize,
}

/// The fitted line `offset(t) = offset_ref + a + b·(t − ref)`, plus its covariance.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Fit {
    ref_nanos: i64,
    offset_ref_nanos: i64,
    a: f64,
    b: f64,
    var_a: f64,
    cov_ab: f64,
    var_b: f64,
    bound_nanos: i64,
    drift_fitted: bool,
    used: usize,
}

impl Fit {
    /// Offset (ns, relative to `offset_ref_nanos`) and its standard deviation at server time `t`.
    fn offset_at(&self, t: i64) -> (f64, f64) {
        let x = (i128::from(t) - i128::from(self.ref_nanos)) as f64;
        let var = self.var_a + 2.0 * x * self.cov_ab + x * x * self.var_b;
        (self.a + self.b * x, var.max(0.0).sqrt())
    }

    fn uncertainty_at(&self, t: i64) -> i64 {
        let (_, sigma) = self.offset_at(t);
        saturating_round(self.bound_nanos as f64 + 3.0 * sigma)
    }
}

/// Offset/drift filter of one sensor clock. See the module docs.
#[derive(Debug, Clone)]
pub struct ClockFilter {
    params: ClockFilterParams,
    window: VecDeque<NtpMeasurement>,
    /// Over-limit samples collected while the window has none within the limit (the fallback).
    overdelayed: VecDeque<NtpMeasurement>,
    pending: Vec<(NtpMeasurement, i64)>,
    fit: Option<Fit>,
    /// Drift and its variance, kept across steps (a step moves the offset, not the rate).
    drift_prior: Option<(f64, f64)>,
    newest_t1: Option<i64>,
    steps: u64,
    /// Exchanges pushed so far.
    exchanges: u64,
    /// While samples keep disagreeing with the fit: the exchange (of [`Self::exchanges`]) that
    /// first disagreed, and the server time of the newest sample that agreed before it.
    disagreeing_since: Option<(u64, i64)>,
    /// Whether the filter has had a fit: after that a step's shorter window still maps.
    synchronised: bool,
}

impl ClockFilter {
    /// A filter with no samples yet. Validates `params`.
    pub fn new(params: ClockFilterParams) -> Result<Self> {
        params.validate()?;
        Ok(ClockFilter {
            params,
            window: VecDeque::new(),
            overdelayed: VecDeque::new(),
            pending: Vec::new(),
            fit: None,
            drift_prior: None,
            newest_t1: None,
            steps: 0,
            exchanges: 0,
            disagreeing_since: None,
            synchronised: false,
        })
    }

    /// Feeds one exchange. Never panics: impossible timestamps come back as
    /// [`SampleOutcome::Rejected`] with the reason.
    pub fn push(&mut self, sample: NtpSample) -> SampleOutcome {
        self.exchanges += 1;
        let m = match sample.measure() {
            Ok(m) => m,
            Err(r) => return SampleOutcome::Rejected(r),
        };
        let limit = self.params.max_delay_nanos;
        let over_limit = m.delay_nanos > limit;
        let too_slow = Rejection::DelayAboveLimit {
            delay_nanos: m.delay_nanos,
            limit_nanos: limit,
        };
        if over_limit && self.window.iter().any(|w| w.delay_nanos <= limit) {
            return SampleOutcome::Rejected(too_slow);
        }
        if let Some(newest_t1) = self.newest_t1
            && sample.t1 <= newest_t1
        {
            return SampleOutcome::Rejected(Rejection::OutOfOrder {
                t1: sample.t1,
                newest_t1,
            });
        }
        self.newest_t1 = Some(sample.t1);
        if over_limit && self.window.is_empty() {
            // Nothing within the limit yet: collect, and fall back once there are enough.
            self.overdelayed.push_back(m);
            while self.overdelayed.len() > self.params.window_len {
                self.overdelayed.pop_front();
            }
            if self.overdelayed.len() < self.params.window_len {
                return SampleOutcome::Rejected(too_slow);
            }
            self.window = std::mem::take(&mut self.overdelayed);
            self.disagreeing_since = None;
            self.refit();
            return SampleOutcome::Accepted(m);
        }
        if !over_limit && self.window.iter().any(|w| w.delay_nanos > limit) {
            // The first sample within the limit ends the fallback.
            self.window.retain(|w| w.delay_nanos <= limit);
            self.overdelayed.clear();
            self.pending.clear();
            self.disagreeing_since = None;
            self.window.push_back(m);
            self.refit();
            return SampleOutcome::Accepted(m);
        }

        if let Some(fit) = self.fit {
            let (predicted, sigma) = fit.offset_at(m.server_mid_nanos);
            let residual =
                (i128::from(m.offset_nanos) - i128::from(fit.offset_ref_nanos)) as f64 - predicted;
            let allowed = m.error_bound_nanos() as f64
                + fit.bound_nanos as f64
                + 3.0 * sigma
                + self.params.step_threshold_nanos as f64;
            if residual.abs() > allowed {
                return self.suspect(
                    m,
                    fit,
                    saturating_round(residual),
                    saturating_round(allowed),
                );
            }
        }
        self.pending.clear();
        self.overdelayed.clear();
        self.disagreeing_since = None;
        self.window.push_back(m);
        while self.window.len() > self.params.window_len {
            self.window.pop_front();
        }
        self.refit();
        SampleOutcome::Accepted(m)
    }

    /// A sample outside every bound: hold it back; enough consistent ones make a step.
    fn suspect(
        &mut self,
        m: NtpMeasurement,
        fit: Fit,
        residual_nanos: i64,
        allowed_nanos: i64,
    ) -> SampleOutcome {
        let agreed = self
            .window
            .back()
            .map_or(m.server_mid_nanos, |w| w.server_mid_nanos);
        let (since, agreed_server_nanos) = *self
            .disagreeing_since
            .get_or_insert((self.exchanges, agreed));
        if let Some((first, _)) = self.pending.first() {
            // Do the held samples agree with each other (allowing for the drift)?
            let dt = (i128::from(m.server_mid_nanos) - i128::from(first.server_mid_nanos)) as f64;
            let expected = first.offset_nanos as f64 + fit.b * dt;
            let tolerance = (m.error_bound_nanos() + first.error_bound_nanos()) as f64
                + self.params.step_threshold_nanos as f64;
            if (m.offset_nanos as f64 - expected).abs() > tolerance {
                self.pending.clear();
            }
        }
        self.pending.push((m, residual_nanos));
        if self.pending.len() < self.params.step_confirm_samples {
            return SampleOutcome::Rejected(Rejection::Inconsistent {
                residual_nanos,
                allowed_nanos,
            });
        }
        let mut residuals: Vec<i64> = self.pending.iter().map(|(_, r)| *r).collect();
        residuals.sort_unstable();
        let step_nanos = residuals[residuals.len() / 2];
        self.window = self.pending.drain(..).map(|(s, _)| s).collect();
        self.steps += 1;
        self.disagreeing_since = None;
        self.refit();
        SampleOutcome::Step {
            step_nanos,
            at_server_nanos: m.server_mid_nanos,
            agreed_server_nanos,
            exchanges: self.exchanges - since + 1,
        }
    }

    fn refit(&mut self) {
        let p = &self.params;
        let Some(newest) = self.window.back().copied() else {
            self.fit = None;
            return;
        };
        if !self.synchronised && self.window.len() < p.min_used {
            return;
        }
        self.synchronised = true;
        let mut used: Vec<NtpMeasurement> = self.window.iter().copied().collect();
        used.sort_by_key(|s| (s.delay_nanos, std::cmp::Reverse(s.server_mid_nanos)));
        let keep = ((used.len() as f64 * p.keep_fraction).ceil() as usize)
            .max(p.min_used)
            .min(used.len());
        used.truncate(keep);

        let ref_nanos = newest.server_mid_nanos;
        let offset_ref_nanos = newest.offset_nanos;
        let bound_nanos = used
            .iter()
            .map(NtpMeasurement::error_bound_nanos)
            .min()
            .unwrap_or(0);
        let floor = p.delay_floor_nanos as f64;
        let points: Vec<(f64, f64, f64)> = used
            .iter()
            .map(|s| {
                let x = (i128::from(s.server_mid_nanos) - i128::from(ref_nanos)) as f64;
                let y = (i128::from(s.offset_nanos) - i128::from(offset_ref_nanos)) as f64;
                let h = (s.error_bound_nanos() as f64).max(floor);
                (x, y, 1.0 / (h * h))
            })
            .collect();
        let (min_x, max_x) = points
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), (x, _, _)| {
                (lo.min(*x), hi.max(*x))
            });
        let n = points.len();

        let line = (n >= 3 && max_x - min_x >= p.min_drift_span_nanos as f64)
            .then(|| weighted_line(&points))
            .flatten()
            .filter(|l| l.b.abs() * 1e6 <= p.max_drift_ppm);
        let fit = if let Some(l) = line {
            self.drift_prior = Some((l.b, l.var_b));
            Fit {
                ref_nanos,
                offset_ref_nanos,
                a: l.a,
                b: l.b,
                var_a: l.var_a,
                cov_ab: l.cov_ab,
                var_b: l.var_b,
                bound_nanos,
                drift_fitted: true,
                used: n,
            }
        } else {
            // Offset only, with the drift carried over (or assumed 0 with a wide variance).
            let (b, var_b) = self.drift_prior.unwrap_or_else(|| {
                let sigma = p.max_drift_ppm * 1e-6 / 3.0;
                (0.0, sigma * sigma)
            });
            let sw: f64 = points.iter().map(|(_, _, w)| w).sum();
            let a = points.iter().map(|(x, y, w)| w * (y - b * x)).sum::<f64>() / sw;
            let ss: f64 = points
                .iter()
                .map(|(x, y, w)| w * (y - a - b * x).powi(2))
                .sum();
            let s2 = if n >= 2 {
                (ss / (n - 1) as f64).max(0.01)
            } else {
                1.0
            };
            Fit {
                ref_nanos,
                offset_ref_nanos,
                a,
                b,
                var_a: s2 / sw,
                cov_ab: 0.0,
                var_b,
                bound_nanos,
                drift_fitted: false,
                used: n,
            }
        };
        self.fit = Some(fit);
    }

    /// Server time of the sensor-local instant `local_nanos`, or `None` before the filter is
    /// synchronised ([`ClockFilterParams::min_used`] samples). Saturates instead of overflowing
    /// for absurd inputs.
    #[must_use]
    pub fn server_from_local(&self, local_nanos: i64) -> Option<ServerTime> {
        let fit = self.fit?;
        // local = server + offset_ref + a + b·(server − ref)
        //   ⇒ server − ref = (local − ref − offset_ref − a) / (1 + b)
        let rel = (i128::from(local_nanos)
            - i128::from(fit.ref_nanos)
            - i128::from(fit.offset_ref_nanos)) as f64
            - fit.a;
        let x = rel / (1.0 + fit.b);
        let server = i128::from(fit.ref_nanos) + x.round() as i128;
        let server_nanos =
            i64::try_from(server).unwrap_or(if server < 0 { i64::MIN } else { i64::MAX });
        Some(ServerTime {
            server_nanos,
            uncertainty_nanos: fit.uncertainty_at(server_nanos),
        })
    }

    /// Sensor-local time of server instant `server_nanos` (the inverse map), or `None` before the
    /// filter is synchronised.
    #[must_use]
    pub fn local_from_server(&self, server_nanos: i64) -> Option<i64> {
        let fit = self.fit?;
        let (offset, _) = fit.offset_at(server_nanos);
        let local =
            i128::from(server_nanos) + i128::from(fit.offset_ref_nanos) + offset.round() as i128;
        Some(i64::try_from(local).unwrap_or(if local < 0 { i64::MIN } else { i64::MAX }))
    }

    /// The current estimate, or `None` before the filter is synchronised.
    #[must_use]
    pub fn estimate(&self) -> Option<ClockEstimate> {
        let fit = self.fit?;
        let (offset, _) = fit.offset_at(fit.ref_nanos);
        Some(ClockEstimate {
            offset_nanos: fit
                .offset_ref_nanos
                .saturating_add(saturating_round(offset)),
            at_server_nanos: fit.ref_nanos,
            drift_ppm: fit.b * 1e6,
            drift_fitted: fit.drift_fitted,
            uncertainty_nanos: fit.uncertainty_at(fit.ref_nanos),
            samples_used: fit.used,
            samples_in_window: self.window.len(),
        })
    }

    /// Clock steps detected so far.
    #[must_use]
    pub fn steps(&self) -> u64 {
        self.steps
    }

    /// The parameters in use.
    #[must_use]
    pub fn params(&self) -> &ClockFilterParams {
        &self.params
    }
}

/// Weighted least-squares line `y = a + b·x` with its covariance scaled by the residuals.
struct Line {
    a: f64,
    b: f64,
    var_a: f64,
    cov_ab: f64,
    var_b: f64,
}

fn weighted_line(points: &[(f64, f64, f64)]) -> Option<Line> {
    let n = points.len();
    // Centre x for conditioning, then shift back.
    let sw: f64 = points.iter().map(|p| p.2).sum();
    let xm = points.iter().map(|p| p.2 * p.0).sum::<f64>() / sw;
    let ym = points.iter().map(|p| p.2 * p.1).sum::<f64>() / sw;
    let sxx: f64 = points.iter().map(|p| p.2 * (p.0 - xm).powi(2)).sum();
    let sxy: f64 = points.iter().map(|p| p.2 * (p.0 - xm) * (p.1 - ym)).sum();
    if !(sxx.is_finite() && sxx > 0.0 && sw.is_finite() && sw > 0.0) {
        return None;
    }
    let b = sxy / sxx;
    let a = ym - b * xm;
    let ss: f64 = points
        .iter()
        .map(|p| p.2 * (p.1 - a - b * p.0).powi(2))
        .sum();
    // A posteriori variance factor; floored so a lucky near-perfect fit does not claim zero.
    let s2 = (ss / (n - 2).max(1) as f64).max(0.01);
    // Centred parameters are uncorrelated: var(a_c) = s2/sw, var(b) = s2/sxx; a = a_c − b·xm.
    let var_b = s2 / sxx;
    let var_ac = s2 / sw;
    let var_a = var_ac + xm * xm * var_b;
    let cov_ab = -xm * var_b;
    (a.is_finite() && b.is_finite()).then_some(Line {
        a,
        b,
        var_a,
        cov_ab,
        var_b,
    })
}

pub(crate) fn saturating_round(v: f64) -> i64 {
    // `as` saturates at the i64 range (and maps NaN to 0) without panicking.
    v.round() as i64
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A perfect sample for a clock `local = server + offset + drift·server`, symmetric delay.
    fn sample(server_t1: i64, offset: i64, drift_ppm: f64, half_delay: i64) -> NtpSample {
        let local = |s: i64| s + offset + (s as f64 * drift_ppm * 1e-6).round() as i64;
        let t2 = local(server_t1 + half_delay);
        let t3 = local(server_t1 + half_delay + 10_000);
        NtpSample {
            t1: server_t1,
            t2,
            t3,
            t4: server_t1 + 2 * half_delay + 10_000,
        }
    }

    /// One exact sample gives the offset; with drift the fit recovers the rate.
    #[test]
    fn recovers_offset_and_drift() {
        let mut f = ClockFilter::new(ClockFilterParams::default()).unwrap();
        assert!(f.server_from_local(0).is_none());
        let (offset, drift) = (-30_000_000, 80.0);
        for k in 0..20 {
            let out = f.push(sample(k * 500_000_000, offset, drift, 100_000));
            assert!(matches!(out, SampleOutcome::Accepted(_)), "{out:?}");
        }
        let e = f.estimate().unwrap();
        assert!(e.drift_fitted);
        assert!((e.drift_ppm - drift).abs() < 0.5, "{e:?}");
        // Map a stamp 2 s past the last sample.
        let server = 11_500_000_000;
        let local = server + offset + (server as f64 * drift * 1e-6).round() as i64;
        let mapped = f.server_from_local(local).unwrap();
        assert!((mapped.server_nanos - server).abs() < 20_000, "{mapped:?}");
        assert!(mapped.uncertainty_nanos >= (mapped.server_nanos - server).abs());
        assert_eq!(
            f.local_from_server(mapped.server_nanos)
                .map(|l| (l - local).abs() < 2),
            Some(true)
        );
    }

    /// A slow start-up exchange alone maps nothing: the filter waits for `min_used` (4)
    /// samples, and the fast ones then carry the fit instead of the slow one's 5.45 ms error.
    #[test]
    fn waits_for_min_used_samples_before_mapping() {
        let mut f = ClockFilter::new(ClockFilterParams::default()).unwrap();
        let offset = 10_000_000;
        // The request waits 11 ms on the way out, the reply takes 0.1 ms: offset +5.45 ms off.
        let slow = NtpSample {
            t1: 0,
            t2: 11_000_000 + offset,
            t3: 11_010_000 + offset,
            t4: 11_110_000,
        };
        assert!(matches!(f.push(slow), SampleOutcome::Accepted(_)));
        for k in 1..=3 {
            assert!(f.server_from_local(offset).is_none(), "after {k} samples");
            assert!(f.estimate().is_none());
            let out = f.push(sample(k * 100_000_000, offset, 0.0, 100_000));
            assert!(matches!(out, SampleOutcome::Accepted(_)), "{out:?}");
        }
        let server = 350_000_000;
        let mapped = f.server_from_local(server + offset).unwrap();
        assert!((mapped.server_nanos - server).abs() < 50_000, "{mapped:?}");
        assert!(mapped.uncertainty_nanos < 1_000_000, "{mapped:?}");
    }

    /// A sample outside the bounds is rejected as inconsistent; three consistent ones are a step.
    #[test]
    fn detects_step() {
        let mut f = ClockFilter::new(ClockFilterParams::default()).unwrap();
        for k in 0..10 {
            f.push(sample(k * 500_000_000, 5_000_000, 0.0, 100_000));
        }
        let out = f.push(sample(5_000_000_000, 25_000_000, 0.0, 100_000));
        assert!(matches!(
            out,
            SampleOutcome::Rejected(Rejection::Inconsistent { .. })
        ));
        let out = f.push(sample(5_500_000_000, 25_000_000, 0.0, 100_000));
        assert!(matches!(
            out,
            SampleOutcome::Rejected(Rejection::Inconsistent { .. })
        ));
        let out = f.push(sample(6_000_000_000, 25_000_000, 0.0, 100_000));
        let SampleOutcome::Step {
            step_nanos,
            exchanges,
            at_server_nanos,
            agreed_server_nanos,
        } = out
        else {
            panic!("expected a step, got {out:?}")
        };
        assert!((step_nanos - 20_000_000).abs() < 1_000, "{step_nanos}");
        assert_eq!(exchanges, 3);
        // The last agreeing exchange was the tenth (4.5 s); the third disagreeing one at 6 s.
        assert!((agreed_server_nanos - 4_500_000_000).abs() < 1_000_000);
        assert!((at_server_nanos - 6_000_000_000).abs() < 1_000_000);
        assert_eq!(f.steps(), 1);
        assert!((f.estimate().unwrap().offset_nanos - 25_000_000).abs() < 1_000);
    }

    /// The exchanges a step took count from the first that disagreed, a slow exchange rejected
    /// in between included; a lone outlier answered by agreeing samples starts no count.
    #[test]
    fn step_counts_exchanges_from_the_first_disagreeing() {
        let mut f = ClockFilter::new(ClockFilterParams::default()).unwrap();
        for k in 0..10 {
            f.push(sample(k * 500_000_000, 5_000_000, 0.0, 100_000));
        }
        f.push(sample(5_000_000_000, 25_000_000, 0.0, 100_000));
        f.push(sample(5_500_000_000, 5_000_000, 0.0, 100_000));
        let stepped = |k: i64| sample(k * 500_000_000, 1_005_000_000, 0.0, 100_000);
        assert!(matches!(
            f.push(stepped(12)),
            SampleOutcome::Rejected(Rejection::Inconsistent { .. })
        ));
        assert!(matches!(
            f.push(sample(6_500_000_000, 1_005_000_000, 0.0, 15_000_000)),
            SampleOutcome::Rejected(Rejection::DelayAboveLimit { .. })
        ));
        f.push(stepped(14));
        let out = f.push(stepped(15));
        // The agreeing sample at 5.5 s ended the lone outlier's count: the step came after it.
        assert!(
            matches!(
                out,
                SampleOutcome::Step {
                    exchanges: 4,
                    agreed_server_nanos: 5_500_000_000..=5_501_000_000,
                    ..
                }
            ),
            "{out:?}"
        );
        assert_eq!(f.steps(), 1);
    }

    /// A lone outlier does not move the estimate and does not count as a step.
    #[test]
    fn lone_outlier_is_rejected() {
        let mut f = ClockFilter::new(ClockFilterParams::default()).unwrap();
        for k in 0..10 {
            f.push(sample(k * 500_000_000, 5_000_000, 0.0, 100_000));
        }
        f.push(sample(5_000_000_000, 25_000_000, 0.0, 100_000));
        for k in 11..15 {
            let out = f.push(sample(k * 500_000_000, 5_000_000, 0.0, 100_000));
            assert!(matches!(out, SampleOutcome::Accepted(_)));
        }
        assert_eq!(f.steps(), 0);
        assert!((f.estimate().unwrap().offset_nanos - 5_000_000).abs() < 1_000);
    }

    /// High-delay and out-of-order samples are rejected with their reason.
    #[test]
    fn rejects_with_reasons() {
        let mut f = ClockFilter::new(ClockFilterParams::default()).unwrap();
        let out = f.push(sample(0, 0, 0.0, 15_000_000));
        assert!(matches!(
            out,
            SampleOutcome::Rejected(Rejection::DelayAboveLimit { .. })
        ));
        f.push(sample(1_000_000_000, 0, 0.0, 100_000));
        let out = f.push(sample(500_000_000, 0, 0.0, 100_000));
        assert!(matches!(
            out,
            SampleOutcome::Rejected(Rejection::OutOfOrder { .. })
        ));
    }

    /// Under load every exchange is over the delay limit: after a window of them the filter
    /// synchronises on them with their wide bound, and the first fast exchange takes over.
    #[test]
    fn falls_back_to_slow_samples_until_a_fast_one_arrives() {
        let mut f = ClockFilter::new(ClockFilterParams::default().with_window_len(4)).unwrap();
        let offset = 12_000_000;
        // 30 ms round trips, asymmetric by up to 10 ms (the truth is inside each d/2 bound).
        let slow = |k: i64| {
            let mut s = sample(k * 100_000_000, offset, 0.0, 15_000_000);
            s.t4 += (k % 3) * 5_000_000;
            s
        };
        for k in 0..3 {
            assert!(matches!(
                f.push(slow(k)),
                SampleOutcome::Rejected(Rejection::DelayAboveLimit { .. })
            ));
            assert!(f.server_from_local(0).is_none());
        }
        assert!(matches!(f.push(slow(3)), SampleOutcome::Accepted(_)));
        let server = 400_000_000;
        let mapped = f.server_from_local(server + offset).unwrap();
        let err = (mapped.server_nanos - server).abs();
        assert!(mapped.uncertainty_nanos >= 15_000_000, "{mapped:?}");
        assert!(err <= mapped.uncertainty_nanos, "{err} > {mapped:?}");
        // More slow samples keep coming in while nothing faster exists.
        assert!(matches!(f.push(slow(4)), SampleOutcome::Accepted(_)));
        // One fast exchange replaces the fallback; slow ones are rejected again.
        assert!(matches!(
            f.push(sample(500_000_000, offset, 0.0, 100_000)),
            SampleOutcome::Accepted(_)
        ));
        let e = f.estimate().unwrap();
        assert_eq!(e.samples_in_window, 1);
        assert!((e.offset_nanos - offset).abs() < 20_000, "{e:?}");
        assert!(e.uncertainty_nanos < 1_000_000, "{e:?}");
        assert!(matches!(
            f.push(slow(6)),
            SampleOutcome::Rejected(Rejection::DelayAboveLimit { .. })
        ));
    }

    /// Invalid parameters are an error naming the parameter.
    #[test]
    fn params_are_validated() {
        let err =
            ClockFilter::new(ClockFilterParams::default().with_keep_fraction(0.0)).unwrap_err();
        assert!(matches!(
            err,
            Error::InvalidParam {
                param: "clock.keep_fraction",
                ..
            }
        ));
    }
}
