//! A lower-body skeleton from Kinect v2 depth frames, with no SDK and no trained weights.
//!
//! The Kinect SDK's body tracker (thesis §2, §6.4) exists only on Windows; on Linux a Kinect v2
//! gives depth and no skeleton. This crate is a model-based tracker in the spirit of
//! Ganapathi et al. 2012 ("Real-time human pose tracking from range data", ECCV): segment the
//! person, then fit an articulated model to the point cloud, frame after frame, starting from
//! the last fit. Per frame ([`LegTracker::track`]):
//!
//! 1. **Floor.** From the rig (the sensor's pose, [`Floor::from_pose`]) or a RANSAC plane fit on
//!    the lower image rows, held once found ([`segment`]). A floor that stops matching the
//!    depth (a bumped tripod: the lower rows' pixels no longer lie on it) is fitted afresh,
//!    and the legs are found again from there.
//! 2. **Person.** Floor pixels and pixels above head height are dropped; the rest form connected
//!    components continuous in depth. Person-like components (standing on the floor, head
//!    height, body-sized) are counted; the one nearest to the last position is followed, with
//!    the pieces of it that occlusion cut off (a lower leg seen past the other leg, its knee
//!    hidden), each of which goes whole to one leg. A person whose thighs reach out from under
//!    the trunk (seated, crouching) is said not to stand, and no legs are fitted
//!    ([`posture`]); the stature of someone who has stood up is learned once their top stops
//!    rising.
//! 3. **Legs.** The model is two chains hip → knee → ankle of straight segments; each point
//!    below the hip goes to the leg whose predicted axis is nearer, so the legs keep their
//!    identities when they cross ([`legs`] fits one leg, [`chains`] both of a frame). The hip
//!    height is where the two thighs' axes cross, seen along the hips' line, while the person
//!    walks (each thigh turns about its hip: the functional hip joint centre); a share of the
//!    measured stature until enough crossings are in. The knee is the breakpoint of a two-line fit
//!    to the limb's axis; the ankle sits above the sole of a foot standing on the floor (lowest
//!    band at the floor, the ankle still; for a person standing still, kept down while the sole
//!    stays) and hangs at the shank length otherwise. During the first frames the tracker
//!    measures the stature and the thigh and shank lengths; then it holds them (too few
//!    measured: halves of the standing leg from the hip height; a hip height found later
//!    lengthens or shortens the leg by its change) and places the knee and ankle at
//!    those distances along the fitted lines, an ankle never below the floor. The body so
//!    learned is kept through frames without anyone, unless the person found next stands more
//!    than 6 cm taller or shorter: someone else, whose body is learned afresh; and so is that
//!    of a person who stands 10 cm taller than the stature held for most of a second (nobody
//!    grows: it was learned while they sat, crouched or bent over; a hand held over the head
//!    counts too). Where the lower
//!    legs pass each other they may land on the wrong chains; the exchange that makes thigh and
//!    shank lines meet at the knees is tried below the predicted knees and below the height
//!    where the predicted axes cross. A hip whose thigh is not seen moves with the seen one; a
//!    leg mostly behind the other, or unseen, moves with the pelvis; a chain that stays
//!    without a fit while two legs stand apart has the legs split afresh. The `Foot` joint
//!    (second metatarsal head) is an anthropometric distance ahead of the ankle along the
//!    walking direction, pitched towards the leg's visible forefoot.
//! 4. **Sides.** Which chain is the left leg follows from the walking direction (the hips'
//!    motion, or the feet, which point forward): left = up × forward. Re-decided from two seen
//!    hips whenever the person walks; for someone standing, from the feet, once.
//! 5. **Report.** Walking, a hip whose thigh is seen less than the other (tracked) one's is
//!    reported beside the other hip, across the walk at the hips' measured width, rather than
//!    at the top of its short thigh line; the leg's track keeps its own fit, and the hip its
//!    confidence and state (the share of its thigh seen).
//!
//! Every joint comes with a confidence (the share of its segments' bands that were seen) and
//! an SDK-like [`TrackingState`]: tracked, inferred (occluded: kept from the model) or not
//! tracked. The model knows nothing of the shapes a renderer draws: limbs are taken as round
//! and straight, and the proportions are population anthropometry.

#![warn(missing_docs)]

mod chains;
mod legs;
mod posture;
pub mod segment;

use nalgebra::{Isometry3, Point3, Vector2, Vector3};
use serde::{Deserialize, Serialize};
use trigait_depth::{DepthFrame, HEIGHT, PIXELS, WIDTH};
use trigait_kinect::Intrinsics;
use trigait_skeleton::{Joint, JointSample, TrackingState};

use chains::{Assign, ChainFits, ChainFitter, LegPoints, drop_legs_behind, nearer_mean, two_means};
use legs::{FitInput, FloorFrame, LegFit, LegPose, place_foot};
pub use segment::{Component, mask_iou};

/// The depth camera as the tracker sees it.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Camera {
    /// Pinhole of the depth camera.
    pub intrinsics: Intrinsics,
    /// Whether images are mirrored (column grows to the sensor's left, as the Kinect SDK and
    /// libfreenect2 deliver them) rather than as [`Intrinsics::project`] draws them.
    pub mirrored: bool,
    /// Nearest depth used, metres (Kinect v2: 0.5 m).
    pub min_depth_m: f64,
    /// Farthest depth used, metres (Kinect v2: 8 m).
    pub max_depth_m: f64,
}

impl Default for Camera {
    fn default() -> Self {
        Self {
            intrinsics: Intrinsics::default(),
            mirrored: false,
            min_depth_m: 0.5,
            max_depth_m: 8.0,
        }
    }
}

impl Camera {
    /// Camera-space ray (z = 1) through the centre of pixel (u, v).
    #[must_use]
    pub fn ray(&self, u: usize, v: usize) -> (f64, f64) {
        let k = &self.intrinsics;
        let x = (k.cx - (u as f64 + 0.5)) / k.fx;
        let y = (k.cy - (v as f64 + 0.5)) / k.fy;
        (if self.mirrored { -x } else { x }, y)
    }

    /// Pixel of a camera-space point, if in front of the camera.
    #[must_use]
    pub fn project(&self, p: &Point3<f64>) -> Option<(f64, f64)> {
        let k = &self.intrinsics;
        let px = k.project(&Point3::new(
            if self.mirrored { -p.x } else { p.x },
            p.y,
            p.z,
        ))?;
        Some((px.x, px.y))
    }

    /// Whether a point projects inside the image.
    #[must_use]
    pub fn in_view(&self, p: &Point3<f64>) -> bool {
        self.project(p).is_some_and(|(u, v)| {
            (0.0..WIDTH as f64).contains(&u) && (0.0..HEIGHT as f64).contains(&v)
        })
    }
}

/// The floor in camera space: a point p is `up · p + camera_height_m` above it.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Floor {
    /// Unit normal of the floor pointing up, camera space.
    pub up_in_kinect: Vector3<f64>,
    /// Height of the optical centre above the floor, metres.
    pub camera_height_m: f64,
}

impl Floor {
    /// The world floor (z = 0) seen from a sensor at `world_from_kinect`, if it is above it.
    #[must_use]
    pub fn from_pose(world_from_kinect: &Isometry3<f64>) -> Option<Self> {
        let h = world_from_kinect.translation.vector.z;
        (h > 0.0 && h.is_finite()).then(|| Self {
            up_in_kinect: world_from_kinect.rotation.inverse() * Vector3::z(),
            camera_height_m: h,
        })
    }

    /// Height of a camera-space point above the floor, metres.
    #[must_use]
    pub fn height_m(&self, p: &Point3<f64>) -> f64 {
        self.up_in_kinect.dot(&p.coords) + self.camera_height_m
    }
}

