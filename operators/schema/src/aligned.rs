//! `aligned_set`: every sensor's joints at one server instant (`sync → trilaterate`), the
//! [`AlignedSet`] of `trigait-sync`.
//!
//! ```text
//! Struct {
//!   seq: UInt64, stamp_nanos: Int64 (server clock), policy: Utf8 ("slots" | "interpolate"),
//!   time_uncertainty_nanos: Int64, missing: List<Utf8>,
//!   sensors: List<Struct {
//!     sensor_id: Utf8, skew_nanos: Int64, time_uncertainty_nanos: Int64, frame_seqs: List<UInt64>,
//!     joints: List<Struct { joint: UInt8, position_m: FixedSizeList<Float64, 3> (camera frame),
//!                           state: UInt8, interpolation_error_m: Float64 (nullable) }>
//!   }>
//! }
//! ```

use std::collections::BTreeMap;
use std::sync::Arc;

use arrow_array::types::{Float64Type, Int64Type, UInt64Type};
use arrow_array::{Array, ArrayRef, Float64Array, Int64Array, UInt8Array, UInt64Array};
use arrow_schema::{DataType, Fields};
use trigait_skeleton::JointSample;
use trigait_sync::{AlignedSet, Policy, SensorView};

use crate::codec::{
    Builder, Col, column, decode_joint_samples, f64_tuple, field, joint_code, list_of, list_range,
    no_null_rows, nullable, optional, point_values, state_code, string, struct_of, value,
};
use crate::{Error, Message, Result};

fn joint_fields() -> Fields {
    Fields::from(vec![
        field("joint", DataType::UInt8),
        field("position_m", f64_tuple(3)),
        field("state", DataType::UInt8),
        nullable("interpolation_error_m", DataType::Float64),
    ])
}

fn sensor_fields() -> Fields {
    Fields::from(vec![
        field("sensor_id", DataType::Utf8),
        field("skew_nanos", DataType::Int64),
        field("time_uncertainty_nanos", DataType::Int64),
        field("frame_seqs", list_of(DataType::UInt64)),
        field("joints", list_of(struct_of(joint_fields()))),
    ])
}

fn fields() -> Fields {
    Fields::from(vec![
        field("seq", DataType::UInt64),
        field("stamp_nanos", DataType::Int64),
        field("policy", DataType::Utf8),
        field("time_uncertainty_nanos", DataType::Int64),
        field("missing", list_of(DataType::Utf8)),
        field("sensors", list_of(struct_of(sensor_fields()))),
    ])
}

impl Message for AlignedSet {
    const NAME: &'static str = "aligned_set";

    fn data_type() -> DataType {
        struct_of(fields())
    }

