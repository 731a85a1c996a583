//! The optional `depth` output: raw 512×424 depth frames (`depth_frame`) for the thesis's depth
//! metrics on the live stream (thesis ch. 3 and §5.1), next to the skeleton.
//!
//! Off unless `DEPTH_RATE_HZ` is set, so graphs without it behave exactly as before (and need
//! not declare the output). Two sources, chosen by `DEPTH_DIR`:
//! - **simulated** (no `DEPTH_DIR`): `trigait_depth`'s simulator renders what a lab images to
//!   check this sensor ([`trigait_depth::lab`]): the walkway floor seen from the sensor's pose in
//!   the rig (`DEPTH_SCENE=floor`) or a flat wall facing it (`wall[:metres]`, the §5.1.1 set-up),
//!   with temporal noise, 1-mm quantisation, the ring bias of §3.5 and the 0.5–4.5 m range;
//! - **replayed** (`DEPTH_DIR`): the 16-bit PNGs of a directory in name order, looped or once.
//!
//! | env var | type | default | meaning |
//! |---|---|---|---|
//! | `DEPTH_RATE_HZ` | Hz | off | depth frames per second (Kinect v2: 30) |
//! | `DEPTH_DIR` | path | none | replay these 512×424 16-bit PNGs instead of simulating |
//! | `DEPTH_LOOP` | bool | `true` | replay: start over after the last file |
//! | `DEPTH_SCENE` | `floor`, `wall`, `wall:<m>` | `floor` | simulated target |
//! | `DEPTH_NOISE_SD_MM` | mm | `1.2` | temporal noise σ (thesis Fig. 5.1: 1.2 mm at 2 m) |
//! | `DEPTH_QUANTISATION_MM` | mm | `1` | output step (the Kinect v2 reports whole mm) |
//! | `DEPTH_RING_MM` | mm | `0` | amplitude of the ring bias around the image centre (§3.5) |
//! | `DEPTH_RING_PERIOD_PX` | px | `40` | period of the rings, pixels of radius |
//!
//! Frames carry the sensor clock's stamp (like skeleton frames) and their own sequence number.
//! A replayed file that cannot be read is skipped with a warning and counted, not fatal; an
//! all-zero frame (a sensor starting up) is a frame and is sent as it is; a directory without
//! a single depth PNG with data is a configuration error at start.

use std::path::PathBuf;

use dora_node_api::dora_core::config::DataId;
use dora_node_api::{DoraNode, MetadataParameters, Parameter};
use eyre::{Context, bail, eyre};
use trigait_depth::io::{list_pngs, read_depth_png, read_depth_png_as_recorded};
use trigait_depth::lab::{LabTarget, lab_scene};
use trigait_depth::sim::{SimParams, Simulator};
use trigait_depth::{HEIGHT, WIDTH};
use trigait_node_config::{env_flag, env_number, env_number_where};
use trigait_schema::{DepthFrameMessage, Message, ports};

use crate::backend::{SensorClock, now_nanos};
use crate::config::Config;

/// Env var: depth rate (unset = no depth output).
pub const DEPTH_RATE_HZ: &str = "DEPTH_RATE_HZ";
/// Env var: replay directory.
pub const DEPTH_DIR: &str = "DEPTH_DIR";
/// Env var: loop the replay.
pub const DEPTH_LOOP: &str = "DEPTH_LOOP";
/// Env var: simulated scene.
pub const DEPTH_SCENE: &str = "DEPTH_SCENE";
/// Env var: noise σ.
pub const DEPTH_NOISE_SD_MM: &str = "DEPTH_NOISE_SD_MM";
/// Env var: quantisation step.
pub const DEPTH_QUANTISATION_MM: &str = "DEPTH_QUANTISATION_MM";
/// Env var: ring amplitude.
pub const DEPTH_RING_MM: &str = "DEPTH_RING_MM";
/// Env var: ring period.
pub const DEPTH_RING_PERIOD_PX: &str = "DEPTH_RING_PERIOD_PX";

const NODE: &str = "kinect-source";

/// Where depth frames come from.
#[derive(Debug, Clone, PartialEq)]
pub enum DepthInput {
    /// The simulator looking at a lab target.
    Sim {
        /// What it looks at.
        target: LabTarget,
        /// Temporal noise σ, mm.
        noise_sd_mm: f64,
        /// Quantisation step, mm.
        quantisation_mm: f64,
        /// Ring amplitude, mm.
        ring_amplitude_mm: f64,
        /// Ring period, px.
        ring_period_px: f64,
    },
    /// PNG files of a directory.
    Dir {
        /// The directory.
        dir: PathBuf,
        /// Start over at the end.
        looped: bool,
    },
}