/// Thresholds of the segmentation.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SegmentParams {
    /// Points lower than this are floor, metres (noise at 4 m plus a fitted floor's error).
    pub floor_tolerance_m: f64,
    /// Points higher than this are not a person, metres.
    pub max_height_m: f64,
    /// Neighbours are connected when their depths differ by less than `jump_m + jump_per_m·z`.
    pub jump_m: f64,
    /// See [`SegmentParams::jump_m`].
    pub jump_per_m: f64,
    /// Smallest component kept, pixels (far from the sensor a smaller piece of a lower leg's
    /// area is kept as well, to be taken in as a limb the person's own legs cut off).
    pub min_pixels: usize,
    /// A person's lowest point is below this, metres (feet may be lifted in swing).
    pub max_foot_height_m: f64,
    /// A person fully in view reaches above this, metres (a child of 1.3 m; tables, counters
    /// and treadmill rails stay below).
    pub min_person_height_m: f64,
    /// A person fits in a vertical cylinder this wide (radius around the centroid: a stride's
    /// foot or a swinging hand ≈ 0.5 m), metres.
    pub max_person_radius_m: f64,
    /// Visible area of a person, m² (a side view of an adult is ≈ 0.5 m²).
    pub min_person_area_m2: f64,
    /// See [`SegmentParams::min_person_area_m2`].
    pub max_person_area_m2: f64,
}

impl Default for SegmentParams {
    fn default() -> Self {
        Self {
            floor_tolerance_m: 0.02,
            max_height_m: 2.3,
            jump_m: 0.03,
            jump_per_m: 0.02,
            min_pixels: 200,
            max_foot_height_m: 0.4,
            min_person_height_m: 1.3,
            max_person_radius_m: 0.65,
            min_person_area_m2: 0.05,
            max_person_area_m2: 2.0,
        }
    }
}

/// Configuration of a [`LegTracker`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TrackerConfig {
    /// The camera.
    pub camera: Camera,
    /// The floor, when the rig gives it; otherwise fitted.
    pub floor: Option<Floor>,
    /// Segmentation thresholds.
    pub segment: SegmentParams,
    /// Hip joint centre height over stature: 0.52 (Winter 2009, Fig. 4.1: greater trochanter
    /// at 0.530 H; the joint centre sits about 1 cm lower).
    pub hip_height_ratio: f64,
    /// Ankle joint centre above the sole over stature: 0.039 (Winter 2009, Fig. 4.1).
    pub ankle_height_ratio: f64,
    /// Ankle joint centre to the `Foot` joint (the second metatarsal head, where the Kinect v2
    /// puts it) over stature: 0.086. The metatarsal heads sit about 0.55 of the foot length
    /// (0.152 H, Winter 2009, Fig. 4.1) ahead of the ankle (the ankle about 20 % and the heads
    /// about 75 % of the foot from the heel), half the ankle height (0.039 H) lower.
    pub foot_ratio: f64,
    /// Frames over which stature and segment lengths are measured before they are held (from
    /// the stature when fewer than 10 thigh or shank lengths were measured).
    pub learning_frames: usize,
    /// A leg band needs this many points to count as seen.
    pub min_band_points: usize,
    /// A joint is tracked when at least this share of its segments' bands was seen.
    pub tracked_share: f64,
    /// Frames a leg is kept from the model (inferred) without a fit before it is dropped.
    pub max_inferred_frames: usize,
    /// From this share of a person's points at thigh height reaching out from under the trunk,
    /// the person is taken as not standing (seated, crouching) and no leg joints are reported
    /// ([`Status::NotStanding`]): 0.2, where walking reaches 0.06 and sitting 0.26 and more.
    /// Above 1 the person is always taken as standing.
    pub not_standing_share: f64,
}

impl TrackerConfig {
    /// The defaults for a sensor at `world_from_kinect` in a rig (the floor from its pose,
    /// §6.4.4's z = 0), its images mirrored or not.
    #[must_use]
    pub fn for_pose(world_from_kinect: &Isometry3<f64>, mirrored: bool) -> Self {
        Self {
            camera: Camera {
                mirrored,
                ..Camera::default()
            },
            floor: Floor::from_pose(world_from_kinect),
            ..Self::default()
        }
    }
}

impl Default for TrackerConfig {
    fn default() -> Self {
        Self {
            camera: Camera::default(),
            floor: None,
            segment: SegmentParams::default(),
            hip_height_ratio: 0.52,
            ankle_height_ratio: 0.039,
            foot_ratio: 0.086,
            learning_frames: 60,
            min_band_points: 6,
            tracked_share: 0.5,
            max_inferred_frames: 15,
            not_standing_share: 0.2,
        }
    }
}

/// What the tracker made of a frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Status {
    /// No valid depth at all (all zeros, or everything out of range).
    NoData,
    /// No floor given and none could be fitted.
    NoFloor,
    /// The floor is known but no person-like object is in view.
    Nobody,
    /// A person was segmented; see the joints for what was found.
    Tracking,
    /// A person was segmented, but their stature is not known: the head has not been seen in
    /// view yet (someone close to the sensor), and the legs are sized from it.
    NoStature,
    /// No person's feet are in view, but something of a person's size is cut off by the
    /// image's lower edge, its lowest point above where feet are: someone too close to the
    /// sensor for their legs to be seen (a Kinect v2 a metre up, looking level, sees the floor
    /// only from about 1.7 m out).
    TooClose,
    /// A person was segmented who does not stand on their legs: at thigh height they reach
    /// out from under the trunk (seated, crouching), which the standing leg model cannot fit,
    /// so no leg joints are reported ([`TrackedFrame::reaching_share`]).
    NotStanding,
}

/// One joint of the output.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct TrackedJoint {
    /// Which joint.
    pub joint: Joint,
    /// Camera-space position, metres.
    pub position_in_kinect: Point3<f64>,
    /// 0–1: the share of the joint's segments that was seen.
    pub confidence: f64,
    /// SDK-like state.
    pub state: TrackingState,
}

/// The tracker's output for one frame.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TrackedFrame {
    /// Outcome.
    pub status: Status,
    /// Person-like components in view.
    pub people: usize,
    /// Pixels with valid depth.
    pub valid_pixels: usize,
    /// Pixels of the followed person.
    pub person_pixels: usize,
    /// `person_pixels / valid_pixels` (0 without data).
    pub person_share: f64,
    /// The followed person's pixels, row-major (empty unless a person was found).
    #[serde(skip)]
    pub person_mask: Vec<bool>,
    /// Leg joints found (hips, knees, ankles, feet); empty unless tracking.
    pub joints: Vec<TrackedJoint>,
    /// The stature in use, metres.
    pub stature_m: Option<f64>,
    /// The hip joint centres' height over the floor in use, metres.
    pub hip_height_m: Option<f64>,
    /// Thigh and shank lengths in use, metres.
    pub segment_lengths_m: Option<(f64, f64)>,
    /// Whether stature and lengths are held (learning is over).
    pub lengths_held: bool,
    /// The floor in use.
    pub floor: Option<Floor>,
    /// Whether the floor was fitted afresh at this frame, because the one in use no longer
    /// matched the depth (the sensor moved); the legs are then found again.
    pub floor_refitted: bool,
    /// Frames in a row the floor in use has matched the depth poorly (under half the share of
    /// the lower image it once held) without a better one found: something large hides it, or
    /// the sensor moved to where too little floor is in view. 0 while it matches.
    pub floor_doubted_frames: usize,
    /// Whether the stature, leg lengths, hip height and width were forgotten at this frame to
    /// be learned afresh: the person found again is someone else (their stature differs), or
    /// the person stands taller than the stature held (it was learned while they sat).
    pub body_relearned: bool,
    /// The share of the person's points at thigh height that reach out from under the trunk
    /// (more than 0.3 m across the floor from the middle of the upper body): a few hundredths
    /// standing or walking, a quarter and more seated; `None` without a person, or with too
    /// few points to tell.
    pub reaching_share: Option<f64>,
    /// The share of the lower image half's valid pixels that lie on the floor in use: near
    /// none says the floor does not match the frame (a rig's floor given for another sensor,
    /// or a sensor that moved); `None` when the frame was not weighed (no data, no floor).
    pub floor_share: Option<f64>,
}

