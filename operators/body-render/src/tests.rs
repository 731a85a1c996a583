use nalgebra::{Isometry3, Point3};
use trigait_motion::{WalkerParams, walker};
use trigait_rig::Rig;
use trigait_skeleton::{Joint, MotionClip};

use super::*;

fn thesis_k1() -> Isometry3<f64> {
    let rig = Rig::builtin("thesis").unwrap();
    rig.sensors[0].world_from_kinect
}

/// A walker standing in the middle of the thesis walkway.
fn clip() -> MotionClip {
    let c = walker(&WalkerParams::default(), 2.0, 30.0).unwrap();
    c.transformed(&Isometry3::translation(-1.2, 0.0, 0.0))
}

fn quiet() -> RenderParams {
    RenderParams {
        noisy: false,
        ..RenderParams::default()
    }
}

/// Without a body, the floor pixels read the depth of the plane z = 0 seen from the pose: the
/// ray through each floor pixel, scaled by its depth, lands on the floor.
#[test]
fn empty_room_floor_is_on_the_floor() {
    let pose = thesis_k1();
    let mut r = Renderer::new(quiet(), &pose, &Room::default()).unwrap();
    let frame = r.render_bodies(&[], Vec::new());
    let k = Intrinsics::default();
    let mut on_floor = 0;
    for v in (HEIGHT / 2..HEIGHT).step_by(20) {
        for u in (0..WIDTH).step_by(20) {
            let mm = frame.depth.at_mm(u, v);
            if mm == 0 {
                continue;
            }
            let z = f64::from(mm) / 1000.0;
            let p = Point3::new(
                (k.cx - (u as f64 + 0.5)) / k.fx * z,
                (k.cy - (v as f64 + 0.5)) / k.fy * z,
                z,
            );
            let w = pose * p;
            if w.z.abs() < 0.01 {
                on_floor += 1;
            }
        }
    }
    assert!(on_floor > 100, "{on_floor} floor samples");
    assert!(frame.labels.iter().all(|&l| l == 0));
}

/// The leg joints of the truth project onto the pixels of their own leg, and the rendered
/// thigh is as wide as its model (≈ 13.5 cm at mid-thigh) at the distance it stands.
#[test]
fn truth_projects_onto_the_body() {
    let pose = thesis_k1();
    let clip = clip();
    let mut r = Renderer::new(quiet(), &pose, &Room::default()).unwrap();
    let out = r
        .render_pose(&BodyShape::default(), |j| clip.position(20, j))
        .unwrap();
    let k = Intrinsics::default();
    for j in [
        Joint::KneeLeft,
        Joint::KneeRight,
        Joint::AnkleLeft,
        Joint::AnkleRight,
    ] {
        let p = out.joint(j).unwrap();
        let px = k.project(&p).unwrap();
        let i = px.y as usize * WIDTH + px.x as usize;
        assert_ne!(out.labels[i], 0, "{j:?} at {px:?} is not on the body");
        // Joint centres are inside the limb: the surface is in front of them.
        let surface = f64::from(out.depth.as_mm()[i]) / 1000.0;
        assert!(
            surface < p.z && surface > p.z - 0.12,
            "{j:?}: {surface} vs {}",
            p.z
        );
    }
    let body = out.labels.iter().filter(|&&l| l != 0).count();
    assert!((2000..40000).contains(&body), "{body} body pixels");
}

/// With noise on, two renders of the same pose differ on the body by about the
/// time-of-flight σ at that distance, and the silhouette has a band of zeros and of depths
/// between body and room.
#[test]
fn noise_dropout_and_flying_pixels() {
    let pose = thesis_k1();
    let clip = clip();
    let mut r = Renderer::new(RenderParams::default(), &pose, &Room::default()).unwrap();
    let a = r
        .render_pose(&BodyShape::default(), |j| clip.position(20, j))
        .unwrap();
    let b = r
        .render_pose(&BodyShape::default(), |j| clip.position(20, j))
        .unwrap();
    let mut diffs = Vec::new();
    let (mut zeros, mut edge) = (0, 0);
    for i in WIDTH..PIXELS - WIDTH {
        let body = a.labels[i] != 0;
        let edge_px = body
            && [i - 1, i + 1, i - WIDTH, i + WIDTH]
                .iter()
                .any(|&n| a.labels[n] == 0);
        if edge_px {
            edge += 1;
            if a.depth.as_mm()[i] == 0 {
                zeros += 1;
            }
        } else if body && a.depth.as_mm()[i] > 0 && b.depth.as_mm()[i] > 0 {
            diffs.push(f64::from(a.depth.as_mm()[i]) - f64::from(b.depth.as_mm()[i]));
        }
    }
    let rms = (diffs.iter().map(|d| d * d).sum::<f64>() / diffs.len() as f64).sqrt() / 2f64.sqrt();
    // σ_tof at 2–3 m facing the sensor is 1.5–3 mm, more at grazing incidence.
    assert!((1.0..8.0).contains(&rms), "per-frame σ {rms} mm");
    let share = f64::from(zeros) / f64::from(edge);
    assert!((0.3..0.7).contains(&share), "dropout share {share}");
}

