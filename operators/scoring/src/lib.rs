//! Scoring estimated joint positions against ground truth, one rule for everyone: `trigait
//! eval` (simulated snapshots) and the dataflow's `recorder` (fused poses against the
//! simulator's truth) report their RMSE, per-axis and per-joint RMSE and percentiles from the
//! same [`PositionErrors`] and [`percentile`], and the recorder finds the truth at a pose's
//! instant with [`TruthTrack`].
//!
//! Errors are 3-D Euclidean distances in metres, world frame (x along the walk, z up).

#![warn(missing_docs)]

use std::collections::BTreeMap;

use nalgebra::{Point3, Vector3};
use trigait_skeleton::Joint;

/// The `q`-quantile (0 ≤ q ≤ 1) of ascending `sorted` by the nearest-rank rule: the smallest
/// value with at least a share `q` of the sample at or below it (`q = 0` gives the smallest).
/// `None` for an empty sample.
#[must_use]
pub fn percentile<T: Copy>(sorted: &[T], q: f64) -> Option<T> {
    let rank = (sorted.len() as f64 * q.clamp(0.0, 1.0)).ceil() as usize;
    sorted.get(rank.saturating_sub(1)).copied()
}

/// √(sum of squares / count); 0 for no samples.
#[must_use]
pub fn rmse(sum_of_squares: f64, count: usize) -> f64 {
    (sum_of_squares / count.max(1) as f64).sqrt()
}

/// Errors of joint estimates against the truth, accumulated sample by sample and mergeable
/// (eval's worker threads each keep one).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct PositionErrors {
    /// |estimate − truth| of every sample, m, in push order.
    errors_m: Vec<f64>,
    squared_xyz: [f64; 3],
    per_joint: BTreeMap<Joint, (f64, usize)>,
}

impl PositionErrors {
    /// Adds one sample: `error = estimate − truth` of `joint`, world frame, m.
    pub fn push(&mut self, joint: Joint, error: Vector3<f64>) {
        self.errors_m.push(error.norm());
        for (sum, e) in self.squared_xyz.iter_mut().zip(error.iter()) {
            *sum += e * e;
        }
        let pj = self.per_joint.entry(joint).or_default();
        pj.0 += error.norm_squared();
        pj.1 += 1;
    }

    /// Adds another tally's samples after this one's.
    pub fn merge(&mut self, other: PositionErrors) {
        self.errors_m.extend(other.errors_m);
        for (a, b) in self.squared_xyz.iter_mut().zip(other.squared_xyz) {
            *a += b;
        }
        for (joint, (sq, n)) in other.per_joint {
            let e = self.per_joint.entry(joint).or_default();
            e.0 += sq;
            e.1 += n;
        }
    }

    /// Samples scored.
    #[must_use]
    pub fn count(&self) -> usize {
        self.errors_m.len()
    }

    /// Whether nothing was scored.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.errors_m.is_empty()
    }

    /// Sum of the squared errors, m².
    #[must_use]
    pub fn sum_of_squares(&self) -> f64 {
        self.errors_m.iter().map(|e| e * e).sum()
    }

    /// Root mean square error, m (0 when empty).
    #[must_use]
    pub fn rmse_m(&self) -> f64 {
        rmse(self.sum_of_squares(), self.count())
    }

    /// Mean error, m (0 when empty), summed smallest first.
    #[must_use]
    pub fn mean_m(&self) -> f64 {
        self.sorted_m().iter().sum::<f64>() / self.count().max(1) as f64
    }

    /// RMSE of the x, y and z components, m.
    #[must_use]
    pub fn rmse_xyz_m(&self) -> [f64; 3] {
        self.squared_xyz.map(|s| rmse(s, self.count()))
    }

    /// RMSE per joint, m.
    #[must_use]
    pub fn per_joint_rmse_m(&self) -> BTreeMap<Joint, f64> {
        self.per_joint
            .iter()
            .map(|(j, (sq, n))| (*j, rmse(*sq, *n)))
            .collect()
    }

    /// The errors, ascending, m.
    #[must_use]
    pub fn sorted_m(&self) -> Vec<f64> {
        let mut v = self.errors_m.clone();
        v.sort_by(f64::total_cmp);
        v
    }

    /// The `q`-quantile of the errors ([`percentile`]), m; NaN when empty.
    #[must_use]
    pub fn percentile_m(&self, q: f64) -> f64 {
        percentile(&self.sorted_m(), q).unwrap_or(f64::NAN)
    }

    /// The largest error, m; NaN when empty.
    #[must_use]
    pub fn max_m(&self) -> f64 {
        self.percentile_m(1.0)
    }
}

/// p50/p95/p99/max of a sample by the [`percentile`] rule, in milliseconds (serialised as is
/// into a run's `summary.json`).
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize)]
pub struct Percentiles {
    /// Samples.
    pub count: usize,
    /// Median.
    pub p50: f64,
    /// 95th percentile: the tail that a few outliers (1 % of the sample) do not move.
    pub p95: f64,
    /// 99th percentile.
    pub p99: f64,
    /// Largest.
    pub max: f64,
}

impl Percentiles {
    /// From nanosecond samples (all zeros for none).
    #[must_use]
    pub fn of_nanos(values: &[i64]) -> Self {
        let mut v = values.to_vec();
        v.sort_unstable();
        let at = |q: f64| percentile(&v, q).map_or(0.0, |n| n as f64 * 1e-6);
        Self {
            count: v.len(),
            p50: at(0.5),
            p95: at(0.95),
            p99: at(0.99),
            max: at(1.0),
        }
    }
}

