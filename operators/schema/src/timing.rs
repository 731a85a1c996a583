//! `frame_timing`: every sensor frame `sync` received, with its placement on the server clock
//! (`sync → recorder`): for the offset plots, the summary's NTP error and frame counts, and the
//! raw joints the recorder draws per sensor. Forwarding the frames here is what keeps the
//! recorder at the same few inputs whatever the number of sensors.
//!
//! ```text
//! Struct { sensor_id: Utf8, seq: UInt64, local_stamp_nanos: Int64 (sensor clock),
//!          server_stamp_nanos: Int64?, uncertainty_nanos: Int64?, offset_nanos: Int64?,
//!          drift_ppm: Float64?, true_stamp_nanos: Int64?, received_nanos: Int64?,
//!          joints: List<Struct { joint: UInt8, position_in_kinect_m: FixedSizeList<Float64, 3>,
//!                                state: UInt8 }> }
//! ```
//! The server fields are null while the sensor is not synchronised yet; `true_stamp_nanos` is the
//! capture instant on the server clock when the source knows it (simulated sensors), so the
//! mapping error is `server_stamp_nanos − true_stamp_nanos`. `received_nanos` is the server clock
//! when `sync` took the frame in: with it a replay hands `sync` the frames in the recorded order
//! and at the recorded instants, so `sync` makes the same sets (the same deadline decisions) as
//! in the recorded run.

use arrow_array::types::{Float64Type, Int64Type, UInt64Type};
use arrow_array::{Array, ArrayRef, Float64Array, Int64Array, StringArray, UInt64Array};
use arrow_schema::{DataType, Fields};

use trigait_skeleton::JointSample;

use crate::codec::{
    Builder, Rows, decode_joint_samples, encode_joint_samples, field, joint_sample_fields, list_of,
    list_range, nullable, struct_of,
};
use crate::{Message, Result};

/// One frame's placement on the server clock.
#[derive(Debug, Clone, PartialEq)]
pub struct FrameTiming {
    /// The sensor.
    pub sensor_id: String,
    /// The frame's sequence number.
    pub seq: u64,
    /// Capture stamp on the sensor clock, nanoseconds.
    pub local_stamp_nanos: i64,
    /// Capture stamp mapped to the server clock, nanoseconds (`None`: not synchronised yet).
    pub server_stamp_nanos: Option<i64>,
    /// Uncertainty of `server_stamp_nanos`, nanoseconds.
    pub uncertainty_nanos: Option<i64>,
    /// The clock filter's offset estimate (sensor − server), nanoseconds.
    pub offset_nanos: Option<i64>,
    /// The clock filter's drift estimate, ppm.
    pub drift_ppm: Option<f64>,
    /// True capture instant on the server clock, when known (simulation), nanoseconds.
    pub true_stamp_nanos: Option<i64>,
    /// Server clock when `sync` received the frame, nanoseconds (`None`: not known).
    pub received_nanos: Option<i64>,
    /// The frame's joints as the sensor sent them (Kinect camera space).
    pub joints: Vec<JointSample>,
}

impl FrameTiming {
    /// Mapping error `server − true`, nanoseconds, when both are known.
    #[must_use]
    pub fn error_nanos(&self) -> Option<i64> {
        Some(self.server_stamp_nanos? - self.true_stamp_nanos?)
    }
}

fn fields() -> Fields {
    Fields::from(vec![
        field("sensor_id", DataType::Utf8),
        field("seq", DataType::UInt64),
        field("local_stamp_nanos", DataType::Int64),
        nullable("server_stamp_nanos", DataType::Int64),
        nullable("uncertainty_nanos", DataType::Int64),
        nullable("offset_nanos", DataType::Int64),
        nullable("drift_ppm", DataType::Float64),
        nullable("true_stamp_nanos", DataType::Int64),
        nullable("received_nanos", DataType::Int64),
        field("joints", list_of(struct_of(joint_sample_fields()))),
    ])
}

impl Message for FrameTiming {
    const NAME: &'static str = "frame_timing";

    fn data_type() -> DataType {
        struct_of(fields())
    }

