use nalgebra::{Isometry3, Point3};
use trigait_body_render::{Body, BodyShape, Part, RenderParams, Renderer, Room};
use trigait_motion::{WalkerParams, there_and_back, walker};
use trigait_rig::Rig;
use trigait_skeleton::{Joint, MotionClip, TrackingState};

use super::*;

const RATE_HZ: f64 = 30.0;

/// The walker's 3 s walk.
pub(super) fn walk() -> MotionClip {
    walker(&WalkerParams::default(), 3.0, 100.0).unwrap()
}

/// The walker as the default graph plays it: a 3 s walk along the walkway, then back.
fn lap() -> MotionClip {
    Turns::Spun.lap(&walk())
}

/// The tracker as a rigged sensor runs it: the floor from the sensor's pose.
pub(super) fn config_for(pose: &Isometry3<f64>) -> TrackerConfig {
    TrackerConfig {
        floor: Floor::from_pose(pose),
        ..TrackerConfig::default()
    }
}

/// A renderer from `pose` into the default room, its sensor noise drawn from `seed`.
pub(super) fn seeded_renderer(pose: &Isometry3<f64>, seed: u64) -> Renderer {
    Renderer::new(
        RenderParams {
            seed,
            ..RenderParams::default()
        },
        pose,
        &Room::default(),
    )
    .unwrap()
}

/// The tracker as `trigait legs` runs it on a recorded Kinect v2 frame: mirrored, the floor
/// fitted.
fn recorded_frame_tracker() -> LegTracker {
    LegTracker::new(TrackerConfig {
        camera: Camera {
            mirrored: true,
            ..Camera::default()
        },
        ..TrackerConfig::default()
    })
    .unwrap()
}

/// The median: the middle value, or the mean of the middle two of an even count.
fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n == 0 {
        f64::NAN
    } else if n.is_multiple_of(2) {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    } else {
        v[n / 2]
    }
}

/// Seconds after the lap's turn, where the simulated walker spins 180° within one sample (no
/// real body does; the tracker needs its short walking-direction window to notice).
fn near_turn(t: f64, lap_secs: f64) -> bool {
    let half = lap_secs / 2.0;
    let since = (t % lap_secs) % half;
    since < 0.35
}

/// One sensor's score over a rendered lap.
struct Score {
    sensor: String,
    /// Median error of hip, knee, ankle, metres.
    medians: [f64; 3],
    /// Their root-mean-square error, metres.
    rms: [f64; 3],
    /// The same leaving out, on a spun lap, the 0.35 s after each instant turn (which no body
    /// makes) and the lap's first 0.35 s; on a two-lane lap, the same as `rms`.
    rms_away: [f64; 3],
    /// Median error of the feet and their median height error (tracker − truth), metres.
    foot: (f64, f64),
    /// Joints reported (tracked or inferred) of those asked for.
    reported: usize,
    asked: usize,
    /// Frames with the legs swapped (outside the 0.35 s after the lap's turn).
    swaps: usize,
    /// Frames on which the tracker fitted its floor afresh (the sensor never moves here).
    refits: usize,
    /// Frames on which it learned the body afresh (there is one walker).
    relearns: usize,
    /// Frames on which it took the walker as not standing.
    not_standing: usize,
    /// The hip height the tracker uses at the end, and the rendered hips' median height over
    /// the floor, metres.
    hip_height: (f64, f64),
}

/// How a lap turns at the walkway's ends.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Turns {
    /// There and back on one line: the walker spins 180° within one sample, and the 0.35 s
    /// after each spin are left out of the swap count ([`near_turn`]).
    Spun,
    /// Out on one lane and back on another, turning unseen: nobody is there during a turn
    /// (the empty room is rendered) and no frame is left out.
    Unseen,
}

impl Turns {
    /// `clip` on the thesis rig's walkway as a lap that turns this way (the two-lane lap's
    /// lanes 1 m apart, a second's turn at each end, as `depth-tracking.yml` walks).
    pub(super) fn lap(self, clip: &MotionClip) -> MotionClip {
        let placed = clip.placed_on_walkway();
        match self {
            Self::Spun => there_and_back(&placed).unwrap(),
            Self::Unseen => trigait_motion::walkway_loop(&placed, 1.0, 1.0).unwrap(),
        }
    }
}

/// The sensor noise seed of the tests that pin one deterministic run.
const NOISE_SEED: u64 = 7;

/// Renders `lap` on the thesis rig for `secs` at 30 Hz, with the sensor noise drawn from
/// `seed`, and tracks it on every sensor: per sensor the median error per joint class against
/// the rendered joint centres, and the frames whose legs are swapped.
fn score_on_the_thesis_rig(lap: &MotionClip, turns: Turns, secs: f64, seed: u64) -> Vec<Score> {
    let rig = Rig::builtin("thesis").unwrap();
    let frames = (secs * RATE_HZ) as usize;
    let mut scores = Vec::new();
    for sensor in &rig.sensors {
        let pose = sensor.world_from_kinect;
        let mut renderer = seeded_renderer(&pose, seed);
        let mut tracker = LegTracker::new(config_for(&pose)).unwrap();
        let mut errors: [Vec<f64>; 3] = Default::default();
        let mut errors_away: [Vec<f64>; 3] = Default::default();
        // The same split by the reported state, and the signed height error of each class.
        let mut by_state: [[Vec<f64>; 3]; 2] = Default::default();
        let mut height_err: [Vec<f64>; 3] = Default::default();
        let floor = Floor::from_pose(&pose).unwrap();
        let up = floor.up_in_kinect;
        let (mut found_hip_h, mut hip_h) = (f64::NAN, Vec::new());
        let (mut swaps, mut reported, mut tracked, mut present) = (0, 0, 0, 0);
        let (mut refits, mut relearns, mut not_standing) = (0, 0, 0);
        let (mut foot_err, mut foot_height) = (Vec::new(), Vec::new());
        for f in 0..frames {
            let t = f as f64 / RATE_HZ;
            let tl = t % lap.duration_secs();
            let rendered = renderer
                .render_pose(&BodyShape::default(), |j| lap.position_at(j, tl))
                .unwrap_or_else(|_| {
                    assert_eq!(turns, Turns::Unseen, "{} at {tl} s", lap.name());
                    renderer.render_bodies(&[], Vec::new())
                });
            let out = tracker.track(&rendered.depth);
            refits += usize::from(out.floor_refitted);
            relearns += usize::from(out.body_relearned);
            not_standing += usize::from(out.status == Status::NotStanding);
            if rendered.joints_in_kinect.is_empty() {
                continue;
            }
            present += 1;
            let spun = turns == Turns::Spun && near_turn(t, lap.duration_secs());
            found_hip_h = out.hip_height_m.unwrap_or(f64::NAN);
            for j in [Joint::HipLeft, Joint::HipRight] {
                hip_h.push(floor.height_m(&rendered.joint(j).unwrap()));
            }
            let pairs = [
                (Joint::HipLeft, Joint::HipRight, 0),
                (Joint::KneeLeft, Joint::KneeRight, 1),
                (Joint::AnkleLeft, Joint::AnkleRight, 2),
            ];
            for (l, r, class) in pairs {
                let (Some(tl_), Some(tr)) = (out.joint(l), out.joint(r)) else {
                    continue;
                };
                let (gl, gr) = (rendered.joint(l).unwrap(), rendered.joint(r).unwrap());
                for (tj, g) in [(tl_, gl), (tr, gr)] {
                    if tj.state != TrackingState::NotTracked {
                        let e = (tj.position_in_kinect - g).norm();
                        errors[class].push(e);
                        if !spun {
                            errors_away[class].push(e);
                        }
                        by_state[usize::from(tj.state == TrackingState::Inferred)][class].push(e);
                        height_err[class].push(up.dot(&(tj.position_in_kinect - g)));
                        reported += 1;
                        if tj.state == TrackingState::Tracked {
                            tracked += 1;
                        }
                    }
                }
            }
            for j in [Joint::FootLeft, Joint::FootRight] {
                if let (Some(tj), Some(g)) = (out.joint(j), rendered.joint(j))
                    && tj.state != TrackingState::NotTracked
                {
                    foot_err.push((tj.position_in_kinect - g).norm());
                    foot_height.push(up.dot(&(tj.position_in_kinect - g)));
                }
            }
            if sides_swapped(&out, &rendered) == Some(true) && !spun {
                eprintln!(
                    "{} {} seed {seed}: legs swapped at {t:.2} s ({:.2} s into the lap's half)",
                    lap.name(),
                    sensor.id,
                    (t % lap.duration_secs()) % (lap.duration_secs() / 2.0)
                );
                swaps += 1;
            }
        }
        let medians: Vec<f64> = errors.iter().map(|e| median(e.clone())).collect();
        let rms_of =
            |e: &Vec<f64>| (e.iter().map(|v| v * v).sum::<f64>() / e.len().max(1) as f64).sqrt();
        let rms: Vec<f64> = errors.iter().map(rms_of).collect();
        let rms_away: Vec<f64> = errors_away.iter().map(rms_of).collect();
        eprintln!(
            "{} {}: median error hip {:.3} knee {:.3} ankle {:.3} m, RMS {:.3} / {:.3} / {:.3} m ({:.3} / {:.3} / {:.3} m away from instant turns); {reported} joints reported of {} ({tracked} tracked); {swaps} swapped frames",
            lap.name(),
            sensor.id,
            medians[0],
            medians[1],
            medians[2],
            rms[0],
            rms[1],
            rms[2],
            rms_away[0],
            rms_away[1],
            rms_away[2],
            present * 6
        );
        for (st, name) in by_state.iter().zip(["tracked", "inferred"]) {
            eprintln!(
                "  {name}: n {} / {} / {}, RMS {:.3} / {:.3} / {:.3} m, > 10 cm {} / {} / {}",
                st[0].len(),
                st[1].len(),
                st[2].len(),
                rms_of(&st[0]),
                rms_of(&st[1]),
                rms_of(&st[2]),
                st[0].iter().filter(|e| **e > 0.1).count(),
                st[1].iter().filter(|e| **e > 0.1).count(),
                st[2].iter().filter(|e| **e > 0.1).count(),
            );
        }
        eprintln!(
            "  median height error {:+.3} / {:+.3} / {:+.3} m",
            median(height_err[0].clone()),
            median(height_err[1].clone()),
            median(height_err[2].clone())
        );
        let hip_height = (found_hip_h, median(hip_h));
        eprintln!(
            "  hip height {:.3} m, rendered {:.3} m",
            hip_height.0, hip_height.1
        );
        let foot = (median(foot_err.clone()), median(foot_height));
        eprintln!(
            "  feet: {} reported, median error {:.3} m, RMS {:.3} m, median height error {:+.3} m",
            foot_err.len(),
            foot.0,
            rms_of(&foot_err),
            foot.1
        );
        scores.push(Score {
            sensor: sensor.id.clone(),
            medians: [medians[0], medians[1], medians[2]],
            rms: [rms[0], rms[1], rms[2]],
            rms_away: [rms_away[0], rms_away[1], rms_away[2]],
            foot,
            reported,
            asked: present * 6,
            swaps,
            refits,
            relearns,
            not_standing,
            hip_height,
        });
    }
    scores
}