/// The depth output's configuration.
#[derive(Debug, Clone, PartialEq)]
pub struct DepthConfig {
    /// Frames per second.
    pub rate_hz: f64,
    /// The source.
    pub input: DepthInput,
}

impl DepthConfig {
    /// `None` unless `DEPTH_RATE_HZ` is set.
    ///
    /// # Errors
    /// A value that does not parse or is out of range, naming the variable.
    pub fn from_lookup(lookup: &impl Fn(&str) -> Option<String>) -> eyre::Result<Option<Self>> {
        if lookup(DEPTH_RATE_HZ).is_none() {
            return Ok(None);
        }
        let rate_hz = env_number_where(
            NODE,
            lookup,
            DEPTH_RATE_HZ,
            30.0,
            |v| (0.1..=100.0).contains(&v),
            "a rate within 0.1–100 Hz",
        )?;
        let input = match lookup(DEPTH_DIR) {
            Some(dir) => DepthInput::Dir {
                dir: PathBuf::from(dir.trim()),
                looped: env_flag(NODE, lookup, DEPTH_LOOP, true)?,
            },
            None => {
                let scene = lookup(DEPTH_SCENE).unwrap_or_else(|| "floor".into());
                DepthInput::Sim {
                    target: LabTarget::from_spec(&scene)
                        .map_err(|e| eyre!("{NODE}: {DEPTH_SCENE}={scene:?} is invalid: {e}"))?,
                    noise_sd_mm: env_number(NODE, lookup, DEPTH_NOISE_SD_MM, 1.2)?,
                    quantisation_mm: env_number(NODE, lookup, DEPTH_QUANTISATION_MM, 1.0)?,
                    ring_amplitude_mm: env_number(NODE, lookup, DEPTH_RING_MM, 0.0)?,
                    ring_period_px: env_number(NODE, lookup, DEPTH_RING_PERIOD_PX, 40.0)?,
                }
            }
        };
        Ok(Some(Self { rate_hz, input }))
    }
}

enum Frames {
    Sim(Box<Simulator>),
    Dir {
        files: Vec<PathBuf>,
        next: usize,
        looped: bool,
    },
}

/// The running depth stream of one sensor.
pub struct DepthStream {
    frames: Frames,
    sensor_id: String,
    period_nanos: i64,
    next_nanos: i64,
    seq: u64,
    /// Replayed files that could not be read (skipped).
    pub skipped: u64,
}

impl std::fmt::Debug for DepthStream {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("DepthStream")
            .field("sensor_id", &self.sensor_id)
            .field("seq", &self.seq)
            .finish_non_exhaustive()
    }
}

impl DepthStream {
    /// Sets the stream up: renders the scene's geometry once, or checks the directory.
    ///
    /// # Errors
    /// The sensor is not in the rig (floor scene), the simulator refuses its parameters, or the
    /// directory has no readable depth PNG.
    pub fn new(depth: &DepthConfig, config: &Config, start_nanos: i64) -> eyre::Result<Self> {
        let frames = match &depth.input {
            DepthInput::Sim {
                target,
                noise_sd_mm,
                quantisation_mm,
                ring_amplitude_mm,
                ring_period_px,
            } => {
                let pose = config
                    .rig
                    .sensors
                    .iter()
                    .find(|s| s.id == config.sensor_id)
                    .ok_or_else(|| {
                        eyre!(
                            "{NODE}: SENSOR_ID={:?} is not in the rig {:?} (needed to place the depth scene)",
                            config.sensor_id,
                            config.rig.name
                        )
                    })?
                    .world_from_kinect;
                let scene =
                    lab_scene(*target, &pose).map_err(|e| eyre!("{NODE}: {DEPTH_SCENE}: {e}"))?;
                let params = SimParams {
                    noise_sd_mm: *noise_sd_mm,
                    quantisation_mm: *quantisation_mm,
                    ring_amplitude_mm: *ring_amplitude_mm,
                    ring_period_px: *ring_period_px,
                    seed: config.seed ^ 0xdee9_u64.rotate_left(17) ^ hash(&config.sensor_id),
                    ..SimParams::default()
                };
                Frames::Sim(Box::new(
                    Simulator::new(&scene, params)
                        .map_err(|e| eyre!("{NODE}: depth simulator: {e}"))?,
                ))
            }
            DepthInput::Dir { dir, looped } => {
                let files = list_pngs(dir).map_err(|e| eyre!("{NODE}: {DEPTH_DIR}: {e}"))?;
                if !files.iter().any(|f| read_depth_png(f).is_ok()) {
                    bail!(
                        "{NODE}: {DEPTH_DIR}={}: no 512x424 16-bit depth PNG among {} file(s)",
                        dir.display(),
                        files.len()
                    );
                }
                Frames::Dir {
                    files,
                    next: 0,
                    looped: *looped,
                }
            }
        };
        Ok(Self {
            frames,
            sensor_id: config.sensor_id.clone(),
            period_nanos: (1e9 / depth.rate_hz).round() as i64,
            next_nanos: start_nanos,
            seq: 0,
            skipped: 0,
        })
    }

