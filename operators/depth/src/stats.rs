//! Small summary statistics shared by the reports.

/// Mean, standard deviation, minimum and maximum of a set of values.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Summary {
    /// Number of values.
    pub count: u64,
    /// Arithmetic mean.
    pub mean: f64,
    /// Population standard deviation.
    pub sd: f64,
    /// Smallest value.
    pub min: f64,
    /// Largest value.
    pub max: f64,
}

/// Streaming accumulator for a [`Summary`] (sums in f64; fine for millimetre-scale values).
#[derive(Debug, Clone, Copy, Default)]
pub struct SummaryAcc {
    n: u64,
    sum: f64,
    sumsq: f64,
    min: f64,
    max: f64,
}

impl SummaryAcc {
    /// Adds one value.
    pub fn push(&mut self, v: f64) {
        self.push_weighted(v, 1);
    }

    /// Adds `count` copies of one value.
    pub fn push_weighted(&mut self, v: f64, count: u64) {
        if count == 0 {
            return;
        }
        if self.n == 0 {
            self.min = v;
            self.max = v;
        } else {
            self.min = self.min.min(v);
            self.max = self.max.max(v);
        }
        self.n += count;
        self.sum += v * count as f64;
        self.sumsq += v * v * count as f64;
    }

    /// Adds pre-summed moments (count, Σv, Σv², min, max).
    pub fn push_moments(&mut self, count: u64, sum: f64, sumsq: f64, min: f64, max: f64) {
        if count == 0 {
            return;
        }
        if self.n == 0 {
            self.min = min;
            self.max = max;
        } else {
            self.min = self.min.min(min);
            self.max = self.max.max(max);
        }
        self.n += count;
        self.sum += sum;
        self.sumsq += sumsq;
    }

    /// Number of values pushed.
    #[must_use]
    pub fn count(&self) -> u64 {
        self.n
    }

    /// The summary, `None` when nothing was pushed.
    #[must_use]
    pub fn summary(&self) -> Option<Summary> {
        if self.n == 0 {
            return None;
        }
        let n = self.n as f64;
        let mean = self.sum / n;
        let var = (self.sumsq / n - mean * mean).max(0.0);
        Some(Summary {
            count: self.n,
            mean,
            sd: var.sqrt(),
            min: self.min,
            max: self.max,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Mean and population sd of a known set.
    #[test]
    fn summary_of_known_values() {
        let mut acc = SummaryAcc::default();
        for v in [2.0, 4.0, 4.0, 4.0, 5.0, 5.0, 7.0, 9.0] {
            acc.push(v);
        }
        let s = acc.summary().unwrap();
        assert_eq!(
            (s.count, s.mean, s.sd, s.min, s.max),
            (8, 5.0, 2.0, 2.0, 9.0)
        );
        assert!(SummaryAcc::default().summary().is_none());
    }
}
