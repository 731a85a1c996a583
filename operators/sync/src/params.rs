//! Parameters of [`SyncBuffer`](crate::SyncBuffer): the policy and its knobs, with YAML-friendly
//! names (`Policy::from_str`, `Interpolation::from_str`).

use std::str::FromStr;

use crate::filter::ClockFilterParams;
use crate::{Error, Result};

/// How frames of different sensors are grouped into one aligned set.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Policy {
    /// Thesis §6.4.2 / Fig. 6.10: a cycle of n+1 slots; sensor i's frame is the one it captured in
    /// slot i; the last slot fuses. One set per cycle.
    Slots,
    /// Fusion instants on the server clock at a fixed rate; each sensor's joint tracks are
    /// resampled there. A Kinect v2 cannot be triggered, so this removes the skew between sensors
    /// that the slot schedule leaves (a walking ankle moves ≈ 4 cm in 10 ms).
    Interpolate,
}

impl Policy {
    /// Every valid name, as accepted by [`Policy::from_str`].
    pub const NAMES: &'static [&'static str] = &["slots", "interpolate"];

    /// The name used in YAML.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Policy::Slots => "slots",
            Policy::Interpolate => "interpolate",
        }
    }
}

impl std::fmt::Display for Policy {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Policy {
    type Err = Error;

    fn from_str(s: &str) -> Result<Self> {
        match s.trim().to_ascii_lowercase().as_str() {
            "slots" => Ok(Policy::Slots),
            "interpolate" => Ok(Policy::Interpolate),
            _ => Err(Error::UnknownPolicy {
                name: s.to_owned(),
                valid: Policy::NAMES,
            }),
        }
    }
}

/// How a joint track is resampled between two frames (policy `interpolate`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Interpolation {
    /// Straight line between the two samples around the instant.
    Linear,
    /// Cubic Hermite with finite-difference tangents (Catmull–Rom on non-uniform times); needs a
    /// sample on each side beyond the bracket, else falls back to one-sided tangents.
    CubicHermite,
}

impl Interpolation {
    /// Every valid name, as accepted by [`Interpolation::from_str`].
    pub const NAMES: &'static [&'static str] = &["linear", "cubic-hermite"];

    /// The name used in YAML.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Interpolation::Linear => "linear",
            Interpolation::CubicHermite => "cubic-hermite",
        }
    }
}

impl std::fmt::Display for Interpolation {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Interpolation {
    type Err = Error;

    fn from_str(s: &str) -> Result<Self> {
        match s.trim().to_ascii_lowercase().replace('_', "-").as_str() {
            "linear" => Ok(Interpolation::Linear),
            "cubic-hermite" | "hermite" | "cubic" => Ok(Interpolation::CubicHermite),
            _ => Err(Error::UnknownInterpolation {
                name: s.to_owned(),
                valid: Interpolation::NAMES,
            }),
        }
    }
}

/// Everything [`SyncBuffer`](crate::SyncBuffer) needs besides the sensor ids.
#[derive(Debug, Clone, PartialEq)]
pub struct SyncParams {
    /// Grouping policy (default [`Policy::Interpolate`]).
    pub policy: Policy,
    /// The per-sensor clock filter.
    pub clock: ClockFilterParams,

    /// `slots`: length of one slot (default 15 ms, thesis §6.4.2); a cycle is n+1 slots.
    pub slot_nanos: i64,
    /// `slots`: server time at which cycle 0 starts (default 0).
    pub slot_origin_nanos: i64,
    /// `slots`: oldest a frame may be at the end of its sensor's slot (default 33.4 ms, one Kinect
    /// v2 frame period: the newest frame the sensor had when its slot ended, which is what the
    /// thesis client read from the SDK during its slot). Set it to `slot_nanos` for the strict
    /// "captured inside the slot" rule.
    pub slot_max_frame_age_nanos: i64,

    /// `interpolate`: fusion instants per second (default 30).
    pub fusion_rate_hz: f64,
    /// `interpolate`: server time of fusion instant 0 (default 0); instants are
    /// `origin + k / rate`.
    pub fusion_origin_nanos: i64,
    /// `interpolate`: resampling method (default linear).
    pub interpolation: Interpolation,
    /// `interpolate`: never interpolate across two samples of a joint further apart than this
    /// (default 100 ms: two lost Kinect frames).
    pub max_gap_nanos: i64,
    /// `interpolate`: how far past the first/last sample a joint may be extrapolated (default
    /// 10 ms).
    pub max_extrapolation_nanos: i64,