impl TrackedFrame {
    fn empty(status: Status, valid: usize, floor: Option<Floor>) -> Self {
        Self {
            status,
            people: 0,
            valid_pixels: valid,
            person_pixels: 0,
            person_share: 0.0,
            person_mask: Vec::new(),
            joints: Vec::new(),
            stature_m: None,
            hip_height_m: None,
            segment_lengths_m: None,
            lengths_held: false,
            floor,
            floor_refitted: false,
            floor_doubted_frames: 0,
            body_relearned: false,
            reaching_share: None,
            floor_share: None,
        }
    }

    /// The output for `joint`, if any.
    #[must_use]
    pub fn joint(&self, joint: Joint) -> Option<&TrackedJoint> {
        self.joints.iter().find(|j| j.joint == joint)
    }

    /// The joints as an SDK-like body tracker reports them (the `skeleton_frame` a source
    /// sends): position and state; the confidence has no place there.
    #[must_use]
    pub fn joint_samples(&self) -> Vec<JointSample> {
        self.joints
            .iter()
            .map(|j| JointSample {
                joint: j.joint,
                position_in_kinect: j.position_in_kinect,
                state: j.state,
            })
            .collect()
    }
}

/// Errors of the configuration.
#[derive(Debug, thiserror::Error, PartialEq)]
#[non_exhaustive]
pub enum Error {
    /// A parameter out of range.
    #[error("leg tracker: {name} = {value} is invalid: expected {expected}")]
    BadParameter {
        /// Parameter.
        name: &'static str,
        /// Value.
        value: f64,
        /// What was expected.
        expected: &'static str,
    },
}

/// Hips and knees that all moved less than this since the last frame belong to a person
/// standing still (0.3 m/s at 30 Hz; walking, the hips move about 4 cm a frame at 1.2 m/s and
/// a swinging knee faster still), metres.
const STILL_BODY_M: f64 = 0.01;

/// Thigh-axis crossings that place the hip (about a second of walking at 30 Hz: the thighs
/// are open enough near each heel strike, some 8 frames a second with both thighs seen).
const MIN_HIP_CROSSINGS: usize = 15;
/// Crossings taken at most, after which the hip height is held.
const MAX_HIP_CROSSINGS: usize = 150;
/// Thighs open by at least this (the sum of their tangents off the vertical, about 27°, when
/// seen along the hips' line) cross at a well-defined height; in a stride they open 40–45°.
const MIN_THIGH_OPENING: f64 = 0.5;
/// The hip height found from the crossings stays within this share of the stature of the
/// configured one (trochanteric height ranges over about 0.49–0.55 of the stature).
const HIP_RATIO_SPAN: f64 = 0.05;

/// The leg (thigh + shank) held is at most this much longer than the hip height over the
/// ankle's, metres: walking, the knees never straighten fully and the pelvis rides a few
/// centimetres below its standing height, where the leg's length is the hip's height over the
/// ankle. Measured through the breakpoint, seen from the front, the leg came out up to 6 cm
/// longer, and ankles hung from it sat 2–3 cm low.
const LEG_SLACK_M: f64 = 0.04;

/// Frames whose hips' width across the walk is taken ([`LegTracker::learn_hip_width`]): some
/// seconds of walking, after which the width is held.
const MAX_HIP_WIDTHS: usize = 150;
/// Frames of it before the width is used: half a second of walking with both thighs seen, so
/// that one poor fit at the start does not set it (as [`MIN_HIP_CROSSINGS`] for the height).
const MIN_HIP_WIDTHS: usize = 15;

/// The floor in use is doubted on a frame where the share of the lower image half's valid
/// pixels that lie on it falls under this share of the most it has held so far. One person
/// close to a sensor hides a sixth of it (rendered: 0.65 of 0.78 for a sensor a metre up
/// looking level, someone a metre ahead); a sensor that moved puts
/// nearly all of it off the plane: lowered by 5 cm, the floor lies 5 cm above the plane, and
/// tilted by 2°, 3 m out, 10 cm off it, beyond [`SegmentParams::floor_tolerance_m`], and the
/// person merges with it. A floor that was poor from the start (fitted to a frame whose floor
/// was mostly hidden) is measured against itself, and is not doubted.
const FLOOR_DOUBT_SHARE: f64 = 0.5;
/// Frames the floor is doubted (in a row, not counting frames whose lower half has too few
/// valid pixels to tell) before a fresh one is fitted, half a second at 30 Hz; the fit is tried
/// again after as many more while the doubt lasts.
const FLOOR_DOUBT_FRAMES: usize = 15;
/// A fresh floor replaces the one in use when this many times the share of the frame's lower
/// pixels lies on it: people hiding the floor leave the plane found again about where it was,
/// and it is kept.
const FLOOR_BETTER: f64 = 2.0;
/// ... and at least this share of them: a plane any lower share lies on is no floor to track
/// a person on (the floor fit itself asks for 2 %).
const FLOOR_MIN_SHARE: f64 = 0.1;

/// Frames with the head in view whose tops tell whether a person found again is the one the
/// held body was learned from (a third of a second at 30 Hz).
const STATURE_CHECK_FRAMES: usize = 10;
/// A person found again whose median top lies further than this from the held stature is
/// someone else, metres: the top of one walker's head bobs by about ±2.5 cm over a stride, and
/// the median of a third of a second of it lies within about 2 cm of the stature measured
/// over the learning frames.
const STATURE_CHANGE_M: f64 = 0.06;

/// Frames without anyone after which whoever is found is checked afresh, half a second at
/// 30 Hz: a shorter loss is the same person flickering out of person-likeness (someone seated,
/// their top near [`SegmentParams::min_person_height_m`]), and a check under way goes on.
const SAME_PERSON_GAP_FRAMES: usize = 15;

/// Frames (with the head and the whole body in view) over which a person followed is found to
/// stand taller than the held stature: a second at 30 Hz, so that a hand raised over the head
/// for less than half of it does not count.
const STANDING_TALLER_FRAMES: usize = 30;
/// How much taller than the held stature the median of those frames must be, metres: someone
/// seated stands 0.4 m taller; walking, the head bobs by about ±2.5 cm.
const STANDING_TALLER_M: f64 = 0.1;

/// A person who has just stood up ([`Status::NotStanding`] before) keeps rising for a second or
/// so, their top with them; their tops are taken again once the rise has stopped: the median
/// of the last this many tops (half a second, a step's time, over which the head's bob of
/// about ±2.5 cm while walking evens out) ...
const SETTLE_FRAMES: usize = 15;
/// ... lies within this of the median of the as many before, metres (rising, the top climbs
/// about 1 cm a frame).
const SETTLED_M: f64 = 0.02;
/// Frames after standing up when the rise is taken as over anyway, its top unseen (the head
/// above the image) or never still (3 s).
const MAX_SETTLE_FRAMES: usize = 90;

/// A person's rise after standing up, followed until it stops.
#[derive(Debug, Clone, Default)]
struct Settling {
    /// The last tops with the head in view, up to twice [`SETTLE_FRAMES`].
    tops: std::collections::VecDeque<f64>,
    /// Frames of standing since.
    frames: usize,
}

/// Frames of hip motion that decide the walking direction (0.2 s at 30 Hz).
const PELVIS_HISTORY: usize = 6;
/// Horizontal hip travel over those frames that counts as walking, metres (0.5 m/s).
const MIN_WALK_M: f64 = 0.1;

#[derive(Debug, Clone)]
struct LegTrack {
    pose: LegPose,
    previous: LegPose,
    /// Frames since the last fit.
    missed: usize,
    /// Where the lowest band seen was (horizontal) at the last fit, and whether that foot was
    /// taken to stand on the floor.
    sole: Option<(Vector2<f64>, bool)>,
}

