//! Property tests: over the range of healthy walking, in any direction, the parameters of the
//! synthetic walker are recovered, and a rigid move of the whole walk changes nothing.
#![allow(clippy::unwrap_used)] // tests may unwrap (STYLE.md §6); helpers outside #[test] fns need saying so

mod common;

use common::Walk;
use nalgebra::Vector2;
use proptest::prelude::*;
use trigait_gait::{EventMethod, GaitParams, Tolerances, analyse, compare};

fn walk_strategy() -> impl Strategy<Value = Walk> {
    (
        0.8f64..1.8,   // speed, m/s
        0.9f64..1.3,   // stride time, s
        0.58f64..0.66, // stance fraction
        0.05f64..0.25, // step width, m
        -3.1f64..3.1,  // heading, rad
        0.0f64..1.0,   // phase of the first heel strike, s
        prop::bool::ANY,
    )
        .prop_map(
            |(speed, stride_time, stance, width, heading, phase, feet)| Walk {
                speed_mps: speed,
                stride_time_secs: stride_time,
                stance_fraction: stance,
                step_width_m: width,
                heading_rad: heading,
                first_left_hs_secs: phase,
                with_feet: feet,
                start: Vector2::new(-2.0 * heading.cos(), -2.0 * heading.sin()),
                ..Walk::default()
            },
        )
        // A human stride: the walker's hips keep their height, so its legs stretch with the
        // stride, and at 2.3 m (1.8 m/s at 1.29 s a stride) they stretch beyond the 30 % the
        // cleaning allows (99 leg samples rejected, the toe offs among them), as no leg does.
        .prop_filter("a human stride length", |w| w.stride_length_m() <= 1.8)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, ..ProptestConfig::default() })]

    /// Stride length, cadence and step width of the walker are recovered by both detectors,
    /// to well within the Kinect tolerances.
    #[test]
    fn parameters_are_recovered(walk in walk_strategy()) {
        let (clip, _) = walk.build();
        for method in [EventMethod::Coordinate, EventMethod::Velocity] {
            let mut params = GaitParams::default();
            params.events.method = method;
            let a = analyse(&clip, &params).unwrap();
            let s = &a.summary;
            prop_assert!(s.left_strides >= 3 && s.right_strides >= 3, "{method:?} {s:?}");
            let stride = s.stride_length_m.mean.unwrap();
            let cadence = s.cadence_steps_per_min.mean.unwrap();
            let width = s.step_width_m.mean.unwrap();
            prop_assert!((stride - walk.stride_length_m()).abs() < 0.01, "{method:?} stride {stride}");
            prop_assert!((cadence / walk.cadence() - 1.0).abs() < 0.005, "{method:?} cadence {cadence}");
            prop_assert!((width - walk.step_width_m).abs() < 0.01, "{method:?} width {width}");
        }
    }

    /// Moving the whole walk (turn about Z, shift on the floor) leaves every parameter as it was.
    #[test]
    fn rigid_moves_change_nothing(walk in walk_strategy(), yaw in -3.1f64..3.1, dx in -5.0f64..5.0, dy in -5.0f64..5.0) {
        let (clip, _) = walk.build();
        let moved = clip.transformed(&nalgebra::Isometry3::new(
            nalgebra::Vector3::new(dx, dy, 0.0),
            nalgebra::Vector3::new(0.0, 0.0, yaw),
        ));
        let a = analyse(&clip, &GaitParams::default()).unwrap();
        let b = analyse(&moved, &GaitParams::default()).unwrap();
        prop_assert_eq!(a.events.len(), b.events.len());
        let c = compare(&a.summary, &b.summary);
        let tight = Tolerances { stride_length_m: 1e-6, cadence_pct: 1e-6, step_width_m: 1e-6 };
        prop_assert!(c.within(&tight), "{c:?}");
    }
}
