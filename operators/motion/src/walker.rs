//! The embedded parametric walker: a kinematic model of level walking, so the default graph runs
//! on a fresh machine with no motion files.
//!
//! How a pose is built at time t (right heel strike at t = 0, left half a cycle later):
//!
//! 1. **Feet.** Each foot is a rigid sagittal triangle heel–ankle–metatarsal head with the
//!    proportions of Winter's anthropometry. In stance (first `stance_fraction` of the leg's own
//!    cycle, 60 % after Perry & Burnfield) it follows the three rockers: it rolls over the heel
//!    from `heel_strike_pitch_deg` toe-up to flat, stays flat (ankle fixed), then rolls over the
//!    metatarsal heads to `toe_off_pitch_deg` heel-up. The contact point never slides. Foot
//!    placements are one step length apart along +X, `step_width_m` apart across.
//! 2. **Swing ankle.** A cubic Hermite from the toe-off state to the next heel-strike state
//!    (positions and velocities of the stance rockers), plus a clearance lift peaking early in
//!    swing, which is what flexes the knee to about 60°.
//! 3. **Pelvis.** It moves along +X at the derived speed, sways toward the stance foot, rotates
//!    about the vertical and tilts frontally (the swing-side hip drops). Its height is the
//!    highest the legs allow: for every leg, the hip may be no further from its ankle than the
//!    leg with the knee flexed by a normal-gait minimum (Winter's stance knee curve: ~5° at heel
//!    strike, the ~18° loading bump, ~5° at mid-stance). A smooth minimum over both legs gives the
//!    height, so in single support the stance knee follows that curve exactly and the pelvis rises
//!    and falls like an inverted pendulum (lowest in double support).
//! 4. **Knees** by two-link inverse kinematics, bending forward, so thigh and shank lengths are
//!    exactly constant.
//!
//! Hip flexion, knee flexion and ankle angle are therefore not prescribed curves but come out of
//! the foot path and the leg geometry; the tests measure them back against Winter's and Perry's
//! normal ranges, and measure step length, cadence and speed back from the trajectories.

use nalgebra::{Point3, Rotation3, Vector2, Vector3};
use trigait_skeleton::{Joint, MotionClip};

use crate::{Error, Result};

/// Parameters of the [`walker`]. The defaults describe a healthy 1.75 m adult walking at a
/// comfortable pace; every length except the gait lengths scales with `height_m` through
/// [`WalkerParams::for_height`].
#[derive(Debug, Clone, PartialEq)]
pub struct WalkerParams {
    /// Standing height, metres (used for the upper body).
    pub height_m: f64,
    /// Hip to knee joint centre, metres. Winter 2009 (Biomechanics and Motor Control of Human
    /// Movement, Fig. 4.1): 0.245 × height.
    pub thigh_m: f64,
    /// Knee to ankle joint centre, metres. Winter: 0.246 × height.
    pub shank_m: f64,
    /// Ankle joint centre above the floor with the foot flat, metres. Winter: 0.039 × height.
    pub ankle_height_m: f64,
    /// Heel to toe tip, metres. Winter: 0.152 × height.
    pub foot_length_m: f64,
    /// Distance between the two hip joint centres, metres. 0.18 m is Harrington et al. 2007's
    /// regression 2 × (0.33 PW + 7.3 mm) for a typical 250 mm inter-ASIS width.
    pub hip_width_m: f64,
    /// Lateral distance between the ankle paths, metres (normal step width ≈ 0.08–0.10 m).
    pub step_width_m: f64,
    /// Steps per minute. Normal adult cadence is about 100–120 (Perry & Burnfield 2010); 105 is a
    /// comfortable pace.
    pub cadence_steps_per_min: f64,
    /// Heel strike to the other foot's heel strike along +X, metres (normal ≈ 0.65–0.75 m).
    pub step_length_m: f64,
    /// Fraction of a gait cycle a foot is on the ground (Perry: 0.60).
    pub stance_fraction: f64,
    /// Peak lateral excursion of the pelvis toward the stance foot, metres (≈ ±2 cm).
    pub pelvis_sway_m: f64,
    /// Peak transverse pelvic rotation, degrees (Perry: ±4°).
    pub pelvis_rotation_deg: f64,
    /// Peak frontal pelvic tilt (swing-side hip drop), degrees (Perry: ±4°).
    pub pelvis_obliquity_deg: f64,
    /// Foot angle to the floor at heel strike, toe up, degrees (≈ 20°).
    pub heel_strike_pitch_deg: f64,
    /// Foot angle to the floor at toe-off, heel up, degrees. With the shank inclined ~50° at
    /// toe-off, 65° gives the ~15° ankle plantarflexion of normal gait (Perry & Burnfield).
    pub toe_off_pitch_deg: f64,
    /// Extra lift of the swing ankle over the straight path between toe-off and heel strike,
    /// metres; sets the swing knee flexion peak (≈ 62° at 73 % of the cycle with the default 0.04).
    pub swing_lift_m: f64,
    /// Peak shoulder flexion/extension of the arm swing, degrees (full-body clips only).
    pub arm_swing_deg: f64,
    /// Generate all 25 Kinect joints (trunk, head, arms) instead of the legs, `SpineBase` and feet.
    pub all_joints: bool,
}

