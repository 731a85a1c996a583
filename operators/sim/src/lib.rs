//! A multi-Kinect rig in software: a motion (ground-truth joint trajectories) is played in front
//! of the rig's sensors, and each sensor reports what the Kinect v2 model says it would see —
//! tracked, inferred behind the other leg, or not at all — with modelled noise.
//!
//! Two ways to sample it:
//! - [`Simulator::snapshot`]: every sensor at the same instant. This isolates the estimator
//!   from timing and is what `trigait eval` measures.
//! - [`Simulator::frame`]: one sensor's [`SkeletonFrame`] at its own capture time and clock,
//!   what the dataflow's `kinect-source` node emits.
//!
//! [`clock`] gives the sensors clocks with offset, drift and jitter and links with LAN-like
//! delays (what the sync code is tested against); [`stream`] turns a sensor into the timed
//! stream of frames — and the ground truth — a dataflow source sends.
//!
//! Determinism: every draw comes from an RNG the caller passes; [`Simulator::sensor_rng`] gives
//! each sensor its own stream from one seed, so a sensor produces the same frames whether it
//! runs alone in a dataflow process or with the others in `trigait eval`.

#![warn(missing_docs)]

pub mod clock;
pub mod stream;

use std::collections::BTreeMap;

use nalgebra::Point3;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use trigait_kinect::{NoiseModel, Report, Sensor, occlusion};
use trigait_rig::Rig;
use trigait_skeleton::{Joint, JointSample, MotionClip, SkeletonFrame};

/// Kinect v2 depth frame period: 30 frames per second (thesis Table 6.1).
pub const FRAME_PERIOD_SECS: f64 = 1.0 / 30.0;

/// A rig of modelled sensors watching one motion.
#[derive(Debug, Clone)]
pub struct Simulator {
    sensors: Vec<Sensor>,
    motion: MotionClip,
    joints: Vec<Joint>,
}

/// What every sensor reports at one instant, with the truth.
#[derive(Debug, Clone)]
pub struct Snapshot {
    /// Time in the motion, seconds.
    pub t_secs: f64,
    /// True position of each simulated joint the motion defines at this instant.
    pub truth: BTreeMap<Joint, Point3<f64>>,
    /// `reports[sensor][joint]`, joints in [`Simulator::joints`] order; `None` where the motion
    /// has no truth for that joint.
    pub reports: Vec<Vec<Option<Report>>>,
}

impl Simulator {
    /// The rig's sensors, each with `noise`, watching `motion`, reporting `joints` (those the
    /// motion does not define are dropped).
    #[must_use]
    pub fn new(rig: &Rig, motion: MotionClip, joints: &[Joint], noise: &NoiseModel) -> Self {
        let sensors = rig
            .sensors
            .iter()
            .map(|s| {
                let mut sensor = Sensor::new(s.id.clone(), s.world_from_kinect);
                sensor.noise = noise.clone();
                sensor
            })
            .collect();
        let joints = joints.iter().copied().filter(|j| motion.has(*j)).collect();
        Self {
            sensors,
            motion,
            joints,
        }
    }

    /// The modelled sensors, in rig order.
    #[must_use]
    pub fn sensors(&self) -> &[Sensor] {
        &self.sensors
    }

    /// The motion being played.
    #[must_use]
    pub fn motion(&self) -> &MotionClip {
        &self.motion
    }

    /// The joints reported, in report order.
    #[must_use]
    pub fn joints(&self) -> &[Joint] {
        &self.joints
    }

