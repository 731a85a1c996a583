//! What the recorder draws in rerun (STYLE.md §2): a Z-up world, each sensor as axes and a
//! frustum, its raw joints in its own camera frame, the fused leg skeleton as keypoints with
//! bones from an annotation context, ground truth, per-axis time series of every joint (thesis
//! Fig. 6.12) and each sensor's clock offset.
//!
//! Entity paths:
//! - `world/sensors/<id>` (transform), `…/<id>/frustum` (pinhole), `…/<id>/joints` (raw);
//! - `world/fused` (points with keypoint ids), `world/fused_bones` (line strips), `world/truth`;
//! - `plots/<joint>/{x,y,z}`, `sync/offset_ms/<id>`, `sync/error_ms/<id>`;
//! - `timing/latency_ms` (end to end, per pose: newest contributing frame sent → recorded).
//!
//! Timelines: `server_time` (ns since the epoch, server clock) and `set` (aligned-set seq).
//! The layout the viewer opens with is [`send_blueprint`].

use rerun::RecordingStream;
use trigait_kinect::Intrinsics;
use trigait_rig::Rig;
use trigait_schema::{FrameTiming, FusedPose};
use trigait_skeleton::Joint;

use crate::config::Config;

/// Timeline of server-clock instants.
pub const SERVER_TIME: &str = "server_time";
/// Timeline of aligned-set numbers.
pub const SET: &str = "set";
/// Entity of the fused skeleton.
pub const FUSED: &str = "world/fused";
/// Entity of the end-to-end latency series.
pub const LATENCY: &str = "timing/latency_ms";

fn f32x3(p: &nalgebra::Point3<f64>) -> [f32; 3] {
    [p.x as f32, p.y as f32, p.z as f32]
}

/// Opens the recording: the `.rrd` file, a live viewer, both, or (neither configured) an
/// in-memory sink that is dropped.
pub fn open(config: &Config) -> eyre::Result<RecordingStream> {
    use eyre::Context;
    let builder = rerun::RecordingStreamBuilder::new("trigait");
    let rec = match (&config.rrd, &config.connect) {
        (Some(path), None) => {
            if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
                std::fs::create_dir_all(dir)
                    .with_context(|| format!("recorder: creating {}", dir.display()))?;
            }
            builder
                .save(path)
                .with_context(|| format!("recorder: RRD={}", path.display()))?
        }
        (None, Some(url)) => builder
            .connect_grpc_opts(url.clone())
            .with_context(|| format!("recorder: RERUN_CONNECT={url:?}"))?,
        (Some(path), Some(url)) => {
            if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
                std::fs::create_dir_all(dir)
                    .with_context(|| format!("recorder: creating {}", dir.display()))?;
            }
            let uri: rerun::external::re_uri::ProxyUri = url
                .parse()
                .with_context(|| format!("recorder: RERUN_CONNECT={url:?} is not a proxy url"))?;
            let file = rerun::sink::FileSink::new(path)
                .with_context(|| format!("recorder: RRD={}", path.display()))?;
            builder
                .set_sinks((file, rerun::sink::GrpcSink::new(uri)))
                .context("recorder: opening the rerun sinks")?
        }
        (None, None) => builder.buffered().context("recorder: opening rerun")?,
    };
    Ok(rec)
}

/// The default viewer layout (sent once, before any data, as the application's default
/// blueprint): the 3-D scene of sensors, raw and fused joints on the left; on the right the
/// per-axis joint trajectories (thesis Fig. 6.12) above the clock offsets of the sync node, and
/// the gait events when the recorder logs them. Time runs on `server_time`.
pub fn send_blueprint(rec: &RecordingStream) -> eyre::Result<()> {
    use rerun::blueprint::{
        Blueprint, BlueprintActivation, ContainerLike, Horizontal, Spatial3DView, TimePanel,
        TimeSeriesView, Vertical,
    };
    let scene: ContainerLike = Spatial3DView::new("walkway (world, Z up)")
        .with_origin("world")
        .into();
    let plots: ContainerLike = Vertical::new([
        TimeSeriesView::new("joint trajectories (m)")
            .with_origin("plots")
            .into(),
        TimeSeriesView::new("gait events")
            .with_origin("gait")
            .into(),
        TimeSeriesView::new("clock sync (ms)")
            .with_origin("sync")
            .into(),
        TimeSeriesView::new("latency (ms)")
            .with_origin("timing")
            .into(),
    ])
    .with_row_shares([2.0, 1.0, 1.0, 1.0])
    .into();
    Blueprint::new(Horizontal::new([scene, plots]).with_column_shares([3.0, 2.0]))
        .with_time_panel(TimePanel::new().with_timeline(SERVER_TIME))
        .send(
            rec,
            BlueprintActivation {
                make_active: true,
                make_default: true,
            },
        )?;
    Ok(())
}