impl Default for WalkerParams {
    fn default() -> Self {
        Self::for_height(1.75)
    }
}

/// Normal stance knee flexion (degrees) over the leg's own gait cycle, after Winter's normative
/// curve: heel strike ~4°, loading-response peak ~18° at 15 %, minimum ~4° near 40 %. Beyond
/// stance it is only a reachability floor.
const KNEE_FLOOR_DEG: [(f64, f64); 7] = [
    (0.00, 4.0),
    (0.06, 12.0),
    (0.15, 18.0),
    (0.27, 10.0),
    (0.40, 4.0),
    (0.60, 4.0),
    (1.00, 4.0),
];

/// Where the hip passes over the flat foot's ankle, as a fraction of that leg's cycle
/// (late mid-stance).
const HIP_OVER_ANKLE_PHASE: f64 = 0.25;
/// End of the heel rocker (foot flat) as a fraction of the cycle (Perry: loading response ends
/// at 10 %).
const FOOT_FLAT_PHASE: f64 = 0.10;
/// Heel rise: start of the forefoot rocker (Perry: terminal stance begins at 31 %).
const HEEL_RISE_PHASE: f64 = 0.35;
/// Smoothness of the minimum over the two legs' pelvis height limits, metres.
const SOFTMIN_M: f64 = 0.01;
/// Heel-rise pitch grows as u^1.5 over the forefoot rocker: slow at heel-off, fast into toe-off.
const HEEL_RISE_EXPONENT: f64 = 1.5;

impl WalkerParams {
    /// The default gait for a person `height_m` tall: segment lengths scaled by Winter's
    /// proportions, the gait-length defaults unchanged.
    #[must_use]
    pub fn for_height(height_m: f64) -> Self {
        Self {
            height_m,
            thigh_m: 0.245 * height_m,
            shank_m: 0.246 * height_m,
            ankle_height_m: 0.039 * height_m,
            foot_length_m: 0.152 * height_m,
            hip_width_m: 0.18,
            step_width_m: 0.10,
            cadence_steps_per_min: 105.0,
            step_length_m: 0.70,
            stance_fraction: 0.60,
            pelvis_sway_m: 0.02,
            pelvis_rotation_deg: 4.0,
            pelvis_obliquity_deg: 4.0,
            heel_strike_pitch_deg: 20.0,
            toe_off_pitch_deg: 65.0,
            swing_lift_m: 0.04,
            arm_swing_deg: 15.0,
            all_joints: false,
        }
    }

    /// Walking speed, m/s: step length × cadence.
    #[must_use]
    pub fn speed_m_per_s(&self) -> f64 {
        self.step_length_m * self.cadence_steps_per_min / 60.0
    }

    /// Duration of one gait cycle (two steps), seconds.
    #[must_use]
    pub fn cycle_secs(&self) -> f64 {
        120.0 / self.cadence_steps_per_min
    }

