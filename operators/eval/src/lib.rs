//! How good is each estimator on a given rig and motion? Plays the motion through the simulator
//! many times with independent noise (seeded trials), runs every method on every joint at
//! every frame, and compares the errors with the Cramér–Rao bound of the same geometry.
//!
//! Every sensor observes the same instant (a [`trigait_sim::Snapshot`]), so the numbers measure
//! the estimators alone; timing effects belong to the dataflow's summary. Each snapshot is
//! fused by [`trigait_fusion`], the code the dataflow's `trilaterate` node runs
//! ([`observe_snapshot`]).
//!
//! Methods are compared like for like: the error statistics of every method
//! ([`MethodReport::rmse_m`] and the rest) are computed on the *common* samples, those every
//! evaluated method solved, so one table compares one set of joint positions. Range-only
//! methods need three sensors and fusion only one, so fusion also solves samples the others
//! cannot; [`MethodReport::own`] scores each method on everything it solved.

#![warn(missing_docs)]

use std::collections::BTreeMap;
use std::str::FromStr;

use serde::Serialize;
use trigait_fusion::{FusedInstant, FusionRig, JointObservations, SensorSamples};
use trigait_scoring::{PositionErrors, rmse};
use trigait_sim::{Simulator, Snapshot};
use trigait_skeleton::{JointSample, TrackingState};
use trigait_trilateration::{Error as EstimateError, Method, Params, crb};

/// A method to evaluate, optionally wrapped in robust outlier rejection.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct MethodSpec {
    /// The estimator.
    pub method: Method,
    /// Wrapped in [`trigait_trilateration::robust`].
    pub robust: bool,
}

impl MethodSpec {
    /// The plain method.
    #[must_use]
    pub fn plain(method: Method) -> Self {
        Self {
            method,
            robust: false,
        }
    }

    /// Name as on the command line and in JSON: `fusion`, `fusion+robust`.
    #[must_use]
    pub fn name(&self) -> String {
        if self.robust {
            format!("{}+robust", self.method)
        } else {
            self.method.to_string()
        }
    }

    /// The estimator parameters for this spec on top of `base`.
    #[must_use]
    pub fn params(&self, base: &Params) -> Params {
        Params {
            method: self.method,
            robust: self.robust,
            ..base.clone()
        }
    }

    /// The default set: the four methods, then fusion with outlier rejection.
    #[must_use]
    pub fn defaults() -> Vec<MethodSpec> {
        let mut specs: Vec<MethodSpec> = Method::ALL.into_iter().map(MethodSpec::plain).collect();
        specs.push(MethodSpec {
            method: Method::Fusion,
            robust: true,
        });
        specs
    }
}

impl FromStr for MethodSpec {
    type Err = trigait_trilateration::UnknownMethod;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let s = s.trim();
        match s.strip_suffix("+robust") {
            Some(base) => Ok(MethodSpec {
                method: base.parse()?,
                robust: true,
            }),
            None => Ok(MethodSpec::plain(s.parse()?)),
        }
    }
}

/// What to evaluate.
#[derive(Debug, Clone)]
pub struct EvalConfig {
    /// Methods, in report order.
    pub methods: Vec<MethodSpec>,
    /// Independent noise draws of the whole motion.
    pub trials: usize,
    /// Seed of trial 0; trial k uses `seed + k`.
    pub seed: u64,
    /// Solver settings shared by all methods.
    pub params: Params,
    /// Worker threads (trials are split between them; results do not depend on the count).
    pub threads: usize,
}

impl Default for EvalConfig {
    fn default() -> Self {
        Self {
            methods: MethodSpec::defaults(),
            trials: 20,
            seed: 1,
            params: Params::default(),
            threads: std::thread::available_parallelism().map_or(1, usize::from),
        }
    }
}