    /// When the next frame is due (host clock, ns); `None` once a single replay has ended.
    #[must_use]
    pub fn next_due(&self) -> Option<i64> {
        match &self.frames {
            Frames::Dir {
                files,
                next,
                looped: false,
            } if *next >= files.len() => None,
            _ => Some(self.next_nanos),
        }
    }

    /// The frame due now, stamped `local_stamp_nanos` on the sensor clock; `None` when the
    /// replay has ended. Unreadable files are skipped (counted in `skipped`).
    pub fn capture(&mut self, local_stamp_nanos: i64) -> Option<DepthFrameMessage> {
        self.next_nanos += self.period_nanos;
        let depth_mm = match &mut self.frames {
            Frames::Sim(sim) => sim.next_frame().as_mm().to_vec(),
            Frames::Dir {
                files,
                next,
                looped,
            } => loop {
                if *next >= files.len() {
                    if *looped && self.skipped < 10 * files.len() as u64 {
                        *next = 0;
                    } else {
                        return None;
                    }
                }
                let file = &files[*next];
                *next += 1;
                match read_depth_png_as_recorded(file) {
                    Ok(frame) => break frame.as_mm().to_vec(),
                    Err(e) => {
                        self.skipped += 1;
                        tracing::warn!("skipping depth file: {e}");
                    }
                }
            },
        };
        let message = DepthFrameMessage {
            sensor_id: self.sensor_id.clone(),
            seq: self.seq,
            local_stamp_nanos,
            width: WIDTH as u32,
            height: HEIGHT as u32,
            depth_mm,
        };
        self.seq += 1;
        Some(message)
    }
}

/// A stable hash of a sensor id (FNV-1a), to give each sensor its own noise stream.
pub(crate) fn hash(id: &str) -> u64 {
    id.bytes().fold(0xcbf2_9ce4_8422_2325_u64, |h, b| {
        (h ^ u64::from(b)).wrapping_mul(0x100_0000_01b3)
    })
}

/// The earlier of the skeleton's next due time and the depth stream's.
#[must_use]
pub fn earliest(skeleton_due: i64, depth: Option<&DepthStream>) -> i64 {
    depth
        .and_then(DepthStream::next_due)
        .map_or(skeleton_due, |d| d.min(skeleton_due))
}

/// Sends every depth frame that is due (the main loop's hook); returns how many went out.
///
/// # Errors
/// Encoding or sending failed.
pub fn send_due(
    depth: Option<&mut DepthStream>,
    node: &mut DoraNode,
    out: &DataId,
    clock: &mut SensorClock,
) -> eyre::Result<u64> {
    let Some(depth) = depth else { return Ok(0) };
    let mut sent = 0;
    while depth.next_due().is_some_and(|due| due <= now_nanos()) {
        // Stamp at the due instant, like skeleton captures, so the rate holds under load.
        let Some(frame) = depth.capture(clock.local(now_nanos())) else {
            break;
        };
        // Behind by more than a period (a slow host): resume from now instead of sending a
        // burst of stale frames; the metrics node sees the lower rate.
        if depth.next_nanos < now_nanos() - depth.period_nanos {
            depth.next_nanos = now_nanos();
        }
        let mut params = MetadataParameters::default();
        params.insert(
            ports::SENT_NANOS.to_owned(),
            Parameter::Integer(now_nanos()),
        );
        let array = frame.encode().context("encoding a depth frame")?;
        node.send_output(out.clone(), params, array)
            .context("kinect-source: sending depth")?;
        sent += 1;
    }
    Ok(sent)
}

#[cfg(test)]
mod tests {
    use trigait_node_testing::lookup;

    use super::*;

    fn config(pairs: &[(&str, &str)]) -> Config {
        let mut all = vec![("SENSOR_ID", "k1")];
        all.extend_from_slice(pairs);
        Config::from_lookup(lookup(&all)).unwrap()
    }

