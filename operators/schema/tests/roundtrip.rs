//! Every message survives encode → decode unchanged (proptest), and malformed arrays are errors
//! naming the field, never panics.
#![allow(clippy::unwrap_used)] // tests may unwrap (STYLE.md §6)

use std::collections::BTreeMap;
use std::sync::Arc;

use arrow_array::{
    Array, ArrayRef, FixedSizeListArray, Float64Array, Int32Array, StringArray, StructArray,
    UInt8Array, UInt64Array,
};
use arrow_schema::{DataType, Field, Fields};
use nalgebra::{Matrix3, Point3};
use proptest::prelude::*;
use trigait_schema::{
    Error, FusedJoint, FusedPose, GroundTruth, Message, NtpExchange, SkeletonFrameMessage,
};
use trigait_skeleton::{Joint, JointSample, SkeletonFrame, TrackingState};
use trigait_sync::{AlignedSet, Policy, SensorView};

// ---- strategies ----------------------------------------------------------------------------

fn finite() -> impl Strategy<Value = f64> {
    -1e6_f64..1e6
}

fn point() -> impl Strategy<Value = Point3<f64>> {
    (finite(), finite(), finite()).prop_map(|(x, y, z)| Point3::new(x, y, z))
}

fn joint() -> impl Strategy<Value = Joint> {
    (0_usize..25).prop_map(|i| Joint::from_index(i).unwrap())
}

fn state() -> impl Strategy<Value = TrackingState> {
    (0_u8..3).prop_map(|i| TrackingState::from_index(i).unwrap())
}

fn sample() -> impl Strategy<Value = JointSample> {
    (joint(), point(), state()).prop_map(|(joint, position_in_kinect, state)| JointSample {
        joint,
        position_in_kinect,
        state,
    })
}

fn skeleton() -> impl Strategy<Value = SkeletonFrameMessage> {
    (
        ".{0,12}",
        any::<u64>(),
        any::<i64>(),
        prop::collection::vec(sample(), 0..26),
    )
        .prop_map(|(sensor_id, seq, local_stamp_nanos, joints)| {
            SkeletonFrameMessage::from(SkeletonFrame {
                sensor_id,
                seq,
                local_stamp_nanos,
                joints,
            })
        })
}

fn ntp() -> impl Strategy<Value = NtpExchange> {
    (
        "[a-z0-9-]{1,10}",
        any::<u64>(),
        any::<i64>(),
        any::<Option<(i64, i64)>>(),
        any::<Option<i64>>(),
    )
        .prop_map(|(id, request_id, t1, reply, t4)| {
            let mut e = NtpExchange::request(id, request_id, t1);
            if let Some((t2, t3)) = reply {
                e = e.answered(t2, t3);
            }
            e.t4_nanos = t4;
            e
        })
}

fn view() -> impl Strategy<Value = SensorView> {
    (
        prop::collection::vec((sample(), prop::option::of(0.0_f64..0.1)), 0..8),
        prop::collection::vec(any::<u64>(), 0..4),
        any::<i64>(),
        any::<i64>(),
    )
        .prop_map(
            |(joints, frame_seqs, skew_nanos, time_uncertainty_nanos)| SensorView {
                interpolation_error_m: joints.iter().map(|(_, e)| *e).collect(),
                joints: joints.into_iter().map(|(s, _)| s).collect(),
                frame_seqs,
                skew_nanos,
                time_uncertainty_nanos,
            },
        )
}

fn aligned() -> impl Strategy<Value = AlignedSet> {
    (
        any::<u64>(),
        any::<i64>(),
        prop_oneof![Just(Policy::Slots), Just(Policy::Interpolate)],
        prop::collection::btree_map("[a-z0-9]{1,6}", view(), 0..5),
        prop::collection::vec("[A-Z]{1,4}", 0..3),
        any::<i64>(),
    )
        .prop_map(
            |(seq, stamp_nanos, policy, sensors, missing, time_uncertainty_nanos)| AlignedSet {
                seq,
                stamp_nanos,
                policy,
                sensors,
                missing,
                time_uncertainty_nanos,
            },
        )
}

