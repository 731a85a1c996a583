//! `trilaterate`: fuses each `aligned_set` with the YAML-selected estimator into a `fused_pose`
//! (world frame, covariance, diagnostics); a joint too few sensors saw is listed in
//! `FusedPose::skipped` with the reason. Configuration: [`config`]. The fusion itself is
//! [`trigait_fusion`], the code `trigait eval` runs; this node only decodes, calls it, encodes.

mod config;
#[cfg(test)]
mod tests;

use dora_node_api::arrow_v59::array::Array;
use dora_node_api::dora_core::config::DataId;
use dora_node_api::{DoraNode, Event, EventStream};
use eyre::Context;
use tracing::{info, warn};
use trigait_fusion::{FusionRig, PoseFuser, SensorSamples};
use trigait_kinect::NoiseModel;
use trigait_node_config::RigStamp;
use trigait_schema::{FusedPose, Message, ports};
use trigait_sync::AlignedSet;

use crate::config::Config;

fn main() -> eyre::Result<()> {
    trigait_node_log::init("trilaterate");
    let config = Config::from_env()?;
    let (node, events) =
        DoraNode::init_from_env().context("trilaterate: connecting to the dora daemon")?;
    trigait_node_config::check_inputs(
        "trilaterate",
        node.node_config().inputs.keys().map(|id| id.as_str()),
        &[ports::ALIGNED_SET],
        &[],
    )?;
    run(config, node, events).map(|_| ())
}

/// Totals the node reports at the end.
#[derive(Debug, Default, Clone, PartialEq, Eq)]
pub struct Counters {
    /// Poses sent.
    pub poses_sent: u64,
    /// Joints fused.
    pub joints_fused: u64,
    /// Joints skipped.
    pub joints_skipped: u64,
    /// Inputs that could not be decoded (skipped).
    pub malformed: u64,
}

/// The event loop.
pub fn run(config: Config, mut node: DoraNode, mut events: EventStream) -> eyre::Result<Counters> {
    let mut fuser = pose_fuser(&config);
    info!(
        "estimator {} on rig {:?} ({} sensors)",
        config.estimator_name(),
        config.rig.name,
        config.rig.sensors.len()
    );
    let pose_out = DataId::from(ports::FUSED_POSE.to_owned());
    let mut counters = Counters::default();
    let mut warned_unknown = false;
    let stamp = RigStamp::new("trilaterate", &config.rig);
    while let Some(event) = events.recv() {
        trigait_node_log::warn_drops(&mut events);
        match event {
            Event::Input { id, metadata, data } => match id.as_str() {
                ports::ALIGNED_SET => {
                    stamp.check_params(&metadata.parameters)?;
                    let Some((set, pose, unknown)) =
                        on_aligned_set(&mut fuser, data.as_array().as_ref())
                    else {
                        counters.malformed += 1;
                        continue;
                    };
                    if counters.poses_sent == 0 {
                        let unwired = unwired_sensors(&config.rig, &set);
                        if !unwired.is_empty() {
                            warn!(
                                "rig {:?} has sensors {} that sync reads no frames of: they are \
                                 not fused (no source wired for them, or a replay of a recording \
                                 made with more sensors than the graph plays)",
                                config.rig.name,
                                unwired.join(", ")
                            );
                        }
                    }
                    if !unknown.is_empty() && !warned_unknown {
                        warned_unknown = true;
                        warn!(
                            "sensors {} are not in rig {:?}; their frames are ignored",
                            unknown.join(", "),
                            config.rig.name
                        );
                    }
                    counters.joints_fused += pose.joints.len() as u64;
                    counters.joints_skipped += pose.skipped.len() as u64;
                    let array = pose.encode().context("encoding a fused pose")?;
                    node.send_output(pose_out.clone(), metadata.parameters, array)
                        .context("trilaterate: sending fused_pose")?;
                    counters.poses_sent += 1;
                }
                other => warn!(input = other, "ignoring an unknown input"),
            },
            Event::Error(e) => warn!("event stream error: {e}"),
            _ => {}
        }
    }
    info!(
        "{} poses, {} joints fused, {} skipped, {} malformed sets",
        counters.poses_sent, counters.joints_fused, counters.joints_skipped, counters.malformed
    );
    Ok(counters)
}

/// The fuser `config` asks for: the rig's sensors with the Kinect v2 noise model.
#[must_use]
pub fn pose_fuser(config: &Config) -> PoseFuser {
    let rig = FusionRig::new(&config.rig, &NoiseModel::default())
        .with_resampling_weights(config.resampling_weights);
    PoseFuser::new(rig, config.params.clone(), config.estimator_name())
}

/// The `aligned_set` handler: the set, its fused pose and the ids of sensors the rig does not
/// know; `None` (logged) for a set that does not decode.
pub fn on_aligned_set(
    fuser: &mut PoseFuser,
    array: &dyn Array,
) -> Option<(AlignedSet, FusedPose, Vec<String>)> {
    let set = match AlignedSet::decode(array) {
        Ok(set) => set,
        Err(e) => {
            warn!("skipping a malformed aligned set: {e}");
            return None;
        }
    };
    let (pose, unknown) = fuse_set(fuser, &set);
    Some((set, pose, unknown))
}

/// The sensors of `rig` that the set's `sync` does not read (neither in the set nor missing
/// from it).
#[must_use]
pub fn unwired_sensors(rig: &trigait_rig::Rig, set: &AlignedSet) -> Vec<String> {
    rig.sensors
        .iter()
        .map(|s| s.id.clone())
        .filter(|id| !set.sensors.contains_key(id) && !set.missing.contains(id))
        .collect()
}

/// Fuses one decoded aligned set.
pub fn fuse_set(fuser: &mut PoseFuser, set: &AlignedSet) -> (FusedPose, Vec<String>) {
    let samples: Vec<SensorSamples<'_>> = set
        .sensors
        .iter()
        .map(|(id, view)| SensorSamples {
            sensor_id: id,
            joints: &view.joints,
            resampling_error_m: &view.interpolation_error_m,
        })
        .collect();
    fuser.fuse(set.seq, set.stamp_nanos, &samples, set.missing.clone())
}
