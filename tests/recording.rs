//! A trial recorded by `dataflow.yml`'s recorder replays through the same chain
//! (`dataflows/replay-recording.yml`, as fast as possible, on the recorded server stamps) and
//! gives the recorded run's fused poses, exactly.

#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use std::collections::BTreeMap;
use std::path::Path;

use common::{LOCK, finish, spawn_graph, workspace};
use trigait_recording::{FRAMES_FILE, POSES_FILE, RIG_FILE, read_frames, read_poses};
use trigait_skeleton::Joint;

/// `(instant, joint) → position` of a `poses.csv`.
fn poses(dir: &Path) -> BTreeMap<(i64, Joint), [f64; 3]> {
    read_poses(&dir.join(POSES_FILE))
        .unwrap()
        .into_iter()
        .map(|p| {
            (
                (p.stamp_nanos, p.joint),
                [p.position.x, p.position.y, p.position.z],
            )
        })
        .collect()
}

fn distance(a: [f64; 3], b: [f64; 3]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(a, b)| (a - b).powi(2))
        .sum::<f64>()
        .sqrt()
}

/// The live run records every frame of every sensor with its stamps and joints, and the rig;
/// its replay as fast as possible fuses the same joints at the same instants, every position
/// within 1e-6 m of the live run's.
#[test]
fn recorded_trial_replays_to_the_same_poses() {
    let _guard = LOCK.lock().unwrap_or_else(|e| e.into_inner());
    let graph = std::fs::read_to_string(workspace().join("dataflow.yml")).unwrap();
    let (child, dir) = spawn_graph("record-live", &graph, "8s");
    let live = finish(child, dir);
    assert!(live.success, "live run failed:\n{}", live.log);
    // A clean run's trajectory.csv grows to its end without a word.
    assert!(
        !live.log.contains("not extended while the run goes"),
        "{}",
        live.log
    );
    let frames = read_frames(&live.out_dir.join(FRAMES_FILE)).unwrap();
    let summary = live.summary();
    for k in ["k1", "k2", "k3"] {
        let recorded: Vec<_> = frames.iter().filter(|f| f.sensor_id == k).collect();
        // Every frame sync received is recorded (the summary counts the same frames).
        assert_eq!(
            recorded.len() as u64,
            summary["frames_in"][k].as_u64().unwrap(),
            "{k}: {summary:#}"
        );
        assert!(recorded.len() > 200, "{k}: {} frames", recorded.len());
        let synced = recorded
            .iter()
            .filter(|f| f.server_stamp_nanos.is_some())
            .count();
        // The first NTP exchanges come before a sensor is synchronised (about a second of
        // the run's eight on a loaded host).
        assert!(
            synced * 10 >= recorded.len() * 7,
            "{k}: {synced} synchronised"
        );
        // The legs, those in the sensor's view.
        assert!(
            recorded
                .iter()
                .all(|f| f.joints.iter().all(|j| Joint::LEGS.contains(&j.joint))),
            "{k}: legs only"
        );
        assert!(recorded.iter().any(|f| f.joints.len() == 6), "{k}: legs");
    }
    let rig = std::fs::read_to_string(live.out_dir.join(RIG_FILE)).unwrap();
    assert!(
        trigait_rig::Rig::from_yaml_str(&rig, "rig.yml").is_ok(),
        "{rig}"
    );

    calibrates_from_the_recording(&live.out_dir);

    let replay = std::fs::read_to_string(workspace().join("dataflows/replay-recording.yml"))
        .unwrap()
        .replace(
            "../out/frames.csv",
            &live.out_dir.join(FRAMES_FILE).display().to_string(),
        )
        .replace(
            "../out/rig.yml",
            &live.out_dir.join(RIG_FILE).display().to_string(),
        );
    let (child, dir) = spawn_graph("record-replay", &replay, "8s");
    let replayed = finish(child, dir);
    assert!(replayed.success, "replay failed:\n{}", replayed.log);
    // Every row of the replay's .rrd is on the `time` timeline: the unsynchronised frames at
    // the recording's start are drawn when they were received then, not on this run's clock.
    assert!(!replayed.log.contains("can't set time"), "{}", replayed.log);
    replayed.assert_sets_delivered();

    // The replaying `sync` took in the recorded frames in the recorded order, on the recorded
    // stamps and arrival instants.
    let placement = |dir: &Path| -> Vec<_> {
        read_frames(&dir.join(FRAMES_FILE))
            .unwrap()
            .into_iter()
            .map(|f| {
                (
                    f.sensor_id,
                    f.seq,
                    f.server_stamp_nanos,
                    f.received_nanos,
                    f.joints.len(),
                )
            })
            .collect()
    };
    assert!(
        placement(&live.out_dir) == placement(&replayed.out_dir),
        "the replay's frames.csv differs from the live run's in order or placement"
    );
    let sensors_used = |dir: &Path| -> BTreeMap<_, _> {
        read_poses(&dir.join(POSES_FILE))
            .unwrap()
            .into_iter()
            .map(|p| ((p.stamp_nanos, p.joint), p.sensors_used))
            .collect()
    };
    assert_eq!(
        sensors_used(&live.out_dir),
        sensors_used(&replayed.out_dir),
        "the sensors used per fused joint"
    );
    let (a, b) = (poses(&live.out_dir), poses(&replayed.out_dir));
    let only_live: Vec<_> = a.keys().filter(|k| !b.contains_key(k)).collect();
    let only_replay: Vec<_> = b.keys().filter(|k| !a.contains_key(k)).collect();
    let common: Vec<_> = a.keys().filter(|k| b.contains_key(k)).collect();
    let max_m = common
        .iter()
        .map(|k| distance(a[k], b[k]))
        .fold(0.0_f64, f64::max);
    let differing: Vec<_> = common
        .iter()
        .filter(|k| distance(a[**k], b[**k]) > 1e-6)
        .collect();
    eprintln!(
        "live {} joint positions, replay {}, common {}, max difference {max_m:e} m, {} above 1e-6 m; only live {only_live:?}, only replay {only_replay:?}",
        a.len(),
        b.len(),
        common.len(),
        differing.len()
    );
    assert!(
        a.len() > 1000,
        "the live run fused {} joint positions",
        a.len()
    );
    // The replay takes the frames in the order and at the clock readings the live `sync`
    // received them, so it makes the same sets from the same frames: every joint the live
    // run fused at every instant, and nothing else, to the rounding of the rig's round trip
    // through rig.yml.
    assert!(
        only_live.is_empty() && only_replay.is_empty(),
        "fused only live: {only_live:?}; only in the replay: {only_replay:?}"
    );
    assert!(
        differing.is_empty(),
        "{} of {} positions differ by more than 1e-6 m (max {max_m:e} m): {:?}",
        differing.len(),
        common.len(),
        &differing[..differing.len().min(10)]
    );

    replays_one_absurd_number_unfused(&live.out_dir, &a);
}