    /// Both policies: a set waits for every sensor to have data past it, but no longer than this
    /// after its instant (measured on the newest server-mapped stamp seen, or
    /// [`SyncBuffer::advance_to`](crate::SyncBuffer::advance_to)); then it goes out with the
    /// sensors available (default 100 ms). The hard cap behind
    /// [`Self::frame_wait_margin_nanos`].
    pub latency_deadline_nanos: i64,
    /// Both policies: how long past a sensor's *expected* next frame a set still waits for it
    /// (default 10 ms). The next frame is expected one frame period (the median interval of the
    /// sensor's buffered frames, or the fusion period before there are two) plus its usual
    /// transport delay (the median of arrival clock − capture stamp of its recent frames) after
    /// its newest one. A sensor whose frame is that overdue (lost in transport, a stalled or
    /// stopped device) no longer holds the set back, so one lost frame costs a set about a
    /// frame period of age instead of the whole [`Self::latency_deadline_nanos`]; the set is
    /// built from what that sensor has (a short extrapolation, or the sensor missing). Nor
    /// does a sensor that has sent nothing usable since the sets started (silent, or not yet
    /// synchronised): the first set waits up to the deadline for every sensor, the later ones
    /// do not.
    pub frame_wait_margin_nanos: i64,
    /// `interpolate`: also wait (up to [`Self::latency_deadline_nanos`]) for a joint that the
    /// frames after an instant lack to reappear, so a gap of up to [`Self::max_gap_nanos`] is
    /// bridged by interpolation rather than the joint being left out of the sets inside it
    /// (default off: bridging a 100 ms gap costs up to 100 ms of age for every set inside it,
    /// and the other sensors usually see the joint).
    pub bridge_gaps: bool,
    /// Frames buffered per sensor at most (default 64; older ones are dropped first).
    pub max_frames_per_sensor: usize,
    /// Once [`SyncBuffer::advance_to`](crate::SyncBuffer::advance_to) has given the server
    /// clock, frames stamped more than this after it are rejected (default 500 ms: covers clock
    /// uncertainty and a timer-driven `advance_to`).
    pub max_future_nanos: i64,
}

/// Fastest fusion rate, Hz: ten times a Kinect v2's 30 frames/s. Instants closer than that
/// interpolate nothing the frames do not already hold; at 100 kHz (a typo for 30) the sets
/// outran every queue of the graph.
pub const MAX_FUSION_RATE_HZ: f64 = 300.0;

impl Default for SyncParams {
    fn default() -> Self {
        SyncParams {
            policy: Policy::Interpolate,
            clock: ClockFilterParams::default(),
            slot_nanos: 15_000_000,
            slot_origin_nanos: 0,
            slot_max_frame_age_nanos: 33_400_000,
            fusion_rate_hz: 30.0,
            fusion_origin_nanos: 0,
            interpolation: Interpolation::Linear,
            max_gap_nanos: 100_000_000,
            max_extrapolation_nanos: 10_000_000,
            latency_deadline_nanos: 100_000_000,
            frame_wait_margin_nanos: 10_000_000,
            bridge_gaps: false,
            max_frames_per_sensor: 64,
            max_future_nanos: 500_000_000,
        }
    }
}

impl SyncParams {
    /// Sets [`Self::policy`].
    #[must_use]
    pub fn with_policy(mut self, policy: Policy) -> Self {
        self.policy = policy;
        self
    }

    /// Sets [`Self::clock`].
    #[must_use]
    pub fn with_clock(mut self, clock: ClockFilterParams) -> Self {
        self.clock = clock;
        self
    }

    /// Sets [`Self::slot_nanos`].
    #[must_use]
    pub fn with_slot_nanos(mut self, slot_nanos: i64) -> Self {
        self.slot_nanos = slot_nanos;
        self
    }

    /// Sets [`Self::slot_origin_nanos`].
    #[must_use]
    pub fn with_slot_origin_nanos(mut self, slot_origin_nanos: i64) -> Self {
        self.slot_origin_nanos = slot_origin_nanos;
        self
    }

    /// Sets [`Self::slot_max_frame_age_nanos`].
    #[must_use]
    pub fn with_slot_max_frame_age_nanos(mut self, age_nanos: i64) -> Self {
        self.slot_max_frame_age_nanos = age_nanos;
        self
    }

    /// Sets [`Self::fusion_rate_hz`].
    #[must_use]
    pub fn with_fusion_rate_hz(mut self, fusion_rate_hz: f64) -> Self {
        self.fusion_rate_hz = fusion_rate_hz;
        self
    }

    /// Sets [`Self::fusion_origin_nanos`].
    #[must_use]
    pub fn with_fusion_origin_nanos(mut self, fusion_origin_nanos: i64) -> Self {
        self.fusion_origin_nanos = fusion_origin_nanos;
        self
    }

    /// Sets [`Self::interpolation`].
    #[must_use]
    pub fn with_interpolation(mut self, interpolation: Interpolation) -> Self {
        self.interpolation = interpolation;
        self
    }

    /// Sets [`Self::max_gap_nanos`].
    #[must_use]
    pub fn with_max_gap_nanos(mut self, max_gap_nanos: i64) -> Self {
        self.max_gap_nanos = max_gap_nanos;
        self
    }

    /// Sets [`Self::max_extrapolation_nanos`].
    #[must_use]
    pub fn with_max_extrapolation_nanos(mut self, max_extrapolation_nanos: i64) -> Self {
        self.max_extrapolation_nanos = max_extrapolation_nanos;
        self
    }