/// Simulated depth of the walker on the thesis rig for 10 s at 30 Hz: for every sensor the
/// tracked hips, knees and ankles are within 4 cm (median per joint class) of the rendered
/// joint centres, and the left and right legs are never swapped (outside the 0.35 s after the
/// simulated lap's instantaneous turn). Measured: medians 2.0–3.3 cm (hip / knee / ankle k1
/// 2.6 / 2.0 / 2.2, k2 2.5 / 2.1 / 2.3, k3 3.3 / 2.2 / 2.2 cm); no swapped frame on this noise
/// seed (swaps over other seeds: [`swapped_frames_over_noise_seeds`]). The hip height
/// found from the walk is within 1.1 cm of the rendered one ([`HIP_HEIGHT_M`]); the feet are
/// pinned to their measured state (see [`FOOT_MEDIAN_M`]).
#[test]
fn walker_on_the_thesis_rig() {
    let mut failures = Vec::new();
    for s in score_on_the_thesis_rig(&lap(), Turns::Spun, 10.0, NOISE_SEED) {
        if s.reported < s.asked * 8 / 10 {
            failures.push(format!("{}: {} joints reported", s.sensor, s.reported));
        }
        for (m, what) in s.medians.iter().zip(["hip", "knee", "ankle"]) {
            if *m > 0.04 {
                failures.push(format!("{}: median {what} error {m:.3} m", s.sensor));
            }
        }
        if s.swaps > 0 {
            failures.push(format!(
                "{}: left/right swapped in {} frames",
                s.sensor, s.swaps
            ));
        }
        if s.foot.0 > FOOT_MEDIAN_M || s.foot.1.abs() > FOOT_HEIGHT_BIAS_M {
            failures.push(format!(
                "{}: feet median error {:.3} m, median height error {:+.3} m",
                s.sensor, s.foot.0, s.foot.1
            ));
        }
        if s.refits > 0 || s.relearns > 0 || s.not_standing > 0 {
            failures.push(format!(
                "{}: floor fitted afresh {} times, body learned afresh {} times, not standing in {} frames",
                s.sensor, s.refits, s.relearns, s.not_standing
            ));
        }
        failures.extend(hip_height_off(&s));
    }
    assert!(failures.is_empty(), "{failures:?}");
}

/// The tracker finds the hip joint centres' height from the walk (where the thighs' axes
/// cross) within this of the rendered hips' median height, metres. With the hips at the
/// configured 0.52 of the measured stature instead, they were 2.3 cm (walker), 1.5 cm (CMU)
/// and 3.5 cm (Rajagopal) low.
const HIP_HEIGHT_M: f64 = 0.025;

/// `Some` failure when the hip height `s` ends with is further than [`HIP_HEIGHT_M`] from the
/// rendered one.
fn hip_height_off(s: &Score) -> Option<String> {
    let (found, rendered) = s.hip_height;
    ((found - rendered).abs() > HIP_HEIGHT_M || found.is_nan()).then(|| {
        format!(
            "{}: hip height {found:.3} m, rendered {rendered:.3} m",
            s.sensor
        )
    })
}

/// The walker's `Foot` joints (second metatarsal heads): median error per sensor, metres.
/// Measured 2.4–2.9 cm (8.1–13.6 cm while the foot was the centre of the points below the
/// ankle).
const FOOT_MEDIAN_M: f64 = 0.035;
/// The same, median height error (tracker − truth), metres. Measured +0.3 to +0.9 cm (+2.0 to
/// +3.2 cm before).
const FOOT_HEIGHT_BIAS_M: f64 = 0.015;

/// A whole leg can be cut off too: on k2, 0.37–0.47 s into the walker's lap, the other leg
/// crosses in front of it and a band of dropped pixels lines the step at its top. The mask held
/// under 30 % of that leg's pixels, so both chains were fitted to the other leg and the sides
/// came out swapped for those frames on some noise seeds. Now each leg's thigh and shank have
/// most of their rendered pixels in the mask on every frame there.
#[test]
fn a_whole_leg_cut_off_by_the_other_stays_in_the_mask() {
    let pose = Rig::builtin("thesis").unwrap().sensors[1].world_from_kinect;
    let lap = lap();
    let mut renderer = seeded_renderer(&pose, 7);
    let mut tracker = LegTracker::new(config_for(&pose)).unwrap();
    let legs = [
        [Part::ThighLeft.label(), Part::ShankLeft.label()],
        [Part::ThighRight.label(), Part::ShankRight.label()],
    ];
    let mut shares = Vec::new();
    for f in 0..=14 {
        let t = f as f64 / RATE_HZ;
        let frame = renderer
            .render_pose(&BodyShape::default(), |j| lap.position_at(j, t))
            .unwrap();
        let out = tracker.track(&frame.depth);
        if f < 11 {
            continue;
        }
        for leg in &legs {
            let seen = |i: &usize| leg.contains(&frame.labels[*i]) && frame.depth.as_mm()[*i] > 0;
            let n = (0..frame.labels.len()).filter(seen).count();
            let kept = (0..frame.labels.len())
                .filter(|i| seen(i) && out.person_mask.get(*i).copied().unwrap_or(false))
                .count();
            assert!(n > 300, "{n} pixels of a leg at {t:.2} s");
            shares.push(kept as f64 / n as f64);
        }
    }
    eprintln!("share of each leg's pixels in the mask, frames 11-14: {shares:.2?}");
    assert!(shares.iter().all(|s| *s > 0.7), "{shares:.2?}");
}

/// Seen past the other leg, a lower leg whose knee that leg hides is cut off from the person's
/// component by the depth jump at the near leg's edge. It stays in the person's mask: on k1,
/// over the walker's frames 119–130 (where the mask held none of the left shank's pixels before
/// cut-off limbs were taken in), most of the left shank's rendered pixels are in the mask.
#[test]
fn a_lower_leg_seen_past_the_other_leg_stays_in_the_mask() {
    let pose = thesis_k1();
    let lap = lap();
    let mut renderer = seeded_renderer(&pose, 7);
    let mut tracker = LegTracker::new(config_for(&pose)).unwrap();
    let shank = trigait_body_render::Part::ShankLeft.label();
    let (mut in_mask, mut rendered) = (0, 0);
    for f in 0..=130 {
        let t = f as f64 / RATE_HZ;
        let frame = renderer
            .render_pose(&BodyShape::default(), |j| lap.position_at(j, t))
            .unwrap();
        let out = tracker.track(&frame.depth);
        if f >= 119 {
            rendered += frame.labels.iter().filter(|l| **l == shank).count();
            in_mask += frame
                .labels
                .iter()
                .zip(&out.person_mask)
                .filter(|(l, m)| **l == shank && **m)
                .count();
        }
    }
    eprintln!("left shank pixels in the person mask: {in_mask} of {rendered}");
    assert!(rendered > 1000, "{rendered}");
    assert!(in_mask * 10 >= rendered * 7, "{in_mask} of {rendered}");
}

/// The recordings the walker is checked against, played there and back through the renderer.
const MOCAP_WALKS: [&str; 2] = [
    "mocap-cmu-07_01/07_01.c3d",
    "mocap-opensim-rajagopal-walk/Rajagopal__motion_capture_walk.trc",
];

/// A mocap walk from the shared data as a lap there and back on the thesis rig's walkway, or
/// `None` when the data is absent outside CI.
fn mocap_lap(file: &str) -> Option<MotionClip> {
    let path = trigait_test_data::shared_file(file)?;
    Some(Turns::Spun.lap(&trigait_motion::load_motion(&path).unwrap()))
}

/// The walker's lap and both mocap laps turning as `turns` says, named, or `None` when the
/// data is absent outside CI.
pub(super) fn all_laps(turns: Turns) -> Option<Vec<(String, MotionClip)>> {
    let mut laps = vec![("walker".to_string(), turns.lap(&walk()))];
    for file in MOCAP_WALKS {
        let path = trigait_test_data::shared_file(file)?;
        let clip = trigait_motion::load_motion(&path).unwrap();
        laps.push((file.to_string(), turns.lap(&clip)));
    }
    Some(laps)
}

/// Real walks played through the renderer: CMU 07_01 and the OpenSim Rajagopal walk (joint
/// centres from their markers), each there and back on the walkway of the thesis rig, 10 s.
/// The goal is the walker's: ≤ 4 cm median per joint class on every sensor, no swap; both are
/// met. Measured (median hip / knee / ankle; swapped frames of 300): CMU 07_01 k1 3.1 / 2.9 /
/// 3.5 cm, 0; k2 3.4 / 3.3 / 3.3 cm, 0; k3 3.5 / 2.8 / 3.2 cm, 0. Rajagopal k1 3.0 / 2.7 / 2.8
/// cm, 0; k2 2.6 / 2.6 / 3.1 cm, 0; k3 3.3 / 2.6 / 2.8 cm, 0; feet (median) 5.6–5.7 cm (CMU),
/// 8.1–8.3 cm (Rajagopal). The hips were 4.4–4.5 cm off on Rajagopal while they sat at a share
/// of the stature; the hip height is now found from the walk, within 2 cm of the rendered one
/// ([`HIP_HEIGHT_M`]). The renderer and the tracker are deterministic, so the test pins that
/// state (≤ 5.5 cm, no swapped frame, feet ≤ 9 cm) and prints where the
/// goal is missed; [`swapped_frames_over_noise_seeds`] counts the swaps over other draws of the
/// sensor noise.
#[test]
fn mocap_walks_through_the_renderer() {
    let (mut failures, mut missed) = (Vec::new(), Vec::new());
    for file in MOCAP_WALKS {
        let Some(lap) = mocap_lap(file) else {
            return;
        };
        for s in score_on_the_thesis_rig(&lap, Turns::Spun, 10.0, NOISE_SEED) {
            for (m, what) in s.medians.iter().zip(["hip", "knee", "ankle"]) {
                let line = format!("{file} {}: median {what} error {m:.3} m", s.sensor);
                if *m > 0.055 {
                    failures.push(line);
                } else if *m > 0.04 {
                    missed.push(line);
                }
            }
            if s.foot.0 > 0.09 {
                failures.push(format!(
                    "{file} {}: median foot error {:.3} m",
                    s.sensor, s.foot.0
                ));
            }
            if s.swaps > 0 {
                failures.push(format!("{file} {}: {} swapped frames", s.sensor, s.swaps));
            }
            failures.extend(hip_height_off(&s).map(|f| format!("{file} {f}")));
            if s.reported < s.asked * 8 / 10 {
                failures.push(format!(
                    "{file} {}: {} joints reported",
                    s.sensor, s.reported
                ));
            }
        }
    }
    eprintln!("goal (4 cm) missed: {missed:#?}");
    assert!(failures.is_empty(), "{failures:?}");
}

