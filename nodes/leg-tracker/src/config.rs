//! `leg-tracker` configuration, read from the node's `env:` block.
//!
//! | env var | type | default | meaning |
//! |---|---|---|---|
//! | `SENSOR_ID` | string | required | the sensor whose depth frames this node tracks (its id in the rig); frames of another sensor are counted and skipped |
//! | `RIG` | `thesis`, `ring-N` or a YAML path | `thesis` | where the sensor stands: its pose gives the floor |
//! | `FLOOR` | `rig` or `fit` | `rig` | the floor from the sensor's pose in the rig, or a plane fitted to the depth (a sensor whose pose is not known well) |
//! | `MIRRORED` | bool | `false` | the images are mirrored (the column grows to the sensor's left, as libfreenect2 and the Kinect SDK deliver them); the simulated body depth is not |
//! | `RERUN` | `off` (or any false flag word), `rrd`, a `.rrd` path or a `rerun+http://…/proxy` url | `off` | for debugging, log every frame's person mask and fitted legs to rerun (`rrd` = `out/legs-<sensor>.rrd`; entities `legs/<sensor>/…`) |
//!
//! Ports: input `depth` (`depth_frame`, from a source's `depth` output), output `frame` (the
//! `skeleton_frame` of the same sensor, seq and sensor-clock stamp, with the depth frame's
//! metadata), so `sync` takes it on `frame_<id>` like an SDK-like source's.

use std::str::FromStr;

use eyre::{bail, eyre};
use trigait_depth_rerun::Sink;
use trigait_leg_tracker::TrackerConfig;
use trigait_node_config::{env_flag, env_parsed, env_rig, flag_word};
use trigait_rig::Rig;

/// Env var: sensor id.
pub const SENSOR_ID: &str = "SENSOR_ID";
/// Env var: where the floor comes from.
pub const FLOOR: &str = "FLOOR";
/// Env var: mirrored images.
pub const MIRRORED: &str = "MIRRORED";
/// Env var: rerun sink for debugging.
pub const RERUN: &str = "RERUN";

const NODE: &str = "leg-tracker";

/// The value of `FLOOR`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FloorSource {
    /// `rig`: from the sensor's pose.
    Rig,
    /// `fit`: a plane fitted to the depth.
    Fit,
}

impl FromStr for FloorSource {
    type Err = &'static str;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s.trim() {
            "rig" => Ok(Self::Rig),
            "fit" => Ok(Self::Fit),
            _ => Err("expected `rig` or `fit`"),
        }
    }
}

/// The node's configuration.
#[derive(Debug, Clone)]
pub struct Config {
    /// Sensor id.
    pub sensor_id: String,
    /// The rig, read from `RIG`.
    pub rig: Rig,
    /// The tracker's configuration for this sensor.
    pub tracker: TrackerConfig,
    /// Where the debugging output goes, if anywhere.
    pub rerun: Option<Sink>,
}

impl Config {
    /// From the process environment.
    pub fn from_env() -> eyre::Result<Self> {
        Self::from_lookup(|k| std::env::var(k).ok())
    }

    /// From any lookup (tests).
    pub fn from_lookup(lookup: impl Fn(&str) -> Option<String>) -> eyre::Result<Self> {
        let sensor_id = lookup(SENSOR_ID)
            .filter(|s| !s.trim().is_empty())
            .ok_or_else(|| eyre!("{NODE}: {SENSOR_ID} is required (the sensor's id in the rig)"))?
            .trim()
            .to_owned();
        let rig = env_rig(NODE, &lookup)?;
        let Some(sensor) = rig.sensors.iter().find(|s| s.id == sensor_id) else {
            bail!(
                "{NODE}: {SENSOR_ID}={sensor_id:?} is not in the rig {:?} (it has {})",
                rig.name,
                rig.sensors
                    .iter()
                    .map(|s| s.id.as_str())
                    .collect::<Vec<_>>()
                    .join(", ")
            );
        };
        let mirrored = env_flag(NODE, &lookup, MIRRORED, false)?;
        let mut tracker = TrackerConfig::for_pose(&sensor.world_from_kinect, mirrored);
        match env_parsed(NODE, &lookup, FLOOR, FloorSource::Rig)? {
            FloorSource::Rig if tracker.floor.is_none() => bail!(
                "{NODE}: {FLOOR}=rig, but {sensor_id}'s pose in the rig {:?} does not stand above its floor (use {FLOOR}=fit)",
                rig.name
            ),
            FloorSource::Rig => {}
            FloorSource::Fit => tracker.floor = None,
        }
        let rerun = match lookup(RERUN).as_deref().map(str::trim) {
            None | Some("" | "off") => None,
            Some(spec) => match flag_word(spec) {
                Some(false) => None,
                Some(true) => bail!(
                    "{NODE}: {RERUN}={spec:?} is invalid: expected off, false, rrd, a .rrd path or a rerun+http:// url"
                ),
                None => Some(Sink::from_spec(
                    spec,
                    &std::path::Path::new("out").join(format!("legs-{sensor_id}.rrd")),
                )),
            },
        };
        Ok(Self {
            sensor_id,
            rig,
            tracker,
            rerun,
        })
    }
}