/// Follows one person's legs through a sensor's depth frames.
#[derive(Debug, Clone)]
pub struct LegTracker {
    config: TrackerConfig,
    rays: Vec<(f32, f32)>,
    floor: Option<Floor>,
    /// The largest share of the lower image half's valid pixels that the floor in use has held
    /// on a frame.
    floor_support: Option<f64>,
    /// This frame's share of the lower image on the floor, once weighed.
    floor_share: Option<f64>,
    /// Frames on which the floor in use held under [`FLOOR_DOUBT_SHARE`] of that, in a row
    /// ([`FLOOR_DOUBT_FRAMES`]).
    floor_doubted: usize,
    /// `floor_doubted` when a fresh floor was last tried.
    floor_tried_at: usize,
    /// Floors fitted afresh so far.
    floor_refits: usize,
    legs: Option<[LegTrack; 2]>,
    /// Index of the chain that is the left leg, once decided.
    left: Option<usize>,
    last_centroid: Option<Point3<f64>>,
    /// The walking direction (horizontal, camera space) while the person walks.
    forward: Option<Vector3<f64>>,
    /// Whether the hips travelled as in a walk over the last [`PELVIS_HISTORY`] frames.
    walking: bool,
    /// Each chain's hip over the last [`PELVIS_HISTORY`] frames, and whether its thigh was seen
    /// (a hidden leg's hip is carried or guessed, and its motion says nothing of the walk).
    pelvis_history: Vec<[(Point3<f64>, bool); 2]>,
    frames: usize,
    statures: Vec<f64>,
    /// Thigh lengths measured, each less the hip height it was measured from: the thigh ends
    /// at the hip, so a better hip height moves them all with it.
    thighs: Vec<f64>,
    shanks: Vec<f64>,
    /// Heights at which the thigh axes crossed while walking ([`legs::thighs_cross_at`]).
    hip_crossings: Vec<f64>,
    /// The hips' distance across the walk, measured while both thighs are seen whole
    /// ([`Self::learn_hip_width`]). A measure of the body, kept when the person is lost, as
    /// the stature and the lengths are.
    hip_widths: Vec<f64>,
    /// Once learned: the stature, and the length of each leg segment (thigh = shank) less half
    /// the hip height (the leg from hip to ankle grows with the hip's height).
    held: Option<(f64, f64)>,
    /// Once a stature is known: the tops measured of a person found again, until there are
    /// [`STATURE_CHECK_FRAMES`] to tell whether they are the one the body was learned from.
    recheck: Option<Vec<f64>>,
    /// The tops of the last [`STANDING_TALLER_FRAMES`] frames with the head and the whole body
    /// in view, while the stature is held.
    recent_tops: std::collections::VecDeque<f64>,
    /// Once the person has stood up, until their top stops rising (see [`SETTLE_FRAMES`]):
    /// meanwhile nothing of the body is learned or checked.
    settling: Option<Settling>,
    /// Bodies learned afresh so far, for someone else found or someone who stood up.
    relearns: usize,
    /// Frames in a row without the person followed.
    absent: usize,
    /// `frames` when the body's learning last started.
    learning_since: usize,
}

fn median(v: &mut [f64]) -> Option<f64> {
    if v.is_empty() {
        return None;
    }
    v.sort_by(f64::total_cmp);
    Some(v[v.len() / 2])
}

impl LegTracker {
    /// A tracker with `config`.
    ///
    /// # Errors
    /// [`Error::BadParameter`] for ratios outside (0, 1) or a tracked share outside 0–1.
    pub fn new(config: TrackerConfig) -> Result<Self, Error> {
        for (name, v) in [
            ("hip_height_ratio", config.hip_height_ratio),
            ("ankle_height_ratio", config.ankle_height_ratio),
            ("foot_ratio", config.foot_ratio),
        ] {
            if !(v > 0.0 && v < 1.0) {
                return Err(Error::BadParameter {
                    name,
                    value: v,
                    expected: "a share of the stature within (0, 1)",
                });
            }
        }
        if !(0.0..=1.0).contains(&config.tracked_share) {
            return Err(Error::BadParameter {
                name: "tracked_share",
                value: config.tracked_share,
                expected: "a share within 0–1",
            });
        }
        if config.not_standing_share.is_nan() || config.not_standing_share <= 0.0 {
            return Err(Error::BadParameter {
                name: "not_standing_share",
                value: config.not_standing_share,
                expected: "a share above 0 (above 1: never)",
            });
        }
        let mut rays = Vec::with_capacity(PIXELS);
        for v in 0..HEIGHT {
            for u in 0..WIDTH {
                let (x, y) = config.camera.ray(u, v);
                rays.push((x as f32, y as f32));
            }
        }
        Ok(Self {
            floor: config.floor,
            floor_support: None,
            floor_share: None,
            floor_doubted: 0,
            floor_tried_at: 0,
            floor_refits: 0,
            config,
            rays,
            legs: None,
            left: None,
            last_centroid: None,
            forward: None,
            walking: false,
            hip_widths: Vec::new(),
            pelvis_history: Vec::new(),
            frames: 0,
            statures: Vec::new(),
            thighs: Vec::new(),
            shanks: Vec::new(),
            hip_crossings: Vec::new(),
            held: None,
            recheck: None,
            recent_tops: std::collections::VecDeque::new(),
            settling: None,
            relearns: 0,
            absent: 0,
            learning_since: 0,
        })
    }

    /// The configuration.
    #[must_use]
    pub fn config(&self) -> &TrackerConfig {
        &self.config
    }

    fn lose(&mut self) {
        // A person found again may be someone else, or the same one turned round.
        self.forget_legs();
        self.last_centroid = None;
        // Whoever is found next may be someone else: their stature tells (once there is one
        // to tell it against, held or being learned). A check under way goes on through a
        // short loss (a person flickering in and out of person-likeness is still the same),
        // and starts over after a long one.
        self.absent += 1;
        if (self.held.is_some() || !self.statures.is_empty())
            && (self.recheck.is_none() || self.absent >= SAME_PERSON_GAP_FRAMES)
        {
            self.recheck = Some(Vec::new());
        }
    }

    /// The stature: held, or while it is learned the median measured so far.
    fn stature(&self) -> Option<f64> {
        match self.held {
            Some((s, _)) => Some(s),
            None => median(&mut self.statures.clone()),
        }
    }

    /// Forgets the legs' tracks, their sides and the walk: they are found afresh.
    fn forget_legs(&mut self) {
        self.left = None;
        self.legs = None;
        self.forward = None;
        self.walking = false;
        self.pelvis_history.clear();
        self.recent_tops.clear();
    }

    /// Takes the top of a person found again (`top`, with the head and the whole body in view)
    /// and, once there are [`STATURE_CHECK_FRAMES`], learns the body afresh when their median
    /// lies more than [`STATURE_CHANGE_M`] from the stature held (or, while it is learned, the
    /// median so far): someone else walked in, and the stature, leg lengths, hip height and
    /// width were another body's.
    fn recheck_stature(&mut self, top: f64) {
        let Some(tops) = self.recheck.as_mut() else {
            return;
        };
        tops.push(top);
        if tops.len() < STATURE_CHECK_FRAMES {
            return;
        }
        let tops = self.recheck.take().unwrap_or_default();
        let Some(known) = self.stature() else {
            self.statures = tops;
            return;
        };
        if median(&mut tops.clone()).is_some_and(|m| (m - known).abs() > STATURE_CHANGE_M) {
            self.learn_body_afresh(tops);
        } else if self.held.is_none() {
            // The same person, still being learned: their tops are statures too.
            self.statures.extend(tops);
        }
    }

    /// Takes the top of the person followed (`top`, with the head and the whole body in view)
    /// while the stature is held, and learns the body afresh when all but a fifth of the last
    /// [`STANDING_TALLER_FRAMES`] lie more than [`STANDING_TALLER_M`] above the held stature:
    /// nobody grows, so the body was learned from someone not standing upright (seated at the
    /// start of a Timed-Up-and-Go, crouching, bending over), or from someone shorter. A hand
    /// held over the head for most of a second counts too (the top is the highest pixel); the
    /// body is then learned afresh from the same person.
    fn watch_stature(&mut self, top: f64) {
        let Some((held, _)) = self.held else {
            return;
        };
        self.recent_tops.push_back(top);
        if self.recent_tops.len() > STANDING_TALLER_FRAMES {
            self.recent_tops.pop_front();
        }
        if self.recent_tops.len() == STANDING_TALLER_FRAMES {
            let mut tops: Vec<f64> = self.recent_tops.iter().copied().collect();
            tops.sort_by(f64::total_cmp);
            if tops[STANDING_TALLER_FRAMES / 5] > held + STANDING_TALLER_M {
                // The stature is measured afresh over the learning frames (the window may
                // hold a raised hand).
                self.learn_body_afresh(Vec::new());
            }
        }
    }