/// The walker and the two mocap walks on the thesis rig over three more draws of the sensor
/// noise (seeds 1–3; the other tests run seed 7): the frames whose legs are swapped, per walk
/// and sensor. The goal is none, and none of the 8100 frames is. The test prints each run's
/// count and medians; [`over_ten_noise_seeds`] and [`over_ten_noise_seeds_on_two_lanes`]
/// measure more.
#[test]
fn swapped_frames_over_noise_seeds() {
    let Some(laps) = all_laps(Turns::Spun) else {
        return;
    };
    let (mut total, mut frames) = (0, 0);
    for seed in 1..=3 {
        for (name, lap) in &laps {
            for s in score_on_the_thesis_rig(lap, Turns::Spun, 10.0, seed) {
                eprintln!(
                    "seed {seed} {name} {}: {} swapped frames; median hip / knee / ankle {:.3} / {:.3} / {:.3} m",
                    s.sensor, s.swaps, s.medians[0], s.medians[1], s.medians[2]
                );
                total += s.swaps;
                frames += s.asked / 6;
            }
        }
    }
    eprintln!("swapped frames over seeds 1-3: {total} of {frames}");
    assert_eq!(total, 0, "swapped frames");
}

/// The real Kinect v2 frame of a person in a room, against the SDK of the same instant.
///
/// Measured: IoU 0.841 with the SDK's body index, whose mask also holds floor speckle that no
/// depth segmentation should call the person (out to the image's sides): 3416 of the 3517
/// pixels the masks disagree on are SDK pixels within 5 cm of the floor, and over the rest of
/// the image the IoU is 0.995 (asserted ≥ 0.98); against the SDK mask's largest 8-connected
/// blob alone (19 884 of its 22 062 pixels; the rest are 104 specks) it is 0.933 (asserted ≥
/// 0.92). Joints: knees and the front ankle 5–7 cm from the SDK's, hips 15–16 cm (the SDK's
/// hips are 8–12 cm below the stature-based hip joint centre here, at 0.45–0.47 of the
/// stature), the rear ankle 28 cm. That foot is lifted behind in early swing (the colour image)
/// and is the far leg's (its depth lies 15 cm beyond the near leg's); the SDK's chains cross,
/// its right ankle is inferred and put on the floor 0.26 m from that foot, and the tracker's
/// far chain ends on the standing foot and calls that ankle tracked, so neither has the lifted
/// foot's ankle. The median of the six (the mean of the middle two) is 0.111 m, as `trigait
/// legs` reports it; over the five the SDK tracked, 0.066 m (asserted ≤ 0.075 m). The goals are
/// IoU ≥ 0.85 and a median ≤ 8 cm against the SDK's mask and skeleton as they are; this test
/// pins the measured state (IoU ≥ 0.835, median ≤ 0.12 m) so it cannot get worse unnoticed. It
/// also prints which leg each skeleton puts nearer the sensor, joint by joint: the SDK's left
/// hip is the far one and its left ankle the near one (its chains cross), and how far the SDK's
/// knees move over the next two frames.
#[test]
fn real_frame_against_the_sdk() {
    let (Some(depth), Some(mask), Some(skel)) = (
        trigait_test_data::shared_file("kinect-v2-depth-person/004378_depth.png"),
        trigait_test_data::shared_file("kinect-v2-depth-person/004378_mask.png"),
        trigait_test_data::shared_file("kinect-v2-skeleton-replay/JointsInfo_Cyrille_v2_2.txt"),
    ) else {
        return;
    };
    let frame = trigait_depth::io::read_depth_png(&depth).unwrap();
    let truth = trigait_depth::io::read_mask_png(&mask).unwrap();
    let sdk = trigait_motion::read_sdk_skeletons(&skel).unwrap();
    assert_eq!(sdk[0].frame_number, 4378);
    let mut tracker = recorded_frame_tracker();
    let out = tracker.track(&frame);
    assert_eq!(out.status, Status::Tracking, "{out:?}");
    let iou = mask_iou(&out.person_mask, truth.as_slice());
    // The same over the pixels more than 5 cm above the tracker's floor (or without depth):
    // what the two masks disagree on besides the floor.
    let floor = out.floor.unwrap();
    let camera = tracker.config().camera;
    let near_floor: Vec<bool> = (0..trigait_depth::PIXELS)
        .map(|i| {
            let z = f64::from(frame.as_mm()[i]) * 1e-3;
            let (rx, ry) = camera.ray(i % trigait_depth::WIDTH, i / trigait_depth::WIDTH);
            z > 0.0 && floor.height_m(&Point3::new(rx * z, ry * z, z)) < 0.05
        })
        .collect();
    let above =
        |m: &[bool]| -> Vec<bool> { m.iter().zip(&near_floor).map(|(m, f)| *m && !f).collect() };
    let iou_up = mask_iou(&above(&out.person_mask), &above(truth.as_slice()));
    let found_and_truth = || out.person_mask.iter().zip(truth.as_slice());
    let floor_only = found_and_truth()
        .zip(&near_floor)
        .filter(|((a, b), f)| **b && !**a && **f)
        .count();
    eprintln!(
        "IoU above the floor {iou_up:.3}; SDK person pixels within 5 cm of the floor that the tracker leaves out: {floor_only} of {}",
        found_and_truth().filter(|(a, b)| a != b).count()
    );
    assert!(iou_up >= 0.98, "IoU above the floor {iou_up:.3}");
    // The same against the SDK mask's person alone: its largest 8-connected blob, without the
    // specks of floor scattered over the image's bottom.
    let person = largest_blob(truth.as_slice());
    let iou_person = mask_iou(&out.person_mask, &person);
    eprintln!(
        "IoU against the SDK mask's largest blob ({} of its {} pixels) {iou_person:.3}",
        person.iter().filter(|p| **p).count(),
        truth.as_slice().iter().filter(|p| **p).count()
    );
    assert!(
        iou_person >= 0.92,
        "IoU against the SDK's blob {iou_person:.3}"
    );
    let mut errors = Vec::new();
    let mut errors_sdk_tracked = Vec::new();
    for j in Joint::LEGS {
        let (Some(t), Some(s)) = (out.joint(j), sdk[0].joints.iter().find(|s| s.joint == j)) else {
            continue;
        };
        let e = (t.position_in_kinect - s.position_in_kinect).norm();
        eprintln!(
            "{j:?}: tracker {:?} sdk {:?} error {e:.3} m (tracker {:?}, SDK {:?})",
            t.position_in_kinect, s.position_in_kinect, t.state, s.state
        );
        errors.push(e);
        if s.state == TrackingState::Tracked {
            errors_sdk_tracked.push(e);
        }
    }
    // Scored only where the SDK tracked the joint: the SDK infers the rear ankle, and puts it on
    // the floor where the colour image shows that foot lifted behind in early swing.
    eprintln!(
        "median error against the joints the SDK tracked ({} of 6): {:.3} m",
        errors_sdk_tracked.len(),
        median(errors_sdk_tracked.clone())
    );
    assert_eq!(errors_sdk_tracked.len(), 5);
    assert!(median(errors_sdk_tracked) <= 0.075);
    eprintln!(
        "IoU {iou:.3}, {} people, share {:.3}, floor {:?}, stature {:?}, lengths {:?}",
        out.people, out.person_share, out.floor, out.stature_m, out.segment_lengths_m
    );
    assert!(iou >= 0.835, "IoU {iou:.3}");
    assert_eq!(errors.len(), 6, "joints found: {:?}", out.joints);
    let m = median(errors);
    eprintln!("median error against the SDK {m:.3} m");
    // Which leg is nearer the sensor, joint by joint, in the SDK's skeleton and the tracker's:
    // how much farther (horizontally, along the line of sight to the mid-hip) the left joint
    // is than the right one. The SDK's left hip is the farther one and its left ankle the
    // nearer one: its chains cross between hips and ankles, where the depth shows the near leg
    // standing straight from its hip to the flat foot.
    let sdk_at = |f: &trigait_motion::SdkFrame, j: Joint| {
        f.joints
            .iter()
            .find(|x| x.joint == j)
            .map(|x| x.position_in_kinect)
    };
    let up = floor.up_in_kinect;
    let (Some(hl), Some(hr)) = (
        sdk_at(&sdk[0], Joint::HipLeft),
        sdk_at(&sdk[0], Joint::HipRight),
    ) else {
        panic!("SDK hips missing");
    };
    let sight = 0.5 * (hl.coords + hr.coords);
    let sight = (sight - up * up.dot(&sight)).normalize();
    let report = |name: &str, at: &dyn Fn(Joint) -> Option<Point3<f64>>| {
        let line: Vec<String> = [
            ("hips", Joint::HipLeft, Joint::HipRight),
            ("knees", Joint::KneeLeft, Joint::KneeRight),
            ("ankles", Joint::AnkleLeft, Joint::AnkleRight),
        ]
        .iter()
        .filter_map(|&(what, l, r)| {
            let d = sight.dot(&(at(l)? - at(r)?));
            Some(format!("{what} {:+.1} cm", 100.0 * d))
        })
        .collect();
        eprintln!("{name}: left farther than right by {}", line.join(", "));
    };
    report("SDK", &|j| sdk_at(&sdk[0], j));
    report("tracker", &|j| out.joint(j).map(|t| t.position_in_kinect));
    // The SDK's knees over the next two frames (66 ms).
    for later in &sdk[1..3] {
        let moved: Vec<String> = [Joint::KneeLeft, Joint::KneeRight]
            .iter()
            .filter_map(|&j| {
                let d = sdk_at(later, j)? - sdk_at(&sdk[0], j)?;
                Some(format!(
                    "{j:?} {:.1} cm ({:+.1} cm up)",
                    100.0 * d.norm(),
                    100.0 * up.dot(&d)
                ))
            })
            .collect();
        eprintln!(
            "SDK frame {}: knees moved {}",
            later.frame_number,
            moved.join(", ")
        );
    }
    assert!(m <= 0.12, "median {m:.3} m");
}

/// The largest 8-connected blob of a mask.
fn largest_blob(mask: &[bool]) -> Vec<bool> {
    let (w, h) = (trigait_depth::WIDTH, trigait_depth::HEIGHT);
    let mut label = vec![usize::MAX; mask.len()];
    let (mut best, mut best_n) = (usize::MAX, 0);
    for start in 0..mask.len() {
        if !mask[start] || label[start] != usize::MAX {
            continue;
        }
        label[start] = start;
        let (mut stack, mut n) = (vec![start], 0);
        while let Some(i) = stack.pop() {
            n += 1;
            let (u, v) = ((i % w) as i64, (i / w) as i64);
            for (du, dv) in [
                (-1, -1),
                (0, -1),
                (1, -1),
                (-1, 0),
                (1, 0),
                (-1, 1),
                (0, 1),
                (1, 1),
            ] {
                let (x, y) = (u + du, v + dv);
                if (0..w as i64).contains(&x) && (0..h as i64).contains(&y) {
                    let k = y as usize * w + x as usize;
                    if mask[k] && label[k] == usize::MAX {
                        label[k] = start;
                        stack.push(k);
                    }
                }
            }
        }
        if n > best_n {
            (best, best_n) = (start, n);
        }
    }
    label.iter().map(|l| best_n > 0 && *l == best).collect()
}

