/// Everything that can go wrong in this crate. Rejected NTP samples are not errors (they are
/// [`SampleOutcome::Rejected`](crate::SampleOutcome::Rejected)); neither are late frames (they are
/// counted in [`SyncCounters`](crate::SyncCounters)).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// A policy name that is not one of [`Policy::NAMES`](crate::Policy::NAMES).
    #[error("unknown sync policy {name:?} (valid: {})", valid.join(", "))]
    UnknownPolicy {
        /// The name given.
        name: String,
        /// The names accepted.
        valid: &'static [&'static str],
    },
    /// An interpolation name that is not one of [`Interpolation::NAMES`](crate::Interpolation::NAMES).
    #[error("unknown interpolation {name:?} (valid: {})", valid.join(", "))]
    UnknownInterpolation {
        /// The name given.
        name: String,
        /// The names accepted.
        valid: &'static [&'static str],
    },
    /// A parameter outside its range.
    #[error("invalid sync parameter {param} = {value}: expected {expected}")]
    InvalidParam {
        /// Parameter name (`clock.` prefix for the clock filter's).
        param: &'static str,
        /// The value given.
        value: String,
        /// What would have been accepted.
        expected: &'static str,
    },
    /// A [`SyncBuffer`](crate::SyncBuffer) needs at least one sensor.
    #[error("no sensors given")]
    NoSensors,
    /// The same sensor id was given twice.
    #[error("sensor id {sensor_id:?} given twice")]
    DuplicateSensor {
        /// The repeated id.
        sensor_id: String,
    },
    /// A frame or NTP sample from a sensor the buffer was not built with.
    #[error("unknown sensor {sensor_id:?} (known: {})", known.join(", "))]
    UnknownSensor {
        /// The id on the frame.
        sensor_id: String,
        /// The ids the buffer knows.
        known: Vec<String>,
    },
    /// A frame arrived before any NTP sample of its sensor was accepted, so it cannot be placed
    /// on the server clock; it was dropped.
    #[error(
        "sensor {sensor_id:?} is not synchronised yet (no accepted NTP sample); frame {seq} dropped"
    )]
    NotSynchronised {
        /// The sensor.
        sensor_id: String,
        /// The dropped frame's sequence number.
        seq: u64,
    },
    /// A frame stamped later than the server clock's present (by more than
    /// [`SyncParams::max_future_nanos`](crate::SyncParams::max_future_nanos)): a garbage stamp or
    /// a clock step not yet detected; it was dropped.
    #[error(
        "frame {seq} of sensor {sensor_id:?} is stamped {lead_nanos} ns in the server's future; dropped"
    )]
    FrameFromFuture {
        /// The sensor.
        sensor_id: String,
        /// The dropped frame's sequence number.
        seq: u64,
        /// How far past the server's present the frame was stamped.
        lead_nanos: i64,
    },
}

/// This crate's result type.
pub type Result<T, E = Error> = std::result::Result<T, E>;