    /// Whether the top of a person who has just stood up (`top`, with the head in view) has
    /// stopped rising: their tops may be taken for the stature again. True for anyone else.
    fn settled(&mut self, top: f64) -> bool {
        let Some(Settling { tops, .. }) = self.settling.as_mut() else {
            return true;
        };
        tops.push_back(top);
        if tops.len() > 2 * SETTLE_FRAMES {
            tops.pop_front();
        }
        if tops.len() < 2 * SETTLE_FRAMES {
            return false;
        }
        let (mut before, mut last): (Vec<f64>, Vec<f64>) = (
            tops.iter().take(SETTLE_FRAMES).copied().collect(),
            tops.iter().skip(SETTLE_FRAMES).copied().collect(),
        );
        let rise = median(&mut last)
            .zip(median(&mut before))
            .map(|(b, a)| b - a);
        if rise.is_some_and(|r| r.abs() < SETTLED_M) {
            self.settling = None;
            return true;
        }
        false
    }

    /// Forgets the stature, leg lengths, hip height and width, and learns them afresh from the
    /// next frames, starting from the `tops` just measured; the legs are found afresh too (fitted
    /// below another hip height, the chains may change legs).
    fn learn_body_afresh(&mut self, tops: Vec<f64>) {
        self.forget_legs();
        self.held = None;
        self.learning_since = self.frames;
        self.statures = tops;
        self.thighs.clear();
        self.shanks.clear();
        self.hip_crossings.clear();
        self.hip_widths.clear();
        self.relearns += 1;
    }

    /// Tracks one frame.
    pub fn track(&mut self, frame: &DepthFrame) -> TrackedFrame {
        let (refits, relearns) = (self.floor_refits, self.relearns);
        self.floor_share = None;
        let mut out = self.track_frame(frame);
        out.floor_share = self.floor_share;
        out.floor_refitted = self.floor_refits > refits;
        out.body_relearned = self.relearns > relearns;
        out.floor_doubted_frames = self.floor_doubted;
        out
    }

    fn track_frame(&mut self, frame: &DepthFrame) -> TrackedFrame {
        let mut cloud = segment::back_project(frame, &self.config.camera, &self.rays);
        if cloud.valid == 0 {
            self.lose();
            return TrackedFrame::empty(Status::NoData, 0, self.floor);
        }
        if self.floor.is_none() {
            self.floor = segment::fit_floor(&cloud);
            self.floor_support = None;
        } else if self.floor_doubted >= self.floor_tried_at + FLOOR_DOUBT_FRAMES {
            self.floor_tried_at = self.floor_doubted;
            self.refit_floor(&cloud);
        }
        let Some(floor) = self.floor else {
            self.lose();
            return TrackedFrame::empty(Status::NoFloor, cloud.valid, None);
        };
        let params = self.config.segment;
        let (labels, comps) = segment::components(
            &mut cloud,
            &floor,
            &params,
            self.config.camera.intrinsics.fx,
        );
        self.watch_floor(&cloud);
        let people: Vec<&Component> = comps.iter().filter(|c| c.person_like(&params)).collect();
        let chosen = match self.last_centroid {
            Some(last) => people
                .iter()
                .filter(|c| (c.centroid - last).norm() < 1.0)
                .min_by(|a, b| {
                    (a.centroid - last)
                        .norm()
                        .total_cmp(&(b.centroid - last).norm())
                }),
            // The nearest large one: most pixels.
            None => people.iter().max_by_key(|c| c.pixels),
        };
        let Some(person) = chosen.copied().cloned() else {
            self.lose();
            let status = if people.is_empty() && segment::too_close(&labels, &comps, &params) {
                Status::TooClose
            } else {
                Status::Nobody
            };
            let mut out = TrackedFrame::empty(status, cloud.valid, Some(floor));
            out.people = people.len();
            return out;
        };
        self.last_centroid = Some(person.centroid);
        self.absent = 0;
        let limbs = segment::cut_off_limbs(&labels, &cloud, &comps, &person, &floor, &params);
        // Per pixel: 0 off the person, 1 on its component, 2 + k on its k-th cut-off limb (any
        // beyond the 253rd share the last id).
        let piece: Vec<u8> = labels
            .iter()
            .map(|&l| {
                if l == person.label {
                    1
                } else {
                    limbs
                        .iter()
                        .position(|&m| m == l)
                        .map_or(0, |k| u8::try_from(k + 2).unwrap_or(u8::MAX))
                }
            })
            .collect();
        let mask: Vec<bool> = piece.iter().map(|&p| p > 0).collect();
        let mut out = TrackedFrame::empty(Status::Tracking, cloud.valid, Some(floor));
        // A leg cut off by the image's edge, taken in as a limb, looked like someone partly
        // out of view.
        out.people = people.iter().filter(|c| !limbs.contains(&c.label)).count();
        out.person_pixels = mask.iter().filter(|m| **m).count();
        out.person_share = out.person_pixels as f64 / cloud.valid as f64;
        let ff = FloorFrame::new(floor.up_in_kinect, floor.camera_height_m);
        out.reaching_share = posture::reaching_share(&cloud, &piece, &ff);
        if out
            .reaching_share
            .is_some_and(|s| s >= self.config.not_standing_share)
        {
            // Seated or crouching: nothing of the body is learned from it, and the legs are
            // found afresh once the person stands. The person stays the one followed.
            self.forget_legs();
            self.settling = Some(Settling::default());
            out.status = Status::NotStanding;
            out.stature_m = self.stature();
            out.hip_height_m = out.stature_m.map(|s| self.hip_height(s));
            out.segment_lengths_m = out.hip_height_m.and_then(|hip_h| self.lengths(hip_h));
            out.lengths_held = self.held.is_some();
            out.person_mask = mask;
            return out;
        }
        self.frames += 1;
        if let Some(s) = self.settling.as_mut() {
            s.frames += 1;
            if s.frames > MAX_SETTLE_FRAMES {
                self.settling = None;
            }
        }
        // Stature: the head must be in view to measure it, and the person reach the height
        // of the smallest person taken for one (lower, only a part of them is in view: the
        // legs of someone seated at the image's side edge measured 1.0 m).
        let top_in_view = !mask[..WIDTH * 2].iter().any(|&m| m);
        if top_in_view && person.height_range_m.1 > params.min_person_height_m {
            if !self.settled(person.height_range_m.1) {
                // Still rising after standing up: the learning frames start once the rise
                // has stopped.
                self.learning_since = self.frames;
            } else if self.held.is_none() && self.recheck.is_none() {
                self.statures.push(person.height_range_m.1);
            } else if !person.at_border {
                // Whole in view: someone walking in past the image's side edge shows a
                // shoulder's height before the head.
                if self.recheck.is_some() {
                    self.recheck_stature(person.height_range_m.1);
                } else {
                    self.watch_stature(person.height_range_m.1);
                }
            }
        }
        let stature = self.stature();
        // This frame's hip height, before the frame adds a crossing.
        out.hip_height_m = stature.map(|s| self.hip_height(s));
        match (stature, out.hip_height_m) {
            (Some(stature), Some(hip_h)) => {
                self.fit_legs(&cloud, &piece, &ff, stature, hip_h, &mut out);
            }
            _ => out.status = Status::NoStature,
        }
        out.stature_m = stature;
        out.segment_lengths_m = out.hip_height_m.and_then(|hip_h| self.lengths(hip_h));
        if self.held.is_none()
            && self.settling.is_none()
            && self.frames - self.learning_since >= self.config.learning_frames
            && self.thighs.len() >= 10
            && self.shanks.len() >= 10
            && let (Some(s), Some(hip_h), Some(l)) =
                (stature, out.hip_height_m, out.segment_lengths_m)
        {
            // The breakpoint splits the leg with a bias that depends on the view (a limb seen
            // from the front shows its narrower side); the leg's total length does not. Thigh
            // and shank are equally long in adults (Winter 2009: 0.245 H and 0.246 H).
            // At most [`LEG_SLACK_M`] longer than the hip stands over the ankle.
            let straight = -0.5 * self.config.ankle_height_ratio * s;
            let measured = 0.5 * (l.0 + l.1) - 0.5 * hip_h;
            self.held = Some((s, measured.min(straight + 0.5 * LEG_SLACK_M)));
        } else if self.held.is_none()
            && self.settling.is_none()
            && self.frames - self.learning_since >= self.config.learning_frames
            && let Some(s) = stature
        {
            // Too few lengths measured in the learning frames: a person standing still bends
            // no knee, and a shank is measured only over a foot on the floor (the OpenSim
            // walk's sensors saw 3-4 in 2 s). Hold the standing leg's halves from the hip
            // height (thigh = shank, as above): unheld, a straight leg's knee would sit at
            // whichever breakpoint fitted best, and any does.
            self.held = Some((s, -0.5 * self.config.ankle_height_ratio * s));
        }
        out.lengths_held = self.held.is_some();
        out.person_mask = mask;
        out
    }