fn thesis_k1() -> Isometry3<f64> {
    Rig::builtin("thesis").unwrap().sensors[0].world_from_kinect
}

/// Frames without a person give clear states and counts and never panic: all zeros, the empty
/// room (with the floor given and fitted), two people, a person walking out of the view, a
/// person standing too close for the head to be seen.
#[test]
fn robustness() {
    let pose = thesis_k1();
    let mut tracker = LegTracker::new(config_for(&pose)).unwrap();
    let out = tracker.track(&DepthFrame::zeros());
    assert_eq!(
        (out.status, out.people, out.valid_pixels),
        (Status::NoData, 0, 0)
    );
    assert!(out.joints.is_empty());

    let mut renderer = Renderer::new(RenderParams::default(), &pose, &Room::default()).unwrap();
    let room = renderer.render_bodies(&[], Vec::new());
    let out = tracker.track(&room.depth);
    assert_eq!((out.status, out.people), (Status::Nobody, 0));
    let mut fitted = LegTracker::new(TrackerConfig::default()).unwrap();
    let out = fitted.track(&room.depth);
    assert_eq!((out.status, out.people), (Status::Nobody, 0), "{out:?}");
    let floor = out.floor.unwrap();
    let given = Floor::from_pose(&pose).unwrap();
    assert!(floor.up_in_kinect.angle(&given.up_in_kinect) < 2f64.to_radians());
    assert!((floor.camera_height_m - given.camera_height_m).abs() < 0.03);

    // Two people side by side on the walkway.
    let clip = walker(&WalkerParams::default(), 1.0, 30.0).unwrap();
    let shape = BodyShape::default();
    let bodies: Vec<Body> = [-0.8, 0.6]
        .iter()
        .map(|y| {
            let moved = clip.transformed(&Isometry3::translation(-0.5, *y, 0.0));
            Body::from_joints(&shape, |j| moved.position(10, j)).unwrap()
        })
        .collect();
    let two = renderer.render_bodies(&bodies, Vec::new());
    let mut t2 = LegTracker::new(config_for(&pose)).unwrap();
    let out = t2.track(&two.depth);
    assert_eq!(
        (out.status, out.people),
        (Status::Tracking, 2),
        "{:?}",
        (out.status, out.people)
    );

    // Walking out of the view: straight on towards k3 and past it, 6 s.
    let k3 = Rig::builtin("thesis").unwrap().sensors[2].world_from_kinect;
    let mut renderer = Renderer::new(RenderParams::default(), &k3, &Room::default()).unwrap();
    let long = walker(&WalkerParams::default(), 6.0, 15.0).unwrap();
    let long = long.transformed(&Isometry3::translation(-2.0, 0.0, 0.0));
    let mut t3 = LegTracker::new(config_for(&k3)).unwrap();
    let mut states = std::collections::BTreeMap::new();
    for f in 0..long.frame_count() {
        let r = renderer
            .render_pose(&shape, |j| long.position(f, j))
            .unwrap();
        let out = t3.track(&r.depth);
        *states.entry(format!("{:?}", out.status)).or_insert(0) += 1;
        for j in &out.joints {
            assert!(j.position_in_kinect.coords.iter().all(|v| v.is_finite()));
            assert!((0.0..=1.0).contains(&j.confidence));
        }
    }
    eprintln!("walking out of view: {states:?}");
    assert!(
        states.get("Nobody").copied().unwrap_or(0) > 10,
        "{states:?}"
    );
    assert!(
        states.get("TooClose").copied().unwrap_or(0) > 0,
        "{states:?}"
    );
    assert!(
        states.get("Tracking").copied().unwrap_or(0) > 10,
        "{states:?}"
    );

    // Standing close to k3 from the start, the head out of view: no stature to size the legs
    // from, said as such, and no joints guessed.
    let near = lap();
    let mut renderer = seeded_renderer(&k3, 3);
    let mut t4 = LegTracker::new(config_for(&k3)).unwrap();
    for _ in 0..10 {
        let r = renderer
            .render_pose(&shape, |j| near.position_at(j, 3.9))
            .unwrap();
        let out = t4.track(&r.depth);
        assert_eq!((out.status, out.people), (Status::NoStature, 1), "{out:?}");
        assert!(out.joints.is_empty() && out.stature_m.is_none());
    }

    // Garbage: a random-looking frame.
    let mut junk = DepthFrame::zeros();
    for (i, v) in junk.as_mm_mut().iter_mut().enumerate() {
        *v = ((i * 7919) % 9000) as u16;
    }
    let out = tracker.track(&junk);
    assert!(matches!(
        out.status,
        Status::Nobody
            | Status::Tracking
            | Status::NoFloor
            | Status::NoStature
            | Status::NotStanding
    ));
}

/// Adds the frame's hip, knee and ankle errors against the rendered joint centres to
/// `errors` (one list per class), for the joints both report.
fn push_leg_errors(
    out: &TrackedFrame,
    truth: &trigait_body_render::Rendered,
    errors: &mut [Vec<f64>; 3],
) {
    let pairs = [
        [Joint::HipLeft, Joint::HipRight],
        [Joint::KneeLeft, Joint::KneeRight],
        [Joint::AnkleLeft, Joint::AnkleRight],
    ];
    for (class, pair) in pairs.iter().enumerate() {
        for j in pair {
            if let (Some(t), Some(g)) = (out.joint(*j), truth.joint(*j)) {
                errors[class].push((t.position_in_kinect - g).norm());
            }
        }
    }
}

/// A sensor knocked during a walk (its tripod 5 cm lower, tilted 2° down) sees the floor off the
/// plane it held: 5 cm above it and, 3 m out, 15 cm, so the person merged with the floor and
/// was `Nobody` on every frame for the rest of the walk, with the floor fitted as with the
/// rig's. Now the tracker fits the floor afresh half a second after the knock and tracks the
/// walker again. On every sensor of the thesis rig, with the floor fitted and with the rig's:
/// no fresh floor before the knock (at 3 s, the body learned by then), one after it, within
/// 0.6 s, and the body kept (the same walker); from 1 s after the knock on, the hips, knees and
/// ankles (at least 100 of each class) are within 4 cm (median per class) of the rendered
/// joint centres, away from the lap's instant turns.
#[test]
fn a_knocked_sensor_finds_its_floor_again() {
    const KNOCK: usize = 90;
    const FRAMES: usize = 240;
    let lap = lap();
    let mut failures = Vec::new();
    for sensor in &Rig::builtin("thesis").unwrap().sensors {
        let before = sensor.world_from_kinect;
        let knocked = nalgebra::Translation3::new(0.0, 0.0, -0.05)
            * before
            * nalgebra::UnitQuaternion::from_axis_angle(
                &nalgebra::Vector3::x_axis(),
                2f64.to_radians(),
            );
        let mut trackers = [
            (
                "fitted",
                LegTracker::new(TrackerConfig {
                    floor: None,
                    ..config_for(&before)
                })
                .unwrap(),
            ),
            ("rig", LegTracker::new(config_for(&before)).unwrap()),
        ];
        let mut renderers = [
            seeded_renderer(&before, NOISE_SEED),
            seeded_renderer(&knocked, NOISE_SEED),
        ];
        let mut refits: [Vec<usize>; 2] = Default::default();
        let mut relearned = [false; 2];
        let mut errors: [[Vec<f64>; 3]; 2] = Default::default();
        for f in 0..FRAMES {
            let t = f as f64 / RATE_HZ;
            let renderer = &mut renderers[usize::from(f >= KNOCK)];
            let Ok(r) = renderer.render_pose(&BodyShape::default(), |j| {
                lap.position_at(j, t % lap.duration_secs())
            }) else {
                continue;
            };
            for (k, (_, tracker)) in trackers.iter_mut().enumerate() {
                let out = tracker.track(&r.depth);
                if out.floor_refitted {
                    refits[k].push(f);
                }
                relearned[k] |= out.body_relearned;
                if f < KNOCK + 30 || near_turn(t, lap.duration_secs()) {
                    continue;
                }
                push_leg_errors(&out, &r, &mut errors[k]);
            }
        }
        for (k, (floor, _)) in trackers.iter().enumerate() {
            let medians: Vec<f64> = errors[k].iter().map(|e| median(e.clone())).collect();
            eprintln!(
                "{} ({floor} floor): floor fitted afresh at frames {:?} (knocked at {KNOCK}); after, median hip / knee / ankle {:.3?} m over {} joints",
                sensor.id,
                refits[k],
                medians,
                errors[k].iter().map(Vec::len).sum::<usize>()
            );
            if relearned[k] {
                failures.push(format!("{} {floor}: body learned afresh", sensor.id));
            }
            if refits[k].len() != 1 || !(KNOCK..KNOCK + 18).contains(&refits[k][0]) {
                failures.push(format!("{} {floor}: refits {:?}", sensor.id, refits[k]));
            }
            if errors[k].iter().any(|e| e.len() < 100)
                || medians.iter().any(|m| m.is_nan() || *m > 0.04)
            {
                failures.push(format!("{} {floor}: medians {medians:.3?}", sensor.id));
            }
        }
    }
    assert!(failures.is_empty(), "{failures:?}");
}

/// The walker at the walkway's end, 0.55-0.8 m from k3 with its legs below the knees out of
/// the image, is said to be too close, not absent; the empty room stays `Nobody`.
#[test]
fn someone_too_close_for_their_feet_is_said_so() {
    let clip = lap();
    let k3 = Rig::builtin("thesis").unwrap().sensors[2].world_from_kinect;
    let mut renderer = seeded_renderer(&k3, 5);
    let mut tracker = LegTracker::new(config_for(&k3)).unwrap();
    for t in [2.8, 2.9, 3.0, 3.1] {
        let r = renderer
            .render_pose(&BodyShape::default(), |j| clip.position_at(j, t))
            .unwrap();
        let out = tracker.track(&r.depth);
        assert_eq!((out.status, out.people), (Status::TooClose, 0), "at {t} s");
        assert!(out.joints.is_empty());
    }
    let room = renderer.render_bodies(&[], Vec::new());
    assert_eq!(tracker.track(&room.depth).status, Status::Nobody);
}