    fn validate(&self) -> Result<()> {
        let leg = self.thigh_m + self.shank_m;
        let checks: [(&'static str, f64, bool, &'static str); 14] = [
            (
                "height_m",
                self.height_m,
                self.height_m > 0.5 && self.height_m < 3.0,
                "must be in (0.5, 3) m",
            ),
            (
                "thigh_m",
                self.thigh_m,
                self.thigh_m > 0.05,
                "must be > 0.05 m",
            ),
            (
                "shank_m",
                self.shank_m,
                self.shank_m > 0.05,
                "must be > 0.05 m",
            ),
            (
                "ankle_height_m",
                self.ankle_height_m,
                self.ankle_height_m > 0.0 && self.ankle_height_m < 0.5 * self.shank_m,
                "must be in (0, shank/2)",
            ),
            (
                "foot_length_m",
                self.foot_length_m,
                self.foot_length_m > 0.0,
                "must be > 0",
            ),
            (
                "hip_width_m",
                self.hip_width_m,
                self.hip_width_m >= 0.0 && self.hip_width_m < leg,
                "must be in [0, leg length)",
            ),
            (
                "step_width_m",
                self.step_width_m,
                self.step_width_m >= 0.0 && self.step_width_m < leg,
                "must be in [0, leg length)",
            ),
            (
                "cadence_steps_per_min",
                self.cadence_steps_per_min,
                self.cadence_steps_per_min >= 20.0 && self.cadence_steps_per_min <= 200.0,
                "must be in [20, 200] steps/min",
            ),
            (
                "step_length_m",
                self.step_length_m,
                self.step_length_m > 0.0 && self.step_length_m <= leg,
                "must be in (0, thigh + shank]",
            ),
            (
                "stance_fraction",
                self.stance_fraction,
                self.stance_fraction > HEEL_RISE_PHASE + 0.05 && self.stance_fraction < 0.9,
                "must be in (0.4, 0.9)",
            ),
            (
                "pelvis_sway_m",
                self.pelvis_sway_m,
                self.pelvis_sway_m.abs() < 0.2,
                "must be within ±0.2 m",
            ),
            (
                "heel_strike_pitch_deg",
                self.heel_strike_pitch_deg,
                (0.0..60.0).contains(&self.heel_strike_pitch_deg),
                "must be in [0, 60)°",
            ),
            (
                "toe_off_pitch_deg",
                self.toe_off_pitch_deg,
                (0.0..80.0).contains(&self.toe_off_pitch_deg),
                "must be in [0, 80)°",
            ),
            (
                "swing_lift_m",
                self.swing_lift_m,
                self.swing_lift_m >= 0.0 && self.swing_lift_m < self.shank_m,
                "must be in [0, shank)",
            ),
        ];
        for (name, value, ok, reason) in checks {
            if !(value.is_finite() && ok) {
                return Err(Error::BadParameter {
                    name,
                    value,
                    reason,
                });
            }
        }
        for (name, value) in [
            ("pelvis_rotation_deg", self.pelvis_rotation_deg),
            ("pelvis_obliquity_deg", self.pelvis_obliquity_deg),
            ("arm_swing_deg", self.arm_swing_deg),
        ] {
            if !(value.is_finite() && value.abs() <= 45.0) {
                return Err(Error::BadParameter {
                    name,
                    value,
                    reason: "must be within ±45°",
                });
            }
        }
        Ok(())
    }
}

/// Smooth step 0 → 1 with zero slope at both ends.
fn smoothstep(u: f64) -> f64 {
    let u = u.clamp(0.0, 1.0);
    u * u * (3.0 - 2.0 * u)
}

/// Rotates a sagittal (forward, up) vector by `pitch` radians, positive = toe up.
fn pitch_rotate(v: Vector2<f64>, pitch: f64) -> Vector2<f64> {
    let (s, c) = pitch.sin_cos();
    Vector2::new(v.x * c - v.y * s, v.x * s + v.y * c)
}

/// Piecewise-linear interpolation in a (phase, value) table with increasing phases.
fn table(points: &[(f64, f64)], phase: f64) -> f64 {
    for w in points.windows(2) {
        let ((p0, v0), (p1, v1)) = (w[0], w[1]);
        if phase <= p1 {
            let u = ((phase - p0) / (p1 - p0)).clamp(0.0, 1.0);
            return v0 + (v1 - v0) * smoothstep(u);
        }
    }
    points.last().map_or(0.0, |p| p.1)
}

/// One leg's ankle and foot state at an instant.
#[derive(Debug, Clone, Copy)]
struct FootState {
    ankle: Point3<f64>,
    /// Foot angle to the floor, radians, toe up positive.
    pitch: f64,
}

