//! Gait analysis on joint trajectories: when each foot strikes and leaves the floor, and the
//! spatiotemporal parameters a gait lab reports from those instants.
//!
//! # Why this crate exists
//! A moving skeleton is not yet a gait measurement. Clinicians compare step and stride lengths,
//! cadence, speed, step width and the stance/swing/double-support split against norms, and they
//! need the *same* numbers from a marker-based reference (C3D/TRC) and from the fused Kinect
//! trajectories to judge the markerless system. Everything here therefore works on a
//! [`MotionClip`](trigait_skeleton::MotionClip) of joint centres, whatever produced it, and needs
//! only the six leg joints the thesis tracks (hips, knees, ankles; §6.4.4). The ankle stands in
//! for the heel; `FootLeft`/`FootRight`, when present, stand in for the toes.
//!
//! # Pipeline
//! 1. [`segment_walk`] estimates the walking direction from the pelvis path (hip mid-point, else
//!    `SpineBase`) and cuts the clip into straight walking segments. Standing (pelvis slower than
//!    a threshold), turning (heading changing faster than a threshold) and gaps are excluded and
//!    reported as [`ExcludedPhase`]s, never silently dropped. Dropouts up to 0.1 s inside a
//!    walk are bridged (still reported): no event is placed next to them, but strides may span
//!    them ([`SegmentParams::max_bridged_gap_secs`]).
//! 2. [`detect_events`] finds heel strikes and toe offs per foot inside each segment, with either
//!    the coordinate method of Zeni et al. (2008) or a foot-velocity method in the manner of
//!    Ghoussayni et al. (2004); see [`EventMethod`].
//! 3. [`strides`] turns events into per-stride parameters and [`summarise`] into means, standard
//!    deviations and left/right asymmetry; [`analyse`] runs all of it, and leaves out of the
//!    figures any step or stride whose heel-to-heel length the pelvis did not travel between
//!    its heel strikes ([`MAX_TRAVEL_MISMATCH_M`]): one of its events is not a landing.
//!
//!    **Partial strides at the edges.** A short walk (the CMU and OpenSim clips hold about two
//!    strides per foot) starts and ends mid-stride. Only turning points seen inside a segment
//!    become events, so an event whose extremum would lie before the first or after the last
//!    frame is not guessed; a stride needs two observed heel strikes of the same foot in one
//!    segment, so the partial strides at either end contribute their events (listed, plotted)
//!    but no parameters; stance and double support need the stride's toe offs and opposite heel
//!    strike in order and are left out of the summary for a stride that lacks them.
//! 4. [`compare`] sets two parameter summaries side by side (markers vs Kinect pipeline).
//! 5. [`filter`] offers a zero-lag Butterworth low-pass (Winter 2009) and the One-Euro filter
//!    (Casiez et al. 2012) for noisy trajectories; [`plot`] draws trajectories with events and a
//!    footfall diagram as SVG and PNG, in memory; [`report`] puts the table, the plots and the
//!    data-quality notes on one self-contained HTML page.
//! 6. [`angles`] gives sagittal hip and knee flexion per gait cycle, normalised to 0–100 %.
//! 7. [`timing`] checks that the swings and steps keep a human rhythm at the clip's rate, which
//!    flags a wrong time base (untimed Kinect text read at 30 Hz).
//! 8. [`stream`] holds the *causal* filters a live dataflow can run (One-Euro, a causal
//!    Butterworth), one state per joint, and [`LiveGait`] runs the analysis over a growing stream
//!    of poses and reports the events it keeps (the recorder node's gait events and
//!    `summary.json` section).
//!
//! # Frames and units
//! World frame of DESIGN.md: metres, seconds, right-handed, Z up, floor at z = 0. The walking
//! direction is *estimated*, so a walk along −Y or diagonally is analysed the same way as one
//! along +X. No function here does I/O or panics on input data.
//!
//! # References
//! - Zeni, Richards, Higginson (2008). Two simple methods for determining gait events during
//!   treadmill and overground walking using kinematic data. *Gait & Posture* 27(4), 710–714.
//! - Ghoussayni, Stevens, Durham, Ewins (2004). Assessment and validation of a simple automated
//!   method for the detection of gait events and intervals. *Gait & Posture* 20(3), 266–272.
//! - Uhlrich et al. (2023). OpenCap: human movement dynamics from smartphone videos. *PLOS Comput.
//!   Biol.* 19(10) — its gait analysis defines step length/width and double support as here.
//! - Winter (2009). *Biomechanics and Motor Control of Human Movement*, 4th ed., §3.4.4.
//! - Casiez, Roussel, Vogel (2012). 1€ filter: a simple speed-based low-pass filter for noisy
//!   input in interactive systems. *CHI '12*, 2527–2530.
//! - Robinson, Herzog, Nigg (1987). Use of force platform variables to quantify the effects of
//!   chiropractic manipulation on gait symmetry. *J. Manipulative Physiol. Ther.* 10(4) — the
//!   symmetry index used for asymmetry.

#![warn(missing_docs)]

pub mod angles;
pub mod clean;
mod error;
mod events;
pub mod filter;
pub mod floor;
mod live;
mod params;
pub mod physics;
pub mod plot;
pub mod report;
mod segment;
mod signal;
pub mod stream;
pub mod timing;
pub mod treadmill;

pub use angles::{CYCLE_SAMPLES, FlexionCycle, flexion_cycles, mean_curve, sagittal_flexion_deg};
pub use clean::{CleanParams, DataQuality, clean};
pub use error::{Error, Result};
pub use events::{
    EventKind, EventMethod, EventParams, Foot, GaitEvent, RUNNING_FLIGHT_FRACTION,
    RUNNING_MIN_FLIGHTS_PER_SEC, detect_events,
};
pub use floor::FloorLevel;
pub use live::{FootCounts, LiveAnalysis, LiveGait, LiveGaitParams, LiveReport, TimedEvent};
pub use params::{
    Comparison, GaitAnalysis, GaitParams, MAX_TRAVEL_MISMATCH_M, MAX_TRAVEL_MISMATCH_SHARE, Stat,
    Step, Stride, Summary, SummaryRow, Tolerances, analyse, analyse_landmarks, compare, strides,
    summarise, summarise_with_steps,
};
pub use physics::{FlightPhase, PhysicsParams};
pub use segment::{
    ExcludedPhase, ExclusionReason, SegmentParams, Segmentation, WalkingSegment, segment_walk,
};
pub use signal::{HeelSource, Landmarks};
pub use timing::Timing;
pub use treadmill::{Treadmill, TreadmillMode};
