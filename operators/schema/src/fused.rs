//! `fused_pose`: world-frame joints with covariance and diagnostics (`trilaterate → recorder`).
//!
//! ```text
//! Struct {
//!   set_seq: UInt64, stamp_nanos: Int64 (server clock),
//!   joints: List<Struct { joint: UInt8, position_in_world_m: FixedSizeList<Float64, 3>,
//!                         covariance_in_world_m2: FixedSizeList<Float64, 9> (row-major),
//!                         sensors_used: List<Utf8>, residual_m: Float64,
//!                         condition_number: Float64, estimator: Utf8 }>,
//!   skipped: List<Struct { joint: UInt8, reason: Utf8 }>,
//!   missing_sensors: List<Utf8>
//! }
//! ```

use std::collections::BTreeMap;

use arrow_array::types::{Float64Type, Int64Type, UInt8Type, UInt64Type};
use arrow_array::{
    Array, ArrayRef, Float64Array, Int64Array, StringArray, UInt8Array, UInt64Array,
};
use arrow_schema::{DataType, Fields};
use nalgebra::{Matrix3, Point3};
use trigait_skeleton::Joint;

use crate::codec::{
    Builder, Rows, f64_tuple, field, joint_code, joint_from_code, list_of, list_range,
    matrix_values, point_values, struct_of,
};
use crate::{Error, Message, Result};

/// One fused joint. Mirrors what `trigait-trilateration` reports per joint; kept here as plain
/// data so the schema does not depend on the estimator crate.
#[derive(Debug, Clone, PartialEq)]
pub struct FusedJoint {
    /// Position in the world frame, metres.
    pub position: Point3<f64>,
    /// Covariance of `position`, m².
    pub covariance: Matrix3<f64>,
    /// Ids of the sensors whose observations were used.
    pub sensors_used: Vec<String>,
    /// RMS residual of the fit, metres.
    pub residual_m: f64,
    /// Condition number of the system solved.
    pub condition_number: f64,
    /// Estimator name (`geometric`, `linear`, `nls`, `fusion`, optionally robust).
    pub estimator: String,
}

/// The fused skeleton at one instant.
#[derive(Debug, Clone, PartialEq)]
pub struct FusedPose {
    /// `seq` of the aligned set it was fused from.
    pub set_seq: u64,
    /// The instant, server clock, nanoseconds.
    pub stamp_nanos: i64,
    /// The joints fused.
    pub joints: BTreeMap<Joint, FusedJoint>,
    /// Joints not fused, with the reason (e.g. too few sensors).
    pub skipped: BTreeMap<Joint, String>,
    /// Sensors expected but absent from the aligned set, sorted (`sync`'s `missing`).
    pub missing_sensors: Vec<String>,
}

fn joint_fields() -> Fields {
    Fields::from(vec![
        field("joint", DataType::UInt8),
        field("position_in_world_m", f64_tuple(3)),
        field("covariance_in_world_m2", f64_tuple(9)),
        field("sensors_used", list_of(DataType::Utf8)),
        field("residual_m", DataType::Float64),
        field("condition_number", DataType::Float64),
        field("estimator", DataType::Utf8),
    ])
}

fn skipped_fields() -> Fields {
    Fields::from(vec![
        field("joint", DataType::UInt8),
        field("reason", DataType::Utf8),
    ])
}

fn fields() -> Fields {
    Fields::from(vec![
        field("set_seq", DataType::UInt64),
        field("stamp_nanos", DataType::Int64),
        field("joints", list_of(struct_of(joint_fields()))),
        field("skipped", list_of(struct_of(skipped_fields()))),
        field("missing_sensors", list_of(DataType::Utf8)),
    ])
}

impl Message for FusedPose {
    const NAME: &'static str = "fused_pose";

    fn data_type() -> DataType {
        struct_of(fields())
    }

