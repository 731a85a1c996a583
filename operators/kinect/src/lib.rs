//! What a Kinect v2 reports about a body joint, and how wrong it is likely to be.
//!
//! The simulator draws observations from this model and the estimators weigh observations by
//! it, so both sides of `trigait eval` agree on one physically grounded description:
//!
//! - [`Intrinsics`]: the 512×424 depth camera with its 70.6°×60° field of view (thesis
//!   Table 6.1), projection and the field-of-view test.
//! - [`NoiseModel`]: the noise of a skeleton joint as a range component (along the ray) and a
//!   lateral component (across it), each growing with distance, with the incidence angle of
//!   the ray on the limb and with the angle off the optical axis, inflated for inferred joints and beyond the 0.5–4.5 m working range.
//!   Every default names its source.
//! - [`occlusion`]: whether one leg hides a joint of the other from a sensor.
//! - [`Sensor::observe`]: the tracking state of a joint and a noisy report of it.
//!
//! Camera space is the SDK's: x to the sensor's left, y up, z out of the lens, metres.

#![warn(missing_docs)]

mod intrinsics;
mod noise;
pub mod occlusion;
mod sensor;

pub use intrinsics::Intrinsics;
pub use noise::{MAX_INCIDENCE_RAD, NoiseModel, limb_axis, limb_incidence_rad, limb_of};
pub use sensor::{Report, Sensor, Visibility};
