//! A synthetic walker with exactly known gait events, footprints and parameters.
//!
//! The pelvis moves at a constant speed along a 2-D path (straight lines and circular arcs).
//! Each foot is planted on a footprint for the stance phase and swings to the next footprint
//! with a trapezoidal speed profile (15 % ramps) and a 10 cm height bump, so the truth is known
//! to the sample: heel strike = arrival on a footprint, toe off = departure.
#![allow(dead_code, clippy::unwrap_used)]

use nalgebra::{Point3, Vector2};
use trigait_gait::Foot;
use trigait_skeleton::{Joint, MotionClip};

/// One piece of the pelvis path.
#[derive(Debug, Clone, Copy)]
pub enum Piece {
    /// Straight for this many metres.
    Straight(f64),
    /// Circular arc of this radius (m) through this angle (rad, + = left turn).
    Arc(f64, f64),
}

/// Parameters of the synthetic walk.
#[derive(Debug, Clone)]
pub struct Walk {
    pub rate_hz: f64,
    pub duration_secs: f64,
    pub speed_mps: f64,
    pub stride_time_secs: f64,
    pub stance_fraction: f64,
    pub step_width_m: f64,
    /// Time of the first left heel strike (may be negative: before the clip).
    pub first_left_hs_secs: f64,
    pub start: Vector2<f64>,
    pub heading_rad: f64,
    pub path: Vec<Piece>,
    pub with_feet: bool,
    /// Amplitude of deterministic pseudo-random noise added to every coordinate (m).
    pub noise_m: f64,
    /// Peak height of the swing foot above its stance height (m); running lifts it higher.
    pub lift_m: f64,
}

impl Default for Walk {
    fn default() -> Self {
        Self {
            rate_hz: 100.0,
            duration_secs: 6.0,
            speed_mps: 1.3,
            stride_time_secs: 1.1,
            stance_fraction: 0.62,
            step_width_m: 0.14,
            first_left_hs_secs: 0.23,
            start: Vector2::new(-3.0, 0.5),
            heading_rad: 0.0,
            path: vec![Piece::Straight(100.0)],
            with_feet: true,
            noise_m: 0.0,
            lift_m: 0.1,
        }
    }
}

/// A known event.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrueEvent {
    pub foot: Foot,
    pub heel_strike: bool,
    pub time_secs: f64,
}

impl Walk {
    pub fn stride_length_m(&self) -> f64 {
        self.speed_mps * self.stride_time_secs
    }

    pub fn cadence(&self) -> f64 {
        120.0 / self.stride_time_secs
    }

    /// Point and unit heading of the path at arc length `s`.
    pub fn path_at(&self, s: f64) -> (Vector2<f64>, Vector2<f64>) {
        let mut p = self.start;
        let mut heading = self.heading_rad;
        if s < 0.0 {
            // Before the start: continue the first heading backwards.
            let dir = Vector2::new(heading.cos(), heading.sin());
            return (p + dir * s, dir);
        }
        let mut left = s;
        for piece in &self.path {
            let dir = Vector2::new(heading.cos(), heading.sin());
            match *piece {
                Piece::Straight(len) => {
                    if left <= len {
                        return (p + dir * left, dir);
                    }
                    p += dir * len;
                    left -= len;
                }
                Piece::Arc(radius, angle) => {
                    let len = radius * angle.abs();
                    let normal = Vector2::new(-dir.y, dir.x) * angle.signum();
                    let centre = p + normal * radius;
                    let take = left.min(len);
                    let turned = heading + angle.signum() * take / radius;
                    let q = centre
                        - Vector2::new(-turned.sin(), turned.cos()) * angle.signum() * radius;
                    if left <= len {
                        return (q, Vector2::new(turned.cos(), turned.sin()));
                    }
                    p = q;
                    heading = turned;
                    left -= len;
                }
            }
        }
        let dir = Vector2::new(heading.cos(), heading.sin());
        (p + dir * left, dir)
    }

    fn hs_times(&self, foot: Foot) -> Vec<f64> {
        let offset = match foot {
            Foot::Left => 0.0,
            Foot::Right => self.stride_time_secs / 2.0,
        };
        let mut t = self.first_left_hs_secs + offset;
        while t > -2.0 * self.stride_time_secs {
            t -= self.stride_time_secs;
        }
        let mut out = Vec::new();
        while t < self.duration_secs + 2.0 * self.stride_time_secs {
            out.push(t);
            t += self.stride_time_secs;
        }
        out
    }

    /// Footprint (heel position on the floor) for a heel strike of `foot` at `t`.
    fn footprint(&self, foot: Foot, t: f64) -> Vector2<f64> {
        // The heel lands a quarter stride ahead of the pelvis.
        let s = self.speed_mps * t + 0.25 * self.stride_length_m();
        let (p, dir) = self.path_at(s);
        let left = Vector2::new(-dir.y, dir.x);
        let side = match foot {
            Foot::Left => 0.5,
            Foot::Right => -0.5,
        };
        p + left * side * self.step_width_m
    }

