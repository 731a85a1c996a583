//! Simulator round trips: each metric recovers the property injected into
//! simulated frames within 10 %.

// Test helpers outside `#[test]` functions panic on failure by design.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use trigait_depth::accuracy::{AccuracyParams, Zone};
use trigait_depth::edge::{EdgeParams, edge_noise};
use trigait_depth::sim::{Scene, Shape, SimParams, Simulator};
use trigait_depth::{MetricsParams, SequenceAnalyzer, SequenceReport};

fn run(scene: &Scene, sim: SimParams, params: MetricsParams, frames: usize) -> SequenceReport {
    let mut sim = Simulator::new(scene, sim).unwrap();
    let mut analyzer = SequenceAnalyzer::new(params, None);
    for _ in 0..frames {
        analyzer.push(&sim.next_frame());
    }
    analyzer.report().unwrap()
}

fn within(measured: f64, truth: f64, rel: f64) -> bool {
    (measured - truth).abs() <= rel * truth.abs()
}

/// Temporal noise: the per-pixel temporal sd over 30 frames recovers the injected sd (plus the
/// 1 mm quantisation's 1/√12), and the thesis' Fig. 5.1 example — target at 2 m, sd 1.2 mm —
/// comes out as mean ≈ 2000 mm, sd ≈ 1.2 mm, accuracy ≈ 0.
#[test]
fn noise_sd_is_recovered() {
    for sd in [1.2, 2.0, 4.0] {
        let params = MetricsParams {
            accuracy: AccuracyParams {
                target_distance_m: Some(2.0),
                ..AccuracyParams::default()
            },
            ..MetricsParams::default()
        };
        let sim = SimParams {
            noise_sd_mm: sd,
            seed: 7,
            ..SimParams::default()
        };
        let r = run(&Scene::wall(2.0), sim, params, 30);
        let acc = r.accuracy.unwrap();
        let expected = (sd * sd + 1.0 / 12.0).sqrt();
        let temporal = acc.temporal_sd_mm.unwrap();
        // The population sd of 30 samples is biased low by ≈ 2.5 %.
        assert!(
            within(temporal, expected, 0.10),
            "sd {sd}: temporal {temporal}"
        );
        let depth = acc.depth_mm.unwrap();
        assert!(
            within(depth.sd, expected, 0.10),
            "sd {sd}: depth sd {}",
            depth.sd
        );
        assert!((depth.mean - 2000.0).abs() < 0.1, "{}", depth.mean);
        assert!(acc.accuracy_mm.abs() < 0.1);
        assert_eq!(acc.target, "given_distance");
    }
}

/// Quantisation: on a plane tilted 60° spanning about 1–4 m, eq. 3.2 (smallest non-zero step)
/// equals the injected quantisation step, and the mean step grows with distance (Fig. 5.3a).
#[test]
fn quantisation_step_is_recovered() {
    for q in [1.0, 2.0, 4.0] {
        let scene = Scene {
            tilt_x_deg: 60.0,
            ..Scene::wall(2.0)
        };
        let sim = SimParams {
            noise_sd_mm: 0.5,
            quantisation_mm: q,
            seed: 3,
            ..SimParams::default()
        };
        let r = run(&scene, sim, MetricsParams::default(), 1);
        let all = r.resolution.overall.clone().unwrap();
        let min = f64::from(all.min_nonzero_step_mm.unwrap());
        assert!(within(min, q, 0.10), "q {q}: min step {min}");
        assert_eq!(all.typical_min_step_mm, all.min_nonzero_step_mm);
        let bins: Vec<_> = r
            .resolution
            .by_distance
            .iter()
            .filter(|b| b.pairs > 5000)
            .collect();
        assert!(bins.len() >= 4, "{bins:?}");
        for w in bins.windows(2) {
            assert!(
                w[1].mean_step_mm > w[0].mean_step_mm,
                "{:?}",
                r.resolution.by_distance
            );
        }
    }
}