    /// Weighs this frame's support for the floor in use (`cloud`'s heights are over it): the
    /// share of the lower image half's valid pixels on it, against the most it has held.
    fn watch_floor(&mut self, cloud: &segment::Cloud) {
        let tolerance = self.config.segment.floor_tolerance_m as f32;
        self.floor_share = segment::floor_share(&cloud.height, tolerance);
        let Some(share) = self.floor_share else {
            return;
        };
        let most = self.floor_support.map_or(share, |m| m.max(share));
        self.floor_support = Some(most);
        if share < FLOOR_DOUBT_SHARE * most {
            self.floor_doubted += 1;
        } else {
            self.floor_doubted = 0;
            self.floor_tried_at = 0;
        }
    }

    /// Fits a fresh floor to `cloud` and takes it when [`FLOOR_BETTER`] times the share of
    /// the lower pixels lies on it as on the one in use, and at least [`FLOOR_MIN_SHARE`]; the
    /// sensor then moved, and the person is found again (stature, lengths and hip height are
    /// the body's and are kept).
    fn refit_floor(&mut self, cloud: &segment::Cloud) {
        let (Some(old), Some(new)) = (self.floor, segment::fit_floor(cloud)) else {
            return;
        };
        let tolerance = self.config.segment.floor_tolerance_m as f32;
        let share = |f: &Floor| segment::floor_share(&segment::heights(cloud, f), tolerance);
        if let (Some(o), Some(n)) = (share(&old), share(&new))
            && n >= FLOOR_BETTER * o
            && n >= FLOOR_MIN_SHARE
        {
            self.floor = Some(new);
            self.floor_support = Some(n);
            self.floor_doubted = 0;
            self.floor_tried_at = 0;
            self.floor_refits += 1;
            // The same person, seen from the moved sensor: the body is kept, and a check of
            // someone found after a loss goes on.
            let pending = self.recheck.take();
            self.lose();
            self.recheck = pending;
        }
    }

    /// Fits the two leg chains to the person's points below the hips at `hip_h` and updates the
    /// tracks, the sides and the frame's joints.
    fn fit_legs(
        &mut self,
        cloud: &segment::Cloud,
        piece: &[u8],
        ff: &FloorFrame,
        stature: f64,
        hip_h: f64,
        out: &mut TrackedFrame,
    ) {
        let ff = *ff;
        let points = LegPoints::gather(cloud, piece, &ff, hip_h);
        if points.pts.len() < 50 {
            return self.coast(out);
        }
        let predicted: Option<[LegPose; 2]> = self.legs.as_ref().map(|l| {
            [
                l[0].pose.extrapolated(&l[0].previous),
                l[1].pose.extrapolated(&l[1].previous),
            ]
        });
        // Assignment: nearest predicted axis, or a 2-means split of the lower legs to start.
        let assign: Box<Assign> = match predicted {
            Some(pred) => Box::new(move |p: &Vector2<f64>, h: f64| {
                let d0 = (p - pred[0].axis_at(&ff, h)).norm();
                let d1 = (p - pred[1].axis_at(&ff, h)).norm();
                let (k, d) = if d0 <= d1 { (0, d0) } else { (1, d1) };
                (d < 0.35).then_some(k)
            }),
            None => {
                let Some((c0, c1)) = two_means(&points.pts, 0.1 * hip_h, 0.6 * hip_h) else {
                    return self.coast(out);
                };
                Box::new(nearer_mean(c0, c1))
            }
        };
        let mut split = points.split(&*assign);
        let last = self.legs.as_ref();
        let fitter = ChainFitter {
            ff: &ff,
            input: self.fit_input(hip_h, stature),
            last,
            // Someone standing still: hips and knees of both legs still since the last frame.
            body_still: last.is_some_and(|l| {
                l.iter().all(|t| {
                    (t.pose.hip - t.previous.hip).norm() < STILL_BODY_M
                        && (t.pose.knee - t.previous.knee).norm() < STILL_BODY_M
                })
            }),
            floor_tolerance_m: self.config.segment.floor_tolerance_m,
            // Before a walk could be told, the seen hips' line; later, a standing person's
            // half-seen hips (a frozen stride) gave a poor one and swapped more still frames.
            lateral: self
                .forward
                .filter(|_| self.walking)
                .map(|f| ff.up.cross(&f))
                .or_else(|| {
                    if self.pelvis_history.len() >= PELVIS_HISTORY {
                        return None;
                    }
                    let l = self.legs.as_ref()?;
                    if !self.both_hips_seen_last() {
                        return None;
                    }
                    let d = l[0].pose.hip - l[1].pose.hip;
                    (d - ff.up * ff.up.dot(&d)).try_normalize(1e-6)
                }),
        };
        let mut fits = fitter.fit(&split.0);
        if let Some(pred) = &predicted {
            fitter.exchange_lower_legs(pred, &mut split, &mut fits);
        }
        let share = self.config.tracked_share;
        if last.is_some() {
            drop_legs_behind(&mut fits.fit, share);
        }
        fitter.resplit_lost_chain(&points, share, &mut split, &mut fits);
        fitter.resplit_merged_chains(&points, share, &mut split, &mut fits);
        // Someone still rising from a seat bends knees and hips as no walk does.
        let learning = self.settling.is_none();
        if learning {
            self.learn_lengths(&fits, hip_h);
        }
        self.carry_unseen_hips(&mut fits.fit);
        let Some(tracks) = self.update_tracks(&fits) else {
            self.legs = None;
            return;
        };
        let seen = |k: usize| fits.fit[k].is_some_and(|f| f.thigh_seen >= share);
        self.pelvis_history
            .push([(tracks[0].pose.hip, seen(0)), (tracks[1].pose.hip, seen(1))]);
        if self.pelvis_history.len() > PELVIS_HISTORY {
            self.pelvis_history.remove(0);
        }
        self.decide_sides(&ff, &tracks, &fits.fit);
        if learning {
            self.learn_hip_height(&ff, &fits.fit);
            self.learn_hip_width(&ff, &tracks, &fits);
        }
        self.emit(&ff, &tracks, &fits.fit, &split.1, stature, out);
        self.legs = Some(tracks);
    }

    /// Whether both thighs were seen in the last frame, so both hips were fitted rather than
    /// carried or guessed.
    fn both_hips_seen_last(&self) -> bool {
        self.pelvis_history.last().is_some_and(|[a, b]| a.1 && b.1)
    }

    /// What fitting a leg needs of the tracker: the hip height, the ankle over the sole, and
    /// the segment lengths, held or, while learning, as measured so far once there are a few.
    fn fit_input(&self, hip_h: f64, stature: f64) -> FitInput {
        FitInput {
            hip_h,
            ankle_above_sole_m: self.config.ankle_height_ratio * stature,
            // While learning, halves of the leg measured so far (thigh = shank, as held).
            lengths: self
                .lengths(hip_h)
                .filter(|_| {
                    self.held.is_some() || (self.thighs.len() >= 5 && self.shanks.len() >= 5)
                })
                .map(|(t, s)| (0.5 * (t + s), 0.5 * (t + s))),
            thigh_for_shank: (self.thighs.len() >= 3)
                .then(|| median(&mut self.thighs.clone()).map(|t| t + hip_h))
                .flatten(),
            min_band_points: self.config.min_band_points as f64,
        }
    }

