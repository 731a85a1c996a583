//! `sensor_status`: a source's device state, sent on every change and periodically while it
//! lasts, so a consumer learns that a sensor is degraded even though its frames have stopped.
//!
//! ```text
//! Struct { sensor_id: Utf8, stamp_nanos: Int64 (host clock), state: Utf8, detail: Utf8,
//!          since_nanos: Int64 (host clock), lost_frames: UInt64 }
//! ```
//! `state` is one of [`SensorStatus::STATES`]; `detail` the human-readable reason.

use arrow_array::types::{Int64Type, UInt64Type};
use arrow_array::{Array, ArrayRef, Int64Array, StringArray, UInt64Array};
use arrow_schema::{DataType, Fields};

use crate::codec::{decode_rows, encode_struct, field, struct_of};
use crate::{Error, Message, Result};

/// One sensor's device state at one instant.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SensorStatus {
    /// The sensor (`k1`).
    pub sensor_id: String,
    /// When the state was reported, host clock, nanoseconds.
    pub stamp_nanos: i64,
    /// One of [`SensorStatus::STATES`].
    pub state: String,
    /// Why, for a person (`degraded: no frames (stalled)`).
    pub detail: String,
    /// When the sensor entered this state, host clock, nanoseconds.
    pub since_nanos: i64,
    /// Frames lost so far on this sensor (sequence gaps and time away).
    pub lost_frames: u64,
}

impl SensorStatus {
    /// Frames are arriving.
    pub const STREAMING: &'static str = "streaming";
    /// Not opened yet.
    pub const STARTING: &'static str = "starting";
    /// Open, but no frames for longer than the stall limit.
    pub const STALLED: &'static str = "stalled";
    /// Not on the bus (never seen, or unplugged).
    pub const ABSENT: &'static str = "absent";
    /// On the bus but it could not be opened or started.
    pub const FAILED: &'static str = "failed";
    /// Every state, in this order.
    pub const STATES: [&'static str; 5] = [
        Self::STREAMING,
        Self::STARTING,
        Self::STALLED,
        Self::ABSENT,
        Self::FAILED,
    ];

    /// Whether the state means the sensor delivers no frames (stalled, absent or failed).
    #[must_use]
    pub fn is_degraded(&self) -> bool {
        [Self::STALLED, Self::ABSENT, Self::FAILED].contains(&self.state.as_str())
    }

    fn validate(&self) -> Result<()> {
        if Self::STATES.contains(&self.state.as_str()) {
            Ok(())
        } else {
            Err(Error::Encode {
                message: Self::NAME,
                detail: format!("state {:?} is not one of {:?}", self.state, Self::STATES),
            })
        }
    }
}

fn fields() -> Fields {
    Fields::from(vec![
        field("sensor_id", DataType::Utf8),
        field("stamp_nanos", DataType::Int64),
        field("state", DataType::Utf8),
        field("detail", DataType::Utf8),
        field("since_nanos", DataType::Int64),
        field("lost_frames", DataType::UInt64),
    ])
}

impl Message for SensorStatus {
    const NAME: &'static str = "sensor_status";

    fn data_type() -> DataType {
        struct_of(fields())
    }

    fn encode_many(messages: &[Self]) -> Result<ArrayRef> {
        for m in messages {
            m.validate()?;
        }
        encode_struct::<Self>(&fields(), |b| {
            Ok(vec![
                b.strings(messages.iter().map(|m| m.sensor_id.as_str())),
                b.values::<Int64Type>(messages.iter().map(|m| m.stamp_nanos)),
                b.strings(messages.iter().map(|m| m.state.as_str())),
                b.strings(messages.iter().map(|m| m.detail.as_str())),
                b.values::<Int64Type>(messages.iter().map(|m| m.since_nanos)),
                b.values::<UInt64Type>(messages.iter().map(|m| m.lost_frames)),
            ])
        })
    }

    fn decode_many(array: &dyn Array) -> Result<Vec<Self>> {
        decode_rows(array, |top| {
            let sensors = top.column::<StringArray>("sensor_id")?;
            let stamps = top.column::<Int64Array>("stamp_nanos")?;
            let states = top.column::<StringArray>("state")?;
            let details = top.column::<StringArray>("detail")?;
            let since = top.column::<Int64Array>("since_nanos")?;
            let lost = top.column::<UInt64Array>("lost_frames")?;
            Ok(move |row| {
                let m = SensorStatus {
                    sensor_id: sensors.get(row)?,
                    stamp_nanos: stamps.get(row)?,
                    state: states.get(row)?,
                    detail: details.get(row)?,
                    since_nanos: since.get(row)?,
                    lost_frames: lost.get(row)?,
                };
                if !Self::STATES.contains(&m.state.as_str()) {
                    return Err(Error::InvalidValue {
                        field: format!("{}.state", Self::NAME),
                        row,
                        value: m.state,
                        expected: "streaming, starting, stalled, absent or failed",
                    });
                }
                Ok(m)
            })
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A batch survives the round trip; an unknown state is refused when encoding.
    #[test]
    fn round_trip_and_unknown_state() {
        let s = |state: &str| SensorStatus {
            sensor_id: "k2".into(),
            stamp_nanos: 5_000,
            state: state.into(),
            detail: format!("degraded: {state}"),
            since_nanos: 1_000,
            lost_frames: 61,
        };
        let many = vec![s(SensorStatus::STALLED), s(SensorStatus::STREAMING)];
        let array = SensorStatus::encode_many(&many).unwrap();
        assert_eq!(array.data_type(), &SensorStatus::data_type());
        assert_eq!(SensorStatus::decode_many(array.as_ref()).unwrap(), many);
        assert!(many[0].is_degraded() && !many[1].is_degraded());
        assert!(s("asleep").encode().is_err());
    }
}
