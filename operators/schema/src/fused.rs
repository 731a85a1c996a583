//! `fused_pose`: world-frame joints with covariance and diagnostics (`trilaterate → recorder`).
//!
//! ```text
//! Struct {
//!   set_seq: UInt64, stamp_nanos: Int64 (server clock),
//!   joints: List<Struct { joint: UInt8, position_m: FixedSizeList<Float64, 3> (world frame),
//!                         covariance_m2: FixedSizeList<Float64, 9> (row-major),
//!                         sensors_used: List<Utf8>, residual_m: Float64,
//!                         condition_number: Float64, estimator: Utf8 }>,
//!   skipped: List<Struct { joint: UInt8, reason: Utf8 }>
//! }
//! ```

use std::collections::BTreeMap;
use std::sync::Arc;

use arrow_array::types::{Float64Type, Int64Type, UInt8Type, UInt64Type};
use arrow_array::{Array, ArrayRef, Float64Array, Int64Array, UInt8Array, UInt64Array};
use arrow_schema::{DataType, Fields};
use nalgebra::{Matrix3, Point3};
use trigait_skeleton::Joint;

use crate::codec::{
    Builder, Col, column, f64_tuple, field, joint_code, joint_from_code, list_of, list_range,
    matrix_values, no_null_rows, point_values, string, struct_of, value,
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
}

fn joint_fields() -> Fields {
    Fields::from(vec![
        field("joint", DataType::UInt8),
        field("position_m", f64_tuple(3)),
        field("covariance_m2", f64_tuple(9)),
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
                Arc::new(UInt8Array::from_iter_values(
                    joints.iter().map(|(j, _)| joint_code(**j)),
                )),
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
                Arc::new(Float64Array::from_iter_values(
                    joints.iter().map(|(_, f)| f.residual_m),
                )),
                Arc::new(Float64Array::from_iter_values(
                    joints.iter().map(|(_, f)| f.condition_number),
                )),
                b.strings(joints.iter().map(|(_, f)| f.estimator.as_str())),
            ],
        )?;
        let skipped: Vec<(&Joint, &String)> =
            messages.iter().flat_map(|m| m.skipped.iter()).collect();
        let skipped_items = b.structs(
            &skipped_fields(),
            vec![
                Arc::new(UInt8Array::from_iter_values(
                    skipped.iter().map(|(j, _)| joint_code(**j)),
                )),
                b.strings(skipped.iter().map(|(_, r)| r.as_str())),
            ],
        )?;
        let joint_lengths: Vec<usize> = messages.iter().map(|m| m.joints.len()).collect();
        let skipped_lengths: Vec<usize> = messages.iter().map(|m| m.skipped.len()).collect();
        b.structs(
            &fields(),
            vec![
                Arc::new(UInt64Array::from_iter_values(
                    messages.iter().map(|m| m.set_seq),
                )),
                Arc::new(Int64Array::from_iter_values(
                    messages.iter().map(|m| m.stamp_nanos),
                )),
                b.list(struct_of(joint_fields()), &joint_lengths, joint_items)?,
                b.list(struct_of(skipped_fields()), &skipped_lengths, skipped_items)?,
            ],
        )
    }

    fn decode_many(array: &dyn Array) -> Result<Vec<Self>> {
        let name = Self::NAME;
        let top = Col::new(array, name).structs()?;
        no_null_rows(top, name)?;
        let (c, seq_path) = column(top, name, "set_seq")?;
        let seqs = Col::new(c, &seq_path).primitive::<UInt64Type>()?;
        let (c, stamp_path) = column(top, name, "stamp_nanos")?;
        let stamps = Col::new(c, &stamp_path).primitive::<Int64Type>()?;
        let (c, joints_path) = column(top, name, "joints")?;
        let joints_list = Col::new(c, &joints_path).list()?;
        let joints = decode_joints(joints_list.values().as_ref(), &joints_path)?;
        let (c, skipped_path) = column(top, name, "skipped")?;
        let skipped_list = Col::new(c, &skipped_path).list()?;
        let skipped = decode_skipped(skipped_list.values().as_ref(), &skipped_path)?;

        let mut out = Vec::with_capacity(top.len());
        for row in 0..top.len() {
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
                set_seq: value(seqs, &seq_path, row)?,
                stamp_nanos: value(stamps, &stamp_path, row)?,
                joints: fused,
                skipped: skipped_map,
            });
        }
        Ok(out)
    }
}

fn decode_joints(array: &dyn Array, path: &str) -> Result<Vec<(Joint, FusedJoint)>> {
    let items = Col::new(array, path).structs()?;
    no_null_rows(items, path)?;
    let (c, joint_path) = column(items, path, "joint")?;
    let joints = Col::new(c, &joint_path).primitive::<UInt8Type>()?;
    let (c, pos_path) = column(items, path, "position_m")?;
    let positions = Col::new(c, &pos_path).f64_tuples(3)?;
    let (c, cov_path) = column(items, path, "covariance_m2")?;
    let covariances = Col::new(c, &cov_path).f64_tuples(9)?;
    let (c, used_path) = column(items, path, "sensors_used")?;
    let used_list = Col::new(c, &used_path).list()?;
    let used_values = Col::new(used_list.values().as_ref(), &used_path).strings()?;
    let (c, res_path) = column(items, path, "residual_m")?;
    let residuals = Col::new(c, &res_path).primitive::<Float64Type>()?;
    let (c, cond_path) = column(items, path, "condition_number")?;
    let conditions = Col::new(c, &cond_path).primitive::<Float64Type>()?;
    let (c, est_path) = column(items, path, "estimator")?;
    let estimators = Col::new(c, &est_path).strings()?;

    (0..items.len())
        .map(|row| {
            let p = positions
                .get(3 * row..3 * row + 3)
                .ok_or_else(|| Error::BadLength {
                    field: pos_path.clone(),
                    expected: 3 * items.len(),
                    found: positions.len(),
                })?;
            let m = covariances
                .get(9 * row..9 * row + 9)
                .ok_or_else(|| Error::BadLength {
                    field: cov_path.clone(),
                    expected: 9 * items.len(),
                    found: covariances.len(),
                })?;
            let sensors_used = list_range(used_list, &used_path, row)?
                .map(|i| string(used_values, &used_path, i))
                .collect::<Result<Vec<String>>>()?;
            Ok((
                joint_from_code(value(joints, &joint_path, row)?, &joint_path, row)?,
                FusedJoint {
                    position: Point3::new(p[0], p[1], p[2]),
                    covariance: Matrix3::from_row_slice(m),
                    sensors_used,
                    residual_m: value(residuals, &res_path, row)?,
                    condition_number: value(conditions, &cond_path, row)?,
                    estimator: string(estimators, &est_path, row)?,
                },
            ))
        })
        .collect()
}

fn decode_skipped(array: &dyn Array, path: &str) -> Result<Vec<(Joint, String)>> {
    let items = Col::new(array, path).structs()?;
    no_null_rows(items, path)?;
    let (c, joint_path) = column(items, path, "joint")?;
    let joints = Col::new(c, &joint_path).primitive::<UInt8Type>()?;
    let (c, reason_path) = column(items, path, "reason")?;
    let reasons = Col::new(c, &reason_path).strings()?;
    (0..items.len())
        .map(|row| {
            Ok((
                joint_from_code(value(joints, &joint_path, row)?, &joint_path, row)?,
                string(reasons, &reason_path, row)?,
            ))
        })
        .collect()
}