/// Which leg: the right strikes at t = 0, the left half a cycle later.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Side {
    Left,
    Right,
}

impl Side {
    /// +1 for the left (+Y) side, −1 for the right.
    fn sign(self) -> f64 {
        match self {
            Side::Left => 1.0,
            Side::Right => -1.0,
        }
    }
    /// Heel-strike time offset in cycles.
    fn offset(self) -> f64 {
        match self {
            Side::Left => 0.5,
            Side::Right => 0.0,
        }
    }
}

/// The walker's geometry, precomputed from the parameters.
struct Model {
    p: WalkerParams,
    cycle: f64,
    stride: f64,
    /// Heel contact point relative to the ankle with the foot flat (forward, up).
    heel: Vector2<f64>,
    /// Metatarsal-head contact point relative to the ankle with the foot flat.
    ball: Vector2<f64>,
    /// The Kinect `Foot` joint relative to the ankle with the foot flat.
    foot_joint: Vector2<f64>,
}

impl Model {
    fn new(p: &WalkerParams) -> Self {
        let lf = p.foot_length_m;
        let ah = p.ankle_height_m;
        Self {
            p: p.clone(),
            cycle: p.cycle_secs(),
            stride: 2.0 * p.step_length_m,
            // Ankle about 20 % of the foot length in front of the heel, metatarsal heads at 75 %.
            heel: Vector2::new(-0.20 * lf, -ah),
            ball: Vector2::new(0.55 * lf, -ah),
            foot_joint: Vector2::new(0.55 * lf, -0.5 * ah),
        }
    }

    /// The flat-foot ankle position of step `k` of `side`.
    fn flat_ankle(&self, side: Side, k: f64) -> Point3<f64> {
        let x = self.stride * (k + side.offset() + HIP_OVER_ANKLE_PHASE);
        Point3::new(
            x,
            side.sign() * self.p.step_width_m / 2.0,
            self.p.ankle_height_m,
        )
    }

    /// The ankle during stance of step `k` at own-cycle phase `phase` ∈ [0, stance].
    fn stance(&self, side: Side, k: f64, phase: f64) -> FootState {
        let flat = self.flat_ankle(side, k);
        let hs = self.p.heel_strike_pitch_deg.to_radians();
        let to = self.p.toe_off_pitch_deg.to_radians();
        let (pitch, pivot) = if phase < FOOT_FLAT_PHASE {
            // Heel rocker: toe-up pitch decays (quadratically, so the ankle still moves at
            // heel strike) to flat.
            let u = 1.0 - phase / FOOT_FLAT_PHASE;
            (hs * u * u, self.heel)
        } else if phase < HEEL_RISE_PHASE {
            (0.0, self.heel)
        } else {
            // Forefoot rocker: the heel rises with growing speed into toe-off.
            let u = (phase - HEEL_RISE_PHASE) / (self.p.stance_fraction - HEEL_RISE_PHASE);
            (-to * u.powf(HEEL_RISE_EXPONENT), self.ball)
        };
        // The contact point stays where it is with the foot flat.
        let contact = Vector2::new(flat.x, flat.z) + pivot;
        let ankle = contact - pitch_rotate(pivot, pitch);
        FootState {
            ankle: Point3::new(ankle.x, flat.y, ankle.y),
            pitch,
        }
    }

    /// Velocity of the stance ankle (m/s) at `phase`, by a one-sided difference.
    fn stance_velocity(&self, side: Side, k: f64, phase: f64, forward: bool) -> Vector3<f64> {
        let h = 1e-6;
        let (a, b) = if forward {
            (phase, phase + h)
        } else {
            (phase - h, phase)
        };
        (self.stance(side, k, b).ankle - self.stance(side, k, a).ankle) / (h * self.cycle)
    }