    /// Sets [`Self::latency_deadline_nanos`].
    #[must_use]
    pub fn with_latency_deadline_nanos(mut self, latency_deadline_nanos: i64) -> Self {
        self.latency_deadline_nanos = latency_deadline_nanos;
        self
    }

    /// Sets [`Self::frame_wait_margin_nanos`].
    #[must_use]
    pub fn with_frame_wait_margin_nanos(mut self, margin_nanos: i64) -> Self {
        self.frame_wait_margin_nanos = margin_nanos;
        self
    }

    /// Sets [`Self::bridge_gaps`].
    #[must_use]
    pub fn with_bridge_gaps(mut self, bridge_gaps: bool) -> Self {
        self.bridge_gaps = bridge_gaps;
        self
    }

    /// Sets [`Self::max_frames_per_sensor`].
    #[must_use]
    pub fn with_max_frames_per_sensor(mut self, max_frames_per_sensor: usize) -> Self {
        self.max_frames_per_sensor = max_frames_per_sensor;
        self
    }

    /// Sets [`Self::max_future_nanos`].
    #[must_use]
    pub fn with_max_future_nanos(mut self, max_future_nanos: i64) -> Self {
        self.max_future_nanos = max_future_nanos;
        self
    }

    /// Interval between fusion instants (`interpolate`), nanoseconds, rounded.
    #[must_use]
    pub fn fusion_period_nanos(&self) -> i64 {
        (1e9 / self.fusion_rate_hz).round() as i64
    }

    /// Checks every field; the error names the first bad one.
    pub fn validate(&self) -> Result<()> {
        self.clock.validate()?;
        let bad = |param: &'static str, value: String, expected: &'static str| {
            Err(Error::InvalidParam {
                param,
                value,
                expected,
            })
        };
        if self.slot_nanos < 1 {
            return bad("slot_nanos", self.slot_nanos.to_string(), "positive");
        }
        if self.slot_max_frame_age_nanos < 1 {
            return bad(
                "slot_max_frame_age_nanos",
                self.slot_max_frame_age_nanos.to_string(),
                "positive",
            );
        }
        if !(self.fusion_rate_hz.is_finite()
            && self.fusion_rate_hz > 0.0
            && self.fusion_rate_hz <= MAX_FUSION_RATE_HZ)
        {
            return bad(
                "fusion_rate_hz",
                self.fusion_rate_hz.to_string(),
                "positive and at most 300 Hz (ten times a Kinect v2's 30 frames/s: faster \
                 instants interpolate nothing new, and a typo such as 100000 floods the graph)",
            );
        }
        if self.max_gap_nanos < 1 {
            return bad("max_gap_nanos", self.max_gap_nanos.to_string(), "positive");
        }
        if self.max_extrapolation_nanos < 0 {
            return bad(
                "max_extrapolation_nanos",
                self.max_extrapolation_nanos.to_string(),
                "non-negative",
            );
        }
        if self.latency_deadline_nanos < 0 {
            return bad(
                "latency_deadline_nanos",
                self.latency_deadline_nanos.to_string(),
                "non-negative",
            );
        }
        if self.frame_wait_margin_nanos < 0 {
            return bad(
                "frame_wait_margin_nanos",
                self.frame_wait_margin_nanos.to_string(),
                "non-negative",
            );
        }
        if self.max_future_nanos < 0 {
            return bad(
                "max_future_nanos",
                self.max_future_nanos.to_string(),
                "non-negative",
            );
        }
        if self.max_frames_per_sensor < 4 {
            return bad(
                "max_frames_per_sensor",
                self.max_frames_per_sensor.to_string(),
                "at least 4",
            );
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Names round-trip; an unknown name lists the valid ones.
    #[test]
    fn names_parse() {
        for p in [Policy::Slots, Policy::Interpolate] {
            assert_eq!(p.name().parse::<Policy>().unwrap(), p);
        }
        assert_eq!(" Slots ".parse::<Policy>().unwrap(), Policy::Slots);
        let err = "tdma".parse::<Policy>().unwrap_err();
        assert_eq!(
            err.to_string(),
            "unknown sync policy \"tdma\" (valid: slots, interpolate)"
        );
        assert_eq!(
            "cubic_hermite".parse::<Interpolation>().unwrap(),
            Interpolation::CubicHermite
        );
        assert!(
            "spline"
                .parse::<Interpolation>()
                .unwrap_err()
                .to_string()
                .contains("linear, cubic-hermite")
        );
    }

    /// Defaults validate; a bad field is named.
    #[test]
    fn validation_names_the_field() {
        SyncParams::default().validate().unwrap();
        let err = SyncParams::default()
            .with_fusion_rate_hz(0.0)
            .validate()
            .unwrap_err();
        assert!(matches!(
            err,
            Error::InvalidParam {
                param: "fusion_rate_hz",
                ..
            }
        ));
        assert_eq!(SyncParams::default().fusion_period_nanos(), 33_333_333);
    }
}
