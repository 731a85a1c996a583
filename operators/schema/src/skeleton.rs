//! `skeleton_frame`: one sensor's body in one depth frame (`kinect-source → sync`).
//!
//! ```text
//! Struct {
//!   sensor_id: Utf8, seq: UInt64, local_stamp_nanos: Int64 (sensor clock),
//!   joints: List<Struct { joint: UInt8, position_in_kinect_m: FixedSizeList<Float64, 3>,
//!                         state: UInt8 }>
//! }
//! ```

use arrow_array::types::{Int64Type, UInt64Type};
use arrow_array::{Array, ArrayRef, Int64Array, StringArray, UInt64Array};
use arrow_schema::{DataType, Fields};
use trigait_skeleton::{JointSample, SkeletonFrame};

use crate::codec::{
    Builder, Rows, decode_joint_samples, encode_joint_samples, field, joint_sample_fields, list_of,
    list_range, struct_of,
};
use crate::{Message, Result};

/// A [`SkeletonFrame`] as sent.
#[derive(Debug, Clone, PartialEq)]
pub struct SkeletonFrameMessage {
    /// The frame.
    pub frame: SkeletonFrame,
}

impl From<SkeletonFrame> for SkeletonFrameMessage {
    fn from(frame: SkeletonFrame) -> Self {
        SkeletonFrameMessage { frame }
    }
}

fn joint_fields() -> Fields {
    joint_sample_fields()
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
        let samples = messages.iter().flat_map(|m| m.frame.joints.iter());
        let columns = encode_joint_samples(&b, samples)?;
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
        let (_, items) = decode_joint_samples(joints_list.values().as_ref(), &joints_path)?;

        let mut out = Vec::with_capacity(top.array.len());
        for row in top.rows() {
            let range = list_range(joints_list, &joints_path, row)?;
            let joints: Vec<JointSample> = items[range].to_vec();
            out.push(SkeletonFrameMessage {
                frame: SkeletonFrame {
                    sensor_id: sensor_ids.get(row)?,
                    seq: seqs.get(row)?,
                    local_stamp_nanos: stamps.get(row)?,
                    joints,
                },
            });
        }
        Ok(out)
    }
}
