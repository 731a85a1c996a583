//! `filter`: smooths each `fused_pose` joint by joint with a causal filter (One-Euro or a causal
//! Butterworth, [`trigait_gait::stream`]) and sends it on as the same `fused_pose` message, so
//! the stage goes between `trilaterate` and `recorder`, or out again, by YAML alone
//! (`dataflows/filtered.yml`). Configuration: [`config`].
//!
//! Positions are replaced by the filtered ones; everything else passes through. In particular
//! the covariance stays that of the single-instant fusion: after filtering it bounds the
//! random part of the error from above (the filter averages several such measurements) and
//! does not include the lag the filter adds while a joint moves fast. A joint with a NaN or
//! infinite coordinate is moved to `skipped` ("filter: non-finite position"), never sent.

mod config;
#[cfg(test)]
mod tests;

use dora_node_api::dora_core::config::DataId;
use dora_node_api::{DoraNode, Event, EventStream};
use eyre::Context;
use tracing::{info, warn};
use trigait_gait::stream::{JointOutcome, PoseFilter, StreamCounts};
use trigait_schema::{FusedPose, Message, ports};

use crate::config::Config;

fn main() -> eyre::Result<()> {
    trigait_node_log::init("filter");
    let config = Config::from_env()?;
    let (node, events) =
        DoraNode::init_from_env().context("filter: connecting to the dora daemon")?;
    run(config, node, events).map(|_| ())
}

/// Reason given in `FusedPose::skipped` for a rejected joint.
pub const NON_FINITE_REASON: &str = "filter: non-finite position";

/// Totals the node reports at the end.
#[derive(Debug, Default, Clone, PartialEq, Eq)]
pub struct Counters {
    /// Poses sent.
    pub poses_sent: u64,
    /// Inputs that could not be decoded (skipped).
    pub malformed: u64,
    /// The filter's own counts (filtered, restarted, resets by reason).
    pub filter: StreamCounts,
}

/// Filters the positions of `pose` in place; joints with a non-finite position move to
/// `skipped`. Returns how many were rejected.
pub fn filter_pose(filter: &mut PoseFilter, pose: &mut FusedPose) -> usize {
    let outcomes = filter.push(
        pose.stamp_nanos,
        pose.joints.iter().map(|(j, f)| (*j, &f.position)),
    );
    let mut rejected = 0;
    for (joint, outcome) in outcomes {
        match outcome {
            JointOutcome::Filtered(p) | JointOutcome::Started(p) => {
                if let Some(fused) = pose.joints.get_mut(&joint) {
                    fused.position = p;
                }
            }
            JointOutcome::NonFinite => {
                pose.joints.remove(&joint);
                pose.skipped.insert(joint, NON_FINITE_REASON.to_owned());
                rejected += 1;
            }
        }
    }
    rejected
}

/// The event loop.
pub fn run(config: Config, mut node: DoraNode, mut events: EventStream) -> eyre::Result<Counters> {
    let mut filter = PoseFilter::new(config.params).context("filter: building the filter")?;
    info!("{}", config.params.filter);
    let pose_out = DataId::from(ports::FUSED_POSE.to_owned());
    let mut counters = Counters::default();
    let mut rejected_total = 0_u64;
    while let Some(event) = events.recv() {
        trigait_node_log::warn_drops(&mut events);
        match event {
            Event::Input { id, metadata, data } => match id.as_str() {
                ports::FUSED_POSE => {
                    let mut pose = match FusedPose::decode(data.as_array().as_ref()) {
                        Ok(pose) => pose,
                        Err(e) => {
                            counters.malformed += 1;
                            warn!("skipping a malformed fused pose: {e}");
                            continue;
                        }
                    };
                    let rejected = filter_pose(&mut filter, &mut pose);
                    if rejected > 0 && rejected_total == 0 {
                        warn!("dropping joints with non-finite positions (counted)");
                    }
                    rejected_total += rejected as u64;
                    let array = pose.encode().context("filter: encoding a fused pose")?;
                    node.send_output(pose_out.clone(), metadata.parameters, array)
                        .context("filter: sending fused_pose")?;
                    counters.poses_sent += 1;
                }
                other => warn!(input = other, "ignoring an unknown input"),
            },
            Event::Error(e) => warn!("event stream error: {e}"),
            _ => {}
        }
    }
    counters.filter = filter.counts().clone();
    let resets: Vec<String> = counters
        .filter
        .resets
        .iter()
        .map(|(r, n)| format!("{} {n}", r.name()))
        .collect();
    info!(
        "{} poses sent, {} joint samples filtered, {} (re)started, resets: {}; {} malformed inputs",
        counters.poses_sent,
        counters.filter.filtered,
        counters.filter.started,
        if resets.is_empty() {
            "none".to_owned()
        } else {
            resets.join(", ")
        },
        counters.malformed
    );
    Ok(counters)
}
