//! Driver errors: each says what failed and, where it helps, what to do.

/// What can go wrong with a Kinect.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum Error {
    /// The serial is not among the connected devices.
    #[error("no Kinect v2 with serial {serial:?} (connected: {available})")]
    NoSuchSerial {
        /// Asked for.
        serial: String,
        /// Connected serials, comma-separated, or "none".
        available: String,
    },
    /// No device at that index.
    #[error("no Kinect v2 at index {index} ({count} connected)")]
    NoSuchIndex {
        /// Asked for.
        index: usize,
        /// Connected.
        count: usize,
    },
    /// The serial is open already in this process.
    #[error("Kinect v2 {0:?} is open already in this process")]
    AlreadyOpen(String),
    /// The pipeline is not compiled into libfreenect2.
    #[error("depth pipeline {0} is not available in this libfreenect2 build")]
    PipelineUnavailable(String),
    /// A device was seen but could not be opened: USB permissions.
    #[error(
        "a Kinect v2 is connected but cannot be opened (LIBUSB_ERROR_ACCESS): install \
         libfreenect2's udev rule (platform/linux/udev/90-kinect2.rules) and replug"
    )]
    UsbAccessDenied,
    /// libfreenect2 could not open the device.
    #[error("libfreenect2 could not open Kinect v2 {0:?}")]
    OpenFailed(String),
    /// The streams did not start.
    #[error("Kinect v2 {0:?}: the streams did not start")]
    StartFailed(String),
    /// libfreenect2 did not return in time (its thread shutdown can deadlock); the objects
    /// involved are leaked and the context must be replaced.
    #[error(
        "libfreenect2 did not return within {millis} ms while {what} (leaked, context replaced)"
    )]
    Watchdog {
        /// What it was doing.
        what: String,
        /// The timeout.
        millis: u64,
    },
    /// The device is gone (fake device, or a closed one).
    #[error("Kinect v2 {0:?} is disconnected")]
    Disconnected(String),
    /// A frame the shim handed over is not what was asked for.
    #[error("malformed frame: {0}")]
    BadFrame(String),
    /// This binary cannot drive real devices.
    #[error(
        "this binary was built without libfreenect2 (rebuild with `--features freenect2`, see README)"
    )]
    NotBuilt,
}

/// Results of this crate.
pub type Result<T> = std::result::Result<T, Error>;
