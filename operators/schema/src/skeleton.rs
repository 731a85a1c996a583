//! `skeleton_frame`: one sensor's body in one depth frame (`kinect-source → sync`).
//!
//! ```text
//! Struct {
//!   sensor_id: Utf8, seq: UInt64, local_stamp_nanos: Int64 (sensor clock),
//!   joints: List<Struct { joint: UInt8, position_m: FixedSizeList<Float64, 3> (camera frame),
//!                         state: UInt8, confidence: Float32 (nullable) }>
//! }
//! ```

use std::sync::Arc;

use arrow_array::types::{Float32Type, Int64Type, UInt64Type};
use arrow_array::{Array, ArrayRef, Float32Array, Int64Array, UInt8Array, UInt64Array};
use arrow_schema::{DataType, Fields};
use trigait_skeleton::{JointSample, SkeletonFrame};

use crate::codec::{
    Builder, Col, column, decode_joint_samples, f64_tuple, field, joint_code, list_of, list_range,
    no_null_rows, nullable, optional, point_values, state_code, string, struct_of, value,
};
use crate::{Error, Message, Result};

/// A [`SkeletonFrame`] as sent, with a per-joint confidence in [0, 1] where the body tracker
/// gives one (the Kinect v2 SDK does not: `None`; a depth-based tracker may).
#[derive(Debug, Clone, PartialEq)]
pub struct SkeletonFrameMessage {
    /// The frame.
    pub frame: SkeletonFrame,
    /// One entry per `frame.joints`, same order; empty means "none given" (all `None`).
    pub confidence: Vec<Option<f32>>,
}

impl From<SkeletonFrame> for SkeletonFrameMessage {
    fn from(frame: SkeletonFrame) -> Self {
        SkeletonFrameMessage {
            frame,
            confidence: Vec::new(),
        }
    }
}

impl SkeletonFrameMessage {
    /// The confidence of joint sample `i`, if given.
    #[must_use]
    pub fn confidence_of(&self, i: usize) -> Option<f32> {
        self.confidence.get(i).copied().flatten()
    }
}

fn joint_fields() -> Fields {
    Fields::from(vec![
        field("joint", DataType::UInt8),
        field("position_m", f64_tuple(3)),
        field("state", DataType::UInt8),
        nullable("confidence", DataType::Float32),
    ])
}

fn fields() -> Fields {
    Fields::from(vec![
        field("sensor_id", DataType::Utf8),
        field("seq", DataType::UInt64),
        field("local_stamp_nanos", DataType::Int64),
        field("joints", list_of(struct_of(joint_fields()))),
    ])
}

impl Message for SkeletonFrameMessage {
    const NAME: &'static str = "skeleton_frame";

    fn data_type() -> DataType {
        struct_of(fields())
    }

    fn encode_many(messages: &[Self]) -> Result<ArrayRef> {
        let b = Builder {
            message: Self::NAME,
        };
        for (row, m) in messages.iter().enumerate() {
            if !m.confidence.is_empty() && m.confidence.len() != m.frame.joints.len() {
                return Err(Error::Encode {
                    message: Self::NAME,
                    detail: format!(
                        "row {row}: {} confidences for {} joints",
                        m.confidence.len(),
                        m.frame.joints.len()
                    ),
                });
            }
        }
        let samples = messages.iter().flat_map(|m| m.frame.joints.iter());
        let confidence: Vec<Option<f32>> = messages
            .iter()
            .flat_map(|m| (0..m.frame.joints.len()).map(|i| m.confidence_of(i)))
            .collect();
        let joints = b.structs(
            &joint_fields(),
            vec![
                Arc::new(UInt8Array::from_iter_values(
                    samples.clone().map(|s| joint_code(s.joint)),
                )),
                b.f64_tuples(
                    3,
                    point_values(samples.clone().map(|s| s.position_in_kinect)),
                )?,
                Arc::new(UInt8Array::from_iter_values(
                    samples.map(|s| state_code(s.state)),
                )),
                Arc::new(Float32Array::from(confidence)),
            ],
        )?;
        let lengths: Vec<usize> = messages.iter().map(|m| m.frame.joints.len()).collect();
        b.structs(
            &fields(),
            vec![
                b.strings(messages.iter().map(|m| m.frame.sensor_id.as_str())),
                Arc::new(UInt64Array::from_iter_values(
                    messages.iter().map(|m| m.frame.seq),
                )),
                Arc::new(Int64Array::from_iter_values(
                    messages.iter().map(|m| m.frame.local_stamp_nanos),
                )),
                b.list(struct_of(joint_fields()), &lengths, joints)?,
            ],
        )
    }

    fn decode_many(array: &dyn Array) -> Result<Vec<Self>> {
        let top = Col::new(array, Self::NAME).structs()?;
        no_null_rows(top, Self::NAME)?;
        let (c, sensor_path) = column(top, Self::NAME, "sensor_id")?;
        let sensor_ids = Col::new(c, &sensor_path).strings()?;
        let (c, seq_path) = column(top, Self::NAME, "seq")?;
        let seqs = Col::new(c, &seq_path).primitive::<UInt64Type>()?;
        let (c, stamp_path) = column(top, Self::NAME, "local_stamp_nanos")?;
        let stamps = Col::new(c, &stamp_path).primitive::<Int64Type>()?;
        let (c, joints_path) = column(top, Self::NAME, "joints")?;
        let joints_list = Col::new(c, &joints_path).list()?;
        let (items, confidence) = decode_joints(joints_list.values().as_ref(), &joints_path)?;

        let mut out = Vec::with_capacity(top.len());
        for row in 0..top.len() {
            let range = list_range(joints_list, &joints_path, row)?;
            let joints: Vec<JointSample> = items[range.clone()].to_vec();
            let conf: Vec<Option<f32>> = confidence[range].to_vec();
            out.push(SkeletonFrameMessage {
                frame: SkeletonFrame {
                    sensor_id: string(sensor_ids, &sensor_path, row)?,
                    seq: value(seqs, &seq_path, row)?,
                    local_stamp_nanos: value(stamps, &stamp_path, row)?,
                    joints,
                },
                confidence: if conf.iter().all(Option::is_none) {
                    Vec::new()
                } else {
                    conf
                },
            });
        }
        Ok(out)
    }
}

/// Decodes the flat joint items of the `joints` list.
fn decode_joints(array: &dyn Array, path: &str) -> Result<(Vec<JointSample>, Vec<Option<f32>>)> {
    let (items, samples) = decode_joint_samples(array, path)?;
    let (c, extra_path) = column(items, path, "confidence")?;
    let extra = Col::new(c, &extra_path).primitive::<Float32Type>()?;
    let confidence = (0..items.len()).map(|row| optional(extra, row)).collect();
    Ok((samples, confidence))
}