    /// The foot of `side` at time `t`.
    fn foot(&self, side: Side, t: f64) -> FootState {
        let cycles = t / self.cycle - side.offset();
        let k = cycles.floor();
        let phase = cycles - k;
        let s = self.p.stance_fraction;
        if phase < s {
            return self.stance(side, k, phase);
        }
        // Swing from toe-off of step k to heel strike of step k + 1.
        let u = (phase - s) / (1.0 - s);
        let duration = (1.0 - s) * self.cycle;
        let start = self.stance(side, k, s);
        let end = self.stance(side, k + 1.0, 0.0);
        let v0 = self.stance_velocity(side, k, s, false) * duration;
        let v1 = self.stance_velocity(side, k + 1.0, 0.0, true) * duration;
        let (u2, u3) = (u * u, u * u * u);
        let h00 = 2.0 * u3 - 3.0 * u2 + 1.0;
        let h10 = u3 - 2.0 * u2 + u;
        let h01 = -2.0 * u3 + 3.0 * u2;
        let h11 = u3 - u2;
        let mut ankle =
            Point3::from(start.ankle.coords * h00 + v0 * h10 + end.ankle.coords * h01 + v1 * h11);
        // Clearance lift u^1.1 (1 − u)^3.4, peaking at 24.5 % of swing (early swing, when the
        // knee flexes most), zero slope at both ends.
        let bump = |u: f64| u.powf(1.1) * (1.0 - u).powf(3.4);
        ankle.z += self.p.swing_lift_m * bump(u) / bump(0.245);
        let pitch = start.pitch + (end.pitch - start.pitch) * smoothstep(u);
        FootState { ankle, pitch }
    }

    /// Own-cycle phase of `side` at `t`, in [0, 1).
    fn phase(&self, side: Side, t: f64) -> f64 {
        let c = t / self.cycle - side.offset();
        c - c.floor()
    }

    /// Pelvis centre (without height), transverse rotation and frontal tilt at `t`.
    fn pelvis_motion(&self, t: f64) -> (f64, f64, f64, f64) {
        let right = self.phase(Side::Right, t) * std::f64::consts::TAU;
        let x = self.p.speed_m_per_s() * t;
        // Toward the right foot during right stance (peak at ~25 % of the cycle).
        let y = -self.p.pelvis_sway_m * right.sin();
        // Right hip forward at right heel strike.
        let rotation = self.p.pelvis_rotation_deg.to_radians() * right.cos();
        // Left (swing) hip drops during right single support.
        let obliquity = self.p.pelvis_obliquity_deg.to_radians() * right.sin();
        (x, y, rotation, obliquity)
    }

    /// Hip centre of `side` relative to the pelvis centre.
    fn hip_offset(&self, side: Side, rotation: f64, obliquity: f64) -> Vector3<f64> {
        let half = self.p.hip_width_m / 2.0;
        let lateral = Rotation3::from_axis_angle(&Vector3::z_axis(), rotation)
            * Vector3::new(0.0, side.sign() * half * obliquity.cos(), 0.0);
        // Positive obliquity raises the right hip (left hip drops).
        lateral + Vector3::new(0.0, 0.0, -side.sign() * half * obliquity.sin())
    }

    /// Hip-to-ankle distance with the knee flexed by `deg`.
    fn leg_span(&self, deg: f64) -> f64 {
        let (a, b) = (self.p.thigh_m, self.p.shank_m);
        (a * a + b * b + 2.0 * a * b * deg.to_radians().cos()).sqrt()
    }

    /// The full lower-body pose at `t`: pelvis centre, hips, knees, feet (left then right).
    fn pose(&self, t: f64) -> Option<Pose> {
        let (x, y, rotation, obliquity) = self.pelvis_motion(t);
        let sides = [Side::Left, Side::Right];
        let feet = sides.map(|s| self.foot(s, t));
        let offsets = sides.map(|s| self.hip_offset(s, rotation, obliquity));
        // Highest pelvis each leg allows with its knee at least at the normal-gait floor.
        let mut limits = [0.0; 2];
        for i in 0..2 {
            let hip_xy = Vector2::new(x + offsets[i].x, y + offsets[i].y);
            let d = hip_xy - Vector2::new(feet[i].ankle.x, feet[i].ankle.y);
            let span = self.leg_span(table(&KNEE_FLOOR_DEG, self.phase(sides[i], t)));
            let vertical2 = span * span - d.norm_squared();
            if vertical2 <= 0.0 {
                return None;
            }
            limits[i] = feet[i].ankle.z + vertical2.sqrt() - offsets[i].z;
        }
        let lo = limits[0].min(limits[1]);
        let z = lo
            - SOFTMIN_M
                * limits
                    .iter()
                    .map(|l| (-(l - lo) / SOFTMIN_M).exp())
                    .sum::<f64>()
                    .ln();
        let centre = Point3::new(x, y, z);
        let hips = offsets.map(|o| centre + o);
        let forward = Rotation3::from_axis_angle(&Vector3::z_axis(), rotation) * Vector3::x();
        let mut knees = [Point3::origin(); 2];
        for i in 0..2 {
            knees[i] = knee_ik(
                hips[i],
                feet[i].ankle,
                self.p.thigh_m,
                self.p.shank_m,
                &forward,
            )?;
        }
        Some(Pose {
            centre,
            rotation,
            hips,
            knees,
            feet,
        })
    }

