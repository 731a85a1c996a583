//! Where the ankle and foot errors come from: every leg of every frame put in one cause class
//! (the 0.35 s after the simulated lap's instant turn; the ankle nearer the other leg's truth,
//! both chains on one leg or the lower legs crossed; reported inferred; its lower leg less than
//! half visible, by the pixels it shows against a render without the other leg; the ankles
//! less than 8 cm apart across the view; partly hidden; seen whole, still or moving), with
//! each class's share of the summed squared error and its mean error along up, the view, across
//! the view and the foot's forward direction. Run by hand:
//! `cargo test --release -p trigait-leg-tracker -- --ignored where_ankle_and_foot_errors --nocapture`;
//! with `DIAG_LANES` set, on the two-lane laps the depth graph walks (turning unseen, so no
//! frame is put in the first class); with `DIAG_SHOW` set, each ankle nearer the other leg's
//! truth is printed with its lap time, to be traced with [`trace_frames`].

use std::collections::BTreeMap;

use nalgebra::{Point3, Vector3};
use trigait_body_render::{Body, BodyShape, Part, RenderParams, Renderer, Room};
use trigait_rig::Rig;
use trigait_skeleton::{Joint, MotionClip, TrackingState};

use super::tests::{Turns, all_laps, walk};
use super::*;

#[derive(Default)]
struct Class {
    n: usize,
    sse: f64,
    up: f64,
    depth: f64,
    lateral: f64,
    forward: f64,
    over10: usize,
}

impl Class {
    fn add(
        &mut self,
        e: &Vector3<f64>,
        up: &Vector3<f64>,
        view: &Vector3<f64>,
        fwd: &Vector3<f64>,
    ) {
        self.n += 1;
        self.sse += e.norm_squared();
        self.up += up.dot(e);
        let h = e - up * up.dot(e);
        self.depth += view.dot(&h);
        self.lateral += up.cross(view).dot(&h);
        self.forward += fwd.dot(&h);
        self.over10 += usize::from(e.norm() > 0.1);
    }
}

fn visible(labels: &[u8], parts: &[Part]) -> usize {
    let ls: Vec<u8> = parts.iter().map(|p| p.label()).collect();
    labels.iter().filter(|l| ls.contains(l)).count()
}