/// People standing close to a sensor hide its floor, but the floor stays where it was. A
/// sensor a metre up looking level (as real rigs stand), where k1 stands and looks: the empty
/// room, then someone a metre ahead for a second, then five people side by side 0.85 m ahead
/// for three seconds, with the floor fitted and with the rig's. The one person hides a sixth
/// of the floor's share of the lower image (0.65 of 0.78) and the floor is not doubted;
/// the five hide more than half (0.36), the floor is doubted on every frame of the three seconds (a
/// fresh one is fitted every half second of it), and none is taken: it lies where the old one
/// does.
#[test]
fn people_hiding_the_floor_leave_it_in_place() {
    let clip = lap();
    let k1 = Rig::builtin("thesis").unwrap().sensors[0].world_from_kinect;
    let ahead = {
        let f = k1.rotation * nalgebra::Vector3::z();
        nalgebra::Vector3::new(f.x, f.y, 0.0).normalize()
    };
    // Camera x left, y up, z ahead.
    let left = nalgebra::Vector3::z().cross(&ahead);
    let level = nalgebra::Matrix3::from_columns(&[left, nalgebra::Vector3::z(), ahead]);
    let at = nalgebra::Vector3::new(k1.translation.vector.x, k1.translation.vector.y, 1.0);
    let pose = Isometry3::from_parts(
        at.into(),
        nalgebra::UnitQuaternion::from_rotation_matrix(
            &nalgebra::Rotation3::from_matrix_unchecked(level),
        ),
    );
    let pelvis = clip.position_at(Joint::SpineBase, 1.0).unwrap();
    // `count` people side by side, 0.5 m apart, `metres` ahead of the sensor.
    let people = |count: usize, metres: f64| -> Vec<Body> {
        (0..count)
            .map(|k| {
                let off = at + ahead * metres - pelvis.coords
                    + left * (0.5 * (k as f64 - (count as f64 - 1.0) / 2.0));
                let off = nalgebra::Vector3::new(off.x, off.y, 0.0);
                Body::from_joints(&BodyShape::default(), |j| {
                    clip.position_at(j, 1.0).map(|p| p + off)
                })
                .unwrap()
            })
            .collect()
    };
    let (one, five) = (people(1, 1.0), people(5, 0.85));
    let mut renderer = seeded_renderer(&pose, 5);
    for (floor, config) in [
        (
            "fitted",
            TrackerConfig {
                floor: None,
                ..config_for(&pose)
            },
        ),
        ("rig", config_for(&pose)),
    ] {
        let mut tracker = LegTracker::new(config).unwrap();
        for _ in 0..5 {
            let room = renderer.render_bodies(&[], Vec::new());
            assert_eq!(tracker.track(&room.depth).status, Status::Nobody);
        }
        let (mut doubted, mut shares) = ([0, 0], [f64::NAN; 2]);
        for (k, (bodies, frames)) in [(&one, 30), (&five, 90)].into_iter().enumerate() {
            for _ in 0..frames {
                let depth = renderer.render_bodies(bodies, Vec::new()).depth;
                let out = tracker.track(&depth);
                assert!(!out.floor_refitted, "{floor} floor: fitted afresh");
                doubted[k] = doubted[k].max(out.floor_doubted_frames);
                let cloud = segment::back_project(&depth, &tracker.config.camera, &tracker.rays);
                shares[k] = out
                    .floor
                    .and_then(|f| segment::floor_share(&segment::heights(&cloud, &f), 0.02))
                    .unwrap_or(f64::NAN);
            }
        }
        eprintln!(
            "{floor} floor: doubted for up to {doubted:?} frames in a row (one person, five); share of the lower image on the floor {shares:.2?}, at most {:.2?}",
            tracker.floor_support
        );
        assert_eq!(doubted[0], 0, "{floor} floor");
        assert!(doubted[1] == 90, "{floor} floor: {doubted:?}");
    }
}

/// Someone else walking in after the person the body was learned from is measured afresh: on
/// each thesis sensor, the walker (1.75 m) walks for 10 s, nobody is there for a second, then a
/// walker of 1.55 m walks from the lap's start for 6 s. It is found to be someone else (its
/// body learned afresh once, within a second), and from 3 s after it walked in its hips, knees
/// and ankles are within 4 cm (median per class, at least 100 of each) of its rendered joint
/// centres, away from the lap's instant turns. The same 1.75 m walker coming back instead is
/// not learned afresh. With the body held from the first walker, the short one's hips were
/// 4.6–11.1 cm off and its knees 3.1–6.6 cm (2.3–3.1 and 2.0–2.3 cm learned afresh).
#[test]
fn someone_else_walking_in_is_measured_afresh() {
    const FIRST: usize = 300;
    const GAP: usize = 30;
    let first = lap();
    let short = Turns::Spun.lap(&walker(&WalkerParams::for_height(1.55), 3.0, 100.0).unwrap());
    let mut failures = Vec::new();
    for sensor in &Rig::builtin("thesis").unwrap().sensors {
        let pose = sensor.world_from_kinect;
        for (who, next, frames) in [
            ("a 1.55 m walker", &short, 180),
            ("the same walker", &first, 60),
        ] {
            let mut renderer = seeded_renderer(&pose, NOISE_SEED);
            let mut tracker = LegTracker::new(config_for(&pose)).unwrap();
            let mut relearned = Vec::new();
            let mut errors: [Vec<f64>; 3] = Default::default();
            for f in 0..FIRST + GAP + frames {
                let (clip, t) = if f < FIRST {
                    (Some(&first), f as f64 / RATE_HZ)
                } else if f < FIRST + GAP {
                    (None, 0.0)
                } else {
                    (Some(next), (f - FIRST - GAP) as f64 / RATE_HZ)
                };
                let r = match clip {
                    Some(c) => renderer
                        .render_pose(&BodyShape::default(), |j| {
                            c.position_at(j, t % c.duration_secs())
                        })
                        .unwrap(),
                    None => renderer.render_bodies(&[], Vec::new()),
                };
                let out = tracker.track(&r.depth);
                if out.body_relearned {
                    relearned.push(f);
                }
                let Some(c) = clip.filter(|_| f >= FIRST + GAP + 90) else {
                    continue;
                };
                if near_turn(t, c.duration_secs()) {
                    continue;
                }
                push_leg_errors(&out, &r, &mut errors);
            }
            let medians: Vec<f64> = errors.iter().map(|e| median(e.clone())).collect();
            eprintln!(
                "{} then {who}: body learned afresh at frames {relearned:?} (walked in at {}); its median hip / knee / ankle {medians:.3?} m, hip height in use {:?}",
                sensor.id,
                FIRST + GAP,
                tracker.hip_height(tracker.held.map_or(0.0, |h| h.0))
            );
            // The check was made (ten tops of the one found again taken), whatever it found.
            if tracker.recheck.is_some() {
                failures.push(format!("{} {who}: stature never checked", sensor.id));
            }
            let expected = std::ptr::eq(next, &short);
            let in_time =
                relearned.len() == 1 && (FIRST + GAP..FIRST + GAP + 30).contains(&relearned[0]);
            if expected != in_time || !expected && !relearned.is_empty() {
                failures.push(format!(
                    "{} {who}: learned afresh at {relearned:?}",
                    sensor.id
                ));
            }
            if expected
                && (errors.iter().any(|e| e.len() < 100)
                    || medians.iter().any(|m| m.is_nan() || *m > 0.04))
            {
                failures.push(format!("{} {who}: medians {medians:.3?}", sensor.id));
            }
        }
    }
    assert!(failures.is_empty(), "{failures:?}");
}

/// A person rising from a chair, as at the start of a Timed-Up-and-Go, in world coordinates
/// at `t` seconds: seated for `seated` s (hip joint centres 0.50 m up, thighs nearly level, shanks
/// upright over the ankles), rising over 1.5 s (the hips move forward over the feet while the
/// trunk leans forward up to 40°, then lift as the knees extend, the feet staying put), then
/// standing upright. The legs keep the walker's segment lengths (each knee placed by two-link
/// inverse kinematics between its hip and its ankle); `at` is the seat's spot on the floor and
/// `forward` the way the person faces. No chair is rendered.
fn rising_from_a_chair(
    p: &WalkerParams,
    lean_deg: f64,
    at: Point3<f64>,
    forward: nalgebra::Vector3<f64>,
    seated: f64,
    t: f64,
) -> impl Fn(Joint) -> Option<Point3<f64>> {
    let up = nalgebra::Vector3::z();
    let left = up.cross(&forward);
    let (thigh, shank, ankle_h) = (p.thigh_m, p.shank_m, p.ankle_height_m);
    let smooth = |x: f64| {
        let x = x.clamp(0.0, 1.0);
        x * x * (3.0 - 2.0 * x)
    };
    let s = ((t - seated) / 1.5).clamp(0.0, 1.0);
    // Ankles under the seated knees; the hips end over them, the knees bent by about 17°.
    let ahead = thigh;
    let along = ahead * smooth(s / 0.6);
    let height = 0.50 + (ankle_h + thigh + shank - 0.01 - 0.50) * smooth((s - 0.25) / 0.75);
    // A smooth bump: no jump in the trunk's angular velocity at its start or end.
    let lean = lean_deg.to_radians() * (std::f64::consts::PI * (s / 0.8).min(1.0)).sin().powi(2);
    let pelvis = at + forward * along + up * height;
    // Pelvis to the base of the neck, as the body is drawn for the walker (which has no
    // `SpineShoulder`).
    let trunk = BodyShape::default().torso_length * thigh;
    let joints: Vec<(Joint, Point3<f64>)> = [
        (
            1.0,
            Joint::HipLeft,
            Joint::KneeLeft,
            Joint::AnkleLeft,
            Joint::FootLeft,
        ),
        (
            -1.0,
            Joint::HipRight,
            Joint::KneeRight,
            Joint::AnkleRight,
            Joint::FootRight,
        ),
    ]
    .iter()
    .flat_map(|&(side, hj, kj, aj, fj)| {
        let hip = pelvis + left * (side * 0.5 * p.hip_width_m);
        let ankle = at + forward * ahead + left * (side * 0.6 * p.hip_width_m) + up * ankle_h;
        // The knee: at `thigh` from the hip and `shank` from the ankle, ahead of the line
        // between them.
        let d = ankle - hip;
        let n = d.norm().min(thigh + shank - 1e-6);
        let a = (thigh * thigh - shank * shank + n * n) / (2.0 * n);
        let h = (thigh * thigh - a * a).max(0.0).sqrt();
        let dir = d / d.norm();
        let out = (forward - dir * dir.dot(&forward)).normalize();
        let knee = hip + dir * a + out * h;
        let foot = ankle + forward * (0.086 * p.height_m) - up * (0.5 * ankle_h);
        [(hj, hip), (kj, knee), (aj, ankle), (fj, foot)]
    })
    .chain([
        (Joint::SpineBase, pelvis),
        (
            Joint::SpineShoulder,
            pelvis + (forward * lean.sin() + up * lean.cos()) * trunk,
        ),
    ])
    .collect();
    move |j| joints.iter().find(|(k, _)| *k == j).map(|(_, p)| *p)
}

