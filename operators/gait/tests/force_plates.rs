//! Acceptance on real recordings with force plates: the events found from the heel, toe and
//! pelvis markers against the force-plate contacts (vertical GRF ≥ 20 N) listed in each folder's
//! `SOURCE.txt`, and the parameters against the same parameters computed from the heel markers
//! at the reference events.
//!
//! The reference events are parsed from `SOURCE.txt` here; nothing our code produced is
//! written down. A *clean* contact is a plate contact by one foot: its heel strike is valid, and
//! its toe off unless `SOURCE.txt` marks it (a `*`, or "no TO"). The reference strides use the
//! plate heel strikes and, where the lab labelled strikes off the plates, the heel marker's
//! plate-calibrated instant near each such label (overground; the label itself on a treadmill).
//!
//! Bounds (from the acceptance): every clean contact matched by a detected event of the same
//! foot and kind (within 60 ms); mean |error| ≤ 10 ms (one frame at 100 Hz) for heel strikes and
//! for toe offs; cadence within 1 %, stride length within 2 cm and step width within 1 cm of the
//! reference values.
#![allow(clippy::unwrap_used, clippy::expect_used)] // a test that cannot unwrap has failed

use nalgebra::{Point3, Vector2};
use trigait_gait::{
    EventKind, Foot, GaitAnalysis, GaitParams, HeelSource, Landmarks, TreadmillMode,
    analyse_landmarks,
};
use trigait_motion::{FootMarkers, MarkerSet};

/// One reference event.
#[derive(Debug, Clone, Copy)]
struct Reference {
    foot: Foot,
    kind: EventKind,
    time: f64,
}

fn foot_of(c: char) -> Option<Foot> {
    match c {
        'L' => Some(Foot::Left),
        'R' => Some(Foot::Right),
        _ => None,
    }
}

/// Plate contacts from the force-plate lines of `block`: a foot designator (`FPn L:` /
/// `Left belt`), then `HS [t_file] <s>` and `TO [t_file] <s>[*]` tokens; a continuation line
/// starting with `HS` keeps the previous foot. Starred toe offs are left out.
fn plate_events(block: &str) -> Vec<Reference> {
    let mut out = Vec::new();
    let mut foot = None;
    for line in block.lines() {
        let tokens: Vec<&str> = line.split_whitespace().collect();
        let mut this = None;
        for (i, t) in tokens.iter().enumerate() {
            let plate =
                t.starts_with("FP") && t.len() > 2 && t[2..].chars().all(|c| c.is_ascii_digit());
            if plate && let Some(next) = tokens.get(i + 1) {
                let side = next.trim_end_matches(':');
                if side.len() == 1 {
                    this = this.or(foot_of(side.chars().next().unwrap_or(' ')));
                }
            }
            if (*t == "Left" || *t == "Right") && tokens.get(i + 1) == Some(&"belt") {
                this = Some(if *t == "Left" {
                    Foot::Left
                } else {
                    Foot::Right
                });
            }
        }
        let continuation = tokens.first() == Some(&"HS");
        match (this, continuation) {
            (Some(f), _) => foot = Some(f),
            (None, true) => {}
            (None, false) => continue,
        }
        let Some(f) = foot else { continue };
        for (i, t) in tokens.iter().enumerate() {
            let kind = match *t {
                "HS" => EventKind::HeelStrike,
                "TO" => EventKind::ToeOff,
                _ => continue,
            };
            let mut j = i + 1;
            if tokens.get(j) == Some(&"t_file") {
                j += 1;
            }
            let Some(value) = tokens.get(j) else { continue };
            let starred = value.ends_with('*');
            let Ok(time) = value.trim_end_matches(['*', ',', ';', ')']).parse::<f64>() else {
                continue;
            };
            if !starred {
                out.push(Reference {
                    foot: f,
                    kind,
                    time,
                });
            }
        }
    }
    out
}