fn run(
    lap: &MotionClip,
    turns: Turns,
    secs: f64,
    table: &mut BTreeMap<String, [BTreeMap<&'static str, Class>; 2]>,
) {
    let rig = Rig::builtin("thesis").unwrap();
    let frames = (secs * 30.0) as usize;
    let shape = BodyShape::default();
    let show = std::env::var("DIAG_SHOW").is_ok();
    for sensor in &rig.sensors {
        let pose = sensor.world_from_kinect;
        let mut renderer = super::tests::seeded_renderer(&pose, 7);
        let mut alone = Renderer::new(RenderParams::default(), &pose, &Room::default()).unwrap();
        let mut tracker = LegTracker::new(super::tests::config_for(&pose)).unwrap();
        let up = pose.rotation.inverse() * Vector3::z();
        let key = format!("{} {}", lap.name(), sensor.id);
        let entry = table.entry(key.clone()).or_default();
        let mut last_truth: Option<[Point3<f64>; 2]> = None;
        for f in 0..frames {
            let t = (f as f64 / 30.0) % lap.duration_secs();
            // A two-lane lap's turns are gaps: nobody is there (the empty room is rendered).
            let rendered = renderer
                .render_pose(&shape, |j| lap.position_at(j, t))
                .unwrap_or_else(|_| renderer.render_bodies(&[], Vec::new()));
            let out = tracker.track(&rendered.depth);
            let Ok(body) = Body::from_joints(&shape, |j| lap.position_at(j, t)) else {
                last_truth = None;
                continue;
            };
            let sides = [
                (
                    Joint::AnkleLeft,
                    Joint::FootLeft,
                    Joint::KneeLeft,
                    [Part::ShankLeft, Part::FootLeft],
                    [Part::ThighRight, Part::ShankRight, Part::FootRight],
                ),
                (
                    Joint::AnkleRight,
                    Joint::FootRight,
                    Joint::KneeRight,
                    [Part::ShankRight, Part::FootRight],
                    [Part::ThighLeft, Part::ShankLeft, Part::FootLeft],
                ),
            ];
            let truth_ankles = [
                rendered.joint(Joint::AnkleLeft).unwrap(),
                rendered.joint(Joint::AnkleRight).unwrap(),
            ];
            for (s, (aj, fj, _kj, mine, other)) in sides.iter().enumerate() {
                if f < 60 {
                    continue;
                }
                let only = Body {
                    ellipsoids: body
                        .ellipsoids
                        .iter()
                        .filter(|e| !other.contains(&e.part))
                        .copied()
                        .collect(),
                };
                let solo = alone.render_bodies(&[only], Vec::new());
                let vis_alone = visible(&solo.labels, mine);
                let vis = visible(&rendered.labels, mine);
                let share = if vis_alone == 0 {
                    0.0
                } else {
                    vis as f64 / vis_alone as f64
                };
                let ta = truth_ankles[s];
                let to = truth_ankles[1 - s];
                let tf = rendered.joint(*fj).unwrap();
                let dx = (ta.x - to.x).abs();
                let speed = last_truth.map_or(0.0, |l| (ta - l[s]).norm() * 30.0);
                let view = {
                    let v = ta.coords - up * up.dot(&ta.coords);
                    v.normalize()
                };
                let fwd = {
                    let v = tf - ta;
                    (v - up * up.dot(&v)).try_normalize(1e-6).unwrap_or(view)
                };
                let Some(a) = out.joint(*aj) else { continue };
                if a.state == TrackingState::NotTracked {
                    continue;
                }
                let e = a.position_in_kinect - ta;
                let e_other = (a.position_in_kinect - to).norm();
                let other_out = out.joint(sides[1 - s].0).map(|o| o.position_in_kinect);
                let both_same = other_out.is_some_and(|o| (o - a.position_in_kinect).norm() < 0.06);
                let half = lap.duration_secs() / 2.0;
                let class = if turns == Turns::Spun && (t % half) < 0.35 {
                    "0 after the lap's instant turn"
                } else if e_other + 0.03 < e.norm() && e.norm() > 0.08 && both_same {
                    "a1 wrong leg, same"
                } else if e_other + 0.03 < e.norm() && e.norm() > 0.08 {
                    "a2 wrong leg, crossed"
                } else if a.state == TrackingState::Inferred {
                    "b inferred"
                } else if share < 0.5 {
                    "c hidden <50%"
                } else if dx < 0.08 {
                    "d overlap dx<8cm"
                } else if share < 0.9 {
                    "e partial 50-90%"
                } else if speed < 0.45 {
                    "f clear still"
                } else {
                    "g clear moving"
                };
                if class.starts_with('a') && show {
                    eprintln!(
                        "{key} at {t:.3} s: ankle {s} {:.3} m off, {e_other:.3} m from the other leg's ({:?})",
                        e.norm(),
                        a.state
                    );
                }
                entry[0].entry(class).or_default().add(&e, &up, &view, &fwd);
                if let Some(ft) = out.joint(*fj) {
                    let ef = ft.position_in_kinect - tf;
                    entry[1]
                        .entry(class)
                        .or_default()
                        .add(&ef, &up, &view, &fwd);
                }
            }
            last_truth = Some(truth_ankles);
        }
    }
}

#[test]
#[ignore = "diagnostic, prints a table"]
fn where_ankle_and_foot_errors_come_from() {
    let turns = if std::env::var("DIAG_LANES").is_ok() {
        Turns::Unseen
    } else {
        Turns::Spun
    };
    let Some(laps) = all_laps(turns) else {
        return;
    };
    let mut table = BTreeMap::new();
    for (_, lap) in &laps {
        run(lap, turns, 10.0, &mut table);
    }
    for (key, [ankle, foot]) in &table {
        for (what, t) in [("ankle", ankle), ("foot", foot)] {
            let total: f64 = t.values().map(|c| c.sse).sum();
            let n: usize = t.values().map(|c| c.n).sum();
            eprintln!(
                "{key} {what}: n {n} RMS {:.3}",
                (total / n.max(1) as f64).sqrt()
            );
            for (name, c) in t {
                let k = c.n.max(1) as f64;
                eprintln!(
                    "   {name:18} n {:4} RMS {:.3} share of SSE {:4.1}% >10cm {:3}  mean up {:+.3} depth {:+.3} lat {:+.3} fwd {:+.3}",
                    c.n,
                    (c.sse / k).sqrt(),
                    100.0 * c.sse / total,
                    c.over10,
                    c.up / k,
                    c.depth / k,
                    c.lateral / k,
                    c.forward / k
                );
            }
        }
    }
}

/// Frame by frame, how far each chain's hip, knee and ankle lie from the left and the right
/// truth, the frames the chain has coasted, the sides, whether the frame came out swapped
/// (where a swap comes from), the reported hips' errors along up, the walk and across it, the
/// segment lengths and hip height in use, and every reported joint's error (cm, `i`
/// inferred). Chosen by `TRACE_CLIP` (`walker` or a shared mocap file), `TRACE_SENSOR` (index
/// in the thesis rig), `TRACE_SEED`, `TRACE_FROM`
/// and `TRACE_TO` (seconds), `TRACE_SHIFT` (seconds added to every instant, so the trace runs
/// from `TRACE_SHIFT` to `TRACE_TO` plus it: the sub-frame offset a graph's capture grid has)
/// and `TRACE_LANES` (set: the two-lane lap); with `TRACE_PNG` set to a directory, every
/// rendered frame from the start is written there as a depth PNG, to be looked at with
/// `trigait legs DIR --rig thesis --sensor ID --mirrored false --out OUT`; run by hand:
/// `TRACE_SENSOR=1 TRACE_FROM=0.7 TRACE_TO=1.1 cargo test --release -p trigait-leg-tracker --lib -- --ignored trace_frames --nocapture`.
#[test]
#[ignore = "diagnostic, prints a trace"]
fn trace_frames() {
    let which = std::env::var("TRACE_CLIP").unwrap_or_else(|_| "walker".into());
    let k: usize = std::env::var("TRACE_SENSOR").map_or(1, |s| s.parse().unwrap());
    let seed: u64 = std::env::var("TRACE_SEED").map_or(7, |s| s.parse().unwrap());
    let from: f64 = std::env::var("TRACE_FROM").map_or(0.7, |s| s.parse().unwrap());
    let to: f64 = std::env::var("TRACE_TO").map_or(1.1, |s| s.parse().unwrap());
    let shift: f64 = std::env::var("TRACE_SHIFT").map_or(0.0, |s| s.parse().unwrap());
    let clip = if which == "walker" {
        walk()
    } else {
        let path = trigait_test_data::shared_file(&which).unwrap();
        trigait_motion::load_motion(&path).unwrap()
    };
    let lap = if std::env::var("TRACE_LANES").is_ok() {
        Turns::Unseen
    } else {
        Turns::Spun
    }
    .lap(&clip);
    let rig = Rig::builtin("thesis").unwrap();
    let pose = rig.sensors[k].world_from_kinect;
    let mut renderer = super::tests::seeded_renderer(&pose, seed);
    let mut tracker = LegTracker::new(super::tests::config_for(&pose)).unwrap();
    let png_dir = std::env::var("TRACE_PNG")
        .ok()
        .map(std::path::PathBuf::from);
    for f in 0..((to * 30.0) as usize + 1) {
        let t = f as f64 / 30.0 + shift;
        let tl = t % lap.duration_secs();
        let r = renderer
            .render_pose(&BodyShape::default(), |j| lap.position_at(j, tl))
            .unwrap_or_else(|_| renderer.render_bodies(&[], Vec::new()));
        let out = tracker.track(&r.depth);
        if let Some(dir) = &png_dir {
            let path = dir.join(format!("{f:04}_{t:.3}.png"));
            trigait_depth::io::write_depth_png(&path, &r.depth).unwrap();
        }
        if t < from || r.joints_in_kinect.is_empty() {
            continue;
        }
        let g = |j| r.joint(j).unwrap();
        let left = tracker.left;
        print!("{t:.3} left {left:?} walk {} ", tracker.walking);
        if let Some(legs) = &tracker.legs {
            for (c, tr) in legs.iter().enumerate() {
                let p = tr.pose;
                print!(
                    "| c{c} m{} hip L{:.2}/R{:.2} knee L{:.2}/R{:.2} ank L{:.2}/R{:.2} ",
                    tr.missed,
                    (p.hip - g(Joint::HipLeft)).norm(),
                    (p.hip - g(Joint::HipRight)).norm(),
                    (p.knee - g(Joint::KneeLeft)).norm(),
                    (p.knee - g(Joint::KneeRight)).norm(),
                    (p.ankle - g(Joint::AnkleLeft)).norm(),
                    (p.ankle - g(Joint::AnkleRight)).norm(),
                );
            }
        }
        if let (Some(fwd), Some(legs)) = (tracker.forward, &tracker.legs) {
            let up = tracker.floor.unwrap().up_in_kinect;
            let lat = up.cross(&fwd);
            let (a, b) = (legs[0].pose, legs[1].pose);
            print!(
                "| lat c0-c1 {:+.2}/{:+.2}/{:+.2} L-R {:+.2}/{:+.2}/{:+.2} ",
                lat.dot(&(a.hip - b.hip)),
                lat.dot(&(a.knee - b.knee)),
                lat.dot(&(a.ankle - b.ankle)),
                lat.dot(&(g(Joint::HipLeft) - g(Joint::HipRight))),
                lat.dot(&(g(Joint::KneeLeft) - g(Joint::KneeRight))),
                lat.dot(&(g(Joint::AnkleLeft) - g(Joint::AnkleRight))),
            );
        }
        if let (Some(fwd), Some(floor)) = (tracker.forward, tracker.floor) {
            let up = floor.up_in_kinect;
            let lat = up.cross(&fwd);
            for j in [Joint::HipLeft, Joint::HipRight] {
                if let (Some(o), Some(gj)) = (out.joint(j), r.joint(j)) {
                    let e = o.position_in_kinect - gj;
                    print!(
                        "| {j:?} up {:+.2} fwd {:+.2} lat {:+.2} ",
                        up.dot(&e),
                        fwd.dot(&e),
                        lat.dot(&e)
                    );
                }
            }
            let (gl, gr) = (g(Joint::HipLeft), g(Joint::HipRight));
            print!(
                "| true L-R lat {:+.2} fwd {:+.2} ",
                lat.dot(&(gl - gr)),
                fwd.dot(&(gl - gr))
            );
        }
        let conf: Vec<String> = out
            .joints
            .iter()
            .map(|j| format!("{:.1}", j.confidence))
            .collect();
        let err: Vec<String> = out
            .joints
            .iter()
            .filter_map(|j| {
                r.joint(j.joint).map(|g| {
                    format!(
                        "{:.0}{}",
                        100.0 * (j.position_in_kinect - g).norm(),
                        match j.state {
                            TrackingState::Tracked => "",
                            TrackingState::Inferred => "i",
                            TrackingState::NotTracked => "n",
                        }
                    )
                })
            })
            .collect();
        println!(
            "| len {:?} hiph {:?} | swapped {:?} conf {} err cm {}",
            out.segment_lengths_m,
            out.hip_height_m,
            super::tests::sides_swapped(&out, &r),
            conf.join(","),
            err.join(",")
        );
    }
}