    /// Capture phase of `sensor` under `seed`, uniform over one frame period: Kinect v2 units run
    /// free at 30 Hz and cannot be triggered, so each has its own phase (DESIGN.md, Time).
    #[must_use]
    pub fn sensor_phase_secs(seed: u64, sensor: usize) -> f64 {
        use rand::Rng;
        let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x0070_6861_7365);
        rng.set_stream(sensor as u64 + 1);
        rng.random::<f64>() * FRAME_PERIOD_SECS
    }

    /// The capture instants `(seq, t_secs)` of `sensor` over the motion: its phase plus whole
    /// frame periods.
    pub fn capture_times(
        &self,
        seed: u64,
        sensor: usize,
    ) -> impl Iterator<Item = (u64, f64)> + use<> {
        let phase = Self::sensor_phase_secs(seed, sensor);
        let end = self.motion.duration_secs();
        (0u64..)
            .map(move |seq| (seq, phase + seq as f64 * FRAME_PERIOD_SECS))
            .take_while(move |(_, t)| *t <= end)
    }

    /// An independent, reproducible RNG for `sensor` under `seed`.
    #[must_use]
    pub fn sensor_rng(seed: u64, sensor: usize) -> ChaCha8Rng {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        rng.set_stream(sensor as u64 + 1);
        rng
    }

    /// True positions of the reported joints at `t_secs` (joints in a motion gap are absent).
    #[must_use]
    pub fn truth(&self, t_secs: f64) -> BTreeMap<Joint, Point3<f64>> {
        self.joints
            .iter()
            .filter_map(|j| Some((*j, self.motion.position_at(*j, t_secs)?)))
            .collect()
    }

    /// What sensor `sensor` reports about each joint at `t_secs`, drawing noise from `rng`.
    pub fn reports(
        &self,
        sensor: usize,
        t_secs: f64,
        rng: &mut impl rand::Rng,
    ) -> Vec<Option<Report>> {
        let Some(s) = self.sensors.get(sensor) else {
            return Vec::new();
        };
        let at = |j: Joint| self.motion.position_at(j, t_secs);
        self.joints
            .iter()
            .map(|joint| {
                let truth = at(*joint)?;
                let occluders = occlusion::other_leg(*joint, at);
                let limb = trigait_kinect::limb_axis(*joint, at);
                Some(s.observe(*joint, &truth, limb, &occluders, rng))
            })
            .collect()
    }

    /// Every sensor at the same instant; sensor i draws from `rngs[i]`.
    ///
    /// # Panics
    /// If `rngs` has fewer entries than there are sensors (a programming error).
    pub fn snapshot(&self, t_secs: f64, rngs: &mut [ChaCha8Rng]) -> Snapshot {
        assert!(rngs.len() >= self.sensors.len(), "one RNG per sensor");
        Snapshot {
            t_secs,
            truth: self.truth(t_secs),
            reports: (0..self.sensors.len())
                .map(|i| self.reports(i, t_secs, &mut rngs[i]))
                .collect(),
        }
    }

    /// One depth frame of `sensor` captured at motion time `t_secs`, stamped `local_stamp_nanos`
    /// by the sensor's own clock.
    pub fn frame(
        &self,
        sensor: usize,
        seq: u64,
        t_secs: f64,
        local_stamp_nanos: i64,
        rng: &mut impl rand::Rng,
    ) -> SkeletonFrame {
        let joints = samples(&self.joints, &self.reports(sensor, t_secs, rng));
        SkeletonFrame {
            sensor_id: self
                .sensors
                .get(sensor)
                .map_or_else(String::new, |s| s.id.clone()),
            seq,
            local_stamp_nanos,
            joints,
        }
    }
}

impl Snapshot {
    /// What sensor `sensor` reported, as the joint samples a frame carries (camera frame;
    /// joints it did not report are absent), in [`Simulator::joints`] order.
    #[must_use]
    pub fn samples(&self, sim: &Simulator, sensor: usize) -> Vec<JointSample> {
        self.reports
            .get(sensor)
            .map(|reports| samples(&sim.joints, reports))
            .unwrap_or_default()
    }
}