/// Structural noise: a wall with injected rings of amplitude A and period P gives back A and P
/// within 10 %; a wall without rings gives an amplitude near 0.
#[test]
fn ring_amplitude_and_period_are_recovered() {
    for (amp, period, dist) in [(3.0, 40.0, 1.0), (1.5, 25.0, 2.0), (5.0, 70.0, 3.0)] {
        let sim = SimParams {
            noise_sd_mm: 1.5,
            ring_amplitude_mm: amp,
            ring_period_px: period,
            seed: 11,
            ..SimParams::default()
        };
        let r = run(&Scene::wall(dist), sim, MetricsParams::default(), 30);
        let s = r.structural_noise.unwrap();
        assert!(
            within(s.ring_amplitude_mm, amp, 0.10),
            "A {amp}: {}",
            s.ring_amplitude_mm
        );
        assert!(
            within(s.ring_period_px, period, 0.10),
            "P {period}: {}",
            s.ring_period_px
        );
        assert!((s.plane_distance_m - dist).abs() < 0.005);
    }
    let sim = SimParams {
        noise_sd_mm: 1.5,
        seed: 11,
        ..SimParams::default()
    };
    let r = run(&Scene::wall(1.0), sim, MetricsParams::default(), 30);
    assert!(r.structural_noise.unwrap().ring_amplitude_mm < 0.1);
}

fn objects_scene() -> Scene {
    let mut scene = Scene::wall(2.5);
    scene.shapes.push(Shape::Disc {
        x_m: -0.3,
        y_m: 0.0,
        radius_m: 0.25,
        distance_m: 1.2,
    });
    scene.shapes.push(Shape::Rectangle {
        left_m: 0.15,
        top_m: -0.3,
        right_m: 0.6,
        bottom_m: 0.35,
        distance_m: 1.5,
    });
    scene
}

/// Edge noise: the no-data band injected along a disc's and a rectangle's contours is measured
/// as that many pixels wide (within 10 %), with and without the object mask, and every rim
/// pixel of a banded object is affected; without a band the width is ~0 and nothing is affected.
#[test]
fn dropout_band_width_is_recovered() {
    for width in [0.0, 1.0, 2.0, 3.0] {
        let sim = SimParams {
            noise_sd_mm: 1.0,
            edge_dropout_px: width,
            seed: 5,
            ..SimParams::default()
        };
        let mut sim = Simulator::new(&objects_scene(), sim).unwrap();
        let mask = sim.object_mask().unwrap();
        let frame = sim.next_frame();
        for m in [None, Some(&mask)] {
            let (e, _, _) = edge_noise(&frame, m, &EdgeParams::default());
            let w = e.band_width_px.unwrap();
            eprintln!(
                "width {width} mask {}: {w:?} affected {}",
                m.is_some(),
                e.affected_share
            );
            if width == 0.0 {
                assert!(w.mean < 0.1, "{w:?}");
                assert!(e.affected_share < 0.01);
            } else {
                assert!(
                    within(w.mean, width, 0.10),
                    "width {width}, mask {}: {w:?}",
                    m.is_some()
                );
                assert!(e.affected_share > 0.95, "{}", e.affected_share);
            }
            assert!(
                e.rim_pixels > 800 && e.rim_pixels_with_background == e.rim_pixels,
                "{e:?}"
            );
        }
    }
}

