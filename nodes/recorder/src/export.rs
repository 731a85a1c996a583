//! The thesis-style ring buffer (1000 positions per joint, thesis §6.4.5) and its exports: a
//! whitespace text file like the thesis's, and a CSV with the covariance and sensors used.

use std::collections::{BTreeMap, BTreeSet, VecDeque};
use std::fmt::Write as _;
use std::path::Path;

use eyre::Context;
use nalgebra::Point3;
use trigait_schema::FusedPose;
use trigait_skeleton::Joint;

/// One buffered position.
#[derive(Debug, Clone, PartialEq)]
pub struct Entry {
    /// Aligned-set sequence number.
    pub set_seq: u64,
    /// Fusion instant, server clock, ns.
    pub stamp_nanos: i64,
    /// World position, m.
    pub position: Point3<f64>,
    /// √trace of the covariance, m.
    pub sigma_m: f64,
    /// Sensors used.
    pub sensors_used: Vec<String>,
}

/// Positions per joint, the oldest dropped beyond `capacity`.
#[derive(Debug, Clone)]
pub struct Ring {
    capacity: usize,
    joints: BTreeMap<Joint, VecDeque<Entry>>,
}

impl Ring {
    /// An empty buffer keeping `capacity` positions per joint.
    #[must_use]
    pub fn new(capacity: usize) -> Self {
        Self {
            capacity: capacity.max(1),
            joints: BTreeMap::new(),
        }
    }

    /// Adds every fused joint of `pose`.
    pub fn push(&mut self, pose: &FusedPose) {
        for (joint, fused) in &pose.joints {
            let q = self.joints.entry(*joint).or_default();
            if q.len() == self.capacity {
                q.pop_front();
            }
            q.push_back(Entry {
                set_seq: pose.set_seq,
                stamp_nanos: pose.stamp_nanos,
                position: fused.position,
                sigma_m: fused.covariance.trace().max(0.0).sqrt(),
                sensors_used: fused.sensors_used.clone(),
            });
        }
    }

    /// Positions held for `joint`.
    #[cfg(test)]
    #[must_use]
    pub fn len(&self, joint: Joint) -> usize {
        self.joints.get(&joint).map_or(0, VecDeque::len)
    }

    /// The thesis text file: a header, then one line per instant — time in seconds from the
    /// first, then x y z (m, world frame) of each joint in column order (`nan` where a joint
    /// was not fused at that instant).
    #[must_use]
    pub fn thesis_text(&self) -> String {
        let joints: Vec<Joint> = self.joints.keys().copied().collect();
        let mut by_instant: BTreeMap<(i64, u64), BTreeMap<Joint, Point3<f64>>> = BTreeMap::new();
        for (joint, q) in &self.joints {
            for e in q {
                by_instant
                    .entry((e.stamp_nanos, e.set_seq))
                    .or_default()
                    .insert(*joint, e.position);
            }
        }
        let mut out =
            String::from("# trigait fused joint trajectories (thesis §6.4.5 text format)\n");
        out.push_str("# world frame, metres; columns: t_secs");
        for j in &joints {
            write!(out, " {0}_x {0}_y {0}_z", j.name()).ok();
        }
        out.push('\n');
        let t0 = by_instant.keys().next().map_or(0, |(t, _)| *t);
        for ((t, _), row) in &by_instant {
            write!(out, "{:.6}", (t - t0) as f64 * 1e-9).ok();
            for j in &joints {
                match row.get(j) {
                    Some(p) => write!(out, " {:.6} {:.6} {:.6}", p.x, p.y, p.z).ok(),
                    None => write!(out, " nan nan nan").ok(),
                };
            }
            out.push('\n');
        }
        out
    }

    /// CSV: `stamp_nanos,set_seq,joint,x_m,y_m,z_m,sigma_m,sensors_used` (sensors `;`-separated).
    #[must_use]
    pub fn csv(&self) -> String {
        let mut rows: BTreeSet<(i64, u64, usize, String)> = BTreeSet::new();
        for (joint, q) in &self.joints {
            for e in q {
                rows.insert((
                    e.stamp_nanos,
                    e.set_seq,
                    joint.index(),
                    format!(
                        "{},{},{},{:.6},{:.6},{:.6},{:.6},{}",
                        e.stamp_nanos,
                        e.set_seq,
                        joint.name(),
                        e.position.x,
                        e.position.y,
                        e.position.z,
                        e.sigma_m,
                        e.sensors_used.join(";")
                    ),
                ));
            }
        }
        let mut out = String::from("stamp_nanos,set_seq,joint,x_m,y_m,z_m,sigma_m,sensors_used\n");
        for (_, _, _, line) in rows {
            out.push_str(&line);
            out.push('\n');
        }
        out
    }

    /// Writes `trajectory.txt` and `trajectory.csv` into `dir`.
    pub fn write(&self, dir: &Path) -> eyre::Result<()> {
        let txt = dir.join("trajectory.txt");
        std::fs::write(&txt, self.thesis_text())
            .with_context(|| format!("writing {}", txt.display()))?;
        let csv = dir.join("trajectory.csv");
        std::fs::write(&csv, self.csv()).with_context(|| format!("writing {}", csv.display()))?;
        Ok(())
    }
}