/// The evaluation's result; serialised as `trigait eval --json` prints it.
#[derive(Debug, Clone, Serialize)]
pub struct Report {
    /// Motion name.
    pub motion: String,
    /// Frames of the motion evaluated per trial.
    pub frames: usize,
    /// Frame rate of the motion, Hz.
    pub rate_hz: f64,
    /// Rig name.
    pub rig: String,
    /// Sensor ids.
    pub sensors: Vec<String>,
    /// Trials run.
    pub trials: usize,
    /// Seed of trial 0.
    pub seed: u64,
    /// Joints evaluated.
    pub joints: Vec<String>,
    /// Joint samples with ground truth (frames × joints × trials, minus motion gaps).
    pub joint_samples: usize,
    /// Joint samples every evaluated method solved: the set the method statistics are
    /// computed on.
    pub common_samples: usize,
    /// What the sensors saw.
    pub visibility: Visibility,
    /// One entry per method.
    pub methods: Vec<MethodReport>,
}

/// How often sensors reported joints, over all sensor × joint samples.
#[derive(Debug, Clone, Default, Serialize)]
pub struct Visibility {
    /// Share reported as tracked.
    pub tracked_share: f64,
    /// Share reported as inferred (hidden by the other leg).
    pub inferred_share: f64,
    /// Share not reported (out of view or range).
    pub not_tracked_share: f64,
    /// Mean number of sensors reporting a joint.
    pub mean_sensors_reporting: f64,
}

/// Errors of one method. Distances are 3-D Euclidean, metres. Unless said otherwise, every
/// figure is over the common samples ([`Report::common_samples`]).
#[derive(Debug, Clone, Serialize)]
pub struct MethodReport {
    /// Method name (`fusion`, `fusion+robust`, …).
    pub method: String,
    /// The method on every sample it solved, not only the common ones.
    pub own: OwnScore,
    /// Root mean square error.
    pub rmse_m: f64,
    /// Mean error.
    pub mean_m: f64,
    /// 95th percentile of the error.
    pub p95_m: f64,
    /// Largest error.
    pub max_m: f64,
    /// RMSE of the x, y and z components (x along the walk, z up).
    pub rmse_xyz_m: [f64; 3],
    /// RMSE per joint.
    pub per_joint_rmse_m: BTreeMap<String, f64>,
    /// The Cramér–Rao bound as an RMSE: √(mean trace of the bound) over the solved samples,
    /// for this method's data model (range-only or full 3-D).
    pub crb_rmse_m: f64,
    /// `rmse_m / crb_rmse_m`: 1 is the best any unbiased estimator can do.
    pub rmse_over_crb: f64,
    /// The single sensor with the lowest RMSE over the samples this method solved (counting only
    /// sensors that reported at least half of them), and that RMSE.
    pub best_single_sensor: Option<String>,
    /// See [`MethodReport::best_single_sensor`].
    pub best_single_sensor_rmse_m: f64,
    /// `1 − RMSE(this) / RMSE(linear)` on the common samples: 0.38 means 38 % below linear
    /// (linear is run as a baseline even when not among the evaluated methods).
    pub gain_over_linear: f64,
    /// Mean sensors dropped per sample (robust variants).
    pub rejected_per_sample: f64,
}

/// One method on every sample it solved.
#[derive(Debug, Clone, Serialize)]
pub struct OwnScore {
    /// Samples solved.
    pub solved: usize,
    /// Solved share of all joint samples.
    pub coverage: f64,
    /// Samples with no estimate, by reason.
    pub failures: BTreeMap<String, usize>,
    /// RMSE over the solved samples.
    pub rmse_m: f64,
    /// The Cramér–Rao bound as an RMSE over the solved samples.
    pub crb_rmse_m: f64,
}

/// Per-method sums, mergeable across worker threads.
#[derive(Debug, Clone, Default)]
struct Tally {
    errors: PositionErrors,
    crb_trace: f64,
    failures: BTreeMap<&'static str, usize>,
    single: BTreeMap<usize, (f64, usize)>,
    linear_squared: f64,
    rejected: usize,
    own_solved: usize,
    own_squared: f64,
    own_crb_trace: f64,
}