/// Lab-labelled strikes (`L Strike 0.704`) in `block`.
fn labelled_strikes(block: &str) -> Vec<Reference> {
    let tokens: Vec<&str> = block.split_whitespace().collect();
    let mut out = Vec::new();
    for w in tokens.windows(3) {
        if w[1] == "Strike"
            && let (Some(foot), Ok(time)) = (
                foot_of(w[0].chars().next().unwrap_or(' ')),
                w[2].trim_end_matches([',', ';', '.']).parse::<f64>(),
            )
            && w[0].len() == 1
        {
            out.push(Reference {
                foot,
                kind: EventKind::HeelStrike,
                time,
            });
        }
    }
    out
}

/// The text between the line containing `start` and the next line containing any of `ends`.
fn section<'a>(text: &'a str, start: &str, ends: &[&str]) -> &'a str {
    let a = text
        .find(start)
        .unwrap_or_else(|| panic!("no {start:?} in SOURCE.txt"));
    let rest = &text[a..];
    let first_line_end = rest.find('\n').unwrap_or(rest.len());
    let b = ends
        .iter()
        .filter_map(|e| rest[first_line_end..].find(e).map(|i| i + first_line_end))
        .min()
        .unwrap_or(rest.len());
    &rest[..b]
}

fn source(folder: &str) -> Option<String> {
    let path = trigait_test_data::shared_file(&format!("{folder}/SOURCE.txt"))?;
    Some(std::fs::read_to_string(path).unwrap())
}

fn landmarks(set: &MarkerSet) -> Landmarks {
    let FootMarkers {
        pelvis, heel, toe, ..
    } = trigait_motion::foot_markers(set).unwrap();
    let toe = [0, 1].map(|s| toe[s].clone().expect("toe marker"));
    Landmarks {
        rate_hz: set.rate_hz(),
        pelvis,
        heel,
        toe,
        heel_source: HeelSource::HeelMarker,
    }
}

/// Linear interpolation of a marker track at time `t`.
fn at(track: &[Option<Point3<f64>>], rate: f64, t: f64) -> Point3<f64> {
    let f = t * rate;
    let i = f.floor() as usize;
    let a = track[i].expect("heel marker at a reference event");
    let b = track.get(i + 1).copied().flatten().unwrap_or(a);
    a + (b - a) * (f - i as f64)
}

/// One reference stride (or step, when `foot_b` differs) from the heel markers at reference
/// heel strikes.
#[derive(Debug, Clone, Copy)]
struct RefStride {
    foot: Foot,
    start: f64,
    end: f64,
    cadence: f64,
    length: f64,
    width: f64,
}

/// Reference strides (same foot, the other foot's strike inside) and, separately, steps (from
/// one foot's strike to the other's next), with `belt` (horizontal m/s) added back on a
/// treadmill.
fn reference_strides(
    l: &Landmarks,
    strikes: &[Reference],
    belt: Vector2<f64>,
) -> (Vec<RefStride>, Vec<RefStride>) {
    let rate = l.rate_hz;
    let heel = |foot: Foot, t: f64| {
        let p = at(&l.heel[foot as usize], rate, t);
        Vector2::new(p.x, p.y) + belt * t
    };
    let mut sorted = strikes.to_vec();
    sorted.sort_by(|a, b| a.time.total_cmp(&b.time));
    let mut strides = Vec::new();
    for foot in Foot::BOTH {
        let own: Vec<f64> = sorted
            .iter()
            .filter(|r| r.foot == foot)
            .map(|r| r.time)
            .collect();
        for w in own.windows(2) {
            let (a, b) = (w[0], w[1]);
            let Some(o) = sorted
                .iter()
                .find(|r| r.foot != foot && r.time > a && r.time < b)
            else {
                continue;
            };
            if b - a > 2.0 {
                continue;
            }
            let (pa, pb, po) = (heel(foot, a), heel(foot, b), heel(o.foot, o.time));
            let stride = pb - pa;
            let rel = po - pa;
            strides.push(RefStride {
                foot,
                start: a,
                end: b,
                cadence: 120.0 / (b - a),
                length: stride.norm(),
                width: (stride.x * rel.y - stride.y * rel.x).abs() / stride.norm(),
            });
        }
    }
    let steps = sorted
        .windows(2)
        .filter(|w| w[0].foot != w[1].foot && w[1].time - w[0].time < 1.0)
        .map(|w| RefStride {
            foot: w[1].foot,
            start: w[0].time,
            end: w[1].time,
            cadence: 60.0 / (w[1].time - w[0].time),
            length: (heel(w[1].foot, w[1].time) - heel(w[0].foot, w[0].time)).norm(),
            width: f64::NAN,
        })
        .collect();
    (strides, steps)
}