fn fused_joint() -> impl Strategy<Value = FusedJoint> {
    (
        point(),
        prop::collection::vec(finite(), 9),
        prop::collection::vec("[a-z0-9]{1,6}", 0..5),
        finite(),
        finite(),
        "[a-z-]{1,12}",
    )
        .prop_map(
            |(position, cov, sensors_used, residual_m, condition_number, estimator)| FusedJoint {
                position,
                covariance: Matrix3::from_row_slice(&cov),
                sensors_used,
                residual_m,
                condition_number,
                estimator,
            },
        )
}

fn fused() -> impl Strategy<Value = FusedPose> {
    (
        any::<u64>(),
        any::<i64>(),
        prop::collection::btree_map(joint(), fused_joint(), 0..7),
        prop::collection::btree_map(joint(), ".{0,20}", 0..3),
        prop::collection::vec("[a-z0-9]{1,4}", 0..3),
    )
        .prop_map(
            |(set_seq, stamp_nanos, joints, skipped, missing_sensors)| FusedPose {
                set_seq,
                stamp_nanos,
                joints,
                skipped,
                missing_sensors,
            },
        )
}

fn truth() -> impl Strategy<Value = GroundTruth> {
    (
        any::<i64>(),
        prop::collection::btree_map(joint(), point(), 0..25),
    )
        .prop_map(|(true_stamp_nanos, position_in_world)| GroundTruth {
            true_stamp_nanos,
            position_in_world,
        })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(128))]

    /// Ground truth batches (one row per instant) decode to the same instants and positions,
    /// and its column says the world frame.
    #[test]
    fn ground_truth_round_trips(ms in prop::collection::vec(truth(), 0..6)) {
        let array = GroundTruth::encode_many(&ms).unwrap();
        prop_assert_eq!(array.data_type(), &GroundTruth::data_type());
        let described = format!("{:?}", GroundTruth::data_type());
        prop_assert!(described.contains("position_in_world_m"), "{}", described);
        prop_assert_eq!(GroundTruth::decode_many(array.as_ref()).unwrap(), ms);
    }

    #[test]
    fn skeleton_frame_round_trips(m in skeleton()) {
        let array = SkeletonFrameMessage::encode(&m).unwrap();
        prop_assert_eq!(array.data_type(), &SkeletonFrameMessage::data_type());
        prop_assert_eq!(SkeletonFrameMessage::decode(array.as_ref()).unwrap(), m);
    }

    #[test]
    fn ntp_exchange_round_trips(m in ntp()) {
        let array = NtpExchange::encode(&m).unwrap();
        prop_assert_eq!(array.data_type(), &NtpExchange::data_type());
        prop_assert_eq!(NtpExchange::decode(array.as_ref()).unwrap(), m);
    }

    #[test]
    fn aligned_set_round_trips(m in aligned()) {
        let array = AlignedSet::encode(&m).unwrap();
        prop_assert_eq!(array.data_type(), &AlignedSet::data_type());
        prop_assert_eq!(AlignedSet::decode(array.as_ref()).unwrap(), m);
    }

    #[test]
    fn fused_pose_round_trips(m in fused()) {
        let array = FusedPose::encode(&m).unwrap();
        prop_assert_eq!(array.data_type(), &FusedPose::data_type());
        prop_assert_eq!(FusedPose::decode(array.as_ref()).unwrap(), m);
    }

    /// Several messages in one array (a recording) decode in order; a slice of it decodes to the
    /// matching sub-range (offsets of sliced lists are honoured).
    #[test]
    fn batches_and_slices_round_trip(ms in prop::collection::vec(aligned(), 0..5), start in 0_usize..5) {
        let array = AlignedSet::encode_many(&ms).unwrap();
        prop_assert_eq!(&AlignedSet::decode_many(array.as_ref()).unwrap(), &ms);
        let start = start.min(ms.len());
        let sliced = array.slice(start, ms.len() - start);
        prop_assert_eq!(&AlignedSet::decode_many(sliced.as_ref()).unwrap(), &ms[start..].to_vec());
    }

    /// Removing any one column, or replacing it by a column of another type, is an error that
    /// names that column, for every message type.
    #[test]
    fn damaged_columns_are_named(f in fused(), a in aligned(), s in skeleton(), n in ntp(), pick in any::<prop::sample::Index>(), replace in any::<bool>()) {
        for (name, array) in [
            ("fused_pose", FusedPose::encode(&f).unwrap()),
            ("aligned_set", AlignedSet::encode(&a).unwrap()),
            ("skeleton_frame", SkeletonFrameMessage::encode(&s).unwrap()),
            ("ntp_exchange", NtpExchange::encode(&n).unwrap()),
        ] {
            let top = array.as_any().downcast_ref::<StructArray>().unwrap();
            let i = pick.index(top.num_columns());
            let victim = top.fields()[i].name().clone();
            let damaged = damage(top, i, replace);
            let err = match name {
                "fused_pose" => FusedPose::decode(damaged.as_ref()).map(|_| ()).unwrap_err(),
                "aligned_set" => AlignedSet::decode(damaged.as_ref()).map(|_| ()).unwrap_err(),
                "skeleton_frame" => SkeletonFrameMessage::decode(damaged.as_ref()).map(|_| ()).unwrap_err(),
                _ => NtpExchange::decode(damaged.as_ref()).map(|_| ()).unwrap_err(),
            };
            let field = format!("{name}.{victim}");
            match &err {
                Error::MissingColumn { field: f } => prop_assert!(!replace && f == &field, "{err}"),
                Error::WrongType { field: f, .. } => prop_assert!(replace && f == &field, "{err}"),
                other => prop_assert!(false, "unexpected error {other}"),
            }
        }
    }
}