impl Tally {
    fn merge(&mut self, other: Tally) {
        self.errors.merge(other.errors);
        self.crb_trace += other.crb_trace;
        for (k, n) in other.failures {
            *self.failures.entry(k).or_default() += n;
        }
        for (k, (s, n)) in other.single {
            let e = self.single.entry(k).or_default();
            e.0 += s;
            e.1 += n;
        }
        self.linear_squared += other.linear_squared;
        self.rejected += other.rejected;
        self.own_solved += other.own_solved;
        self.own_squared += other.own_squared;
        self.own_crb_trace += other.own_crb_trace;
    }
}

#[derive(Debug, Clone, Default)]
struct Partial {
    tallies: Vec<Tally>,
    samples: usize,
    common: usize,
    states: [usize; 3],
    reporting: usize,
}

impl Partial {
    fn merge(&mut self, other: Partial) {
        for (a, b) in self.tallies.iter_mut().zip(other.tallies) {
            a.merge(b);
        }
        self.samples += other.samples;
        self.common += other.common;
        for i in 0..3 {
            self.states[i] += other.states[i];
        }
        self.reporting += other.reporting;
    }
}

/// Short stable names of estimator errors, used as keys of [`MethodReport::failures`].
#[must_use]
pub fn failure_kind(error: &EstimateError) -> &'static str {
    match error {
        EstimateError::TooFewSensors { .. } => "too_few_sensors",
        EstimateError::NonFinite { .. } => "non_finite",
        EstimateError::BadCovariance { .. } => "bad_covariance",
        EstimateError::SensorAtTarget { .. } => "sensor_at_target",
        EstimateError::Degenerate { .. } => "degenerate",
        EstimateError::NotConverged { .. } => "not_converged",
        _ => "other",
    }
}

/// Runs the evaluation; `progress` is called with the number of finished trials.
#[must_use]
pub fn evaluate(
    sim: &Simulator,
    rig_name: &str,
    config: &EvalConfig,
    progress: &(dyn Fn(usize) + Sync),
) -> Report {
    let threads = config.threads.clamp(1, config.trials.max(1));
    let fusion = FusionRig::from_sensors(sim.sensors().to_vec());
    let done = std::sync::atomic::AtomicUsize::new(0);
    let mut total = Partial {
        tallies: vec![Tally::default(); config.methods.len()],
        ..Partial::default()
    };
    std::thread::scope(|scope| {
        let workers: Vec<_> = (0..threads)
            .map(|worker| {
                let (done, fusion) = (&done, &fusion);
                scope.spawn(move || {
                    let mut partial = Partial {
                        tallies: vec![Tally::default(); config.methods.len()],
                        ..Partial::default()
                    };
                    for trial in (worker..config.trials).step_by(threads) {
                        run_trial(sim, fusion, config, trial, &mut partial);
                        let finished = done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
                        progress(finished);
                    }
                    partial
                })
            })
            .collect();
        for w in workers {
            if let Ok(partial) = w.join() {
                total.merge(partial);
            }
        }
    });
    report(sim, rig_name, config, total)
}

/// Every sensor's samples of one snapshot as the fusion's observations — the first half of
/// [`trigait_fusion::fuse_instant`], the code the dataflow's `trilaterate` node runs on an
/// aligned set; eval then calls [`trigait_fusion::Observed::estimate`] once per method.
#[must_use]
pub fn observe_snapshot(
    fusion: &FusionRig,
    sim: &Simulator,
    snapshot: &Snapshot,
) -> trigait_fusion::Observed {
    with_samples(sim, snapshot, |views| fusion.observe(views))
}

/// One snapshot through [`trigait_fusion::fuse_instant`] with `params`.
#[must_use]
pub fn fuse_snapshot(
    fusion: &FusionRig,
    sim: &Simulator,
    snapshot: &Snapshot,
    params: &Params,
) -> FusedInstant {
    with_samples(sim, snapshot, |views| {
        trigait_fusion::fuse_instant(fusion, views, params).0
    })
}