    /// Heel position (on the floor plane, plus height) of `foot` at `t`.
    fn heel(&self, foot: Foot, t: f64) -> (Vector2<f64>, f64, Vector2<f64>) {
        let hs = self.hs_times(foot);
        let k = hs.iter().rposition(|h| *h <= t).unwrap_or(0);
        let h0 = hs[k];
        let stance_end = h0 + self.stance_fraction * self.stride_time_secs;
        let here = self.footprint(foot, h0);
        let (_, dir_here) = self.path_at(self.speed_mps * h0);
        if t <= stance_end {
            return (here, 0.0, dir_here);
        }
        let next = self.footprint(foot, h0 + self.stride_time_secs);
        let swing = (1.0 - self.stance_fraction) * self.stride_time_secs;
        let phi = ((t - stance_end) / swing).clamp(0.0, 1.0);
        let p = trapezoid(phi);
        let pos = here + (next - here) * p;
        let d = next - here;
        let dir = if d.norm() > 1e-9 {
            d.normalize()
        } else {
            dir_here
        };
        (pos, self.lift_m * (std::f64::consts::PI * phi).sin(), dir)
    }

    fn noise(&self, seed: usize) -> f64 {
        if self.noise_m == 0.0 {
            return 0.0;
        }
        // A fixed hash mapped to [-1, 1], then scaled: deterministic and roughly uniform.
        let mut x = (seed as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ 0xD1B5_4A32_D192_ED03;
        x ^= x >> 33;
        x = x.wrapping_mul(0xFF51_AFD7_ED55_8CCD);
        x ^= x >> 33;
        ((x % 20_001) as f64 / 10_000.0 - 1.0) * self.noise_m
    }

    /// The clip (6 leg joints, plus feet when `with_feet`) and the true events in it.
    pub fn build(&self) -> (MotionClip, Vec<TrueEvent>) {
        let mut joints = Joint::LEGS.to_vec();
        if self.with_feet {
            joints.push(Joint::FootLeft);
            joints.push(Joint::FootRight);
        }
        let mut frame_index = 0usize;
        let clip = MotionClip::from_fn(
            "synthetic walk",
            self.rate_hz,
            self.duration_secs,
            joints.clone(),
            |joint, t| {
                let column = joints.iter().position(|j| *j == joint).unwrap_or(0);
                let seed = frame_index;
                frame_index += 1;
                let (pelvis, dir) = self.path_at(self.speed_mps * t);
                let left = Vector2::new(-dir.y, dir.x);
                let sway = 0.02 * (std::f64::consts::TAU * t / self.stride_time_secs).sin();
                let pelvis = pelvis + left * sway;
                let foot = match joint {
                    Joint::HipLeft | Joint::KneeLeft | Joint::AnkleLeft | Joint::FootLeft => {
                        Foot::Left
                    }
                    _ => Foot::Right,
                };
                let side = if foot == Foot::Left { 1.0 } else { -1.0 };
                let (heel, lift, foot_dir) = self.heel(foot, t);
                let p = match joint {
                    Joint::HipLeft | Joint::HipRight => {
                        let q = pelvis + left * side * 0.09;
                        Point3::new(q.x, q.y, 0.92)
                    }
                    Joint::AnkleLeft | Joint::AnkleRight => {
                        Point3::new(heel.x, heel.y, 0.08 + lift)
                    }
                    Joint::FootLeft | Joint::FootRight => {
                        let q = heel + foot_dir * 0.17;
                        Point3::new(q.x, q.y, 0.03 + lift)
                    }
                    _ => {
                        let hip = pelvis + left * side * 0.09;
                        let q = (hip + heel) / 2.0 + dir * 0.05;
                        Point3::new(q.x, q.y, 0.5 + lift / 2.0)
                    }
                };
                let n = |axis: usize| self.noise(seed * 3 + axis + column * 7_919);
                Some(Point3::new(p.x + n(0), p.y + n(1), p.z + n(2)))
            },
        )
        .unwrap();
        let mut truth = Vec::new();
        for foot in Foot::BOTH {
            for h in self.hs_times(foot) {
                for (t, heel_strike) in [
                    (h, true),
                    (h + self.stance_fraction * self.stride_time_secs, false),
                ] {
                    if t >= 0.0 && t <= self.duration_secs {
                        truth.push(TrueEvent {
                            foot,
                            heel_strike,
                            time_secs: t,
                        });
                    }
                }
            }
        }
        truth.sort_by(|a, b| a.time_secs.total_cmp(&b.time_secs));
        (clip, truth)
    }
}

/// Swing progress for swing phase `phi` ∈ [0, 1]: speed ramps up linearly over the first 15 %,
/// stays constant, ramps down over the last 15 %.
fn trapezoid(phi: f64) -> f64 {
    let r = 0.15;
    let vmax = 1.0 / (1.0 - r);
    if phi < r {
        vmax * phi * phi / (2.0 * r)
    } else if phi > 1.0 - r {
        let q = 1.0 - phi;
        1.0 - vmax * q * q / (2.0 * r)
    } else {
        vmax * (phi - r / 2.0)
    }
}