/// One coordinate of the recording overwritten with 1e300 (a corrupted byte, a unit slip): the
/// replay records the frame as it came, but `sync` leaves that joint out before it is fused or
/// interpolated into its neighbours, and the summary counts it. Before, the fused joint went
/// to 1e298 m in two poses, with a small sigma, and into every export.
fn replays_one_absurd_number_unfused(recording: &Path, live: &BTreeMap<(i64, Joint), [f64; 3]>) {
    let dir = common::scratch_dir("recording", "absurd");
    let text = std::fs::read_to_string(recording.join(FRAMES_FILE)).unwrap();
    let mut lines: Vec<String> = text.lines().map(str::to_owned).collect();
    let header: Vec<&str> = lines[0].split(',').collect();
    let x = header.iter().position(|c| *c == "x_m").unwrap();
    let row = lines.len() / 2;
    let mut cells: Vec<String> = lines[row].split(',').map(str::to_owned).collect();
    cells[x] = "1e300".to_owned();
    lines[row] = cells.join(",");
    std::fs::write(dir.join(FRAMES_FILE), lines.join("\n") + "\n").unwrap();
    std::fs::copy(recording.join(RIG_FILE), dir.join(RIG_FILE)).unwrap();
    let replay = std::fs::read_to_string(workspace().join("dataflows/replay-recording.yml"))
        .unwrap()
        .replace(
            "../out/frames.csv",
            &dir.join(FRAMES_FILE).display().to_string(),
        )
        .replace("../out/rig.yml", &dir.join(RIG_FILE).display().to_string());
    let (child, graph_dir) = spawn_graph("record-replay-absurd", &replay, "8s");
    let run = finish(child, graph_dir);
    assert!(run.success, "replay failed:\n{}", run.log);
    let summary = run.summary();
    let impossible: u64 = summary["impossible_joints"]
        .as_object()
        .unwrap()
        .values()
        .map(|v| v.as_u64().unwrap())
        .sum();
    assert_eq!(impossible, 1, "{summary:#}");
    // The frame is recorded as it came.
    let recorded = read_frames(&run.out_dir.join(FRAMES_FILE)).unwrap();
    assert!(
        recorded
            .iter()
            .flat_map(|f| &f.joints)
            .any(|j| j.position_in_kinect.x == 1e300),
        "the absurd number was not recorded"
    );
    let replayed = poses(&run.out_dir);
    let farthest = replayed
        .values()
        .flatten()
        .fold(0.0_f64, |m, c| m.max(c.abs()));
    assert!(farthest < 20.0, "a fused coordinate of {farthest:e} m");
    // Everything but that joint's neighbourhood is fused as live.
    let same = replayed
        .iter()
        .filter(|(k, p)| live.get(k).is_some_and(|q| distance(**p, *q) < 1e-6))
        .count();
    assert!(
        same + 10 >= live.len(),
        "{same} of {} live positions fused the same",
        live.len()
    );
}