/// Horizontal speed (m/s) of a marker track at time `t`: central differences at the frames,
/// interpolated linearly between them.
fn horizontal_speed(track: &[Option<Point3<f64>>], rate: f64, t: f64) -> Option<f64> {
    let at_frame = |i: usize| -> Option<f64> {
        let (a, b) = (
            track.get(i.checked_sub(1)?)?.as_ref()?,
            track.get(i + 1)?.as_ref()?,
        );
        Some(Vector2::new(b.x - a.x, b.y - a.y).norm() * rate / 2.0)
    };
    let f = t * rate;
    let i = f.floor() as usize;
    let (a, b) = (at_frame(i)?, at_frame(i + 1)?);
    Some(a + (b - a) * (f - i as f64))
}

/// Where the heel, overground, slows to the horizontal speed it had at `template` (the same
/// foot's 20 N plate contact): the first downward crossing of that speed within ±0.12 s of
/// `near`. A marker-derived strike off the plates, calibrated by the plate, independent of the
/// detector under test (which uses the pelvis–heel distance and fixed speed gates).
fn plate_calibrated_strike(l: &Landmarks, foot: Foot, template: f64, near: f64) -> Option<f64> {
    let (rate, track) = (l.rate_hz, &l.heel[foot as usize]);
    let threshold = horizontal_speed(track, rate, template)?;
    let first = ((near - 0.12) * rate).floor().max(1.0) as usize;
    let last = ((near + 0.12) * rate).ceil() as usize;
    let speed = |i: usize| horizontal_speed(track, rate, i as f64 / rate);
    (first..last).find_map(|i| {
        let (a, b) = (speed(i)?, speed(i + 1)?);
        (a > threshold && b <= threshold).then(|| (i as f64 + (a - threshold) / (a - b)) / rate)
    })
}

/// Merges plate and labelled strikes: a labelled strike within 30 ms of a plate one is the same.
/// Overground, a labelled strike off the plates is replaced by the plate-calibrated heel-speed
/// instant near it ([`plate_calibrated_strike`]) when that foot has a plate contact: labels are
/// placed by hand or by a vendor's rule, and the plates show them 0–9 ms early (frame times,
/// floored) where they can check them. Both instants are printed.
fn merged_strikes(
    l: &Landmarks,
    plates: &[Reference],
    labels: &[Reference],
    treadmill: bool,
) -> Vec<Reference> {
    let mut out: Vec<Reference> = plates
        .iter()
        .filter(|r| r.kind == EventKind::HeelStrike)
        .copied()
        .collect();
    let on_plates = out.clone();
    for label in labels {
        if on_plates
            .iter()
            .any(|p| p.foot == label.foot && (p.time - label.time).abs() < 0.03)
        {
            continue;
        }
        let template = on_plates.iter().find(|p| p.foot == label.foot);
        let calibrated = template
            .filter(|_| !treadmill)
            .and_then(|p| plate_calibrated_strike(l, label.foot, p.time, label.time));
        match calibrated {
            Some(time) => {
                println!(
                    "{} strike off the plates: label {:.3} s, plate-calibrated heel speed {time:.3} s \
                     ({:+.0} ms)",
                    label.foot.name(),
                    label.time,
                    (time - label.time) * 1e3
                );
                out.push(Reference { time, ..*label });
            }
            None => out.push(*label),
        }
    }
    out
}

