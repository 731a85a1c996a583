//! One joint of one sensor as a function of time: cubic Hermite between the sensor's samples,
//! never across a gap or a jump no body can make.

use nalgebra::{Point3, Vector3};

/// Where interpolation stops.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Limits {
    /// Longest time between two samples interpolated across, seconds.
    pub max_gap_secs: f64,
    /// Fastest a joint can move between two samples, m/s (a faster jump is a tracking error or
    /// a cut in the recording).
    pub max_speed_mps: f64,
}

/// A joint's position and velocity at one instant, and whether an inferred sample went in.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Sample {
    pub position: Point3<f64>,
    pub velocity: Vector3<f64>,
    pub inferred: bool,
}

/// One joint's samples from one sensor, sorted by time.
#[derive(Debug, Clone, Default)]
pub(crate) struct JointTrack {
    pub t: Vec<f64>,
    pub p: Vec<Point3<f64>>,
    pub inferred: Vec<bool>,
}

impl JointTrack {
    fn linked(&self, a: usize, b: usize, limits: &Limits) -> bool {
        let dt = self.t[b] - self.t[a];
        dt > 0.0
            && dt <= limits.max_gap_secs
            && (self.p[b] - self.p[a]).norm() <= limits.max_speed_mps * dt
    }

    /// The track at `t`: cubic Hermite with central-difference tangents (Catmull–Rom on
    /// uneven times) between the two samples around `t`, one-sided at the ends of a run;
    /// `None` outside the track, across a gap or across an impossible jump.
    pub fn at(&self, t: f64, limits: &Limits) -> Option<Sample> {
        let n = self.t.len();
        if n < 2 || !t.is_finite() || t < self.t[0] || t > self.t[n - 1] {
            return None;
        }
        let i = self.t.partition_point(|x| *x <= t).clamp(1, n - 1) - 1;
        if !self.linked(i, i + 1, limits) {
            return None;
        }
        let (p0, p1) = (self.p[i], self.p[i + 1]);
        let h = self.t[i + 1] - self.t[i];
        let chord = (p1 - p0) / h;
        let m0 = if i > 0 && self.linked(i - 1, i, limits) {
            (p1 - self.p[i - 1]) / (self.t[i + 1] - self.t[i - 1])
        } else {
            chord
        };
        let m1 = if i + 2 < n && self.linked(i + 1, i + 2, limits) {
            (self.p[i + 2] - p0) / (self.t[i + 2] - self.t[i])
        } else {
            chord
        };
        let s = (t - self.t[i]) / h;
        let (s2, s3) = (s * s, s * s * s);
        let position = Point3::from(
            p0.coords * (2.0 * s3 - 3.0 * s2 + 1.0)
                + m0 * (h * (s3 - 2.0 * s2 + s))
                + p1.coords * (-2.0 * s3 + 3.0 * s2)
                + m1 * (h * (s3 - s2)),
        );
        let velocity = (p0.coords * (6.0 * s2 - 6.0 * s) + p1.coords * (-6.0 * s2 + 6.0 * s)) / h
            + m0 * (3.0 * s2 - 4.0 * s + 1.0)
            + m1 * (3.0 * s2 - 2.0 * s);
        Some(Sample {
            position,
            velocity,
            inferred: self.inferred[i] || self.inferred[i + 1],
        })
    }
}

#[cfg(test)]
mod tests {
    use approx::assert_relative_eq;

    use super::*;

    const LIMITS: Limits = Limits {
        max_gap_secs: 0.1,
        max_speed_mps: 15.0,
    };

    fn track(f: impl Fn(f64) -> Point3<f64>, times: &[f64]) -> JointTrack {
        JointTrack {
            t: times.to_vec(),
            p: times.iter().map(|t| f(*t)).collect(),
            inferred: vec![false; times.len()],
        }
    }

    /// A quadratic path is reproduced exactly inside a run (Catmull–Rom is exact to second
    /// order on even spacing), with its velocity; gaps and jumps are refused.
    #[test]
    fn hermite_is_exact_on_quadratics_and_stops_at_gaps() {
        let f = |t: f64| Point3::new(t * t, 2.0 * t, 1.0 - t);
        let times: Vec<f64> = (0..10).map(|i| f64::from(i) / 30.0).collect();
        let tr = track(f, &times);
        let s = tr.at(0.11, &LIMITS).unwrap();
        assert_relative_eq!(s.position, f(0.11), epsilon = 1e-12);
        assert_relative_eq!(s.velocity, Vector3::new(0.22, 2.0, -1.0), epsilon = 1e-9);
        assert!(tr.at(-0.01, &LIMITS).is_none());
        assert!(tr.at(0.31, &LIMITS).is_none());
        let gap = track(f, &[0.0, 0.033, 0.5, 0.533]);
        assert!(gap.at(0.2, &LIMITS).is_none());
        let mut jump = track(f, &times);
        jump.p[5].x += 1.0;
        assert!(jump.at(5.5 / 30.0, &LIMITS).is_none());
    }
}