/// Someone seated when the tracker starts, who then stands up, is measured as they stand: a
/// tall person seated for 3 s (no chair rendered), rising over 1.5 s, then standing still for
/// 4 s ([`rising_from_a_chair`], on the walkway where the walker is 1.5 s into its lap, facing
/// its way), 1.95 m tall leaning 40° forward to rise and 2.0 m leaning 20°. Seated, the top of
/// the head is 1.38–1.40 m up, person-like.
///
/// As the tracker runs, the seated frames are [`Status::NotStanding`] on every sensor (their
/// thighs reach out from under the trunk), with no joint, and nothing of the body is learned
/// from them; the stature is learned once the rising head stops rising. On k1 and k2 no body is
/// learned afresh, the stature held is within 6 cm of the person's height (the top of the
/// rendered head lies 5 cm under it), and over the last 2 s the hips are within 5 cm of the
/// rendered joint centres (median; measured 3.9–4.0 cm: standing still, the hip sits at the
/// anthropometric 0.52 of the stature, about 4 cm under the rendered body's), the knees within
/// 2.5 cm and the ankles within 4 cm (1.6–1.9 and 1.2–1.3 cm; the stature learned while the
/// head still rose had been 7 cm short and the knees 3.6–3.7 cm off). k3 sees the
/// standing person's head above its image, never the whole standing person, and reports no
/// joint at all rather than legs sized from a seated stature (hips 0.24–0.33 m off before).
///
/// With the posture not judged (`not_standing_share` above 1), the seated body is learned, and
/// the watches on the stature catch the standing person instead: on k1 and k2 the body is
/// learned afresh once as they stand, with the same goals (measured 3.9–4.0, 1.8–2.5 and
/// 1.2–1.3 cm). Leaning 40°, the head dips under a person's height, the person is lost and
/// found again taller; leaning 20°, nobody grows tells: a second of standing 10 cm taller than
/// the held stature (without either, the seated body was kept, and the standing hips were
/// 0.32–0.38 m off, the knees 0.19–0.28 m).
#[test]
fn someone_who_stands_up_is_measured_afresh() {
    const SEATED: f64 = 3.0;
    const FRAMES: usize = 255;
    let clip = lap();
    let at = {
        let p = clip.position_at(Joint::SpineBase, 1.5).unwrap();
        Point3::new(p.x, p.y, 0.0)
    };
    let forward = {
        let d = clip.position_at(Joint::SpineBase, 1.6).unwrap()
            - clip.position_at(Joint::SpineBase, 1.4).unwrap();
        nalgebra::Vector3::new(d.x, d.y, 0.0).normalize()
    };
    let mut failures = Vec::new();
    for posture in [true, false] {
        for (height, lean) in [(1.95, 40.0), (2.0, 20.0)] {
            let person = WalkerParams::for_height(height);
            for sensor in &Rig::builtin("thesis").unwrap().sensors {
                let pose = sensor.world_from_kinect;
                let mut renderer = seeded_renderer(&pose, NOISE_SEED);
                let mut tracker = LegTracker::new(TrackerConfig {
                    not_standing_share: if posture { 0.2 } else { 2.0 },
                    ..config_for(&pose)
                })
                .unwrap();
                let (mut relearned, mut seated_stature) = (Vec::new(), None);
                let (mut seated_statuses, mut seated_joints) = (Vec::new(), 0);
                let mut reported = 0;
                let mut errors: [Vec<f64>; 3] = Default::default();
                for f in 0..FRAMES {
                    let t = f as f64 / RATE_HZ;
                    let r = renderer
                        .render_pose(
                            &BodyShape::default(),
                            rising_from_a_chair(&person, lean, at, forward, SEATED, t),
                        )
                        .unwrap();
                    let out = tracker.track(&r.depth);
                    reported += out.joints.len();
                    if out.body_relearned {
                        relearned.push(f);
                    }
                    if f < 90 {
                        if !seated_statuses.contains(&out.status) {
                            seated_statuses.push(out.status);
                        }
                        seated_joints += out.joints.len();
                    }
                    if f < 100 && out.lengths_held {
                        seated_stature = out.stature_m;
                    }
                    if f + 60 < FRAMES {
                        continue;
                    }
                    push_leg_errors(&out, &r, &mut errors);
                }
                let medians: Vec<f64> = errors.iter().map(|e| median(e.clone())).collect();
                let stature = tracker.held.map(|h| h.0);
                eprintln!(
                    "{} ({height} m, leaning {lean}°, posture judged {posture}): seated {seated_statuses:?}, {seated_joints} joints, held {seated_stature:.2?} m; body learned afresh at frames {relearned:?} (rising over 90-135); standing, median hip / knee / ankle {medians:.3?} m, stature {stature:.2?} m; {reported} joints in all",
                    sensor.id,
                );
                let who = format!("{} ({height} m, posture judged {posture})", sensor.id);
                if posture {
                    let person_statuses = seated_statuses
                        .iter()
                        .filter(|s| **s != Status::Nobody)
                        .collect::<Vec<_>>();
                    if seated_joints > 0 || person_statuses != [&Status::NotStanding] {
                        failures.push(format!(
                            "{who}: seated {seated_statuses:?}, {seated_joints} joints"
                        ));
                    }
                }
                if sensor.id == "k3" {
                    if posture && reported > 0 {
                        failures.push(format!("{who}: {reported} joints"));
                    }
                    continue;
                }
                if posture {
                    if !relearned.is_empty() || stature.is_none_or(|s| (s - height).abs() > 0.06) {
                        failures.push(format!(
                            "{who}: learned afresh at {relearned:?}, stature {stature:?}"
                        ));
                    }
                } else {
                    if seated_stature.is_none_or(|s| s > 1.5) {
                        failures.push(format!("{who}: seated, held {seated_stature:?}"));
                    }
                    if relearned.len() != 1 || !(90..150).contains(&relearned[0]) {
                        failures.push(format!("{who}: learned afresh at {relearned:?}"));
                    }
                }
                // Judged, the knees are held to 2.5 cm: learned while the head still rose,
                // the stature had come out 7 cm short and the knees 3.6–3.7 cm off.
                let goals = [0.05, if posture { 0.025 } else { 0.04 }, 0.04];
                if errors.iter().any(|e| e.len() < 60)
                    || medians.iter().zip(goals).any(|(m, g)| m.is_nan() || *m > g)
                {
                    failures.push(format!("{who}: medians {medians:.3?}"));
                }
            }
        }
    }
    assert!(failures.is_empty(), "{failures:?}");
}

/// Someone who stands up and walks off at once, as in a Timed-Up-and-Go: seated for 2 s, rising
/// over 1.5 s ([`rising_from_a_chair`], leaning 30°), then walking the walker's lap (the same
/// body, 1.85 m, its pelvis taking over where the rise left it; the legs jump from standing
/// straight into the walk's stride within a frame, harsher than a real first step). The seat is
/// at the walkway's start, at k1's image edge, where k1 sees only the legs and the seat height
/// (1.0 m, which had been learned as the stature, and legs sized from it reported for a second,
/// until nobody-grows caught it). The stature waits for the rise to stop, which the head's bob
/// while walking must not hide: on k1 and k2 no stature is ever reported more than 8 cm from
/// the height, and over the last 1.5 s of the walk joints are reported in 80 % of the frames or
/// more, the hips, knees and ankles within 5, 4 and 4 cm (median; measured 3.5, 2.5–2.9 and
/// 1.8 cm), and the stature within 6 cm of the height.
#[test]
fn someone_who_stands_up_and_walks_off_is_tracked() {
    const SEATED: f64 = 2.0;
    const RISEN: f64 = SEATED + 1.5;
    const WALK_FROM: f64 = 0.2;
    const WALK_SECS: f64 = 2.7;
    let height = 1.85;
    let person = WalkerParams::for_height(height);
    let lap = Turns::Spun.lap(&walker(&person, 3.0, 100.0).unwrap());
    let spine = |t: f64| lap.position_at(Joint::SpineBase, t).unwrap();
    let forward = {
        let d = spine(WALK_FROM + 0.1) - spine(WALK_FROM);
        nalgebra::Vector3::new(d.x, d.y, 0.0).normalize()
    };
    let at = {
        let p = spine(WALK_FROM) - forward * person.thigh_m;
        Point3::new(p.x, p.y, 0.0)
    };
    let frames = ((RISEN + WALK_SECS) * RATE_HZ) as usize;
    let mut failures = Vec::new();
    for sensor in &Rig::builtin("thesis").unwrap().sensors[..2] {
        let pose = sensor.world_from_kinect;
        let mut renderer = seeded_renderer(&pose, NOISE_SEED);
        let mut tracker = LegTracker::new(config_for(&pose)).unwrap();
        let mut errors: [Vec<f64>; 3] = Default::default();
        let (mut scored, mut with_joints) = (0, 0);
        let mut first_stature = None;
        for f in 0..frames {
            let t = f as f64 / RATE_HZ;
            let r = if t < RISEN {
                renderer.render_pose(
                    &BodyShape::default(),
                    rising_from_a_chair(&person, 30.0, at, forward, SEATED, t),
                )
            } else {
                renderer.render_pose(&BodyShape::default(), |j| {
                    lap.position_at(j, WALK_FROM + t - RISEN)
                })
            }
            .unwrap();
            let out = tracker.track(&r.depth);
            if first_stature.is_none() && out.stature_m.is_some() {
                first_stature = Some(f);
            }
            if let Some(s) = out.stature_m.filter(|s| (s - height).abs() > 0.08) {
                failures.push(format!("{} frame {f}: stature {s:.3} m", sensor.id));
            }
            if t < RISEN + WALK_SECS - 1.5 {
                continue;
            }
            scored += 1;
            with_joints += usize::from(!out.joints.is_empty());
            push_leg_errors(&out, &r, &mut errors);
        }
        let medians: Vec<f64> = errors.iter().map(|e| median(e.clone())).collect();
        let stature = tracker.stature();
        eprintln!(
            "{}: stature from frame {first_stature:?} (risen at {}), {stature:.3?} m; walking, joints in {with_joints} of {scored} frames, median hip / knee / ankle {medians:.3?} m",
            sensor.id,
            (RISEN * RATE_HZ) as usize
        );
        if with_joints * 10 < scored * 8
            || medians
                .iter()
                .zip([0.05, 0.04, 0.04])
                .any(|(m, g)| m.is_nan() || *m > g)
            || stature.is_none_or(|s| (s - height).abs() > 0.06)
        {
            failures.push(format!(
                "{}: {with_joints} of {scored} frames, medians {medians:.3?}, stature {stature:?}",
                sensor.id
            ));
        }
    }
    assert!(failures.is_empty(), "{failures:?}");
}

/// A real seated person is not taken for a standing one: a cellist on a stool seen by the ten
/// Kinects of the CMU Panoptic studio at one instant (`171026_cello3`), each view tracked on its
/// own as `trigait legs --separately` does. Before the posture was judged, six of the eight views
/// with a person came out as standing legs, every joint tracked with confidence 1 (hips on the
/// cello, knees on the stool); now every one is [`Status::NotStanding`] with no joint (the share
/// reaching out at thigh height: 0.37–0.85). The standing person of frame 004378 is tracked.
#[test]
fn a_real_seated_person_is_not_standing() {
    let mut shares = Vec::new();
    for i in 0..10 {
        let Some(path) = trigait_test_data::shared_file(&format!(
            "kinect-v2-panoptic-10-sensors/depth_{i:05}.png"
        )) else {
            return;
        };
        let frame = trigait_depth::io::read_depth_png(&path).unwrap();
        let out = recorded_frame_tracker().track(&frame);
        if out.status == Status::Nobody {
            continue;
        }
        assert_eq!(out.status, Status::NotStanding, "view {i}: {out:?}");
        assert!(out.joints.is_empty(), "view {i}");
        shares.push(out.reaching_share.unwrap());
    }
    eprintln!(
        "cellist: {} views with a person, reaching shares {shares:.2?}",
        shares.len()
    );
    assert!(shares.len() >= 8, "{shares:?}");
    let Some(path) = trigait_test_data::shared_file("kinect-v2-depth-person/004378_depth.png")
    else {
        return;
    };
    let out = recorded_frame_tracker().track(&trigait_depth::io::read_depth_png(&path).unwrap());
    assert_eq!(out.status, Status::Tracking);
    assert!(
        out.reaching_share.is_some_and(|s| s < 0.05),
        "{:?}",
        out.reaching_share
    );
}

