//! Clock synchronisation and aligned-set assembly for several Kinect v2 sensors (thesis §6.4.1,
//! §6.4.2, §6.4.4 / Fig. 6.10), as pure code: no I/O, no threads, no clock reads. The `sync` node
//! of the dataflow is a thin adapter around [`SyncBuffer`].
//!
//! Why it exists: trilateration (thesis ch. 4) combines one joint seen by several sensors *at one
//! instant*. The sensors run on different PCs with their own clocks, and a Kinect v2 cannot be
//! triggered, so two things must happen before fusion:
//!
//! 1. **Clock sync** ([`ntp`], [`ClockFilter`]): the thesis's four-timestamp NTP exchange
//!    (eq. 6.1–6.3) measures each sensor clock's offset to the server clock to ±d/2. We add what a
//!    long recording needs: a window of exchanges, rejection of high-delay samples, a weighted
//!    least-squares fit of offset **and drift**, an uncertainty for every mapped stamp, and
//!    detection of clock steps.
//! 2. **Alignment** ([`SyncBuffer`]): frames, now on the server clock, are grouped into
//!    [`AlignedSet`]s under one of two [`Policy`]s. `slots` is the thesis's time schedule: a
//!    cycle of n+1 slots (60 ms = 4 × 15 ms for 3 sensors), sensor i's frame from slot i, fusion
//!    in the last slot. `interpolate` resamples every sensor's joint tracks at common fusion
//!    instants, which removes the inter-sensor skew that the slot schedule leaves (up to a cycle:
//!    ≈ 20 cm for an ankle at 4 m/s), and reports an interpolation error budget per joint.
//!
//! Time is `i64` nanoseconds everywhere (`_nanos`); positions are metres in each sensor's Kinect
//! camera frame (x left, y up, z out of the lens) — this crate never changes frames. Simulated
//! clocks (offset, drift, jitter) and links (asymmetric, heavy-tailed delays) to test it against
//! are in `trigait_sim::clock`.
//!
//! ```
//! use trigait_skeleton::{Joint, JointSample, SkeletonFrame, TrackingState};
//! use trigait_sync::{NtpSample, SyncBuffer, SyncParams};
//!
//! let mut sync = SyncBuffer::new(["k1", "k2"], SyncParams::default())?;
//! // Each sensor clock is 5 ms ahead, 0.2 ms round trip; a clock filter maps once it has four
//! // exchanges (`ClockFilterParams::min_used`), here in the 0.4 s before the first frame.
//! for t1 in [-400_000_000, -300_000_000, -200_000_000, -100_000_000] {
//!     for id in ["k1", "k2"] {
//!         let (t2, t4) = (t1 + 5_100_000, t1 + 200_000);
//!         sync.push_ntp(id, NtpSample { t1, t2, t3: t2, t4 })?;
//!     }
//! }
//! let frame = |id: &str, seq: u64, local: i64| SkeletonFrame {
//!     sensor_id: id.into(),
//!     seq,
//!     local_stamp_nanos: local,
//!     joints: vec![JointSample {
//!         joint: Joint::KneeLeft,
//!         position_in_kinect: [0.0, 0.0, 2.0 + local as f64 * 1e-9].into(),
//!         state: TrackingState::Tracked,
//!     }],
//! };
//! let mut sets = Vec::new();
//! for seq in 0..4 {
//!     let local = 5_000_000 + seq as i64 * 33_333_333; // captured at server time seq/30 s
//!     sets.extend(sync.push(frame("k1", seq, local))?);
//!     sets.extend(sync.push(frame("k2", seq, local + 10_000_000))?);
//! }
//! // Fusion instants at 30 Hz on the server clock, both sensors resampled there.
//! assert!(sets.len() >= 2);
//! assert!(sets.iter().all(|s| s.is_complete() && s.stamp_nanos % 33_333_333 <= 1));
//! # Ok::<(), trigait_sync::Error>(())
//! ```
#![warn(missing_docs)]

mod buffer;
mod error;
mod filter;
pub mod ntp;
mod params;
mod schedule;

pub use buffer::{AlignedSet, Release, SensorView, SyncBuffer, SyncCounters, TimedFrame};
pub use error::{Error, Result};
pub use filter::{ClockEstimate, ClockFilter, ClockFilterParams, SampleOutcome, ServerTime};
pub use ntp::{NtpMeasurement, NtpSample, Rejection};
pub use params::{Interpolation, Policy, SyncParams};
pub use schedule::NtpSchedule;