    /// The segment lengths (thigh, shank) for a hip at `hip_h`: held, or while learning the
    /// medians measured so far (thigh and shank apart), once there are any.
    fn lengths(&self, hip_h: f64) -> Option<(f64, f64)> {
        if let Some((_, half_less)) = self.held {
            let half = half_less + 0.5 * hip_h;
            return Some((half, half));
        }
        Some((
            median(&mut self.thighs.clone())? + hip_h,
            median(&mut self.shanks.clone())?,
        ))
    }

    /// The hip joint centre's height over the floor: where the thighs' axes cross while the
    /// person walks (the median of up to [`MAX_HIP_CROSSINGS`], once there are
    /// [`MIN_HIP_CROSSINGS`]), within [`HIP_RATIO_SPAN`] of the stature of the configured
    /// share; until then, that share of the stature. People's proportions differ: the
    /// share is 0.52 on average (Winter 2009), but a 3 % longer trunk lowers the hip of a
    /// 1.7 m person by 5 cm.
    fn hip_height(&self, stature: f64) -> f64 {
        let prior = self.config.hip_height_ratio * stature;
        if self.hip_crossings.len() < MIN_HIP_CROSSINGS {
            return prior;
        }
        let span = HIP_RATIO_SPAN * stature;
        median(&mut self.hip_crossings.clone())
            .map_or(prior, |h| h.clamp(prior - span, prior + span))
    }

    /// Takes the height at which this frame's thigh axes cross, when both thighs were seen,
    /// the person walks (a standing person's thighs are still and may be apart for any
    /// reason) and the thighs are open by at least [`MIN_THIGH_OPENING`].
    fn learn_hip_height(&mut self, ff: &FloorFrame, fits: &[Option<LegFit>; 2]) {
        let share = self.config.tracked_share;
        if self.hip_crossings.len() < MAX_HIP_CROSSINGS
            && let [Some(a), Some(b)] = fits
            && a.thigh_seen >= share
            && b.thigh_seen >= share
            && self.walking
            && let Some(forward) = self.forward
            && let Some(h) =
                legs::thighs_cross_at(&a.thigh, &b.thigh, ff, &forward, MIN_THIGH_OPENING)
        {
            self.hip_crossings.push(h);
        }
    }

    /// While the lengths are not yet held: the thighs measured this frame, and the shanks over
    /// a foot on the floor (a hung ankle says nothing of the shank's length).
    fn learn_lengths(&mut self, fits: &ChainFits, hip_h: f64) {
        if self.held.is_some() {
            return;
        }
        for (f, on_floor) in fits.fit.iter().zip(fits.on_floor) {
            let Some(f) = f else { continue };
            if let Some(lt) = f.thigh_measured.filter(|l| (0.2..0.7).contains(l)) {
                self.thighs.push(lt - hip_h);
            }
            if let Some(ls) = f
                .shank_measured
                .filter(|l| on_floor && (0.2..0.7).contains(l))
            {
                self.shanks.push(ls);
            }
        }
    }

    /// A hip is placed on its thigh's line: with the thigh unseen, that line is the shank's or
    /// another leg's, and the hip may land anywhere (a hand's breadth across, enough to put the
    /// sides the wrong way round). It moves with the pelvis instead, by the seen hip's step, as
    /// an unseen leg does in [`Self::update_tracks`]. The knee and ankle stay where the seen
    /// shank put them (the hip-knee distance is then not the held thigh length; both joints
    /// are reported inferred).
    fn carry_unseen_hips(&self, fits: &mut [Option<LegFit>; 2]) {
        let Some(old) = &self.legs else {
            return;
        };
        let share = self.config.tracked_share;
        let thigh_seen = |f: &Option<LegFit>| f.is_some_and(|f| f.thigh_seen >= share);
        for k in 0..2 {
            if !thigh_seen(&fits[k])
                && thigh_seen(&fits[1 - k])
                && let Some(step) = pelvis_step(old, fits, k)
                && let Some(f) = fits[k].as_mut()
            {
                f.pose.hip = old[k].pose.hip + step;
            }
        }
    }

    /// The tracks after this frame's fits, taking the old ones: a fitted leg takes its fit; an
    /// unseen leg moves with the pelvis (the seen hip's step), as the pelvis is rigid and a leg
    /// hidden behind the other is carried along by the body, until it has missed too many
    /// frames. `None` when a leg is lost, or at start-up without both legs.
    fn update_tracks(&mut self, fits: &ChainFits) -> Option<[LegTrack; 2]> {
        let fitted = |k: usize, f: &LegFit, previous: LegPose| LegTrack {
            pose: f.pose,
            previous,
            missed: 0,
            sole: fits.sole[k].map(|s| (s, fits.on_floor[k])),
        };
        match (self.legs.take(), &fits.fit) {
            (Some(old), _) => {
                let upd = |k: usize, t: &LegTrack| match &fits.fit[k] {
                    Some(f) => Some(fitted(k, f, t.pose)),
                    None if t.missed < self.config.max_inferred_frames => {
                        let step = pelvis_step(&old, &fits.fit, k).unwrap_or_else(Vector3::zeros);
                        Some(LegTrack {
                            previous: t.pose,
                            pose: LegPose {
                                hip: t.pose.hip + step,
                                knee: t.pose.knee + step,
                                ankle: t.pose.ankle + step,
                            },
                            missed: t.missed + 1,
                            sole: None,
                        })
                    }
                    None => None,
                };
                Some([upd(0, &old[0])?, upd(1, &old[1])?])
            }
            (None, [Some(a), Some(b)]) => Some([fitted(0, a, a.pose), fitted(1, b, b.pose)]),
            (None, _) => None,
        }
    }

    /// The frame's joints from the tracks, once the sides are decided: each with its
    /// confidence (the share of its segments' bands seen) and state, and the `Foot` joint
    /// where the fitted leg's foot points (`low`: each chain's points low enough to be its
    /// foot).
    fn emit(
        &self,
        ff: &FloorFrame,
        tracks: &[LegTrack; 2],
        fits: &[Option<LegFit>; 2],
        low: &[Vec<(Vector2<f64>, f64)>; 2],
        stature: f64,
        out: &mut TrackedFrame,
    ) {
        let Some(left) = self.left else {
            return;
        };
        let share = self.config.tracked_share;
        for (k, (hip_j, knee_j, ankle_j, foot_j)) in [
            (
                Joint::HipLeft,
                Joint::KneeLeft,
                Joint::AnkleLeft,
                Joint::FootLeft,
            ),
            (
                Joint::HipRight,
                Joint::KneeRight,
                Joint::AnkleRight,
                Joint::FootRight,
            ),
        ]
        .into_iter()
        .enumerate()
        {
            let chain = if k == 0 { left } else { 1 - left };
            let t = &tracks[chain];
            let (thigh, shank) = fits[chain].map_or((0.0, 0.0), |f| (f.thigh_seen, f.shank_seen));
            let mut emit = |joint, p: Point3<f64>, c: f64| {
                let state = if !self.config.camera.in_view(&p) {
                    TrackingState::NotTracked
                } else if c >= share {
                    TrackingState::Tracked
                } else {
                    TrackingState::Inferred
                };
                out.joints.push(TrackedJoint {
                    joint,
                    position_in_kinect: p,
                    confidence: c.clamp(0.0, 1.0),
                    state,
                });
            };
            emit(hip_j, self.hip_out(ff, tracks, fits, chain), thigh);
            emit(knee_j, t.pose.knee, thigh.min(shank));
            emit(ankle_j, t.pose.ankle, shank);
            // The foot points forward: along the walking direction, or standing, from the
            // ankle towards the centre of the foot's points.
            let forward = self.forward.or_else(|| {
                let d = fits[chain].and_then(|f| f.foot)? - t.pose.ankle;
                (d - ff.up * ff.up.dot(&d)).try_normalize(1e-6)
            });
            if fits[chain].is_some()
                && let Some(forward) = forward
                && let Some(foot) = place_foot(
                    ff,
                    &t.pose.ankle,
                    &low[chain],
                    &forward,
                    self.config.foot_ratio * stature,
                )
            {
                emit(foot_j, foot, shank);
            }
        }
    }