/// Static content: axes convention, sensors, the skeleton's annotation context.
pub fn log_static(rec: &RecordingStream, rig: &Rig) -> eyre::Result<()> {
    rec.log_static("world", &rerun::ViewCoordinates::RIGHT_HAND_Z_UP())?;
    let k = Intrinsics::default();
    for sensor in &rig.sensors {
        let t = sensor.world_from_kinect.translation.vector;
        let q = sensor.world_from_kinect.rotation.into_inner();
        let path = format!("world/sensors/{}", sensor.id);
        rec.log_static(
            path.as_str(),
            &rerun::Transform3D::from_translation_rotation(
                [t.x as f32, t.y as f32, t.z as f32],
                rerun::Quaternion::from_xyzw([q.i as f32, q.j as f32, q.k as f32, q.w as f32]),
            ),
        )?;
        rec.log_static(format!("{path}/axes"), &rerun::TransformAxes3D::new(0.3))?;
        rec.log_static(
            format!("{path}/frustum"),
            &rerun::Pinhole::from_focal_length_and_resolution(
                [k.fx as f32, k.fy as f32],
                [k.width as f32, k.height as f32],
            )
            .with_camera_xyz(rerun::components::ViewCoordinates::LUF)
            .with_image_plane_distance(0.4),
        )?;
    }
    let mut connections: Vec<rerun::datatypes::KeypointPair> = Joint::BONES
        .iter()
        .map(|(a, b)| (a.index() as u16, b.index() as u16).into())
        .collect();
    connections.push(
        (
            Joint::HipLeft.index() as u16,
            Joint::HipRight.index() as u16,
        )
            .into(),
    );
    rec.log_static(
        FUSED,
        &rerun::AnnotationContext::new([rerun::datatypes::ClassDescription {
            info: (0, "fused skeleton").into(),
            keypoint_annotations: Joint::ALL
                .iter()
                .map(|j| (j.index() as u16, j.name()).into())
                .collect(),
            keypoint_connections: connections,
        }]),
    )?;
    for joint in Joint::LEGS {
        for axis in ["x", "y", "z"] {
            rec.log_static(
                format!("plots/{}/{axis}", joint.name()),
                &rerun::SeriesLines::new().with_names([format!("{} {axis} (m)", joint.name())]),
            )?;
        }
    }
    Ok(())
}

/// One fused pose, with the ground truth at its instant when known.
pub fn log_pose(
    rec: &RecordingStream,
    pose: &FusedPose,
    truth: &[nalgebra::Point3<f64>],
    latency_nanos: Option<i64>,
) -> eyre::Result<()> {
    rec.set_timestamp_nanos_since_epoch(SERVER_TIME, pose.stamp_nanos);
    rec.set_time_sequence(SET, i64::try_from(pose.set_seq).unwrap_or(i64::MAX));
    let points: Vec<[f32; 3]> = pose.joints.values().map(|j| f32x3(&j.position)).collect();
    let ids: Vec<u16> = pose.joints.keys().map(|j| j.index() as u16).collect();
    rec.log(
        FUSED,
        &rerun::Points3D::new(points)
            .with_class_ids([0_u16])
            .with_keypoint_ids(ids)
            .with_radii([0.025_f32])
            .with_labels(pose.joints.keys().map(|j| j.name())),
    )?;
    let bones: Vec<[[f32; 3]; 2]> = Joint::BONES
        .iter()
        .chain(std::iter::once(&(Joint::HipLeft, Joint::HipRight)))
        .filter_map(|(a, b)| {
            Some([
                f32x3(&pose.joints.get(a)?.position),
                f32x3(&pose.joints.get(b)?.position),
            ])
        })
        .collect();
    rec.log("world/fused_bones", &rerun::LineStrips3D::new(bones))?;
    if !truth.is_empty() {
        rec.log(
            "world/truth",
            &rerun::Points3D::new(truth.iter().map(f32x3))
                .with_radii([0.012_f32])
                .with_colors([rerun::Color::from_rgb(160, 160, 160)]),
        )?;
    }
    for (joint, fused) in &pose.joints {
        for (axis, v) in ["x", "y", "z"].iter().zip(fused.position.iter()) {
            rec.log(
                format!("plots/{}/{axis}", joint.name()),
                &rerun::Scalars::single(*v),
            )?;
        }
    }
    if let Some(latency) = latency_nanos {
        rec.log(LATENCY, &rerun::Scalars::single(latency as f64 * 1e-6))?;
    }
    Ok(())
}

/// One raw frame, drawn in its sensor's camera frame at `now_nanos`.
pub fn log_raw(rec: &RecordingStream, frame: &FrameTiming, now_nanos: i64) -> eyre::Result<()> {
    rec.reset_time();
    rec.set_timestamp_nanos_since_epoch(SERVER_TIME, frame.server_stamp_nanos.unwrap_or(now_nanos));
    rec.log(
        format!("world/sensors/{}/joints", frame.sensor_id),
        &rerun::Points3D::new(frame.joints.iter().map(|s| f32x3(&s.position_in_kinect)))
            .with_radii([0.015_f32]),
    )?;
    Ok(())
}

/// Clock offsets and mapping errors.
pub fn log_timing(rec: &RecordingStream, rows: &[FrameTiming]) -> eyre::Result<()> {
    rec.reset_time();
    for row in rows {
        let Some(server) = row.server_stamp_nanos else {
            continue;
        };
        rec.set_timestamp_nanos_since_epoch(SERVER_TIME, server);
        if let Some(offset) = row.offset_nanos {
            rec.log(
                format!("sync/offset_ms/{}", row.sensor_id),
                &rerun::Scalars::single(offset as f64 * 1e-6),
            )?;
        }
        if let Some(err) = row.error_nanos() {
            rec.log(
                format!("sync/error_ms/{}", row.sensor_id),
                &rerun::Scalars::single(err as f64 * 1e-6),
            )?;
        }
    }
    Ok(())
}