/// Ground truth as it streams in: world positions of the joints at true instants (ns), kept
/// over a horizon behind the newest, and interpolated linearly to the instant of an estimate.
#[derive(Debug, Clone)]
pub struct TruthTrack {
    samples: BTreeMap<i64, BTreeMap<Joint, Point3<f64>>>,
    horizon_nanos: i64,
    max_span_nanos: i64,
}

impl TruthTrack {
    /// Keeps `horizon_nanos` of truth behind the newest instant; interpolates only between
    /// samples at most `max_span_nanos` apart.
    #[must_use]
    pub fn new(horizon_nanos: i64, max_span_nanos: i64) -> Self {
        Self {
            samples: BTreeMap::new(),
            horizon_nanos,
            max_span_nanos,
        }
    }

    /// Adds the truth of one instant; returns whether it was new (an instant already held is
    /// left as it was).
    pub fn insert(&mut self, at_nanos: i64, joints: BTreeMap<Joint, Point3<f64>>) -> bool {
        if self.samples.contains_key(&at_nanos) {
            return false;
        }
        self.samples.insert(at_nanos, joints);
        if let Some((&newest, _)) = self.samples.last_key_value() {
            self.samples = self.samples.split_off(&(newest - self.horizon_nanos));
        }
        true
    }

    /// Whether no truth is held.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.samples.is_empty()
    }

    /// The newest instant held, ns.
    #[must_use]
    pub fn newest_nanos(&self) -> Option<i64> {
        self.samples.last_key_value().map(|(t, _)| *t)
    }

    /// True position of `joint` at `at_nanos`, interpolated between the samples around it.
    #[must_use]
    pub fn at(&self, joint: Joint, at_nanos: i64) -> Option<Point3<f64>> {
        let (t0, a) = self.samples.range(..=at_nanos).next_back()?;
        let (t1, b) = self.samples.range(at_nanos..).next()?;
        if t1 - t0 > self.max_span_nanos {
            return None;
        }
        let (a, b) = (a.get(&joint)?, b.get(&joint)?);
        if t1 == t0 {
            return Some(*a);
        }
        let f = (at_nanos - t0) as f64 / (t1 - t0) as f64;
        Some(a + (b - a) * f)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Nearest rank: p50 of 1..=100 is 50, p95 is 95, p99 99, max 100; one value is every
    /// percentile; nothing has none.
    #[test]
    fn nearest_rank_percentiles() {
        let v: Vec<i64> = (1..=100).collect();
        assert_eq!(percentile(&v, 0.5), Some(50));
        assert_eq!(percentile(&v, 0.95), Some(95));
        assert_eq!(percentile(&v, 0.99), Some(99));
        assert_eq!(percentile(&v, 1.0), Some(100));
        assert_eq!(percentile(&v, 0.0), Some(1));
        assert_eq!(percentile(&[7], 0.5), Some(7));
        assert_eq!(percentile::<f64>(&[], 0.5), None);
        let p = Percentiles::of_nanos(&[3_000_000]);
        assert_eq!((p.count, p.p50, p.p99, p.max), (1, 3.0, 3.0, 3.0));
        assert_eq!(Percentiles::of_nanos(&[]), Percentiles::default());
    }

    /// Errors of 3 cm and 4 cm along different axes: RMSE √((9+16)/2) cm, per axis and per
    /// joint as expected, and merging two halves gives the whole.
    #[test]
    fn rmse_per_axis_and_joint() {
        let mut a = PositionErrors::default();
        a.push(Joint::KneeLeft, Vector3::new(0.03, 0.0, 0.0));
        let mut b = PositionErrors::default();
        b.push(Joint::AnkleLeft, Vector3::new(0.0, 0.0, 0.04));
        a.merge(b);
        assert_eq!(a.count(), 2);
        assert!((a.rmse_m() - (0.0025_f64 / 2.0).sqrt()).abs() < 1e-15);
        let xyz = a.rmse_xyz_m();
        assert!((xyz[0] - 0.03 / 2f64.sqrt()).abs() < 1e-15 && xyz[1] == 0.0);
        assert!((a.per_joint_rmse_m()[&Joint::KneeLeft] - 0.03).abs() < 1e-15);
        assert!((a.max_m() - 0.04).abs() < 1e-15);
        assert!((a.mean_m() - 0.035).abs() < 1e-15);
    }

    /// Truth is interpolated between neighbouring instants, not across a long gap, and old
    /// instants fall off the horizon.
    #[test]
    fn truth_track_interpolates_within_span() {
        let mut t = TruthTrack::new(1_000, 20);
        let at = |x: f64| BTreeMap::from([(Joint::KneeLeft, Point3::new(x, 0.0, 0.5))]);
        assert!(t.insert(0, at(0.0)));
        assert!(t.insert(10, at(1.0)));
        assert!(!t.insert(10, at(5.0)), "an instant held stays");
        assert!((t.at(Joint::KneeLeft, 5).unwrap().x - 0.5).abs() < 1e-12);
        assert_eq!(t.at(Joint::KneeLeft, 10).unwrap().x, 1.0);
        assert!(t.at(Joint::HipLeft, 5).is_none());
        t.insert(100, at(2.0));
        assert!(
            t.at(Joint::KneeLeft, 50).is_none(),
            "90 ns apart > 20 ns span"
        );
        t.insert(2_000, at(3.0));
        assert!(t.at(Joint::KneeLeft, 5).is_none(), "fell off the horizon");
        assert_eq!(t.newest_nanos(), Some(2_000));
    }
}
