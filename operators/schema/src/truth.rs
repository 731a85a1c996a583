//! `ground_truth`: where the simulated body's joints really are at one true instant (a
//! simulated source → `recorder`), in the world frame. Sent once per instant by one source,
//! batched: a message may hold many rows, one per instant.
//!
//! ```text
//! Struct {
//!   true_stamp_nanos: Int64 (server clock),
//!   joints: List<Struct { joint: UInt8, position_in_world_m: FixedSizeList<Float64, 3> }>
//! }
//! ```

use std::collections::BTreeMap;

use arrow_array::types::{Int64Type, UInt8Type};
use arrow_array::{Array, ArrayRef, Int64Array, UInt8Array};
use arrow_schema::{DataType, Fields};
use nalgebra::Point3;
use trigait_skeleton::Joint;

use crate::codec::{
    Builder, Rows, f64_tuple, field, joint_code, joint_from_code, list_of, list_range,
    point_values, struct_of,
};
use crate::{Message, Result};

/// The true world positions of the simulated joints at one instant.
#[derive(Debug, Clone, PartialEq)]
pub struct GroundTruth {
    /// The true instant, server clock, ns.
    pub true_stamp_nanos: i64,
    /// World frame (Z up, floor z = 0), metres.
    pub position_in_world: BTreeMap<Joint, Point3<f64>>,
}

fn joint_fields() -> Fields {
    Fields::from(vec![
        field("joint", DataType::UInt8),
        field("position_in_world_m", f64_tuple(3)),
    ])
}

fn fields() -> Fields {
    Fields::from(vec![
        field("true_stamp_nanos", DataType::Int64),
        field("joints", list_of(struct_of(joint_fields()))),
    ])
}

impl Message for GroundTruth {
    const NAME: &'static str = "ground_truth";

    fn data_type() -> DataType {
        struct_of(fields())
    }

    fn encode_many(messages: &[Self]) -> Result<ArrayRef> {
        let b = Builder {
            message: Self::NAME,
        };
        let joints = || messages.iter().flat_map(|m| m.position_in_world.iter());
        let items = b.structs(
            &joint_fields(),
            vec![
                b.values::<UInt8Type>(joints().map(|(j, _)| joint_code(*j))),
                b.f64_tuples(3, point_values(joints().map(|(_, p)| *p)))?,
            ],
        )?;
        let lengths: Vec<usize> = messages.iter().map(|m| m.position_in_world.len()).collect();
        b.structs(
            &fields(),
            vec![
                b.values::<Int64Type>(messages.iter().map(|m| m.true_stamp_nanos)),
                b.list(struct_of(joint_fields()), &lengths, items)?,
            ],
        )
    }

    fn decode_many(array: &dyn Array) -> Result<Vec<Self>> {
        let top = Rows::new(array, Self::NAME)?;
        let stamps = top.column::<Int64Array>("true_stamp_nanos")?;
        let (joints_list, joints_path) = top.nested("joints")?;
        let items = Rows::new(joints_list.values().as_ref(), &joints_path)?;
        let codes = items.column::<UInt8Array>("joint")?;
        let positions = items.tuples("position_in_world_m", 3)?;
        let mut out = Vec::with_capacity(top.array.len());
        for row in top.rows() {
            let mut position_in_world = BTreeMap::new();
            for i in list_range(joints_list, &joints_path, row)? {
                let joint = joint_from_code(codes.get(i)?, &codes.path, i)?;
                position_in_world.insert(joint, positions.point(i)?);
            }
            out.push(GroundTruth {
                true_stamp_nanos: stamps.get(row)?,
                position_in_world,
            });
        }
        Ok(out)
    }
}