    fn encode_many(messages: &[Self]) -> Result<ArrayRef> {
        let b = Builder {
            message: Self::NAME,
        };
        let views: Vec<(&String, &SensorView)> =
            messages.iter().flat_map(|m| m.sensors.iter()).collect();
        for (id, v) in &views {
            if v.interpolation_error_m.len() != v.joints.len() {
                return Err(Error::Encode {
                    message: Self::NAME,
                    detail: format!(
                        "sensor {id:?}: {} interpolation errors for {} joints",
                        v.interpolation_error_m.len(),
                        v.joints.len()
                    ),
                });
            }
        }
        let samples = views.iter().flat_map(|(_, v)| v.joints.iter());
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
                Arc::new(Float64Array::from_iter(
                    views
                        .iter()
                        .flat_map(|(_, v)| v.interpolation_error_m.iter().copied()),
                )),
            ],
        )?;
        let joint_lengths: Vec<usize> = views.iter().map(|(_, v)| v.joints.len()).collect();
        let seq_lengths: Vec<usize> = views.iter().map(|(_, v)| v.frame_seqs.len()).collect();
        let sensors = b.structs(
            &sensor_fields(),
            vec![
                b.strings(views.iter().map(|(id, _)| id.as_str())),
                Arc::new(Int64Array::from_iter_values(
                    views.iter().map(|(_, v)| v.skew_nanos),
                )),
                Arc::new(Int64Array::from_iter_values(
                    views.iter().map(|(_, v)| v.time_uncertainty_nanos),
                )),
                b.list(
                    DataType::UInt64,
                    &seq_lengths,
                    Arc::new(UInt64Array::from_iter_values(
                        views.iter().flat_map(|(_, v)| v.frame_seqs.iter().copied()),
                    )),
                )?,
                b.list(struct_of(joint_fields()), &joint_lengths, joints)?,
            ],
        )?;
        let sensor_lengths: Vec<usize> = messages.iter().map(|m| m.sensors.len()).collect();
        let missing_lengths: Vec<usize> = messages.iter().map(|m| m.missing.len()).collect();
        b.structs(
            &fields(),
            vec![
                Arc::new(UInt64Array::from_iter_values(
                    messages.iter().map(|m| m.seq),
                )),
                Arc::new(Int64Array::from_iter_values(
                    messages.iter().map(|m| m.stamp_nanos),
                )),
                b.strings(messages.iter().map(|m| m.policy.name())),
                Arc::new(Int64Array::from_iter_values(
                    messages.iter().map(|m| m.time_uncertainty_nanos),
                )),
                b.list(
                    DataType::Utf8,
                    &missing_lengths,
                    b.strings(
                        messages
                            .iter()
                            .flat_map(|m| m.missing.iter().map(String::as_str)),
                    ),
                )?,
                b.list(struct_of(sensor_fields()), &sensor_lengths, sensors)?,
            ],
        )
    }

    fn decode_many(array: &dyn Array) -> Result<Vec<Self>> {
        let name = Self::NAME;
        let top = Col::new(array, name).structs()?;
        no_null_rows(top, name)?;
        let (c, seq_path) = column(top, name, "seq")?;
        let seqs = Col::new(c, &seq_path).primitive::<UInt64Type>()?;
        let (c, stamp_path) = column(top, name, "stamp_nanos")?;
        let stamps = Col::new(c, &stamp_path).primitive::<Int64Type>()?;
        let (c, policy_path) = column(top, name, "policy")?;
        let policies = Col::new(c, &policy_path).strings()?;
        let (c, unc_path) = column(top, name, "time_uncertainty_nanos")?;
        let uncertainties = Col::new(c, &unc_path).primitive::<Int64Type>()?;
        let (c, missing_path) = column(top, name, "missing")?;
        let missing_list = Col::new(c, &missing_path).list()?;
        let missing_values = Col::new(missing_list.values().as_ref(), &missing_path).strings()?;
        let (c, sensors_path) = column(top, name, "sensors")?;
        let sensors_list = Col::new(c, &sensors_path).list()?;
        let views = decode_sensors(sensors_list.values().as_ref(), &sensors_path)?;

        let mut out = Vec::with_capacity(top.len());
        for row in 0..top.len() {
            let policy_name = string(policies, &policy_path, row)?;
            let policy: Policy = policy_name.parse().map_err(|_| Error::InvalidValue {
                field: policy_path.clone(),
                row,
                value: policy_name.clone(),
                expected: "a sync policy: slots or interpolate",
            })?;
            let missing = list_range(missing_list, &missing_path, row)?
                .map(|i| string(missing_values, &missing_path, i))
                .collect::<Result<Vec<String>>>()?;
            let range = list_range(sensors_list, &sensors_path, row)?;
            let sensors: BTreeMap<String, SensorView> = views
                .get(range.clone())
                .ok_or_else(|| Error::BadLength {
                    field: sensors_path.clone(),
                    expected: range.end,
                    found: views.len(),
                })?
                .iter()
                .cloned()
                .collect();
            if sensors.len() != range.len() {
                return Err(Error::InvalidValue {
                    field: format!("{sensors_path}.sensor_id"),
                    row,
                    value: "a repeated sensor id".to_owned(),
                    expected: "each sensor at most once per set",
                });
            }
            out.push(AlignedSet {
                seq: value(seqs, &seq_path, row)?,
                stamp_nanos: value(stamps, &stamp_path, row)?,
                policy,
                sensors,
                missing,
                time_uncertainty_nanos: value(uncertainties, &unc_path, row)?,
            });
        }
        Ok(out)
    }
}

fn decode_sensors(array: &dyn Array, path: &str) -> Result<Vec<(String, SensorView)>> {
    let items = Col::new(array, path).structs()?;
    no_null_rows(items, path)?;
    let (c, id_path) = column(items, path, "sensor_id")?;
    let ids = Col::new(c, &id_path).strings()?;
    let (c, skew_path) = column(items, path, "skew_nanos")?;
    let skews = Col::new(c, &skew_path).primitive::<Int64Type>()?;
    let (c, unc_path) = column(items, path, "time_uncertainty_nanos")?;
    let uncertainties = Col::new(c, &unc_path).primitive::<Int64Type>()?;
    let (c, seqs_path) = column(items, path, "frame_seqs")?;
    let seqs_list = Col::new(c, &seqs_path).list()?;
    let seq_values = Col::new(seqs_list.values().as_ref(), &seqs_path).primitive::<UInt64Type>()?;
    let (c, joints_path) = column(items, path, "joints")?;
    let joints_list = Col::new(c, &joints_path).list()?;
    let (samples, errors) = decode_joints(joints_list.values().as_ref(), &joints_path)?;

    (0..items.len())
        .map(|row| {
            let frame_seqs = list_range(seqs_list, &seqs_path, row)?
                .map(|i| value(seq_values, &seqs_path, i))
                .collect::<Result<Vec<u64>>>()?;
            let range = list_range(joints_list, &joints_path, row)?;
            let bad = || Error::BadLength {
                field: joints_path.clone(),
                expected: range.end,
                found: samples.len(),
            };
            Ok((
                string(ids, &id_path, row)?,
                SensorView {
                    joints: samples.get(range.clone()).ok_or_else(bad)?.to_vec(),
                    interpolation_error_m: errors.get(range.clone()).ok_or_else(bad)?.to_vec(),
                    frame_seqs,
                    skew_nanos: value(skews, &skew_path, row)?,
                    time_uncertainty_nanos: value(uncertainties, &unc_path, row)?,
                },
            ))
        })
        .collect()
}

fn decode_joints(array: &dyn Array, path: &str) -> Result<(Vec<JointSample>, Vec<Option<f64>>)> {
    let (items, samples) = decode_joint_samples(array, path)?;
    let (c, extra_path) = column(items, path, "interpolation_error_m")?;
    let extra = Col::new(c, &extra_path).primitive::<Float64Type>()?;
    let errors = (0..items.len()).map(|row| optional(extra, row)).collect();
    Ok((samples, errors))
}