/// Column `i` of `top` removed, or replaced by an `Int32` column of the same length.
fn damage(top: &StructArray, i: usize, replace: bool) -> ArrayRef {
    let mut fields: Vec<Arc<Field>> = top.fields().iter().cloned().collect();
    let mut columns: Vec<ArrayRef> = top.columns().to_vec();
    if replace {
        fields[i] = Arc::new(Field::new(fields[i].name(), DataType::Int32, false));
        columns[i] = Arc::new(Int32Array::from(vec![7; top.len()]));
    } else {
        fields.remove(i);
        columns.remove(i);
    }
    Arc::new(
        StructArray::try_new_with_length(Fields::from(fields), columns, None, top.len()).unwrap(),
    )
}

// ---- specific malformed inputs ---------------------------------------------------------------

fn frame_with(joints: Vec<JointSample>) -> SkeletonFrameMessage {
    SkeletonFrame {
        sensor_id: "k1".into(),
        seq: 3,
        local_stamp_nanos: 42,
        joints,
    }
    .into()
}

/// Replaces the `joints` list's item column `name` with `column`.
fn with_joint_column(array: &ArrayRef, name: &str, column: ArrayRef) -> ArrayRef {
    let top = array.as_any().downcast_ref::<StructArray>().unwrap();
    let list = top
        .column_by_name("joints")
        .unwrap()
        .as_any()
        .downcast_ref::<arrow_array::ListArray>()
        .unwrap();
    let items = list
        .values()
        .as_any()
        .downcast_ref::<StructArray>()
        .unwrap();
    let idx = items
        .fields()
        .iter()
        .position(|f| f.name() == name)
        .unwrap();
    let mut fields: Vec<Arc<Field>> = items.fields().iter().cloned().collect();
    let mut columns = items.columns().to_vec();
    fields[idx] = Arc::new(Field::new(name, column.data_type().clone(), true));
    columns[idx] = column;
    let items = StructArray::try_new(Fields::from(fields.clone()), columns, None).unwrap();
    let list = arrow_array::ListArray::try_new(
        Arc::new(Field::new_list_field(
            DataType::Struct(Fields::from(fields)),
            false,
        )),
        list.offsets().clone(),
        Arc::new(items),
        None,
    )
    .unwrap();
    let mut top_fields: Vec<Arc<Field>> = top.fields().iter().cloned().collect();
    let mut top_columns = top.columns().to_vec();
    let j = top
        .fields()
        .iter()
        .position(|f| f.name() == "joints")
        .unwrap();
    top_fields[j] = Arc::new(Field::new("joints", list.data_type().clone(), false));
    top_columns[j] = Arc::new(list);
    Arc::new(StructArray::try_new(Fields::from(top_fields), top_columns, None).unwrap())
}

fn knee(state: TrackingState) -> JointSample {
    JointSample {
        joint: Joint::KneeLeft,
        position_in_kinect: Point3::new(0.1, 0.2, 2.0),
        state,
    }
}