/// Zone shares on a known plane: a wall at 2 m with a ring bias; the zone shares inside the
/// cone match those of the simulator's noise-free bias field within 10 %.
#[test]
fn zone_shares_are_recovered() {
    let sim_params = SimParams {
        noise_sd_mm: 1.0,
        ring_amplitude_mm: 6.0,
        ring_period_px: 60.0,
        seed: 21,
        ..SimParams::default()
    };
    let params = MetricsParams {
        accuracy: AccuracyParams {
            target_distance_m: Some(2.0),
            ..AccuracyParams::default()
        },
        ..MetricsParams::default()
    };
    let sim = Simulator::new(&Scene::wall(2.0), sim_params).unwrap();
    // Ground truth from the noise-free bias field.
    let mut counts = [0usize; 3];
    for i in 0..trigait_depth::PIXELS {
        let (x, y) = sim.rays().at(i);
        if !trigait_depth::frame::in_elliptical_cone(x, y, 70.0, 60.0) {
            continue;
        }
        let bias = sim.biased_mm()[i] - sim.surface_mm()[i];
        counts[params.accuracy.zone(bias.abs()) as usize] += 1;
    }
    let n = counts.iter().sum::<usize>() as f64;
    let truth = counts.map(|c| c as f64 / n);
    let r = run(&Scene::wall(2.0), sim_params, params, 30);
    let z = r.accuracy.unwrap().zones_in_cone;
    for (k, (m, t)) in [z.green, z.yellow, z.red].iter().zip(truth).enumerate() {
        assert!(
            t > 0.1,
            "zone {k} must be populated for the test to mean anything"
        );
        assert!(within(*m, t, 0.10), "zone {k}: measured {m}, truth {t}");
    }
    assert_eq!(z.pixels as f64, n);
    let _ = Zone::Green;
}

/// Without a given distance the target plane is fitted: a wall tilted 30° is found with its
/// tilt and the noise-only frames are all green.
#[test]
fn fitted_target_plane() {
    let scene = Scene {
        tilt_y_deg: 30.0,
        ..Scene::wall(2.0)
    };
    let sim = SimParams {
        noise_sd_mm: 1.0,
        seed: 2,
        ..SimParams::default()
    };
    let r = run(&scene, sim, MetricsParams::default(), 30);
    let acc = r.accuracy.unwrap();
    assert_eq!(acc.target, "fitted_plane");
    assert!(
        (acc.target_tilt_deg - 30.0).abs() < 0.5,
        "{}",
        acc.target_tilt_deg
    );
    assert!(acc.zones_in_cone.green > 0.99);
    let h = r.entropy.unwrap().bits.unwrap();
    // Differences of two N(0, 1) draws quantised to 1 mm: entropy ≈ 2.5 bits, less with 29 samples.
    assert!(h.mean > 1.5 && h.mean < 3.0, "{h:?}");
}

/// A sequence that starts with frames of all zeros (a sensor starting up): the single-frame
/// metrics are taken from the first frame with depth, so the edge noise and the resolution come
/// out as they do for the same frames without the empty ones in front, and the empty frames
/// count in the sequence's frames and its valid share.
#[test]
fn empty_frames_in_front_leave_the_single_frame_metrics_alone() {
    let sim = SimParams {
        noise_sd_mm: 1.0,
        edge_dropout_px: 2.0,
        seed: 5,
        ..SimParams::default()
    };
    let frames: Vec<_> = {
        let mut sim = Simulator::new(&objects_scene(), sim).unwrap();
        (0..3).map(|_| sim.next_frame()).collect()
    };
    let report = |empty: usize| {
        let mut analyzer = SequenceAnalyzer::new(MetricsParams::default(), None);
        for _ in 0..empty {
            analyzer.push(&trigait_depth::DepthFrame::zeros());
        }
        for f in &frames {
            analyzer.push(f);
        }
        analyzer.report().unwrap()
    };
    let (plain, after) = (report(0), report(2));
    assert_eq!(after.frames, plain.frames + 2);
    assert!((after.valid_share - plain.valid_share * 3.0 / 5.0).abs() < 1e-12);
    assert_eq!(after.edge_noise.frames, 1);
    assert_eq!(after.edge_noise, plain.edge_noise);
    assert_eq!(after.resolution, plain.resolution);
    assert!(
        plain.edge_noise.affected_share > 0.95,
        "{:?}",
        plain.edge_noise
    );
}