/// Checks the events against the plates and prints what was measured; returns the failures.
fn check_events(name: &str, analysis: &GaitAnalysis, plates: &[Reference]) -> Vec<String> {
    let mut failures = Vec::new();
    for kind in [EventKind::HeelStrike, EventKind::ToeOff] {
        let mut errors = Vec::new();
        for r in plates.iter().filter(|r| r.kind == kind) {
            let nearest = analysis
                .events_of(r.foot, kind)
                .map(|e| e.time_secs - r.time)
                .min_by(|a, b| a.abs().total_cmp(&b.abs()));
            match nearest {
                Some(e) if e.abs() <= 0.06 => errors.push(e),
                other => failures.push(format!(
                    "{name}: {kind:?} {} at {:.3} s not matched (nearest {other:?})",
                    r.foot.name(),
                    r.time
                )),
            }
        }
        if errors.is_empty() {
            continue;
        }
        let mean_abs = errors.iter().map(|e| e.abs()).sum::<f64>() / errors.len() as f64;
        let signed: Vec<String> = errors.iter().map(|e| format!("{:+.0}", e * 1e3)).collect();
        println!(
            "{name}: {kind:?} errors (ms) [{}], mean |error| {:.1} ms",
            signed.join(" "),
            mean_abs * 1e3
        );
        if mean_abs > 0.010 + 1e-9 {
            failures.push(format!(
                "{name}: {kind:?} mean |error| {:.1} ms > 10 ms",
                mean_abs * 1e3
            ));
        }
    }
    failures
}

/// Our strides that are the reference strides (same foot, both strikes within 30 ms) against
/// them: cadence within 1 %, stride length within 2 cm, step width within 1 cm (means over the
/// matched strides). Without a reference stride, our steps against the reference steps
/// (cadence only).
fn check_params(
    name: &str,
    analysis: &GaitAnalysis,
    strides: &[RefStride],
    steps: &[RefStride],
) -> Vec<String> {
    let mut failures = Vec::new();
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    let close = |a: f64, b: f64| (a - b).abs() < 0.03;
    if strides.is_empty() {
        let mut ours = Vec::new();
        let mut refs = Vec::new();
        for r in steps {
            match analysis.steps.iter().find(|s| {
                s.foot == r.foot && close(s.start_secs, r.start) && close(s.end_secs, r.end)
            }) {
                Some(s) => {
                    ours.push(s.cadence_steps_per_min);
                    refs.push(r.cadence);
                }
                None => failures.push(format!("{name}: reference step {r:?} not found")),
            }
        }
        assert!(!refs.is_empty(), "{name}: no reference step");
        let (c, rc) = (mean(&ours), mean(&refs));
        println!(
            "{name}: no reference stride; step cadence {c:.2} vs {rc:.2} ({:+.2} %) over {} steps",
            (c - rc) / rc * 100.0,
            refs.len()
        );
        if ((c - rc) / rc).abs() > 0.01 {
            failures.push(format!("{name}: step cadence {c:.2} vs {rc:.2}"));
        }
        return failures;
    }
    let (mut c, mut rc, mut len, mut rlen, mut w, mut rw) =
        (vec![], vec![], vec![], vec![], vec![], vec![]);
    for r in strides {
        let Some(s) = analysis
            .strides
            .iter()
            .find(|s| s.foot == r.foot && close(s.start_secs, r.start) && close(s.end_secs, r.end))
        else {
            failures.push(format!("{name}: reference stride {r:?} not found"));
            continue;
        };
        println!(
            "{name}: {} stride {:.3}-{:.3} s vs {:.3}-{:.3} s: cadence {:.2} vs {:.2} ({:+.2} %)",
            r.foot.name(),
            s.start_secs,
            s.end_secs,
            r.start,
            r.end,
            s.cadence_steps_per_min,
            r.cadence,
            (s.cadence_steps_per_min - r.cadence) / r.cadence * 100.0
        );
        c.push(s.cadence_steps_per_min);
        rc.push(r.cadence);
        len.push(s.stride_length_m);
        rlen.push(r.length);
        if let Some(v) = s.step_width_m {
            w.push(v);
            rw.push(r.width);
        }
    }
    if c.is_empty() {
        return failures;
    }
    let (c, rc, len, rlen) = (mean(&c), mean(&rc), mean(&len), mean(&rlen));
    println!(
        "{name}: over {} matched strides (of {} found): cadence {c:.2} vs {rc:.2} ({:+.2} %), \
         stride {len:.3} vs {rlen:.3} m ({:+.1} cm), step width {} vs {} m",
        strides.len(),
        analysis.summary.strides,
        (c - rc) / rc * 100.0,
        (len - rlen) * 100.0,
        if w.is_empty() {
            "-".into()
        } else {
            format!("{:.3}", mean(&w))
        },
        if rw.is_empty() {
            "-".into()
        } else {
            format!("{:.3}", mean(&rw))
        },
    );
    if ((c - rc) / rc).abs() > 0.01 {
        failures.push(format!("{name}: cadence {c:.2} vs {rc:.2}"));
    }
    if (len - rlen).abs() > 0.02 {
        failures.push(format!("{name}: stride length {len:.3} vs {rlen:.3}"));
    }
    if !w.is_empty() && (mean(&w) - mean(&rw)).abs() > 0.01 {
        failures.push(format!(
            "{name}: step width {:.3} vs {:.3}",
            mean(&w),
            mean(&rw)
        ));
    }
    failures
}

