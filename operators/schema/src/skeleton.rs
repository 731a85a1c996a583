//! `skeleton_frame`: one sensor's body in one depth frame (`kinect-source → sync`).
//!
//! ```text
//! Struct {
//!   sensor_id: Utf8, seq: UInt64, local_stamp_nanos: Int64 (sensor clock),
//!   joints: List<Struct { joint: UInt8, position_m: FixedSizeList<Float64, 3> (camera frame),
//!                         state: UInt8, confidence: Float32 (nullable) }>
//! }
//! ```

use arrow_array::types::{Float32Type, Int64Type, UInt64Type};
use arrow_array::{Array, ArrayRef, Float32Array, Int64Array, StringArray, UInt64Array};
use arrow_schema::{DataType, Fields};
use trigait_skeleton::{JointSample, SkeletonFrame};

use crate::codec::{
    Builder, Rows, decode_joint_samples, encode_joint_samples, f64_tuple, field, list_of,
    list_range, nullable, struct_of,
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
        let confidence = messages
            .iter()
            .flat_map(|m| (0..m.frame.joints.len()).map(|i| m.confidence_of(i)));
        let mut columns = encode_joint_samples(&b, samples)?;
        columns.push(b.optionals::<Float32Type>(confidence));
        let joints = b.structs(&joint_fields(), columns)?;
        let lengths: Vec<usize> = messages.iter().map(|m| m.frame.joints.len()).collect();
        b.structs(
            &fields(),
            vec![
                b.strings(messages.iter().map(|m| m.frame.sensor_id.as_str())),
                b.values::<UInt64Type>(messages.iter().map(|m| m.frame.seq)),
                b.values::<Int64Type>(messages.iter().map(|m| m.frame.local_stamp_nanos)),
                b.list(struct_of(joint_fields()), &lengths, joints)?,
            ],
        )
    }

    fn decode_many(array: &dyn Array) -> Result<Vec<Self>> {
        let top = Rows::new(array, Self::NAME)?;
        let sensor_ids = top.column::<StringArray>("sensor_id")?;
        let seqs = top.column::<UInt64Array>("seq")?;
        let stamps = top.column::<Int64Array>("local_stamp_nanos")?;
        let (joints_list, joints_path) = top.nested("joints")?;
        let (items, confidence) = decode_joints(joints_list.values().as_ref(), &joints_path)?;

        let mut out = Vec::with_capacity(top.array.len());
        for row in top.rows() {
            let range = list_range(joints_list, &joints_path, row)?;
            let joints: Vec<JointSample> = items[range.clone()].to_vec();
            let conf: Vec<Option<f32>> = confidence[range].to_vec();
            out.push(SkeletonFrameMessage {
                frame: SkeletonFrame {
                    sensor_id: sensor_ids.get(row)?,
                    seq: seqs.get(row)?,
                    local_stamp_nanos: stamps.get(row)?,
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
    let extra = items.column::<Float32Array>("confidence")?;
    let confidence = items.rows().map(|row| extra.optional(row)).collect();
    Ok((samples, confidence))
}