/// Something that is not a struct at all.
#[test]
fn wrong_top_level_type() {
    let array: ArrayRef = Arc::new(UInt64Array::from(vec![1_u64]));
    let err = SkeletonFrameMessage::decode(array.as_ref()).unwrap_err();
    assert_eq!(
        err,
        Error::WrongType {
            field: "skeleton_frame".into(),
            expected: "Struct".into(),
            found: "UInt64".into()
        }
    );
    assert_eq!(
        err.to_string(),
        "skeleton_frame: expected Struct, found UInt64"
    );
}

/// A position with two coordinates is a length error naming `position_in_kinect_m`.
#[test]
fn position_of_wrong_length() {
    let array =
        SkeletonFrameMessage::encode(&frame_with(vec![knee(TrackingState::Tracked)])).unwrap();
    let pair = FixedSizeListArray::try_new(
        Arc::new(Field::new_list_field(DataType::Float64, false)),
        2,
        Arc::new(Float64Array::from(vec![1.0, 2.0])),
        None,
    )
    .unwrap();
    let damaged = with_joint_column(&array, "position_in_kinect_m", Arc::new(pair));
    let err = SkeletonFrameMessage::decode(damaged.as_ref()).unwrap_err();
    assert_eq!(
        err,
        Error::BadLength {
            field: "skeleton_frame.joints.position_in_kinect_m".into(),
            expected: 3,
            found: 2
        }
    );
}

/// Joint number 30 and tracking state 7 are invalid values naming their field.
#[test]
fn out_of_range_codes() {
    let array =
        SkeletonFrameMessage::encode(&frame_with(vec![knee(TrackingState::Tracked); 2])).unwrap();
    let damaged = with_joint_column(&array, "joint", Arc::new(UInt8Array::from(vec![13, 30])));
    let err = SkeletonFrameMessage::decode(damaged.as_ref()).unwrap_err();
    assert!(
        matches!(&err, Error::InvalidValue { field, row: 1, value, .. } if field == "skeleton_frame.joints.joint" && value == "30"),
        "{err}"
    );
    let damaged = with_joint_column(&array, "state", Arc::new(UInt8Array::from(vec![7, 2])));
    let err = SkeletonFrameMessage::decode(damaged.as_ref()).unwrap_err();
    assert!(
        matches!(&err, Error::InvalidValue { field, row: 0, .. } if field == "skeleton_frame.joints.state"),
        "{err}"
    );
}

/// A null where a value is required is an error with the field and row.
#[test]
fn null_required_value() {
    let array =
        SkeletonFrameMessage::encode(&frame_with(vec![knee(TrackingState::Inferred); 2])).unwrap();
    let damaged = with_joint_column(
        &array,
        "state",
        Arc::new(UInt8Array::from(vec![Some(1), None])),
    );
    assert_eq!(
        SkeletonFrameMessage::decode(damaged.as_ref()).unwrap_err(),
        Error::NullValue {
            field: "skeleton_frame.joints.state".into(),
            row: 1
        }
    );
}

/// An unknown policy name in an aligned set is an invalid value.
#[test]
fn unknown_policy_name() {
    let set = AlignedSet {
        seq: 1,
        stamp_nanos: 2,
        policy: Policy::Slots,
        sensors: BTreeMap::new(),
        missing: vec![],
        time_uncertainty_nanos: 0,
    };
    let array = AlignedSet::encode(&set).unwrap();
    let top = array.as_any().downcast_ref::<StructArray>().unwrap();
    let i = top
        .fields()
        .iter()
        .position(|f| f.name() == "policy")
        .unwrap();
    let mut columns = top.columns().to_vec();
    columns[i] = Arc::new(StringArray::from(vec!["tdma"]));
    let damaged = StructArray::try_new(top.fields().clone(), columns, None).unwrap();
    let err = AlignedSet::decode(&damaged).unwrap_err();
    assert!(
        matches!(&err, Error::InvalidValue { field, value, .. } if field == "aligned_set.policy" && value == "tdma"),
        "{err}"
    );
}