/// Bad parameters and missing joints are errors, not panics.
#[test]
fn errors() {
    let pose = thesis_k1();
    let bad = RenderParams {
        edge_dropout: 0.8,
        flying_pixels: 0.5,
        ..RenderParams::default()
    };
    assert!(matches!(
        Renderer::new(bad, &pose, &Room::default()),
        Err(Error::BadParameter { .. })
    ));
    let mut r = Renderer::new(quiet(), &pose, &Room::default()).unwrap();
    let e = r.render_pose(&BodyShape::default(), |_| None).unwrap_err();
    assert_eq!(e, Error::MissingJoint(Joint::HipLeft));
    let e = r
        .render_pose(&BodyShape::default(), |_| {
            Some(Point3::new(f64::NAN, 0.0, 0.0))
        })
        .unwrap_err();
    assert!(matches!(e, Error::MissingJoint(_)));
}

/// The renderer as first written, kept as the reference of the fast path: every ellipsoid
/// tested against every pixel of the image, σ and the discontinuity test computed per pixel
/// from the frame's depth, on a copy of the renderer's room and an RNG of the same seed.
fn reference_render(r: &Renderer, rng: &mut ChaCha8Rng, bodies: &[Body]) -> (Vec<u16>, Vec<u8>) {
    let p = &r.params;
    let mut z = r.room_z.clone();
    let mut incidence = r.room_incidence.clone();
    let mut labels = vec![0_u8; PIXELS];
    for e in bodies.iter().flat_map(|b| &b.ellipsoids) {
        let c = r.kinect_from_world * e.centre;
        if c.z - e.bounding_radius_m() < 0.05 {
            continue;
        }
        let q = Quadric::new(&r.kinect_from_world, e);
        for i in 0..PIXELS {
            if let Some((t, inc)) = q.hit(&r.rays[i], z[i]) {
                z[i] = t;
                incidence[i] = inc;
                labels[i] = e.part.label();
            }
        }
    }
    let mut out = vec![0_u16; PIXELS];
    for i in 0..PIXELS {
        let zi = z[i];
        if !zi.is_finite() || incidence[i] > trigait_kinect::MAX_INCIDENCE_RAD {
            continue;
        }
        let mut zm = zi;
        if p.noisy {
            let n: f64 = StandardNormal.sample(rng);
            zm += n * p.noise.tof_sigma_m(zi, incidence[i]);
            let far = neighbours_far(&z, i);
            if far - zi > p.edge_jump_m {
                let roll: f64 = rng.random();
                if roll < p.edge_dropout {
                    continue;
                }
                if roll < p.edge_dropout + p.flying_pixels {
                    let far = if far.is_finite() { far } else { zi + 1.0 };
                    zm = zi + rng.random::<f64>() * (far - zi);
                }
            }
        }
        if (p.noise.min_depth_m..=p.noise.max_depth_m).contains(&zm) {
            out[i] = (zm * 1000.0).round() as u16;
        }
    }
    (out, labels)
}

/// The fast path (bounding boxes from the tangent planes, the room's σ and discontinuities
/// from tables, the room restored in place between frames) renders exactly what the
/// brute-force reference renders: the same depth in every pixel and the same labels, with
/// noise on, frame after frame, from all three sensors of the thesis rig, for a body close
/// enough to a sensor to leave the image and for two bodies at once.
#[test]
fn fast_path_renders_what_the_reference_renders() {
    let rig = Rig::builtin("thesis").unwrap();
    let clip = walker(&WalkerParams::default(), 3.0, 30.0).unwrap();
    let shape = BodyShape::default();
    let body =
        |clip: &MotionClip, f: usize| Body::from_joints(&shape, |j| clip.position(f, j)).unwrap();
    for (s, sensor) in rig.sensors.iter().enumerate() {
        let params = RenderParams {
            seed: 7 + s as u64,
            ..RenderParams::default()
        };
        let mut r =
            Renderer::new(params.clone(), &sensor.world_from_kinect, &Room::default()).unwrap();
        // 1.2 m in front of the sensor, where the body is taller than the view.
        let axis = sensor.world_from_kinect.rotation * nalgebra::Vector3::z();
        let target = sensor.world_from_kinect.translation.vector + axis * 1.2;
        let pelvis = clip.position(10, Joint::SpineBase).unwrap();
        let near = clip.transformed(&Isometry3::translation(
            target.x - pelvis.x,
            target.y - pelvis.y,
            0.0,
        ));
        let mut frames: Vec<Vec<Body>> =
            (0..90).step_by(23).map(|f| vec![body(&clip, f)]).collect();
        frames.push(vec![body(&near, 10)]);
        frames.push(vec![
            body(&clip, 40),
            body(&clip.transformed(&Isometry3::translation(0.8, 0.6, 0.0)), 5),
        ]);
        frames.push(Vec::new());
        let mut rng = ChaCha8Rng::seed_from_u64(params.seed);
        let mut on_border = 0;
        for (k, bodies) in frames.iter().enumerate() {
            let fast = r.render_bodies(bodies, Vec::new());
            let (depth, labels) = reference_render(&r, &mut rng, bodies);
            on_border += (0..PIXELS)
                .filter(|i| {
                    labels[*i] != 0
                        && (i % WIDTH == 0 || i % WIDTH == WIDTH - 1 || i / WIDTH == HEIGHT - 1)
                })
                .count();
            assert_eq!(fast.labels, labels, "sensor {s} frame {k}: labels");
            let differ = fast
                .depth
                .as_mm()
                .iter()
                .zip(&depth)
                .filter(|(a, b)| a != b)
                .count();
            assert_eq!(differ, 0, "sensor {s} frame {k}: {differ} pixels differ");
        }
        assert!(
            on_border > 0,
            "sensor {s}: no frame had the body leave the image"
        );
    }
}