    fn encode_many(messages: &[Self]) -> Result<ArrayRef> {
        let b = Builder {
            message: Self::NAME,
        };
        let joints: Vec<(&Joint, &FusedJoint)> =
            messages.iter().flat_map(|m| m.joints.iter()).collect();
        let used_lengths: Vec<usize> = joints.iter().map(|(_, j)| j.sensors_used.len()).collect();
        let joint_items = b.structs(
            &joint_fields(),
            vec![
                b.values::<UInt8Type>(joints.iter().map(|(j, _)| joint_code(**j))),
                b.f64_tuples(3, point_values(joints.iter().map(|(_, f)| f.position)))?,
                b.f64_tuples(9, matrix_values(joints.iter().map(|(_, f)| f.covariance)))?,
                b.list(
                    DataType::Utf8,
                    &used_lengths,
                    b.strings(
                        joints
                            .iter()
                            .flat_map(|(_, f)| f.sensors_used.iter().map(String::as_str)),
                    ),
                )?,
                b.values::<Float64Type>(joints.iter().map(|(_, f)| f.residual_m)),
                b.values::<Float64Type>(joints.iter().map(|(_, f)| f.condition_number)),
                b.strings(joints.iter().map(|(_, f)| f.estimator.as_str())),
            ],
        )?;
        let skipped: Vec<(&Joint, &String)> =
            messages.iter().flat_map(|m| m.skipped.iter()).collect();
        let skipped_items = b.structs(
            &skipped_fields(),
            vec![
                b.values::<UInt8Type>(skipped.iter().map(|(j, _)| joint_code(**j))),
                b.strings(skipped.iter().map(|(_, r)| r.as_str())),
            ],
        )?;
        let joint_lengths: Vec<usize> = messages.iter().map(|m| m.joints.len()).collect();
        let skipped_lengths: Vec<usize> = messages.iter().map(|m| m.skipped.len()).collect();
        let missing_lengths: Vec<usize> =
            messages.iter().map(|m| m.missing_sensors.len()).collect();
        b.structs(
            &fields(),
            vec![
                b.values::<UInt64Type>(messages.iter().map(|m| m.set_seq)),
                b.values::<Int64Type>(messages.iter().map(|m| m.stamp_nanos)),
                b.list(struct_of(joint_fields()), &joint_lengths, joint_items)?,
                b.list(struct_of(skipped_fields()), &skipped_lengths, skipped_items)?,
                b.list(
                    DataType::Utf8,
                    &missing_lengths,
                    b.strings(
                        messages
                            .iter()
                            .flat_map(|m| m.missing_sensors.iter().map(String::as_str)),
                    ),
                )?,
            ],
        )
    }

    fn decode_many(array: &dyn Array) -> Result<Vec<Self>> {
        let top = Rows::new(array, Self::NAME)?;
        let seqs = top.column::<UInt64Array>("set_seq")?;
        let stamps = top.column::<Int64Array>("stamp_nanos")?;
        let (joints_list, joints_path) = top.nested("joints")?;
        let joints = decode_joints(joints_list.values().as_ref(), &joints_path)?;
        let (skipped_list, skipped_path) = top.nested("skipped")?;
        let skipped = decode_skipped(skipped_list.values().as_ref(), &skipped_path)?;
        let missing = top.list::<StringArray>("missing_sensors")?;

        let mut out = Vec::with_capacity(top.array.len());
        for row in top.rows() {
            let pick = |list, path: &str, len: usize| -> Result<std::ops::Range<usize>> {
                let range = list_range(list, path, row)?;
                if range.end > len {
                    return Err(Error::BadLength {
                        field: path.to_owned(),
                        expected: range.end,
                        found: len,
                    });
                }
                Ok(range)
            };
            let joint_range = pick(joints_list, &joints_path, joints.len())?;
            let skipped_range = pick(skipped_list, &skipped_path, skipped.len())?;
            let fused: BTreeMap<Joint, FusedJoint> =
                joints[joint_range.clone()].iter().cloned().collect();
            let skipped_map: BTreeMap<Joint, String> =
                skipped[skipped_range.clone()].iter().cloned().collect();
            if fused.len() != joint_range.len() || skipped_map.len() != skipped_range.len() {
                return Err(Error::InvalidValue {
                    field: format!("{joints_path}.joint"),
                    row,
                    value: "a repeated joint".to_owned(),
                    expected: "each joint at most once per pose",
                });
            }
            out.push(FusedPose {
                set_seq: seqs.get(row)?,
                stamp_nanos: stamps.get(row)?,
                joints: fused,
                skipped: skipped_map,
                missing_sensors: missing.get(row)?,
            });
        }
        Ok(out)
    }
}

fn decode_joints(array: &dyn Array, path: &str) -> Result<Vec<(Joint, FusedJoint)>> {
    let items = Rows::new(array, path)?;
    let joints = items.column::<UInt8Array>("joint")?;
    let positions = items.tuples("position_in_world_m", 3)?;
    let covariances = items.tuples("covariance_in_world_m2", 9)?;
    let used_lists = items.list::<StringArray>("sensors_used")?;
    let residuals = items.column::<Float64Array>("residual_m")?;
    let conditions = items.column::<Float64Array>("condition_number")?;
    let estimators = items.column::<StringArray>("estimator")?;

    items
        .rows()
        .map(|row| {
            let position = positions.point(row)?;
            let covariance = Matrix3::from_row_slice(covariances.get(row)?);
            let sensors_used = used_lists.get(row)?;
            Ok((
                joint_from_code(joints.get(row)?, &joints.path, row)?,
                FusedJoint {
                    position,
                    covariance,
                    sensors_used,
                    residual_m: residuals.get(row)?,
                    condition_number: conditions.get(row)?,
                    estimator: estimators.get(row)?,
                },
            ))
        })
        .collect()
}

fn decode_skipped(array: &dyn Array, path: &str) -> Result<Vec<(Joint, String)>> {
    let items = Rows::new(array, path)?;
    let joints = items.column::<UInt8Array>("joint")?;
    let reasons = items.column::<StringArray>("reason")?;
    items
        .rows()
        .map(|row| {
            Ok((
                joint_from_code(joints.get(row)?, &joints.path, row)?,
                reasons.get(row)?,
            ))
        })
        .collect()
}