/// Reports (in `joints` order) as the joint samples a frame carries.
fn samples(joints: &[Joint], reports: &[Option<Report>]) -> Vec<JointSample> {
    joints
        .iter()
        .zip(reports)
        .filter_map(|(joint, report)| {
            let report = report.as_ref()?;
            Some(JointSample {
                joint: *joint,
                position_in_kinect: report.position_in_kinect?,
                state: report.state(),
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use trigait_skeleton::TrackingState;

    fn standing_clip() -> MotionClip {
        MotionClip::from_fn("stand", 30.0, 1.0, Joint::LEGS.to_vec(), |j, _| {
            let y = if j.name().ends_with("left") {
                0.1
            } else {
                -0.1
            };
            let z = match j {
                Joint::HipLeft | Joint::HipRight => 0.9,
                Joint::KneeLeft | Joint::KneeRight => 0.5,
                _ => 0.08,
            };
            Some(Point3::new(0.0, y, z))
        })
        .unwrap()
    }

    /// Each sensor reports every leg joint of a walker in its view, reproducibly per seed, near
    /// the truth once mapped through the sensor's pose.
    #[test]
    fn snapshot_reports_visible_joints() {
        let rig = Rig::builtin("thesis").unwrap();
        let sim = Simulator::new(&rig, standing_clip(), &Joint::LEGS, &NoiseModel::default());
        let rngs = || -> Vec<ChaCha8Rng> { (0..3).map(|i| Simulator::sensor_rng(9, i)).collect() };
        let a = sim.snapshot(0.5, &mut rngs());
        let b = sim.snapshot(0.5, &mut rngs());
        assert_eq!(a.truth.len(), 6);
        for (i, s) in rig.sensors.iter().enumerate() {
            let (sa, sb) = (a.samples(&sim, i), b.samples(&sim, i));
            assert_eq!(sa, sb);
            assert_eq!(sa.len(), 6, "sensor {i} sees every leg joint");
            for sample in &sa {
                let in_world = s.world_from_kinect * sample.position_in_kinect;
                assert!((in_world - a.truth[&sample.joint]).norm() < 0.2);
            }
        }
    }

    /// Each sensor captures at 30 Hz from its own phase within one frame period; phases differ
    /// between sensors and are reproducible per seed.
    #[test]
    fn sensors_capture_at_their_own_phase() {
        let rig = Rig::builtin("thesis").unwrap();
        let sim = Simulator::new(&rig, standing_clip(), &Joint::LEGS, &NoiseModel::default());
        let phases: Vec<f64> = (0..3).map(|s| Simulator::sensor_phase_secs(4, s)).collect();
        assert!(phases.iter().all(|p| (0.0..FRAME_PERIOD_SECS).contains(p)));
        assert!(phases[0] != phases[1] && phases[1] != phases[2]);
        assert_eq!(phases[1], Simulator::sensor_phase_secs(4, 1));
        let times: Vec<(u64, f64)> = sim.capture_times(4, 1).collect();
        assert_eq!(times.len(), 30, "1 s of motion at 30 Hz");
        assert_eq!(times[0], (0, phases[1]));
        assert!((times[29].1 - times[0].1 - 29.0 * FRAME_PERIOD_SECS).abs() < 1e-12);
    }

    /// Side-on, the far leg hides behind the near one: k3 in front sees both knees, a sensor
    /// level with the walker's right side reports the left knee as inferred.
    #[test]
    fn side_sensor_infers_hidden_knee() {
        let rig = Rig::from_yaml_str(
            "sensors:\n  - id: side\n    position: [0, -3, 0.5]\n    look_at: [0, 0, 0.5]\n  - id: front\n    position: [3, 0, 0.5]\n    look_at: [0, 0, 0.5]\n",
            "test",
        )
        .unwrap();
        let sim = Simulator::new(&rig, standing_clip(), &Joint::LEGS, &NoiseModel::default());
        let mut rng = Simulator::sensor_rng(1, 0);
        let frame = sim.frame(0, 7, 0.2, 123, &mut rng);
        assert_eq!(frame.sensor_id, "side");
        assert_eq!((frame.seq, frame.local_stamp_nanos), (7, 123));
        let state = |f: &SkeletonFrame, j| f.joints.iter().find(|s| s.joint == j).unwrap().state;
        assert_eq!(state(&frame, Joint::KneeLeft), TrackingState::Inferred);
        assert_eq!(state(&frame, Joint::KneeRight), TrackingState::Tracked);
        let front = sim.frame(1, 0, 0.2, 0, &mut Simulator::sensor_rng(1, 1));
        assert_eq!(state(&front, Joint::KneeLeft), TrackingState::Tracked);
    }
}