/// Parameters out of range are errors.
#[test]
fn bad_config() {
    let bad = TrackerConfig {
        hip_height_ratio: 1.5,
        ..TrackerConfig::default()
    };
    assert!(matches!(
        LegTracker::new(bad),
        Err(Error::BadParameter {
            name: "hip_height_ratio",
            ..
        })
    ));
    let _ = Point3::<f64>::origin();
}

/// The `Foot` joint from a foot's visible points: a box 26 cm long from 5 cm behind the ankle,
/// 9 cm wide, from 6.8 cm below the ankle to 1 cm above it, seen on its top and one side,
/// flat and pitched toe-down by 40° about the ankle (heel off), with the second metatarsal
/// head 14.6 cm ahead of the ankle and 3.4 cm below it. The joint is placed at the model's
/// 0.15 m from the ankle, within 2.5 cm of the head (measured 0.3 cm flat; 2.3 cm pitched, where
/// the top of the foot, above the head, comes below the ankle and into view); too few points
/// give none.
#[test]
fn foot_joint_from_the_forefoot_points() {
    use nalgebra::{Rotation3, Vector2, Vector3};
    let ff = legs::FloorFrame::new(Vector3::y(), 1.0);
    let ankle_h = 0.068;
    let ankle = ff.join(&Vector2::new(3.0, 0.2), ankle_h);
    // Forward: horizontal, across the view (camera x).
    let forward = Vector3::x();
    let lateral = ff.up.cross(&forward);
    let length = 0.15;
    for pitch_deg in [0.0_f64, 40.0] {
        let pitch = Rotation3::from_axis_angle(
            &nalgebra::Unit::new_normalize(lateral),
            pitch_deg.to_radians(),
        );
        // Foot frame (forward, up, lateral) → camera space, about the ankle.
        let place = |f: f64, u: f64, l: f64| -> (Vector2<f64>, f64) {
            let p = ankle + pitch * (forward * f + ff.up * u + lateral * l);
            ff.split(&p.coords)
        };
        let mut points = Vec::new();
        for i in 0..=52 {
            let f = -0.05 + 0.26 * f64::from(i) / 52.0;
            for k in 0..=9 {
                // Top face and the side facing the sensor.
                points.push(place(f, 0.01, -0.045 + 0.09 * f64::from(k) / 9.0));
                points.push(place(f, -0.068 + 0.078 * f64::from(k) / 9.0, 0.045));
            }
        }
        let head = ankle + pitch * (forward * 0.146 - ff.up * 0.034);
        let foot = legs::place_foot(&ff, &ankle, &points, &forward, length).unwrap();
        assert!((foot - ankle).norm() - length < 1e-9);
        assert!(
            (foot - head).norm() < 0.025,
            "pitch {pitch_deg}°: foot {foot:?}, head {head:?}, off by {:.3} m",
            (foot - head).norm()
        );
        assert!(legs::place_foot(&ff, &ankle, &points[..8], &forward, length).is_none());
    }
}

/// The hips, knees and ankles a frame reports (tracked or inferred), with their positions.
fn reported_leg_joints(out: &TrackedFrame) -> Vec<(Joint, Point3<f64>)> {
    out.joints
        .iter()
        .filter(|j| Joint::LEGS.contains(&j.joint) && j.state != TrackingState::NotTracked)
        .map(|j| (j.joint, j.position_in_kinect))
        .collect()
}

/// Per joint, the largest distance from its median position over `frames` (each a list of
/// (joint, position)), and the frames that reported fewer than the six leg joints.
fn spread(frames: &[Vec<(Joint, Point3<f64>)>]) -> (Vec<(Joint, f64)>, usize) {
    let incomplete = frames
        .iter()
        .filter(|f| Joint::LEGS.iter().any(|j| !f.iter().any(|(k, _)| k == j)))
        .count();
    let mut out = Vec::new();
    for j in Joint::LEGS {
        let ps: Vec<Point3<f64>> = frames
            .iter()
            .filter_map(|f| f.iter().find(|(k, _)| *k == j).map(|(_, p)| *p))
            .collect();
        if ps.is_empty() {
            continue;
        }
        let centre = Point3::from(nalgebra::Vector3::from_fn(|i, _| {
            median(ps.iter().map(|p| p[i]).collect())
        }));
        let far = ps.iter().map(|p| (p - centre).norm()).fold(0.0, f64::max);
        out.push((j, far));
    }
    (out, incomplete)
}

/// A person standing still gives still joints: the real frame 004378 tracked 90 times over.
/// Each hip, knee and ankle stays within 2 cm of its median position over the frames after the
/// learning. What could be wrong: the prediction feeding the tracker's own jitter back, the
/// standing decision moving the ankle it is judged on (the rear foot there cycled every third
/// frame between over the floor and hung at the shank length, 10.6 cm apart), the lower legs
/// changing chains on an unchanged image, the sides flipping. Measured: every joint within
/// 0.0 cm.
#[test]
fn a_still_person_on_a_real_frame_gives_still_joints() {
    const FRAMES: usize = 90;
    let learned = TrackerConfig::default().learning_frames + 5;
    let Some(depth) = trigait_test_data::shared_file("kinect-v2-depth-person/004378_depth.png")
    else {
        return;
    };
    let frame = trigait_depth::io::read_depth_png(&depth).unwrap();
    let mut tracker = recorded_frame_tracker();
    let mut seen = Vec::new();
    for f in 0..FRAMES {
        let out = tracker.track(&frame);
        if f >= learned {
            seen.push(reported_leg_joints(&out));
        }
    }
    let (real, incomplete) = spread(&seen);
    eprintln!("frame 004378 {FRAMES} times: spread {real:.3?}, {incomplete} frames incomplete");
    assert_eq!(incomplete, 0);
    assert_eq!(real.len(), 6);
    assert!(real.iter().all(|(_, d)| *d <= 0.02), "{real:.3?}");
}

/// A rendered person standing still gives still joints: the walker's pose in double support
/// (ankles at least 0.5 m apart horizontally) whose left hip is nearest the middle of k1's view
/// (horizontally), rendered afresh each frame (new sensor noise every frame). Each hip, knee
/// and ankle stays within 2 cm of its median position over the frames after the learning and
/// within 5 cm of its truth.
/// Not met: the right thigh, half seen, is fitted two ways by turns (hip and knee 3.6 and
/// 4.6 cm apart), and a joint sits 7.7 cm from its truth (the left ankle, on its raised heel,
/// was 14 cm off while a foot on the floor always had its ankle over a flat sole).
#[test]
#[ignore = "a rendered still person's joints do not hold still yet: see the README's leg tracker section"]
fn a_still_person_gives_still_joints() {
    const FRAMES: usize = 90;
    let learned = TrackerConfig::default().learning_frames + 5;
    let pose = thesis_k1();
    let clip = lap();
    let apart = |t: f64| {
        let (l, r) = (
            clip.position_at(Joint::AnkleLeft, t).unwrap(),
            clip.position_at(Joint::AnkleRight, t).unwrap(),
        );
        (l - r).xy().norm()
    };
    // A person standing at the edge of the image has joints out of view.
    let off_axis = |t: f64| {
        let hip = pose.inverse() * clip.position_at(Joint::HipLeft, t).unwrap();
        (hip.x / hip.z).abs()
    };
    let stance = (0..(clip.duration_secs() * RATE_HZ) as u32)
        .map(|k| f64::from(k) / RATE_HZ)
        .filter(|t| apart(*t) >= 0.5)
        .min_by(|a, b| off_axis(*a).total_cmp(&off_axis(*b)))
        .unwrap();
    let mut renderer = seeded_renderer(&pose, 11);
    let mut tracker = LegTracker::new(config_for(&pose)).unwrap();
    let mut seen = Vec::new();
    let mut worst_truth: f64 = 0.0;
    for f in 0..FRAMES {
        let r = renderer
            .render_pose(&BodyShape::default(), |j| clip.position_at(j, stance))
            .unwrap();
        let out = tracker.track(&r.depth);
        let joints = reported_leg_joints(&out);
        if f >= learned {
            for (j, p) in &joints {
                worst_truth = worst_truth.max((p - r.joint(*j).unwrap()).norm());
            }
            seen.push(joints);
        }
    }
    let (rendered, incomplete) = spread(&seen);
    eprintln!(
        "walker standing at {stance:.2} s (feet {:.2} m apart): spread {rendered:.3?}, worst error {worst_truth:.3} m, {incomplete} frames incomplete",
        apart(stance)
    );
    assert_eq!(incomplete, 0);
    assert!(rendered.iter().all(|(_, d)| *d <= 0.02), "{rendered:.3?}");
    assert!(worst_truth <= 0.05, "{worst_truth:.3} m");
}

/// The walker and both mocap walks on every sensor over ten draws of the sensor noise (seeds
/// 1–10, two threads, about 2 minutes on two cores): swapped frames, the mean of the median
/// errors per joint class, and the runs with a median over 4 cm. One draw or three move by
/// more than most tracker changes do (a change to the fit moves the swaps from run to run), so
/// this is how a change is judged; with `PER_RUN` set, every run's medians and RMS are listed
/// too, to find the runs a change moves. Run by hand:
/// `cargo test --release -p trigait-leg-tracker -- --ignored over_ten_noise_seeds --nocapture`.
#[test]
#[ignore = "a measurement run by hand, about 2 minutes"]
fn over_ten_noise_seeds() {
    let Some(laps) = all_laps(Turns::Spun) else {
        return;
    };
    ten_noise_seeds(&laps, Turns::Spun);
}

/// [`over_ten_noise_seeds`] on the walkway as the depth graph paces it: out on one lane, back
/// on a second 1 m to the side, turning unseen for a second at each end (no instant spin, so
/// no frame is left out of the swap count).
#[test]
#[ignore = "a measurement run by hand, about 2 minutes"]
fn over_ten_noise_seeds_on_two_lanes() {
    let Some(laps) = all_laps(Turns::Unseen) else {
        return;
    };
    ten_noise_seeds(&laps, Turns::Unseen);
}