    /// Chain `chain`'s hip as reported. A hip is extrapolated up its thigh's line from the
    /// bands seen, and a thigh partly hidden behind the other leg leaves a short line whose
    /// top may miss the hip by a hand's breadth, mostly along the view. Walking, the pelvis
    /// holds the hips side by side across the walk (it turns only a few degrees each way), so
    /// when the other thigh is seen better and tracked, the hip is reported beside the other
    /// hip instead: level with it along the walk and, once measured, the hips' width across
    /// it ([`Self::learn_hip_width`], once [`MIN_HIP_WIDTHS`] frames measured it), at its own
    /// height. Only the position changes: the leg's track keeps its fit, as the hip of a thigh
    /// seen again must be free to move, and the hip keeps the confidence and state its thigh's
    /// seen share gives it.
    fn hip_out(
        &self,
        ff: &FloorFrame,
        tracks: &[LegTrack; 2],
        fits: &[Option<LegFit>; 2],
        chain: usize,
    ) -> Point3<f64> {
        let hip = tracks[chain].pose.hip;
        let seen = |k: usize| fits[k].map_or(0.0, |f| f.thigh_seen);
        let (own, other) = (seen(chain), seen(1 - chain));
        let (Some(forward), Some(left)) = (self.forward.filter(|_| self.walking), self.left) else {
            return hip;
        };
        if own >= other || other < self.config.tracked_share {
            return hip;
        }
        let from_other = hip - tracks[1 - chain].pose.hip;
        let mut beside = hip - forward * forward.dot(&from_other);
        if self.hip_widths.len() >= MIN_HIP_WIDTHS
            && let Some(width) = median(&mut self.hip_widths.clone())
        {
            let lateral = ff.up.cross(&forward);
            let side = if chain == left { 1.0 } else { -1.0 };
            beside += lateral * (side * width - lateral.dot(&from_other));
        }
        beside
    }

    /// Takes the hips' distance across the walk while the person walks with both thighs seen
    /// whole, up to [`MAX_HIP_WIDTHS`] frames.
    fn learn_hip_width(&mut self, ff: &FloorFrame, tracks: &[LegTrack; 2], fits: &ChainFits) {
        if self.walking
            && self.hip_widths.len() < MAX_HIP_WIDTHS
            && let Some(forward) = self.forward
            && fits
                .fit
                .iter()
                .all(|f| f.is_some_and(|f| f.thigh_seen >= 1.0))
        {
            let lateral = ff.up.cross(&forward);
            self.hip_widths.push(
                lateral
                    .dot(&(tracks[0].pose.hip - tracks[1].pose.hip))
                    .abs(),
            );
        }
    }

    /// No fit this frame: the model coasts (inferred) until it has missed too many frames.
    fn coast(&mut self, out: &mut TrackedFrame) {
        let Some(mut legs) = self.legs.take() else {
            return;
        };
        for t in &mut legs {
            t.missed += 1;
            t.previous = t.pose;
            t.sole = None;
        }
        if legs
            .iter()
            .any(|t| t.missed > self.config.max_inferred_frames)
        {
            return;
        }
        if let Some(left) = self.left {
            for (k, joints) in [
                [Joint::HipLeft, Joint::KneeLeft, Joint::AnkleLeft],
                [Joint::HipRight, Joint::KneeRight, Joint::AnkleRight],
            ]
            .into_iter()
            .enumerate()
            {
                let t = &legs[if k == 0 { left } else { 1 - left }];
                for (j, p) in joints
                    .into_iter()
                    .zip([t.pose.hip, t.pose.knee, t.pose.ankle])
                {
                    out.joints.push(TrackedJoint {
                        joint: j,
                        position_in_kinect: p,
                        confidence: 0.0,
                        state: TrackingState::Inferred,
                    });
                }
            }
        }
        self.legs = Some(legs);
    }

    /// Which chain is the left leg: left = up × forward, forward from the hips' motion over
    /// the last frames or, standing still, from the feet (they point forward). Re-decided
    /// whenever the person clearly walks, so a turn on the spot does not swap the sides. The
    /// motion is read off hips whose thighs were seen, and the sides only when both thighs are
    /// seen: at start-up with one leg hidden, its guessed hip lay 0.35 m off and flipped the
    /// sides for 10 frames. Walking, the sides are the hips'; from the feet, the hips', knees'
    /// and ankles' together.
    fn decide_sides(
        &mut self,
        ff: &FloorFrame,
        tracks: &[LegTrack; 2],
        fits: &[Option<LegFit>; 2],
    ) {
        // The pelvis's travel over the window, from the hips seen at both of its ends (the
        // pelvis is rigid, so either hip's travel is the walk's).
        let horizontal = |v: &Vector3<f64>| v - ff.up * ff.up.dot(v);
        let travel = match (self.pelvis_history.first(), self.pelvis_history.last()) {
            (Some(a), Some(b)) if self.pelvis_history.len() >= PELVIS_HISTORY => {
                let steps: Vec<Vector3<f64>> = a
                    .iter()
                    .zip(b)
                    .filter(|(a, b)| a.1 && b.1)
                    .map(|(a, b)| b.0 - a.0)
                    .collect();
                (!steps.is_empty()).then(|| steps.iter().sum::<Vector3<f64>>() / steps.len() as f64)
            }
            _ => None,
        };
        // The travel when it is a walk rather than sway.
        let walk = travel.filter(|v| horizontal(v).norm() > MIN_WALK_M);
        let by_motion = walk.is_some();
        self.walking = by_motion;
        // The feet decide only for someone standing (seen still over the whole window) or on
        // the very first frame (a single recorded image); a person found again waits for the
        // window, as the feet of someone close to the sensor are often out of view, and a
        // window whose hips were not seen tells nothing.
        let standing = travel.is_some() && !by_motion;
        if self.left.is_some() && !by_motion
            || self.left.is_none() && !by_motion && !standing && self.frames > 1
        {
            return;
        }
        let forward = if let Some(v) = walk {
            v
        } else {
            let mut f = Vector3::zeros();
            for (t, fit) in tracks.iter().zip(fits) {
                if let Some(foot) = fit.and_then(|f| f.foot) {
                    f += foot - t.pose.ankle;
                }
            }
            f
        };
        let forward = horizontal(&forward);
        if forward.norm() < 0.03 {
            return;
        }
        if by_motion {
            self.forward = Some(forward.normalize());
        }
        // Which hip lies on which side is read only off two hips seen now: a hidden leg's hip
        // is carried along or guessed, and may lie anywhere.
        if !self.both_hips_seen_last() {
            return;
        }
        // Walking, the hips say it (the pelvis is rigid; knees and ankles swing past each
        // other). From the feet (standing, or a first frame), the hips, knees and ankles
        // together: a half-seen hip may sit anywhere (22 cm off in one rendered still pose, on
        // the wrong side), while a standing person's knees and ankles lie apart as the hips do.
        let lateral = ff.up.cross(&forward.normalize());
        let (a, b) = (&tracks[0].pose, &tracks[1].pose);
        let d = if by_motion {
            lateral.dot(&(a.hip - b.hip))
        } else {
            lateral.dot(&((a.hip - b.hip) + (a.knee - b.knee) + (a.ankle - b.ankle))) / 3.0
        };
        if d.abs() > 0.03 {
            self.left = Some(if d > 0.0 { 0 } else { 1 });
        }
    }
}

/// How far the pelvis moved this frame as chain `k` would be carried by it: the other chain's
/// hip step from its track to its fit, if it was fitted (the pelvis is rigid).
fn pelvis_step(old: &[LegTrack; 2], fits: &[Option<LegFit>; 2], k: usize) -> Option<Vector3<f64>> {
    fits[1 - k].map(|f| f.pose.hip - old[1 - k].pose.hip)
}

#[cfg(test)]
mod tests;

#[cfg(test)]
mod diag;
