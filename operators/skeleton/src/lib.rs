//! The vocabulary every trigait crate shares: which joint, how sure the sensor was of it, and a
//! clip of joint positions over time.
//!
//! Joints use the Kinect v2 SDK's 25 `JointType`s, in the SDK's order, so that SDK recordings,
//! simulated sensors and mocap-derived ground truth all index the same way. The thesis tracks the
//! six leg joints ([`Joint::LEGS`], thesis §6.4.4); every other joint is accepted and carried.
//!
//! Positions in a [`MotionClip`] are in the world frame of DESIGN.md: metres, right-handed, Z up,
//! floor at z = 0, walking along +X once the clip is [placed on the walkway](MotionClip::placed_on_walkway).

mod clip;
mod frame;
mod joint;

pub use clip::{ClipError, MotionClip, frame_runs};
pub use frame::{JointSample, MAX_REPORT_RANGE_M, SkeletonFrame};
pub use joint::{Joint, Side, TrackingState};
