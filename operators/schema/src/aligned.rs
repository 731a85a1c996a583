//! `aligned_set`: every sensor's joints at one server instant (`sync → trilaterate`), the
//! [`AlignedSet`] of `trigait-sync`.
//!
//! ```text
//! Struct {
//!   seq: UInt64, stamp_nanos: Int64 (server clock), policy: Utf8 ("slots" | "interpolate"),
//!   time_uncertainty_nanos: Int64, missing: List<Utf8>,
//!   sensors: List<Struct {
//!     sensor_id: Utf8, skew_nanos: Int64, time_uncertainty_nanos: Int64, frame_seqs: List<UInt64>,
//!     joints: List<Struct { joint: UInt8, position_in_kinect_m: FixedSizeList<Float64, 3>,
//!                           state: UInt8, interpolation_error_m: Float64 (nullable) }>
//!   }>
//! }
//! ```

use std::collections::BTreeMap;

use arrow_array::types::{Float64Type, Int64Type, UInt64Type};
use arrow_array::{Array, ArrayRef, Float64Array, Int64Array, StringArray, UInt64Array};
use arrow_schema::{DataType, Fields};
use trigait_skeleton::JointSample;
use trigait_sync::{AlignedSet, Policy, SensorView};

use crate::codec::{
    Builder, POSITION_IN_KINECT, Rows, decode_joint_samples, encode_joint_samples, f64_tuple,
    field, list_of, list_range, nullable, struct_of,
};
use crate::{Error, Message, Result};

fn joint_fields() -> Fields {
    Fields::from(vec![
        field("joint", DataType::UInt8),
        field(POSITION_IN_KINECT, f64_tuple(3)),
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
        let mut columns = encode_joint_samples(&b, samples)?;
        columns.push(
            b.optionals::<Float64Type>(
                views
                    .iter()
                    .flat_map(|(_, v)| v.interpolation_error_m.iter().copied()),
            ),
        );
        let joints = b.structs(&joint_fields(), columns)?;
        let joint_lengths: Vec<usize> = views.iter().map(|(_, v)| v.joints.len()).collect();
        let seq_lengths: Vec<usize> = views.iter().map(|(_, v)| v.frame_seqs.len()).collect();
        let sensors = b.structs(
            &sensor_fields(),
            vec![
                b.strings(views.iter().map(|(id, _)| id.as_str())),
                b.values::<Int64Type>(views.iter().map(|(_, v)| v.skew_nanos)),
                b.values::<Int64Type>(views.iter().map(|(_, v)| v.time_uncertainty_nanos)),
                b.list(
                    DataType::UInt64,
                    &seq_lengths,
                    b.values::<UInt64Type>(
                        views.iter().flat_map(|(_, v)| v.frame_seqs.iter().copied()),
                    ),
                )?,
                b.list(struct_of(joint_fields()), &joint_lengths, joints)?,
            ],
        )?;
        let sensor_lengths: Vec<usize> = messages.iter().map(|m| m.sensors.len()).collect();
        let missing_lengths: Vec<usize> = messages.iter().map(|m| m.missing.len()).collect();
        b.structs(
            &fields(),
            vec![
                b.values::<UInt64Type>(messages.iter().map(|m| m.seq)),
                b.values::<Int64Type>(messages.iter().map(|m| m.stamp_nanos)),
                b.strings(messages.iter().map(|m| m.policy.name())),
                b.values::<Int64Type>(messages.iter().map(|m| m.time_uncertainty_nanos)),
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
        let top = Rows::new(array, Self::NAME)?;
        let seqs = top.column::<UInt64Array>("seq")?;
        let stamps = top.column::<Int64Array>("stamp_nanos")?;
        let policies = top.column::<StringArray>("policy")?;
        let uncertainties = top.column::<Int64Array>("time_uncertainty_nanos")?;
        let missing_lists = top.list::<StringArray>("missing")?;
        let (sensors_list, sensors_path) = top.nested("sensors")?;
        let views = decode_sensors(sensors_list.values().as_ref(), &sensors_path)?;

        let mut out = Vec::with_capacity(top.array.len());
        for row in top.rows() {
            let policy_name = policies.get(row)?;
            let policy: Policy = policy_name.parse().map_err(|_| Error::InvalidValue {
                field: policies.path.clone(),
                row,
                value: policy_name.clone(),
                expected: "a sync policy: slots or interpolate",
            })?;
            let missing = missing_lists.get(row)?;
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
                seq: seqs.get(row)?,
                stamp_nanos: stamps.get(row)?,
                policy,
                sensors,
                missing,
                time_uncertainty_nanos: uncertainties.get(row)?,
            });
        }
        Ok(out)
    }
}

fn decode_sensors(array: &dyn Array, path: &str) -> Result<Vec<(String, SensorView)>> {
    let items = Rows::new(array, path)?;
    let ids = items.column::<StringArray>("sensor_id")?;
    let skews = items.column::<Int64Array>("skew_nanos")?;
    let uncertainties = items.column::<Int64Array>("time_uncertainty_nanos")?;
    let seq_lists = items.list::<UInt64Array>("frame_seqs")?;
    let (joints_list, joints_path) = items.nested("joints")?;
    let (samples, errors) = decode_joints(joints_list.values().as_ref(), &joints_path)?;

    items
        .rows()
        .map(|row| {
            let frame_seqs = seq_lists.get(row)?;
            let range = list_range(joints_list, &joints_path, row)?;
            let bad = || Error::BadLength {
                field: joints_path.clone(),
                expected: range.end,
                found: samples.len(),
            };
            Ok((
                ids.get(row)?,
                SensorView {
                    joints: samples.get(range.clone()).ok_or_else(bad)?.to_vec(),
                    interpolation_error_m: errors.get(range.clone()).ok_or_else(bad)?.to_vec(),
                    frame_seqs,
                    skew_nanos: skews.get(row)?,
                    time_uncertainty_nanos: uncertainties.get(row)?,
                },
            ))
        })
        .collect()
}

fn decode_joints(array: &dyn Array, path: &str) -> Result<(Vec<JointSample>, Vec<Option<f64>>)> {
    let (items, samples) = decode_joint_samples(array, path)?;
    let extra = items.column::<Float64Array>("interpolation_error_m")?;
    let errors = items.rows().map(|row| extra.optional(row)).collect();
    Ok((samples, errors))
}