    fn encode_many(messages: &[Self]) -> Result<ArrayRef> {
        let b = Builder {
            message: Self::NAME,
        };
        let ints =
            |f: fn(&FrameTiming) -> Option<i64>| b.optionals::<Int64Type>(messages.iter().map(f));
        let samples = messages.iter().flat_map(|m| m.joints.iter());
        let joints = b.structs(&joint_sample_fields(), encode_joint_samples(&b, samples)?)?;
        let lengths: Vec<usize> = messages.iter().map(|m| m.joints.len()).collect();
        b.structs(
            &fields(),
            vec![
                b.strings(messages.iter().map(|m| m.sensor_id.as_str())),
                b.values::<UInt64Type>(messages.iter().map(|m| m.seq)),
                b.values::<Int64Type>(messages.iter().map(|m| m.local_stamp_nanos)),
                ints(|m| m.server_stamp_nanos),
                ints(|m| m.uncertainty_nanos),
                ints(|m| m.offset_nanos),
                b.optionals::<Float64Type>(messages.iter().map(|m| m.drift_ppm)),
                ints(|m| m.true_stamp_nanos),
                ints(|m| m.received_nanos),
                b.list(struct_of(joint_sample_fields()), &lengths, joints)?,
            ],
        )
    }

    fn decode_many(array: &dyn Array) -> Result<Vec<Self>> {
        let top = Rows::new(array, Self::NAME)?;
        let sensor_ids = top.column::<StringArray>("sensor_id")?;
        let seqs = top.column::<UInt64Array>("seq")?;
        let drifts = top.column::<Float64Array>("drift_ppm")?;
        let local = top.column::<Int64Array>("local_stamp_nanos")?;
        let server = top.column::<Int64Array>("server_stamp_nanos")?;
        let uncertainty = top.column::<Int64Array>("uncertainty_nanos")?;
        let offset = top.column::<Int64Array>("offset_nanos")?;
        let truth = top.column::<Int64Array>("true_stamp_nanos")?;
        let received = top.column::<Int64Array>("received_nanos")?;
        let (joints_list, joints_path) = top.nested("joints")?;
        let (_, items) = decode_joint_samples(joints_list.values().as_ref(), &joints_path)?;
        top.rows()
            .map(|row| {
                Ok(FrameTiming {
                    sensor_id: sensor_ids.get(row)?,
                    seq: seqs.get(row)?,
                    local_stamp_nanos: local.get(row)?,
                    server_stamp_nanos: server.optional(row),
                    uncertainty_nanos: uncertainty.optional(row),
                    offset_nanos: offset.optional(row),
                    drift_ppm: drifts.optional(row),
                    true_stamp_nanos: truth.optional(row),
                    received_nanos: received.optional(row),
                    joints: items[list_range(joints_list, &joints_path, row)?].to_vec(),
                })
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A synchronised row with joints and an unsynchronised one without survive a round trip;
    /// the error is server − true.
    #[test]
    fn round_trip() {
        let rows = vec![
            FrameTiming {
                sensor_id: "k1".into(),
                seq: 3,
                local_stamp_nanos: 1_000,
                server_stamp_nanos: Some(900),
                uncertainty_nanos: Some(50),
                offset_nanos: Some(100),
                drift_ppm: Some(12.5),
                true_stamp_nanos: Some(880),
                received_nanos: Some(2_000),
                joints: vec![
                    JointSample {
                        joint: trigait_skeleton::Joint::KneeLeft,
                        position_in_kinect: nalgebra::Point3::new(0.1, -0.2, 2.5),
                        state: trigait_skeleton::TrackingState::Tracked,
                    },
                    JointSample {
                        joint: trigait_skeleton::Joint::AnkleRight,
                        position_in_kinect: nalgebra::Point3::new(-0.1, -0.6, 2.4),
                        state: trigait_skeleton::TrackingState::Inferred,
                    },
                ],
            },
            FrameTiming {
                sensor_id: "k2".into(),
                seq: 0,
                local_stamp_nanos: -5,
                server_stamp_nanos: None,
                uncertainty_nanos: None,
                offset_nanos: None,
                drift_ppm: None,
                true_stamp_nanos: None,
                received_nanos: None,
                joints: Vec::new(),
            },
        ];
        let array = FrameTiming::encode_many(&rows).unwrap();
        assert_eq!(array.data_type(), &FrameTiming::data_type());
        let back = FrameTiming::decode_many(array.as_ref()).unwrap();
        assert_eq!(back, rows);
        assert_eq!(back[0].error_nanos(), Some(20));
        assert_eq!(back[1].error_nanos(), None);
    }

    /// Another message is refused with the field named, not a panic.
    #[test]
    fn wrong_message_is_an_error() {
        let ntp = crate::NtpExchange::request("k1", 1, 2).encode().unwrap();
        let err = FrameTiming::decode_many(ntp.as_ref()).unwrap_err();
        assert!(err.to_string().starts_with("frame_timing."), "{err}");
    }
}