fn ten_noise_seeds(laps: &[(String, MotionClip)], turns: Turns) {
    let seeds: Vec<u64> = (1..=10).collect();
    let runs = std::sync::Mutex::new(Vec::new());
    std::thread::scope(|scope| {
        for part in seeds.chunks(seeds.len().div_ceil(2)) {
            let runs = &runs;
            scope.spawn(move || {
                for &seed in part {
                    for (name, lap) in laps {
                        for s in score_on_the_thesis_rig(lap, turns, 10.0, seed) {
                            runs.lock().unwrap().push((seed, name.clone(), s));
                        }
                    }
                }
            });
        }
    });
    let runs = runs.into_inner().unwrap();
    if std::env::var("PER_RUN").is_ok() {
        let mut sorted: Vec<_> = runs.iter().collect();
        sorted.sort_by(|a, b| (a.0, &a.1, &a.2.sensor).cmp(&(b.0, &b.1, &b.2.sensor)));
        for (seed, name, s) in sorted {
            eprintln!(
                "seed {seed} {name} {}: medians {:.4?} m, RMS away from instant turns {:.4?} m",
                s.sensor, s.medians, s.rms_away
            );
        }
    }
    for (seed, name, s) in runs.iter().filter(|r| r.2.swaps > 0) {
        eprintln!(
            "seed {seed} {name} {}: {} swapped frames",
            s.sensor, s.swaps
        );
    }
    let mean_of = |of: fn(&Score) -> [f64; 3], class: usize| {
        runs.iter().map(|r| of(&r.2)[class]).sum::<f64>() / runs.len() as f64
    };
    let mean = |class: usize| mean_of(|s| s.medians, class);
    eprintln!(
        "mean RMS hip / knee / ankle {:.4} / {:.4} / {:.4} m",
        mean_of(|s| s.rms, 0),
        mean_of(|s| s.rms, 1),
        mean_of(|s| s.rms, 2)
    );
    if turns == Turns::Spun {
        eprintln!(
            "  away from the instant turns {:.4} / {:.4} / {:.4} m",
            mean_of(|s| s.rms_away, 0),
            mean_of(|s| s.rms_away, 1),
            mean_of(|s| s.rms_away, 2)
        );
    }
    let refits = runs.iter().map(|r| r.2.refits).sum::<usize>();
    let relearns = runs.iter().map(|r| r.2.relearns).sum::<usize>();
    let not_standing = runs.iter().map(|r| r.2.not_standing).sum::<usize>();
    eprintln!(
        "floors fitted afresh (the sensors never move): {refits}; bodies learned afresh (one walker): {relearns}; frames taken as not standing: {not_standing}"
    );
    eprintln!(
        "{} runs: {} swapped frames of {}; mean median hip / knee / ankle {:.4} / {:.4} / {:.4} m; runs with a median over 4 cm: {}",
        runs.len(),
        runs.iter().map(|r| r.2.swaps).sum::<usize>(),
        runs.iter().map(|r| r.2.asked / 6).sum::<usize>(),
        mean(0),
        mean(1),
        mean(2),
        runs.iter()
            .filter(|r| r.2.medians.iter().any(|m| *m > 0.04))
            .count()
    );
    assert_eq!(
        refits, 0,
        "the floor was fitted afresh on a sensor that never moved"
    );
    assert_eq!(relearns, 0, "the one walker was taken for someone else");
    assert_eq!(not_standing, 0, "the walker was taken as not standing");
}

/// People standing still in the walker's poses: 16 instants over the lap (the 0.35 s after each
/// turn left out) on each sensor of the thesis rig, each rendered 30 times afresh (new sensor
/// noise), counting the frames whose sides came out swapped and the poses with any. A frozen
/// walking pose is harder than standing: one foot is off the floor and a leg often half hidden.
/// What goes wrong: a half-seen hip jumps and makes a still person "walk", the wrong way round
/// as often as not, or the feet, one off the floor, point backwards.
/// Run by hand: `cargo test --release -p trigait-leg-tracker -- --ignored still_poses --nocapture`.
#[test]
#[ignore = "a measurement run by hand, about 10 seconds"]
fn still_poses_over_the_lap() {
    let clip = lap();
    let rig = Rig::builtin("thesis").unwrap();
    let (mut swapped, mut complete, mut poses, mut poses_swapped) = (0, 0, 0, 0);
    let mut not_standing = 0;
    for sensor in &rig.sensors {
        let pose = sensor.world_from_kinect;
        for i in 0..16_u32 {
            let t = clip.duration_secs() * (f64::from(i) + 0.5) / 16.0;
            if near_turn(t, clip.duration_secs()) {
                continue;
            }
            poses += 1;
            let mut renderer = seeded_renderer(&pose, 11 + u64::from(i));
            let mut tracker = LegTracker::new(config_for(&pose)).unwrap();
            let mut swaps = 0;
            for _ in 0..30 {
                let r = renderer
                    .render_pose(&BodyShape::default(), |j| clip.position_at(j, t))
                    .unwrap();
                let out = tracker.track(&r.depth);
                not_standing += usize::from(out.status == Status::NotStanding);
                if let Some(swapped) = sides_swapped(&out, &r) {
                    complete += 1;
                    swaps += usize::from(swapped);
                }
            }
            if swaps > 0 {
                eprintln!("{} at {t:.2} s: {swaps} of 30 frames swapped", sensor.id);
                poses_swapped += 1;
            }
            swapped += swaps;
        }
    }
    eprintln!(
        "{poses} still poses: {poses_swapped} with swapped sides, {swapped} swapped frames of {complete} with all six joints; {not_standing} frames taken as not standing"
    );
    assert!(complete > 0);
    assert_eq!(not_standing, 0);
}

/// Whether the frame's sides came out swapped against the rendered truth, if all six joints
/// were reported. A swap exchanges the legs' identities: at least two of the hip, knee and
/// ankle pairs lie nearer the other side's truth (one misplaced joint is a fit error, not a
/// swap).
pub(super) fn sides_swapped(
    out: &TrackedFrame,
    truth: &trigait_body_render::Rendered,
) -> Option<bool> {
    let mut crossed = 0;
    for (left, right) in [
        (Joint::HipLeft, Joint::HipRight),
        (Joint::KneeLeft, Joint::KneeRight),
        (Joint::AnkleLeft, Joint::AnkleRight),
    ] {
        let (a, b) = (out.joint(left)?, out.joint(right)?);
        let (gl, gr) = (truth.joint(left)?, truth.joint(right)?);
        let (a, b) = (a.position_in_kinect, b.position_in_kinect);
        let direct = (a - gl).norm() + (b - gr).norm();
        let across = (a - gr).norm() + (b - gl).norm();
        crossed += usize::from(across + 0.03 < direct);
    }
    Some(crossed >= 2)
}

/// A person standing still side-on to k2, feet together (the walker's pose 5.6 s into the lap,
/// ankles 11 cm apart), gets the sides right from the first frame. The far hip is half seen and
/// was fitted 22 cm off, on the wrong side: read off the hips alone, the sides came out swapped
/// on every frame; the knees and ankles, which a standing person holds apart as the hips, put
/// them right.
#[test]
fn a_still_person_with_a_half_seen_hip_gets_the_sides_right() {
    let clip = lap();
    let pose = Rig::builtin("thesis").unwrap().sensors[1].world_from_kinect;
    let mut renderer = seeded_renderer(&pose, 11);
    let mut tracker = LegTracker::new(config_for(&pose)).unwrap();
    let mut complete = 0;
    for f in 0..40 {
        let r = renderer
            .render_pose(&BodyShape::default(), |j| clip.position_at(j, 5.6))
            .unwrap();
        let out = tracker.track(&r.depth);
        if let Some(swapped) = sides_swapped(&out, &r) {
            assert!(!swapped, "frame {f}: sides swapped");
            complete += 1;
        }
    }
    assert!(
        complete >= 35,
        "{complete} frames of 40 with all six joints"
    );
}

/// Walking, the hip of the less seen thigh is reported beside the other hip: level with it
/// along the walk, the measured width across it on its own side (left = up × forward), at its
/// own height; before the width is measured only the offset along the walk goes; standing, or
/// with the other thigh not tracked, the hip stays where its thigh put it.
#[test]
fn a_less_seen_hip_is_reported_beside_the_other() {
    let up = Vector3::new(0.0, 1.0, 0.0);
    let ff = FloorFrame::new(up, 1.0);
    let forward = Vector3::new(0.0, 0.0, -1.0);
    let lateral = up.cross(&forward);
    let mut tracker = LegTracker::new(TrackerConfig::default()).unwrap();
    tracker.walking = true;
    tracker.forward = Some(forward);
    let seen_hip = Point3::new(0.3, 0.0, 3.0);
    // The hidden thigh's hip: 7 cm ahead along the walk, 4 cm across, 1 cm low.
    let fitted_hip = seen_hip + forward * 0.07 - lateral * 0.04 - up * 0.01;
    let track = |hip: Point3<f64>| LegTrack {
        pose: LegPose {
            hip,
            knee: hip - up * 0.45,
            ankle: hip - up * 0.9,
        },
        previous: LegPose {
            hip,
            knee: hip - up * 0.45,
            ankle: hip - up * 0.9,
        },
        missed: 0,
        sole: None,
    };
    let fit = |t: &LegTrack, thigh_seen: f64| LegFit {
        pose: t.pose,
        thigh_seen,
        shank_seen: 1.0,
        foot: None,
        knee_gap_m: 0.0,
        thigh_measured: None,
        shank_measured: None,
        thigh: legs::HeightLine {
            h0: 0.0,
            c0: nalgebra::Vector2::zeros(),
            slope: nalgebra::Vector2::zeros(),
            residual: 0.0,
        },
    };
    let tracks = [track(fitted_hip), track(seen_hip)];
    let fits = [Some(fit(&tracks[0], 0.5)), Some(fit(&tracks[1], 1.0))];
    let offset = |t: &LegTracker, fits: &[Option<LegFit>; 2]| {
        let d = t.hip_out(&ff, &tracks, fits, 0) - seen_hip;
        (forward.dot(&d), lateral.dot(&d), up.dot(&d))
    };
    for (left, side) in [(0, 1.0), (1, -1.0)] {
        tracker.left = Some(left);
        tracker.hip_widths.clear();
        let (along, across, height) = offset(&tracker, &fits);
        assert!(
            along.abs() < 1e-12 && (across + 0.04).abs() < 1e-12,
            "{along} {across}"
        );
        assert!((height + 0.01).abs() < 1e-12, "{height}");
        tracker.hip_widths = vec![0.18; MIN_HIP_WIDTHS];
        let (along, across, height) = offset(&tracker, &fits);
        assert!(along.abs() < 1e-12, "{along}");
        assert!(
            (across - side * 0.18).abs() < 1e-12,
            "left {left}: {across}"
        );
        assert!((height + 0.01).abs() < 1e-12, "{height}");
        // The seen hip itself stays put.
        assert_eq!(tracker.hip_out(&ff, &tracks, &fits, 1), seen_hip);
    }
    let other_inferred = 0.9 * tracker.config.tracked_share;
    let weak = [
        Some(fit(&tracks[0], 0.5 * other_inferred)),
        Some(fit(&tracks[1], other_inferred)),
    ];
    assert_eq!(tracker.hip_out(&ff, &tracks, &weak, 0), fitted_hip);
    tracker.walking = false;
    assert_eq!(tracker.hip_out(&ff, &tracks, &fits, 0), fitted_hip);
}
