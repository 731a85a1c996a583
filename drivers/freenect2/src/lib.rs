//! Kinect v2 sensors for trigait, behind two traits so the capture logic never knows whether a
//! device is real:
//! - [`Driver`] enumerates and opens devices, [`Device`] waits for frames with a timeout;
//! - [`Kinect`]/[`Freenect2`] implement them over libfreenect2 through `libfreenect2-sys`'s C++
//!   shim (`freenect2` feature; `fake-freenect2` links the same shim against trigait's fake
//!   libfreenect2 so CI exercises it);
//! - [`fake::FakeDriver`] implements them in plain Rust, playing given depth frames with device
//!   timestamps and injecting stalls, unplugs, sequence gaps and timestamp wrap;
//! - [`capture::Capture`] is the state machine a source node runs: open by serial or index,
//!   stream, count lost frames from sequence gaps, map device time to the host clock, report a
//!   stalled or unplugged device as degraded, re-enumerate and rejoin.
//!
//! Frames are [`Frame`]s: owned pixels (a `Vec`, or the shim's buffer freed on drop), borrowed
//! only through `&self`, so no slice outlives its frame. Device time is libfreenect2's: 0.125 ms
//! ticks in a `u32` (+266 per frame at 30 Hz), which wraps after 149 h.

mod error;
mod frame;
mod traits;

pub mod capture;
pub mod fake;
#[cfg(any(feature = "freenect2", feature = "fake-freenect2"))]
mod kinect;

pub use error::{Error, Result};
pub use frame::{Frame, FrameKind, IrParams, TICK_NANOS, TICKS_PER_FRAME};
#[cfg(any(feature = "freenect2", feature = "fake-freenect2"))]
pub use kinect::{Freenect2, Kinect, registration_xyz};
pub use traits::{Device, DeviceInfo, Driver, Enumeration, Pipeline, Streams};

/// Whether this build can drive real Kinects (`freenect2` feature).
pub const REAL_DRIVER: bool = cfg!(feature = "freenect2");

/// Whether this build links the fake libfreenect2 (tests of the shim).
pub const FAKE_LIBRARY: bool = libfreenect2_sys::FAKE_LIBRARY;

/// The fake libfreenect2's USB bus (tests of the shim only).
#[cfg(feature = "fake-freenect2")]
pub use kinect::fake_bus;
