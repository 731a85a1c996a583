//! `trilaterate`: fuses each `aligned_set` with the YAML-selected estimator into a `fused_pose`
//! (world frame, covariance, diagnostics); a joint too few sensors saw is listed in
//! `FusedPose::skipped` with the reason. Configuration: [`config`].

mod config;
mod fuse;
#[cfg(test)]
mod tests;

use dora_node_api::dora_core::config::DataId;
use dora_node_api::{DoraNode, Event, EventStream};
use eyre::Context;
use tracing::{info, warn};
use trigait_schema::{Message, ports};
use trigait_sync::AlignedSet;

use crate::config::Config;
use crate::fuse::Fuser;

fn main() -> eyre::Result<()> {
    trigait_node_log::init("trilaterate");
    let config = Config::from_env()?;
    let (node, events) =
        DoraNode::init_from_env().context("trilaterate: connecting to the dora daemon")?;
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
    let mut fuser = Fuser::new(&config.rig, config.params.clone(), config.estimator_name())
        .with_resampling_weights(config.resampling_weights);
    let pose_out = DataId::from(ports::FUSED_POSE.to_owned());
    let mut counters = Counters::default();
    let mut warned_unknown = false;
    while let Some(event) = events.recv() {
        trigait_node_log::warn_drops(&mut events);
        match event {
            Event::Input { id, metadata, data } => match id.as_str() {
                ports::ALIGNED_SET => {
                    let set = match AlignedSet::decode(data.as_array().as_ref()) {
                        Ok(set) => set,
                        Err(e) => {
                            counters.malformed += 1;
                            warn!("skipping a malformed aligned set: {e}");
                            continue;
                        }
                    };
                    let (pose, unknown) = fuser.fuse(&set);
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