fn with_samples<T>(
    sim: &Simulator,
    snapshot: &Snapshot,
    f: impl FnOnce(&[SensorSamples<'_>]) -> T,
) -> T {
    let samples: Vec<Vec<JointSample>> = (0..sim.sensors().len())
        .map(|s| snapshot.samples(sim, s))
        .collect();
    let views: Vec<SensorSamples<'_>> = sim
        .sensors()
        .iter()
        .zip(&samples)
        .map(|(sensor, joints)| SensorSamples {
            sensor_id: &sensor.id,
            joints,
            resampling_error_m: &[],
        })
        .collect();
    f(&views)
}

fn run_trial(
    sim: &Simulator,
    fusion: &FusionRig,
    config: &EvalConfig,
    trial: usize,
    partial: &mut Partial,
) {
    let seed = config.seed.wrapping_add(trial as u64);
    let mut rngs: Vec<_> = (0..sim.sensors().len())
        .map(|s| Simulator::sensor_rng(seed, s))
        .collect();
    let linear = Params::new(Method::Linear);
    let params: Vec<Params> = config
        .methods
        .iter()
        .map(|spec| spec.params(&config.params))
        .collect();
    let motion = sim.motion();
    let unseen = JointObservations::default();
    for frame in 0..motion.frame_count() {
        let t = frame as f64 / motion.rate_hz();
        let snapshot = sim.snapshot(t, &mut rngs);
        let observed = observe_snapshot(fusion, sim, &snapshot);
        let linear_fused = observed.estimate(&linear);
        let fused: Vec<FusedInstant> = params.iter().map(|p| observed.estimate(p)).collect();
        for (column, joint) in sim.joints().iter().enumerate() {
            let Some(truth) = snapshot.truth.get(joint) else {
                continue;
            };
            partial.samples += 1;
            for reports in &snapshot.reports {
                let state = reports
                    .get(column)
                    .and_then(Option::as_ref)
                    .map_or(TrackingState::NotTracked, trigait_kinect::Report::state);
                partial.states[state as usize] += 1;
            }
            let seen = observed.joints.get(joint).unwrap_or(&unseen);
            let at_truth = observed.at_truth(fusion, *joint, &snapshot.truth);
            partial.reporting += seen.sensors.len();
            let single: Vec<(usize, f64)> = seen
                .sensors
                .iter()
                .zip(&seen.observations)
                .map(|(s, o)| (*s, (o.position_in_world() - truth).norm_squared()))
                .collect();
            let linear_error = linear_fused
                .joints
                .get(joint)
                .and_then(|f| f.result.as_ref().ok())
                .map(|e| (e.position - truth).norm_squared());
            let mut solved = Vec::with_capacity(config.methods.len());
            for ((spec, tally), fused) in
                config.methods.iter().zip(&mut partial.tallies).zip(&fused)
            {
                match fused.joints.get(joint).map(|f| &f.result) {
                    Some(Ok(e)) => {
                        let bound = if spec.method.is_range_only() {
                            crb::range_only(&at_truth)
                        } else {
                            crb::full(&at_truth)
                        };
                        let crb_trace = bound.map_or(f64::NAN, |b| b.trace());
                        let error = e.position - truth;
                        tally.own_solved += 1;
                        tally.own_squared += error.norm_squared();
                        tally.own_crb_trace += crb_trace;
                        solved.push(Some((error, crb_trace, e.diagnostics.rejected.len())));
                    }
                    Some(Err(err)) => {
                        *tally.failures.entry(failure_kind(err)).or_default() += 1;
                        solved.push(None);
                    }
                    // No sensor reported the joint.
                    None => {
                        *tally.failures.entry("too_few_sensors").or_default() += 1;
                        solved.push(None);
                    }
                }
            }
            // Like for like: only samples every method (and the linear baseline) solved count
            // towards the compared statistics.
            let (Some(linear_sq), true) = (linear_error, solved.iter().all(Option::is_some)) else {
                continue;
            };
            partial.common += 1;
            for (result, tally) in solved.into_iter().zip(&mut partial.tallies) {
                let Some((error, crb_trace, rejected)) = result else {
                    continue;
                };
                tally.errors.push(*joint, error);
                tally.crb_trace += crb_trace;
                for (s, sq) in &single {
                    let entry = tally.single.entry(*s).or_default();
                    entry.0 += sq;
                    entry.1 += 1;
                }
                tally.linear_squared += linear_sq;
                tally.rejected += rejected;
            }
        }
    }
}

fn report(sim: &Simulator, rig_name: &str, config: &EvalConfig, total: Partial) -> Report {
    let samples = total.samples;
    let sensor_samples: usize = total.states.iter().sum();
    let share = |n: usize| n as f64 / sensor_samples.max(1) as f64;
    let methods = config
        .methods
        .iter()
        .zip(total.tallies)
        .map(|(spec, t)| method_report(sim, spec, t, samples))
        .collect();
    Report {
        motion: sim.motion().name().to_owned(),
        frames: sim.motion().frame_count(),
        rate_hz: sim.motion().rate_hz(),
        rig: rig_name.to_owned(),
        sensors: sim.sensors().iter().map(|s| s.id.clone()).collect(),
        trials: config.trials,
        seed: config.seed,
        joints: sim.joints().iter().map(|j| j.name().to_owned()).collect(),
        joint_samples: samples,
        common_samples: total.common,
        visibility: Visibility {
            tracked_share: share(total.states[TrackingState::Tracked as usize]),
            inferred_share: share(total.states[TrackingState::Inferred as usize]),
            not_tracked_share: share(total.states[TrackingState::NotTracked as usize]),
            mean_sensors_reporting: total.reporting as f64 / samples.max(1) as f64,
        },
        methods,
    }
}

fn method_report(sim: &Simulator, spec: &MethodSpec, mut t: Tally, samples: usize) -> MethodReport {
    let solved = t.errors.count();
    let own = OwnScore {
        solved: t.own_solved,
        coverage: t.own_solved as f64 / samples.max(1) as f64,
        failures: std::mem::take(&mut t.failures)
            .into_iter()
            .map(|(k, v)| (k.to_owned(), v))
            .collect(),
        rmse_m: rmse(t.own_squared, t.own_solved),
        crb_rmse_m: rmse(t.own_crb_trace, t.own_solved),
    };
    let n = solved.max(1) as f64;
    let squared = t.errors.sum_of_squares();
    let crb_rmse = (t.crb_trace / n).sqrt();
    let best = t
        .single
        .iter()
        .filter(|(_, (_, count))| 2 * count >= solved)
        .map(|(s, (sq, count))| (*s, rmse(*sq, *count)))
        .min_by(|a, b| a.1.total_cmp(&b.1));
    MethodReport {
        method: spec.name(),
        own,
        rmse_m: t.errors.rmse_m(),
        mean_m: t.errors.mean_m(),
        p95_m: t.errors.percentile_m(0.95),
        max_m: t.errors.max_m(),
        rmse_xyz_m: t.errors.rmse_xyz_m(),
        per_joint_rmse_m: t
            .errors
            .per_joint_rmse_m()
            .into_iter()
            .map(|(j, r)| (j.name().to_owned(), r))
            .collect(),
        crb_rmse_m: crb_rmse,
        rmse_over_crb: t.errors.rmse_m() / crb_rmse,
        best_single_sensor: best.and_then(|(s, _)| sim.sensors().get(s).map(|s| s.id.clone())),
        best_single_sensor_rmse_m: best.map_or(f64::NAN, |b| b.1),
        gain_over_linear: 1.0 - (squared / t.linear_squared.max(f64::MIN_POSITIVE)).sqrt(),
        rejected_per_sample: t.rejected as f64 / n,
    }
}