/// `trigait calibrate --recording` on the live run's recording, started from a rig moved by up
/// to 30 cm and turned by up to 20°: the sensors' distances to each other (what the walk
/// determines whatever the world frame) come out within 2 cm of the true rig's.
fn calibrates_from_the_recording(out: &Path) {
    let rough = out.join("rough-rig.yml");
    std::fs::write(
        &rough,
        "name: rough\nsensors:\n\
         - id: k1\n  position: [-2.1, 2.3, 1.4]\n  look_at: [0.4, -0.3, 0.5]\n\
         - id: k2\n  position: [-2.5, -1.9, 1.6]\n  look_at: [-0.3, 0.4, 0.5]\n\
         - id: k3\n  position: [2.1, 0.3, 1.5]\n  look_at: [0.0, -0.5, 0.6]\n",
    )
    .unwrap();
    let calibrated = out.join("rig.calibrated.yml");
    let run = std::process::Command::new(env!("CARGO_BIN_EXE_trigait"))
        .args(["calibrate", "--recording"])
        .arg(out)
        .arg("--start-rig")
        .arg(&rough)
        .arg("--output")
        .arg(&calibrated)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&run.stdout);
    assert!(
        run.status.success(),
        "{stdout}{}",
        String::from_utf8_lossy(&run.stderr)
    );
    eprintln!("{stdout}");
    let got = trigait_rig::Rig::from_spec(&calibrated.display().to_string()).unwrap();
    let truth = trigait_rig::Rig::builtin("thesis").unwrap();
    let position = |rig: &trigait_rig::Rig, id: &str| {
        rig.sensors
            .iter()
            .find(|s| s.id == id)
            .unwrap()
            .world_from_kinect
            .translation
            .vector
    };
    for (a, b) in [("k1", "k2"), ("k1", "k3"), ("k2", "k3")] {
        let d = (position(&got, a) - position(&got, b)).norm();
        let t = (position(&truth, a) - position(&truth, b)).norm();
        assert!((d - t).abs() < 0.02, "{a}-{b}: {d:.3} m, truth {t:.3} m");
    }
}