/// `decode` wants exactly one message; `decode_many` takes any number, including none.
#[test]
fn row_count() {
    let a = NtpExchange::request("k1", 1, 10);
    let b = a.clone().answered(20, 30).completed(40);
    let two = NtpExchange::encode_many(&[a.clone(), b.clone()]).unwrap();
    assert_eq!(
        NtpExchange::decode(two.as_ref()).unwrap_err(),
        Error::RowCount {
            message: "ntp_exchange",
            found: 2
        }
    );
    assert_eq!(
        NtpExchange::decode_many(two.as_ref()).unwrap(),
        vec![a.clone(), b.clone()]
    );
    let none = NtpExchange::encode_many(&[]).unwrap();
    assert_eq!(none.len(), 0);
    assert!(matches!(
        NtpExchange::decode(none.as_ref()),
        Err(Error::RowCount { found: 0, .. })
    ));
    assert_eq!(a.sample(), None);
    assert_eq!(
        b.sample(),
        Some(trigait_sync::NtpSample {
            t1: 10,
            t2: 20,
            t3: 30,
            t4: 40
        })
    );
}

/// Covariances are row-major on the wire: element (0, 1) is the second value.
#[test]
fn covariance_is_row_major() {
    let mut joints = BTreeMap::new();
    let covariance = Matrix3::new(1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0);
    joints.insert(
        Joint::AnkleRight,
        FusedJoint {
            position: Point3::new(1.0, 2.0, 0.1),
            covariance,
            sensors_used: vec!["k1".into(), "k2".into()],
            residual_m: 0.01,
            condition_number: 3.5,
            estimator: "fusion".into(),
        },
    );
    let pose = FusedPose {
        set_seq: 9,
        stamp_nanos: 1,
        joints,
        skipped: BTreeMap::from([(Joint::Head, "1 sensor < 3".into())]),
        missing_sensors: Vec::new(),
    };
    let array = FusedPose::encode(&pose).unwrap();
    let top = array.as_any().downcast_ref::<StructArray>().unwrap();
    let list = top
        .column_by_name("joints")
        .unwrap()
        .as_any()
        .downcast_ref::<arrow_array::ListArray>()
        .unwrap();
    let items = list
        .values()
        .as_any()
        .downcast_ref::<StructArray>()
        .unwrap();
    let cov = items
        .column_by_name("covariance_in_world_m2")
        .unwrap()
        .as_any()
        .downcast_ref::<FixedSizeListArray>()
        .unwrap();
    let values = cov.value(0);
    let values = values.as_any().downcast_ref::<Float64Array>().unwrap();
    assert_eq!(
        values.values().to_vec(),
        (1..=9).map(f64::from).collect::<Vec<_>>()
    );
    assert_eq!(FusedPose::decode(array.as_ref()).unwrap(), pose);
}

/// Any message decoded as any other message type is an error, not a panic or a wrong value.
#[test]
fn messages_are_not_interchangeable() {
    let set = AlignedSet {
        seq: 1,
        stamp_nanos: 2,
        policy: Policy::Interpolate,
        sensors: BTreeMap::from([(
            "k1".to_owned(),
            SensorView {
                joints: vec![knee(TrackingState::Tracked)],
                interpolation_error_m: vec![Some(0.001)],
                frame_seqs: vec![4, 5],
                skew_nanos: -3,
                time_uncertainty_nanos: 100,
            },
        )]),
        missing: vec!["k2".into()],
        time_uncertainty_nanos: 100,
    };
    let pose = FusedPose {
        set_seq: 1,
        stamp_nanos: 2,
        joints: BTreeMap::new(),
        skipped: BTreeMap::new(),
        missing_sensors: vec!["k3".into()],
    };
    let arrays = [
        SkeletonFrameMessage::encode(&frame_with(vec![knee(TrackingState::Tracked)])).unwrap(),
        NtpExchange::encode(&NtpExchange::request("k1", 1, 2)).unwrap(),
        AlignedSet::encode(&set).unwrap(),
        FusedPose::encode(&pose).unwrap(),
    ];
    for (i, array) in arrays.iter().enumerate() {
        let results = [
            SkeletonFrameMessage::decode(array.as_ref()).is_ok(),
            NtpExchange::decode(array.as_ref()).is_ok(),
            AlignedSet::decode(array.as_ref()).is_ok(),
            FusedPose::decode(array.as_ref()).is_ok(),
        ];
        for (j, ok) in results.into_iter().enumerate() {
            assert_eq!(ok, i == j, "message {i} decoded as {j}");
        }
    }
}