    /// Without `DEPTH_RATE_HZ` there is no depth stream (existing graphs unchanged); bad values
    /// name their variable.
    #[test]
    fn off_by_default_and_errors_name_the_key() {
        assert_eq!(config(&[]).depth, None);
        let d = config(&[("DEPTH_RATE_HZ", "15"), ("DEPTH_SCENE", "wall:3")])
            .depth
            .unwrap();
        assert_eq!(d.rate_hz, 15.0);
        assert!(matches!(
            d.input,
            DepthInput::Sim {
                target: LabTarget::Wall { distance_m: 3.0 },
                ..
            }
        ));
        for (key, value) in [
            ("DEPTH_RATE_HZ", "fast"),
            ("DEPTH_RATE_HZ", "0"),
            ("DEPTH_SCENE", "ceiling"),
            ("DEPTH_NOISE_SD_MM", "NaN"),
            ("DEPTH_LOOP", "maybe"),
        ] {
            // The lookup takes the first pair of a key: the bad value wins over the default rate.
            let mut pairs = vec![("SENSOR_ID", "k1"), (key, value), ("DEPTH_RATE_HZ", "30")];
            if key == "DEPTH_LOOP" {
                pairs.push(("DEPTH_DIR", "/tmp"));
            }
            let err = Config::from_lookup(lookup(&pairs)).unwrap_err();
            assert!(err.to_string().contains(key), "{key}: {err}");
        }
    }

    /// The simulated floor frames of thesis-rig sensor k1 have the floor in the lower part of
    /// the image, nothing above the horizon, consecutive sequence numbers and fresh noise.
    #[test]
    fn simulated_floor_frames() {
        let c = config(&[("DEPTH_RATE_HZ", "30")]);
        let mut s = DepthStream::new(c.depth.as_ref().unwrap(), &c, 0).unwrap();
        assert_eq!(s.next_due(), Some(0));
        let a = s.capture(5).unwrap();
        let b = s.capture(6).unwrap();
        assert_eq!((a.seq, b.seq, a.local_stamp_nanos), (0, 1, 5));
        assert_eq!(s.next_due(), Some(2 * 33_333_333));
        assert_eq!(a.depth_mm.len(), WIDTH * HEIGHT);
        assert_eq!(a.depth_mm[WIDTH / 2], 0, "top row sees no floor");
        assert!(a.depth_mm[(HEIGHT - 1) * WIDTH + WIDTH / 2] > 1000);
        assert_ne!(a.depth_mm, b.depth_mm, "noise differs frame to frame");
        // A sensor missing from the rig is a configuration error.
        let c =
            Config::from_lookup(lookup(&[("SENSOR_ID", "k9"), ("DEPTH_RATE_HZ", "30")])).unwrap();
        assert!(DepthStream::new(c.depth.as_ref().unwrap(), &c, 0).is_err());
    }

    /// The real Panoptic frames replay in name order, once or looped; a directory without
    /// depth PNGs is refused at start.
    #[test]
    fn replays_a_directory() {
        let dir = concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../../shared/data/kinect-v2-panoptic-10-sensors"
        );
        if !std::path::Path::new(dir).exists() {
            assert!(
                std::env::var("CI").is_err(),
                "{dir} is missing (shared/data must sit beside the clone)"
            );
            eprintln!("skipping: {dir} not found");
            return;
        }
        let c = config(&[
            ("DEPTH_RATE_HZ", "30"),
            ("DEPTH_DIR", dir),
            ("DEPTH_LOOP", "no"),
        ]);
        let mut s = DepthStream::new(c.depth.as_ref().unwrap(), &c, 0).unwrap();
        let first = read_depth_png(&std::path::Path::new(dir).join("depth_00000.png")).unwrap();
        let mut n = 0;
        while let Some(f) = s.capture(0) {
            if n == 0 {
                assert_eq!(f.depth_mm, first.as_mm());
            }
            n += 1;
        }
        assert_eq!(n, 10);
        assert_eq!(s.next_due(), None);
        let c = config(&[("DEPTH_RATE_HZ", "30"), ("DEPTH_DIR", dir)]);
        let mut s = DepthStream::new(c.depth.as_ref().unwrap(), &c, 0).unwrap();
        assert_eq!((0..25).filter_map(|_| s.capture(0)).count(), 25);

        let empty = std::env::temp_dir().join("trigait-depth-empty-dir");
        std::fs::create_dir_all(&empty).unwrap();
        let c = config(&[
            ("DEPTH_RATE_HZ", "30"),
            ("DEPTH_DIR", empty.to_str().unwrap()),
        ]);
        assert!(DepthStream::new(c.depth.as_ref().unwrap(), &c, 0).is_err());
    }
}