    /// The Kinect `Foot` joint of a foot state.
    fn foot_joint(&self, foot: &FootState) -> Point3<f64> {
        let v = pitch_rotate(self.foot_joint, foot.pitch);
        foot.ankle + Vector3::new(v.x, 0.0, v.y)
    }
}

/// A lower-body pose, arrays indexed left = 0, right = 1.
struct Pose {
    centre: Point3<f64>,
    rotation: f64,
    hips: [Point3<f64>; 2],
    knees: [Point3<f64>; 2],
    feet: [FootState; 2],
}

/// Knee position for a hip, an ankle and segment lengths, bending toward `forward`.
/// `None` when the ankle is out of reach (more than 0.1 mm beyond the stretched leg).
fn knee_ik(
    hip: Point3<f64>,
    ankle: Point3<f64>,
    thigh: f64,
    shank: f64,
    forward: &Vector3<f64>,
) -> Option<Point3<f64>> {
    let axis = ankle - hip;
    let d = axis.norm();
    if d > thigh + shank + 1e-4 || d < (thigh - shank).abs() || d < 1e-9 {
        return None;
    }
    let d = d.min(thigh + shank);
    let u = axis / d;
    let along = (thigh * thigh - shank * shank + d * d) / (2.0 * d);
    let out = (thigh * thigh - along * along).max(0.0).sqrt();
    let bend = (forward - u * u.dot(forward)).try_normalize(1e-9)?;
    Some(hip + u * along + bend * out)
}

/// Generates `duration_secs` of walking sampled at `rate_hz`, starting at a right heel strike
/// at t = 0 with the pelvis at x = 0, walking along +X (floor z = 0, +Y left).
///
/// Joints: the six leg joints, `SpineBase` (pelvis centre) and both feet, or all 25 Kinect joints
/// when [`WalkerParams::all_joints`] is set.
///
/// # Errors
/// [`Error::BadParameter`] for out-of-range parameters (including a step too long for the legs
/// to reach), [`Error::Clip`] for a non-positive rate.
pub fn walker(params: &WalkerParams, duration_secs: f64, rate_hz: f64) -> Result<MotionClip> {
    params.validate()?;
    if !(duration_secs.is_finite() && duration_secs >= 0.0) {
        return Err(Error::BadParameter {
            name: "duration_secs",
            value: duration_secs,
            reason: "must be a finite duration ≥ 0 s",
        });
    }
    if !(rate_hz.is_finite() && rate_hz > 0.0) {
        return Err(trigait_skeleton::ClipError::BadRate { rate_hz }.into());
    }
    let model = Model::new(params);
    let joints: Vec<Joint> = if params.all_joints {
        Joint::ALL.to_vec()
    } else {
        let mut j = Joint::LEGS.to_vec();
        j.extend([Joint::SpineBase, Joint::FootLeft, Joint::FootRight]);
        j
    };
    let count = (duration_secs * rate_hz).floor() as usize + 1;
    let mut frames = Vec::with_capacity(count);
    for i in 0..count {
        let t = i as f64 / rate_hz;
        let pose = model.pose(t).ok_or(Error::BadParameter {
            name: "step_length_m",
            value: params.step_length_m,
            reason: "the feet are out of the legs' reach; shorten the step or lengthen the legs",
        })?;
        let upper = params.all_joints.then(|| upper_body(&model, &pose, t));
        frames.push(
            joints
                .iter()
                .map(|j| Some(joint_position(&model, &pose, upper.as_ref(), *j)))
                .collect(),
        );
    }
    Ok(MotionClip::new("walker", rate_hz, joints, frames)?)
}