fn run_file(
    folder: &str,
    file: &str,
    plates: &[Reference],
    labels: &[Reference],
    treadmill: bool,
) -> Vec<String> {
    let Some(path) = trigait_test_data::shared_file(&format!("{folder}/{file}")) else {
        return Vec::new();
    };
    let set = trigait_motion::read_markers(&path).unwrap();
    let l = landmarks(&set);
    let analysis =
        analyse_landmarks(&l, &GaitParams::default()).unwrap_or_else(|e| panic!("{file}: {e}"));
    assert_eq!(analysis.heel_source, HeelSource::HeelMarker);
    assert!(!analysis.running, "{file} is walking");
    // Clean marker walks: every stride and step travels with the body.
    assert!(
        analysis.inconsistent_steps.is_empty() && analysis.inconsistent_strides.is_empty(),
        "{file}: left out {:?} {:?}",
        analysis.inconsistent_steps,
        analysis.inconsistent_strides
    );
    assert_eq!(
        analysis.treadmill.is_some(),
        treadmill,
        "{file}: treadmill?"
    );
    let belt = analysis.treadmill.map_or(Vector2::zeros(), |t| {
        Vector2::new(t.walking_direction[0], t.walking_direction[1])
            * reference_belt_speed(&l, plates)
    });
    let mut failures = check_events(file, &analysis, plates);
    let (strides, steps) =
        reference_strides(&l, &merged_strikes(&l, plates, labels, treadmill), belt);
    failures.extend(check_params(file, &analysis, &strides, &steps));
    failures
}

/// Treadmill belt speed from the heel markers' horizontal speed in the middle of the clean
/// plate stances (from HS + 30 % to TO − 30 % of each contact): what the plates say is stance,
/// not what our detector says.
fn reference_belt_speed(l: &Landmarks, plates: &[Reference]) -> f64 {
    let rate = l.rate_hz;
    let mut speeds = Vec::new();
    for hs in plates.iter().filter(|r| r.kind == EventKind::HeelStrike) {
        let Some(to) = plates
            .iter()
            .filter(|r| r.kind == EventKind::ToeOff && r.foot == hs.foot && r.time > hs.time)
            .map(|r| r.time)
            .min_by(f64::total_cmp)
        else {
            continue;
        };
        if to - hs.time > 0.8 {
            continue;
        }
        let (a, b) = (hs.time + 0.3 * (to - hs.time), to - 0.3 * (to - hs.time));
        let track = &l.heel[hs.foot as usize];
        let (pa, pb) = (at(track, rate, a), at(track, rate, b));
        speeds.push(Vector2::new(pb.x - pa.x, pb.y - pa.y).norm() / (b - a));
    }
    speeds.sort_by(f64::total_cmp);
    let v = speeds[speeds.len() / 2];
    println!(
        "reference belt speed {v:.3} m/s from {} stances",
        speeds.len()
    );
    v
}