fn joint_position(
    model: &Model,
    pose: &Pose,
    upper: Option<&UpperBody>,
    joint: Joint,
) -> Point3<f64> {
    match joint {
        Joint::SpineBase => pose.centre,
        Joint::HipLeft => pose.hips[0],
        Joint::KneeLeft => pose.knees[0],
        Joint::AnkleLeft => pose.feet[0].ankle,
        Joint::FootLeft => model.foot_joint(&pose.feet[0]),
        Joint::HipRight => pose.hips[1],
        Joint::KneeRight => pose.knees[1],
        Joint::AnkleRight => pose.feet[1].ankle,
        Joint::FootRight => model.foot_joint(&pose.feet[1]),
        other => upper
            .and_then(|u| u.joints.iter().find(|(j, _)| *j == other).map(|(_, p)| *p))
            .unwrap_or(pose.centre),
    }
}

/// Trunk, head and arms of a full-body pose.
struct UpperBody {
    joints: Vec<(Joint, Point3<f64>)>,
}

/// Trunk upright over the pelvis, counter-rotating against it; arms swinging opposite to the legs.
/// Proportions of height H from Winter: shoulder height 0.818 H, chin 0.870 H, upper arm 0.186 H,
/// forearm 0.146 H, hand 0.108 H.
fn upper_body(model: &Model, pose: &Pose, t: f64) -> UpperBody {
    let h = model.p.height_m;
    let base = pose.centre;
    let hip_height = 0.530 * h;
    let up = Vector3::z();
    // Thorax rotation opposes the pelvis (about half its amplitude).
    let thorax = Rotation3::from_axis_angle(&Vector3::z_axis(), -0.5 * pose.rotation);
    let shoulder_rise = 0.818 * h - hip_height;
    let spine_shoulder = base + up * (shoulder_rise - 0.02 * h);
    let spine_mid = base + up * (0.55 * shoulder_rise);
    let neck = base + up * (0.870 * h - hip_height);
    let head = base + up * (0.936 * h - hip_height);
    let half_shoulders = 0.1 * h;
    let right_phase = model.phase(Side::Right, t) * std::f64::consts::TAU;
    let swing = model.p.arm_swing_deg.to_radians();
    let mut joints = vec![
        (Joint::SpineMid, spine_mid),
        (Joint::SpineShoulder, spine_shoulder),
        (Joint::Neck, neck),
        (Joint::Head, head),
    ];
    for side in [Side::Left, Side::Right] {
        let shoulder =
            spine_shoulder + thorax * Vector3::new(0.0, side.sign() * half_shoulders, -0.01 * h);
        // The left arm is forward when the right leg is (right heel strike).
        let flexion = match side {
            Side::Left => swing * right_phase.cos(),
            Side::Right => -swing * right_phase.cos(),
        };
        let elbow_flexion = 20f64.to_radians() + 0.5 * flexion.max(0.0);
        let arm_dir = |angle: f64| Vector3::new(angle.sin(), 0.0, -angle.cos());
        let elbow = shoulder + arm_dir(flexion) * (0.186 * h);
        let forearm = arm_dir(flexion + elbow_flexion);
        let wrist = elbow + forearm * (0.146 * h);
        let hand = wrist + forearm * (0.4 * 0.108 * h);
        let tip = wrist + forearm * (0.108 * h);
        let thumb =
            wrist + forearm * (0.3 * 0.108 * h) + Vector3::new(0.02, -side.sign() * 0.02, 0.0);
        let names = match side {
            Side::Left => [
                Joint::ShoulderLeft,
                Joint::ElbowLeft,
                Joint::WristLeft,
                Joint::HandLeft,
                Joint::HandTipLeft,
                Joint::ThumbLeft,
            ],
            Side::Right => [
                Joint::ShoulderRight,
                Joint::ElbowRight,
                Joint::WristRight,
                Joint::HandRight,
                Joint::HandTipRight,
                Joint::ThumbRight,
            ],
        };
        joints.extend(
            names
                .into_iter()
                .zip([shoulder, elbow, wrist, hand, tip, thumb]),
        );
    }
    UpperBody { joints }
}