fn report(failures: Vec<String>) {
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// One of the three child walks (Plug-in Gait + Oxford Foot Model, > 255 labels, both
/// directions): its two plate contacts and the lab's labelled strikes.
fn biomechzoo_child_walk(name: &str) {
    let folder = "mocap-biomechzoo-child-walk-fp";
    let Some(text) = source(folder) else { return };
    let plates_all = section(&text, "Force-plate events", &["Lab-labelled"]);
    let labels_all = section(&text, "Lab-labelled EVENT", &["Good for"]);
    let names = ["HC036A10", "HC039A17", "HC050A11"];
    let others = names.map(|n| if n == name { "\u{0}" } else { n });
    let plates = plate_events(section(plates_all, name, &others));
    let labels = labelled_strikes(section(labels_all, &format!("{name} ("), &others));
    assert_eq!(plates.len(), 4, "{name}: {plates:?}");
    assert!(labels.len() >= 2, "{name}: {labels:?}");
    report(run_file(
        folder,
        &format!("{name}.c3d"),
        &plates,
        &labels,
        false,
    ));
}

/// A child walking along −Y: one stride per foot, each closed by a labelled strike off the
/// plates.
#[test]
fn biomechzoo_hc036a10() {
    biomechzoo_child_walk("HC036A10");
}

/// A child walking along +Y: one stride per foot, each closed by a labelled strike off the
/// plates (the left one where the heel reaches its lowest point still moving forward at
/// 1.8 m/s and lands 40 ms later).
#[test]
fn biomechzoo_hc039a17() {
    biomechzoo_child_walk("HC039A17");
}

/// A child walking along +Y: two plate contacts and no further labelled strike, so one step.
#[test]
fn biomechzoo_hc050a11() {
    biomechzoo_child_walk("HC050A11");
}

/// An adult CGM2 walk over 4 plates (FP1 struck by both feet: its heel strike only).
#[test]
fn ktk_cgm2_walk() {
    let folder = "mocap-ktk-cgm2-walk-4fp";
    let Some(text) = source(folder) else { return };
    let plates = plate_events(section(&text, "Force-plate events", &["Lab-labelled"]));
    let labels = labelled_strikes(section(&text, "Lab-labelled EVENT", &["Good for"]));
    assert_eq!(plates.len(), 5, "{plates:?}");
    report(run_file(folder, "walk.c3d", &plates, &labels, false));
}

/// A BTS walk: Y up, lower-case names with spaces, long gaps, no EVENT section.
#[test]
fn bts_walk() {
    let folder = "mocap-bts-walk-6fp";
    let Some(text) = source(folder) else { return };
    let plates = plate_events(section(&text, "Force-plate events", &["(FP2, FP3"]));
    assert_eq!(plates.len(), 6, "{plates:?}");
    report(run_file(folder, "BTS.c3d", &plates, &[], false));
}

/// 12 s of split-belt treadmill walking: detected, belt speed estimated, strides belt-corrected;
/// the recording starts 52 ms before a right plate contact.
#[test]
fn gaitalytics_treadmill_walk() {
    let folder = "mocap-gaitalytics-treadmill-walk";
    let Some(text) = source(folder) else { return };
    let plates = plate_events(section(&text, "Force-plate events", &["* = contact"]));
    let labels = labelled_strikes(section(&text, "Labelled EVENT", &["(EVENT:TIMES"]));
    assert_eq!(plates.len(), 33, "{plates:?}");
    report(run_file(
        folder,
        "treadmill_events.c3d",
        &plates,
        &labels,
        true,
    ));
}

/// Declaring the treadmill with the belt speed gives the same strides as detecting it.
#[test]
fn treadmill_declared_matches_detected() {
    let Some(path) =
        trigait_test_data::shared_file("mocap-gaitalytics-treadmill-walk/treadmill_events.c3d")
    else {
        return;
    };
    let l = landmarks(&trigait_motion::read_markers(&path).unwrap());
    let detected = analyse_landmarks(&l, &GaitParams::default()).unwrap();
    let t = detected.treadmill.unwrap();
    assert!(!t.declared && t.speed_estimated);
    let params = GaitParams {
        treadmill: TreadmillMode::Treadmill {
            belt_speed_mps: Some(t.belt_speed_mps),
        },
        ..GaitParams::default()
    };
    let declared = analyse_landmarks(&l, &params).unwrap();
    let dt = declared.treadmill.unwrap();
    assert!(dt.declared && !dt.speed_estimated);
    assert_eq!(declared.summary.strides, detected.summary.strides);
    let overground = analyse_landmarks(
        &l,
        &GaitParams {
            treadmill: TreadmillMode::Overground,
            ..GaitParams::default()
        },
    );
    assert!(
        overground.is_err(),
        "a treadmill clip read overground has no walking"
    );
}

/// `folder/file` cut to start at each frame of its first 0.75 s: a heel strike found in the
/// first 0.6 s is a plate contact (within 20 ms), never the first frames of a clip that starts
/// with a heel on the floor; and a plate contact that comes 30 ms to 0.5 s after the cut is
/// found (the heel is then seen coming down).
fn clip_start(folder: &str, file: &str, plates: &[Reference]) -> Vec<String> {
    let Some(path) = trigait_test_data::shared_file(&format!("{folder}/{file}")) else {
        return Vec::new();
    };
    let l = landmarks(&trigait_motion::read_markers(&path).unwrap());
    let mut failures = Vec::new();
    for from in 0..75 {
        let cut = Landmarks {
            rate_hz: l.rate_hz,
            pelvis: l.pelvis[from..].to_vec(),
            heel: [0, 1].map(|s| l.heel[s][from..].to_vec()),
            toe: [0, 1].map(|s| l.toe[s][from..].to_vec()),
            heel_source: l.heel_source,
        };
        let start = from as f64 / l.rate_hz;
        let analysis = analyse_landmarks(&cut, &GaitParams::default())
            .unwrap_or_else(|e| panic!("{file} cut at {start:.2} s: {e}"));
        let strikes: Vec<(Foot, f64)> = analysis
            .events
            .iter()
            .filter(|e| e.kind == EventKind::HeelStrike && e.time_secs < 0.6)
            .map(|e| (e.foot, e.time_secs + start))
            .collect();
        for (foot, t) in &strikes {
            if !plates.iter().any(|r| {
                r.kind == EventKind::HeelStrike && r.foot == *foot && (r.time - t).abs() <= 0.02
            }) {
                failures.push(format!(
                    "{file} cut at {start:.2} s: {} heel strike at {t:.3} s is no plate contact",
                    foot.name()
                ));
            }
        }
        for r in plates.iter().filter(|r| {
            r.kind == EventKind::HeelStrike && r.time >= start + 0.03 && r.time < start + 0.5
        }) {
            if !strikes
                .iter()
                .any(|(f, t)| *f == r.foot && (r.time - t).abs() <= 0.02)
            {
                failures.push(format!(
                    "{file} cut at {start:.2} s: {} plate contact at {:.3} s not found",
                    r.foot.name(),
                    r.time
                ));
            }
        }
    }
    failures
}

/// The treadmill recording starts 52 ms before a right contact, with the left foot on the belt.
#[test]
fn treadmill_clip_start() {
    let folder = "mocap-gaitalytics-treadmill-walk";
    let Some(text) = source(folder) else { return };
    let plates = plate_events(section(&text, "Force-plate events", &["* = contact"]));
    report(clip_start(folder, "treadmill_events.c3d", &plates));
}

/// The CGM2 walk starts with the left heel at rest (settling by 1 mm) and the right one 0.14 s
/// before its contact.
#[test]
fn ktk_clip_start() {
    let folder = "mocap-ktk-cgm2-walk-4fp";
    let Some(text) = source(folder) else { return };
    let plates = plate_events(section(&text, "Force-plate events", &["Lab-labelled"]));
    report(clip_start(folder, "walk.c3d", &plates));
}
