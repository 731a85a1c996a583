use std::fmt;
use std::str::FromStr;

use nalgebra::{DVector, Matrix3, Point3, SVD, Vector3};
use serde::{Deserialize, Serialize};

use crate::observation::validate_all;
use crate::{Error, Observation, Result, mirror};

/// The estimators of this crate; see the crate docs for what each uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Method {
    /// Thesis §4.2.1: three spheres intersected in the frame of the sensors' triangle.
    Geometric,
    /// Thesis §4.2.2: the linearised sphere equations solved by SVD pseudo-inverse.
    Linear,
    /// Weighted range-only nonlinear least squares (Levenberg–Marquardt), started from `Linear`.
    Nls,
    /// Maximum likelihood on full 3-D observations with their anisotropic covariances.
    Fusion,
}

impl Method {
    /// All methods, thesis first.
    pub const ALL: [Method; 4] = [
        Method::Geometric,
        Method::Linear,
        Method::Nls,
        Method::Fusion,
    ];

    /// The name used on the command line, in YAML and in JSON.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Method::Geometric => "geometric",
            Method::Linear => "linear",
            Method::Nls => "nls",
            Method::Fusion => "fusion",
        }
    }

    /// Fewest sensors that determine a position with this method.
    #[must_use]
    pub fn min_sensors(self) -> usize {
        match self {
            Method::Geometric | Method::Linear | Method::Nls => 3,
            Method::Fusion => 1,
        }
    }

    /// Whether the method sees only ranges (and so is bounded by the range-only CRB).
    #[must_use]
    pub fn is_range_only(self) -> bool {
        self != Method::Fusion
    }

    /// Measurements one sensor contributes (1 range, or 3 coordinates).
    fn dims_per_sensor(self) -> usize {
        if self.is_range_only() { 1 } else { 3 }
    }
}

impl fmt::Display for Method {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// An unknown method name; its message lists the valid ones.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("unknown estimator {given:?}; expected one of: geometric, linear, nls, fusion")]
pub struct UnknownMethod {
    /// The name that was given.
    pub given: String,
}

impl FromStr for Method {
    type Err = UnknownMethod;

    fn from_str(s: &str) -> std::result::Result<Self, Self::Err> {
        Method::ALL
            .into_iter()
            .find(|m| m.name().eq_ignore_ascii_case(s.trim()))
            .ok_or_else(|| UnknownMethod {
                given: s.to_owned(),
            })
    }
}

/// How to estimate: which method, whether to reject outliers, and solver tolerances.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct Params {
    /// The estimator.
    pub method: Method,
    /// Wrap the estimator in [`robust`] outlier rejection.
    pub robust: bool,
    /// Smallest-to-largest singular value ratio of the sensor geometry below which the rig is
    /// treated as planar and the mirror rule picks the side (0.01: a 3.5 m rig whose sensors
    /// differ in height by less than a few centimetres is planar for trilateration).
    pub coplanar_tolerance: f64,
    /// Iteration cap of the Levenberg–Marquardt solver.
    pub max_iterations: usize,
    /// Step length (m) below which the iterative solver has converged.
    pub step_tolerance_m: f64,
    /// False-alarm probability of the χ² consistency test used by [`robust`]: how often a
    /// consistent sensor is dropped.
    pub outlier_probability: f64,
}

impl Default for Params {
    fn default() -> Self {
        Self {
            method: Method::Fusion,
            robust: false,
            coplanar_tolerance: 0.01,
            max_iterations: 50,
            step_tolerance_m: 1e-12,
            outlier_probability: 1e-3,
        }
    }
}

impl Params {
    /// Default parameters for `method`.
    #[must_use]
    pub fn new(method: Method) -> Self {
        Self {
            method,
            ..Self::default()
        }
    }

    /// The same parameters with outlier rejection switched on or off.
    #[must_use]
    pub fn with_robust(mut self, robust: bool) -> Self {
        self.robust = robust;
        self
    }
}

/// Where the joint is, how uncertain that is, and how the answer came about.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Estimate {
    /// The joint in the world frame.
    pub position: Point3<f64>,
    /// Covariance of `position` (m²), propagated from the observations' noise.
    pub covariance: Matrix3<f64>,
    /// How the estimate was reached.
    pub diagnostics: Diagnostics,
}

/// How an estimate was reached: which sensors, how well they agree, how well-posed it was.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct Diagnostics {
    /// Indices (into the input slice) of the observations used.
    pub used: Vec<usize>,
    /// Indices of observations dropped as inconsistent by [`robust`].
    pub rejected: Vec<usize>,
    /// RMS of the unweighted residuals (range residuals, or 3-D distances for `Fusion`), metres.
    pub residual_rms_m: f64,
    /// Sum of squared noise-normalised residuals; χ²-distributed with `dof` degrees of freedom
    /// when the noise model holds.
    pub chi2: f64,
    /// Degrees of freedom of `chi2`: measurements minus 3.
    pub dof: usize,
    /// Ratio of largest to smallest singular value of the system solved.
    pub condition_number: f64,
    /// Solver iterations (0 for closed forms).
    pub iterations: usize,
    /// The sensors were coplanar and the mirror rule picked the side.
    pub mirror_resolved: bool,
    /// The spheres did not meet (noise) and the point was put in the sensors' plane.
    pub clamped: bool,
}

/// Estimates the joint with `params.method`, wrapped in [`robust`] when `params.robust`.
///
/// # Errors
/// See [`Error`]: too few sensors, non-finite input, a sensor at the target, a degenerate rig,
/// or a solver that did not converge.
pub fn estimate(observations: &[Observation], params: &Params) -> Result<Estimate> {
    if params.robust {
        robust(observations, params)
    } else {
        estimate_plain(observations, params)
    }
}

fn estimate_plain(observations: &[Observation], params: &Params) -> Result<Estimate> {
    match params.method {
        Method::Geometric => geometric(observations),
        Method::Linear => linear(observations, params),
        Method::Nls => nls(observations, params),
        Method::Fusion => fusion(observations),
    }
}

fn require(method: Method, observations: &[Observation]) -> Result<()> {
    let need = method.min_sensors();
    if observations.len() < need {
        return Err(Error::TooFewSensors {
            method,
            got: observations.len(),
            need,
        });
    }
    validate_all(observations)
}

/// Thesis §4.2.1, generalised to sensors anywhere in 3-D: of the given sensors, the three
/// spanning the largest triangle are placed in their own plane frame from their pairwise
/// distances (eq. 4.2, [`crate::thesis::heron_rig`]), their three spheres are intersected
/// (eq. 4.5), and the mirror pair is resolved by [`mirror::side`]. Extra sensors are ignored.
///
/// # Errors
/// Fewer than 3 sensors, invalid input, or collinear sensors ([`Error::Degenerate`]).
pub fn geometric(observations: &[Observation]) -> Result<Estimate> {
    require(Method::Geometric, observations)?;
    let triple = widest_triangle(observations);
    let picked: Vec<Observation> = triple.iter().map(|i| observations[*i].clone()).collect();
    let solver = TriangleFrame::new(&picked)?;
    let ranges: Vec<f64> = picked.iter().map(Observation::range_m).collect();
    let (position, clamped) = solver.solve(&ranges);
    let covariance = propagate_range_noise(&picked, &ranges, |r| solver.solve(r).0);
    Ok(range_estimate(
        observations,
        triple.to_vec(),
        position,
        covariance,
        Extra {
            condition_number: solver.condition_number,
            iterations: 0,
            mirror_resolved: true,
            clamped,
        },
    ))
}

/// Thesis §4.2.2: eq. 4.12's n − 1 linear equations `A x = b` relative to the first sensor,
/// solved with the SVD pseudo-inverse (eq. 4.15). With sensors in one plane `A` has rank 2; the
/// in-plane part comes from the rank-2 pseudo-inverse and the out-of-plane part from the spheres
/// themselves, on the side [`mirror::side`] picks.
///
/// # Errors
/// Fewer than 3 sensors, invalid input, or collinear sensors ([`Error::Degenerate`]).
pub fn linear(observations: &[Observation], params: &Params) -> Result<Estimate> {
    require(Method::Linear, observations)?;
    let solver = LinearSystem::new(observations, params.coplanar_tolerance)?;
    let ranges: Vec<f64> = observations.iter().map(Observation::range_m).collect();
    let (position, clamped) = solver.solve(&ranges);
    let covariance = propagate_range_noise(observations, &ranges, |r| solver.solve(r).0);
    Ok(range_estimate(
        observations,
        (0..observations.len()).collect(),
        position,
        covariance,
        Extra {
            condition_number: solver.condition_number,
            iterations: 0,
            mirror_resolved: solver.planar.is_some(),
            clamped,
        },
    ))
}

/// Range-only maximum likelihood: minimises Σ ((|x − kᵢ| − rᵢ)/σᵢ)² by Levenberg–Marquardt,
/// with σᵢ each observation's range standard deviation, started from [`linear`] (so it stays on
/// the side the mirror rule chose). The covariance is the inverse Fisher information at the
/// solution.
///
/// # Errors
/// As [`linear`], plus [`Error::NotConverged`] (carrying the best estimate) and
/// [`Error::Degenerate`] when the joint lies in the plane of a planar rig, where ranges carry no
/// information across the plane.
pub fn nls(observations: &[Observation], params: &Params) -> Result<Estimate> {
    require(Method::Nls, observations)?;
    let start = linear(observations, params)?;
    let sensors: Vec<Point3<f64>> = observations
        .iter()
        .map(Observation::sensor_in_world)
        .collect();
    let ranges: Vec<f64> = observations.iter().map(Observation::range_m).collect();
    let weights: Vec<f64> = observations
        .iter()
        .map(|o| 1.0 / o.range_sigma_m().max(1e-9))
        .collect();

    let cost = |x: &Point3<f64>| -> f64 {
        sensors
            .iter()
            .zip(&ranges)
            .zip(&weights)
            .map(|((k, r), w)| ((x - k).norm() - r) * w)
            .map(|e| e * e)
            .sum()
    };
    let normal_equations = |x: &Point3<f64>| -> (Matrix3<f64>, Vector3<f64>) {
        let mut jtj = Matrix3::zeros();
        let mut jtf = Vector3::zeros();
        for ((k, r), w) in sensors.iter().zip(&ranges).zip(&weights) {
            let d = x - k;
            let dist = d.norm().max(1e-12);
            let j = d / dist * *w;
            let f = (dist - r) * w;
            jtj += j * j.transpose();
            jtf += j * f;
        }
        (jtj, jtf)
    };

    let mut x = start.position;
    let mut current = cost(&x);
    let mut lambda = 1e-3;
    let mut last_step = f64::INFINITY;
    let mut iterations = 0;
    while iterations < params.max_iterations {
        iterations += 1;
        let (jtj, jtf) = normal_equations(&x);
        let mut damped = jtj;
        for i in 0..3 {
            damped[(i, i)] += lambda * jtj[(i, i)].max(1e-12);
        }
        let Some(step) = damped.cholesky().map(|c| c.solve(&(-jtf))) else {
            lambda *= 10.0;
            continue;
        };
        let candidate = x + step;
        let candidate_cost = cost(&candidate);
        if candidate_cost <= current {
            x = candidate;
            current = candidate_cost;
            lambda = (lambda * 0.1).max(1e-12);
            last_step = step.norm();
            if last_step <= params.step_tolerance_m.max(1e-15 * x.coords.norm()) {
                break;
            }
        } else {
            lambda *= 10.0;
            if lambda > 1e12 {
                // No descent direction left at machine precision: x is the minimum.
                last_step = 0.0;
                break;
            }
        }
    }
    let converged = last_step <= params.step_tolerance_m.max(1e-15 * x.coords.norm())
        || last_step == 0.0
        || current <= f64::EPSILON;
    if !converged {
        return Err(Error::NotConverged {
            method: Method::Nls,
            iterations,
            last_step_m: last_step,
            estimate: x,
        });
    }
    let (information, _) = normal_equations(&x);
    let condition_number = condition_number(&information).sqrt();
    let Some(covariance) = information
        .try_inverse()
        .filter(|c| c.iter().all(|v| v.is_finite()))
    else {
        return Err(Error::Degenerate {
            method: Method::Nls,
            rank: 2,
            condition_number,
        });
    };
    Ok(range_estimate(
        observations,
        (0..observations.len()).collect(),
        x,
        covariance,
        Extra {
            condition_number,
            iterations,
            mirror_resolved: start.diagnostics.mirror_resolved,
            clamped: false,
        },
    ))
}

/// Maximum likelihood on full 3-D observations: each sensor's report, mapped to the world, is
/// the joint plus Gaussian noise with that observation's covariance Σᵢ, so the estimate is the
/// information-weighted mean `x = (Σ Wᵢ)⁻¹ Σ Wᵢ zᵢ` with `Wᵢ = Σᵢ⁻¹`, and its covariance
/// `(Σ Wᵢ)⁻¹` is the Cramér–Rao bound of that model ([`crate::crb::full`]).
///
/// Range-only trilateration is the limit of infinite lateral variance; plain averaging is the
/// limit of equal isotropic variances. Works from one sensor up.
///
/// # Errors
/// No observations or invalid input.
pub fn fusion(observations: &[Observation]) -> Result<Estimate> {
    require(Method::Fusion, observations)?;
    let mut information = Matrix3::zeros();
    let mut weighted = Vector3::zeros();
    let mut weights = Vec::with_capacity(observations.len());
    for (index, o) in observations.iter().enumerate() {
        let w = o
            .covariance_in_world()
            .cholesky()
            .map(|c| c.inverse())
            .ok_or(Error::BadCovariance { index })?;
        information += w;
        weighted += w * o.position_in_world().coords;
        weights.push(w);
    }
    let covariance = information
        .try_inverse()
        .ok_or(Error::BadCovariance { index: 0 })?;
    let position = Point3::from(covariance * weighted);
    let mut chi2 = 0.0;
    let mut squared = 0.0;
    for (o, w) in observations.iter().zip(&weights) {
        let e = o.position_in_world() - position;
        chi2 += (e.transpose() * w * e)[(0, 0)];
        squared += e.norm_squared();
    }
    Ok(Estimate {
        position,
        covariance,
        diagnostics: Diagnostics {
            used: (0..observations.len()).collect(),
            rejected: Vec::new(),
            residual_rms_m: (squared / observations.len() as f64).sqrt(),
            chi2,
            dof: 3 * observations.len() - 3,
            condition_number: condition_number(&information),
            iterations: 0,
            mirror_resolved: false,
            clamped: false,
        },
    })
}

/// Runs `params.method` and, while the χ² consistency test fails at `outlier_probability`,
/// drops the sensor whose removal leaves the most consistent rest (leave-one-out), then
/// re-estimates. A sensor is dropped only while the rest can still be tested (one more than
/// the method's minimum remains: 2 for `Fusion`, 4 for range-only methods); with fewer, an
/// inconsistency cannot be blamed on one sensor and the plain estimate is returned.
///
/// # Errors
/// As the wrapped method.
pub fn robust(observations: &[Observation], params: &Params) -> Result<Estimate> {
    let method = params.method;
    let mut kept: Vec<usize> = (0..observations.len()).collect();
    let mut rejected = Vec::new();
    let subset = |kept: &[usize]| -> Vec<Observation> {
        kept.iter().map(|i| observations[*i].clone()).collect()
    };
    let mut best = estimate_plain(observations, params)?;
    while kept.len() > method.min_sensors() + 1
        && best.diagnostics.dof > 0
        && best.diagnostics.chi2 > chi2_quantile(best.diagnostics.dof, params.outlier_probability)
    {
        let mut candidate: Option<(usize, Estimate, f64)> = None;
        for drop in 0..kept.len() {
            let rest: Vec<usize> = kept
                .iter()
                .enumerate()
                .filter(|(i, _)| *i != drop)
                .map(|(_, k)| *k)
                .collect();
            let Ok(e) = estimate_plain(&subset(&rest), params) else {
                continue;
            };
            // Compare subsets by how far inside their own acceptance region they are.
            let score = if e.diagnostics.dof == 0 {
                0.0
            } else {
                e.diagnostics.chi2 / chi2_quantile(e.diagnostics.dof, params.outlier_probability)
            };
            if candidate.as_ref().is_none_or(|c| score < c.2) {
                candidate = Some((drop, e, score));
            }
        }
        let Some((drop, e, _)) = candidate else {
            break;
        };
        rejected.push(kept.remove(drop));
        best = e;
    }
    best.diagnostics.used = best.diagnostics.used.iter().map(|i| kept[*i]).collect();
    rejected.sort_unstable();
    best.diagnostics.rejected = rejected;
    Ok(best)
}

/// Upper `p`-quantile of the χ² distribution with `dof` degrees of freedom: exact for 1 and 2
/// degrees of freedom, the Wilson–Hilferty cube-root approximation above (at p = 0.001 it errs
/// high by under 2 %, so the test drops consistent sensors slightly less often than asked).
#[must_use]
pub(crate) fn chi2_quantile(dof: usize, p: f64) -> f64 {
    match dof {
        0 | 1 => return normal_upper_quantile(p / 2.0).powi(2),
        2 => return -2.0 * p.clamp(1e-300, 1.0).ln(),
        _ => {}
    }
    let k = dof as f64;
    let z = normal_upper_quantile(p);
    let a = 2.0 / (9.0 * k);
    k * (1.0 - a + z * a.sqrt()).powi(3)
}

/// Upper `p`-quantile of the standard normal (Acklam's rational approximation, |error| < 1.2e-9).
fn normal_upper_quantile(p: f64) -> f64 {
    let p = p.clamp(1e-300, 0.5);
    // Lower-tail quantile of p, negated.
    let q = (-2.0 * p.ln()).sqrt();
    let c = [
        -7.784_894_002_430_293e-3,
        -3.223_964_580_411_365e-1,
        -2.400_758_277_161_838,
        -2.549_732_539_343_734,
        4.374_664_141_464_968,
        2.938_163_982_698_783,
    ];
    let d = [
        7.784_695_709_041_462e-3,
        3.224_671_290_700_398e-1,
        2.445_134_137_142_996,
        3.754_408_661_907_416,
    ];
    if p < 0.024_25 {
        -((((((c[0] * q + c[1]) * q + c[2]) * q + c[3]) * q + c[4]) * q + c[5])
            / ((((d[0] * q + d[1]) * q + d[2]) * q + d[3]) * q + 1.0))
    } else {
        let a = [
            -3.969_683_028_665_376e1,
            2.209_460_984_245_205e2,
            -2.759_285_104_469_687e2,
            1.383_577_518_672_69e2,
            -3.066_479_806_614_716e1,
            2.506_628_277_459_239,
        ];
        let b = [
            -5.447_609_879_822_406e1,
            1.615_858_368_580_409e2,
            -1.556_989_798_598_866e2,
            6.680_131_188_771_972e1,
            -1.328_068_155_288_572e1,
        ];
        let q = p - 0.5;
        let r = q * q;
        -((((((a[0] * r + a[1]) * r + a[2]) * r + a[3]) * r + a[4]) * r + a[5]) * q
            / (((((b[0] * r + b[1]) * r + b[2]) * r + b[3]) * r + b[4]) * r + 1.0))
    }
}

/// Largest over smallest singular value; infinite when singular.
fn condition_number(m: &Matrix3<f64>) -> f64 {
    let s = m.singular_values();
    let (max, min) = (s.max(), s.min());
    if min > 0.0 { max / min } else { f64::INFINITY }
}

/// Indices of the three sensors spanning the largest triangle (best-conditioned triple).
fn widest_triangle(observations: &[Observation]) -> [usize; 3] {
    let p: Vec<Point3<f64>> = observations
        .iter()
        .map(Observation::sensor_in_world)
        .collect();
    let mut best = ([0, 1, 2], -1.0);
    for i in 0..p.len() {
        for j in i + 1..p.len() {
            for k in j + 1..p.len() {
                let area = (p[j] - p[i]).cross(&(p[k] - p[i])).norm();
                if area > best.1 {
                    best = ([i, j, k], area);
                }
            }
        }
    }
    best.0
}

/// The thesis's triangle frame (§4.2.1, eq. 4.2): k1 at the origin, k2 on +x, k3 in the xy
/// plane, built from the pairwise distances alone, then embedded back into the world.
struct TriangleFrame {
    origin: Point3<f64>,
    axes: [Vector3<f64>; 3],
    rig: [nalgebra::Point2<f64>; 3],
    side: f64,
    condition_number: f64,
}

impl TriangleFrame {
    fn new(picked: &[Observation]) -> Result<Self> {
        let k: Vec<Point3<f64>> = picked.iter().map(Observation::sensor_in_world).collect();
        let (l12, l13, l23) = (
            (k[1] - k[0]).norm(),
            (k[2] - k[0]).norm(),
            (k[2] - k[1]).norm(),
        );
        let scale = l12.max(l13).max(l23);
        let degenerate = || Error::Degenerate {
            method: Method::Geometric,
            rank: 1,
            condition_number: f64::INFINITY,
        };
        let rig = crate::thesis::heron_rig(l12, l13, l23).ok_or_else(degenerate)?;
        if rig[2].y < 1e-9 * scale {
            return Err(degenerate());
        }
        let ex = (k[1] - k[0]) / l12;
        let ey = (k[2] - k[0] - ex * rig[2].x) / rig[2].y;
        let ez = ex.cross(&ey);
        let side = mirror::side(&ez, &k[0], picked);
        Ok(Self {
            origin: k[0],
            axes: [ex, ey, ez],
            rig,
            side,
            condition_number: scale / rig[2].y,
        })
    }

    /// Eq. 4.5 in the triangle frame, mapped to the world; `true` when the spheres missed.
    fn solve(&self, r: &[f64]) -> (Point3<f64>, bool) {
        let [_, k2, k3] = self.rig;
        let x = (r[0] * r[0] - r[1] * r[1] + k2.x * k2.x) / (2.0 * k2.x);
        let y =
            (r[0] * r[0] - r[2] * r[2] + k3.x * k3.x + k3.y * k3.y - 2.0 * k3.x * x) / (2.0 * k3.y);
        let z_sq = r[0] * r[0] - x * x - y * y;
        let z = self.side * z_sq.max(0.0).sqrt();
        let [ex, ey, ez] = self.axes;
        (self.origin + ex * x + ey * y + ez * z, z_sq < 0.0)
    }
}

/// Eq. 4.12–4.15 with a precomputed SVD of `A`, so propagating noise re-solves cheaply.
struct LinearSystem {
    reference: Point3<f64>,
    /// Sensor offsets from the reference sensor (rows of `A`), including the reference's zero.
    offsets: Vec<Vector3<f64>>,
    svd: SVD<f64, nalgebra::Dyn, nalgebra::U3>,
    /// For a planar rig: the plane normal, the sensors' mean offset along it, and the side.
    planar: Option<(Vector3<f64>, f64, f64)>,
    condition_number: f64,
}

impl LinearSystem {
    fn new(observations: &[Observation], coplanar_tolerance: f64) -> Result<Self> {
        let reference = observations[0].sensor_in_world();
        let offsets: Vec<Vector3<f64>> = observations
            .iter()
            .map(|o| o.sensor_in_world() - reference)
            .collect();
        // Zero rows pad A to at least 3×3 so the SVD always yields 3 singular values and a full
        // V (three sensors give only 2 equations); they change no solution.
        let rows = (offsets.len() - 1).max(3);
        let a = nalgebra::OMatrix::<f64, nalgebra::Dyn, nalgebra::U3>::from_fn(rows, |r, c| {
            offsets.get(r + 1).map_or(0.0, |o| o[c])
        });
        let svd = SVD::new(a, true, true);
        let s = &svd.singular_values;
        let (s1, s2, s3) = (s[0], s[1], s.get(2).copied().unwrap_or(0.0));
        let collinear = s1 <= 0.0 || s2 < 1e-9 * s1;
        if collinear {
            return Err(Error::Degenerate {
                method: Method::Linear,
                rank: usize::from(s1 > 0.0),
                condition_number: if s2 > 0.0 { s1 / s2 } else { f64::INFINITY },
            });
        }
        let (planar, condition_number) = if s3 < coplanar_tolerance * s1 {
            let v_t = svd.v_t.as_ref().ok_or(Error::Degenerate {
                method: Method::Linear,
                rank: 2,
                condition_number: s1 / s2,
            })?;
            let normal: Vector3<f64> = v_t.row(2).transpose().into_owned();
            let mean_offset =
                offsets.iter().map(|a| a.dot(&normal)).sum::<f64>() / offsets.len() as f64;
            let plane_point = reference + normal * mean_offset;
            let side = mirror::side(&normal, &plane_point, observations);
            (Some((normal, mean_offset, side)), s1 / s2)
        } else {
            (None, s1 / s3)
        };
        Ok(Self {
            reference,
            offsets,
            svd,
            planar,
            condition_number,
        })
    }

    fn solve(&self, r: &[f64]) -> (Point3<f64>, bool) {
        let b = DVector::from_fn((self.offsets.len() - 1).max(3), |i, _| {
            match self.offsets.get(i + 1) {
                Some(a) => 0.5 * (r[0] * r[0] - r[i + 1] * r[i + 1] + a.norm_squared()),
                None => 0.0,
            }
        });
        let (Some(u), Some(v_t)) = (&self.svd.u, &self.svd.v_t) else {
            return (Point3::new(f64::NAN, f64::NAN, f64::NAN), false);
        };
        let rank = if self.planar.is_some() { 2 } else { 3 };
        let mut x = Vector3::zeros();
        for k in 0..rank {
            let coefficient = u.column(k).dot(&b) / self.svd.singular_values[k];
            x += v_t.row(k).transpose() * coefficient;
        }
        let Some((normal, mean_offset, side)) = self.planar else {
            return (self.reference + x, false);
        };
        // x is the in-plane part; the joint is x + t·n. Every sphere gives
        // t² − 2t (n·aᵢ) + |x − aᵢ|² − rᵢ² = 0; their mean is a quadratic whose roots are the
        // mirror pair about the sensors' mean plane t = m.
        let count = self.offsets.len() as f64;
        let c = self
            .offsets
            .iter()
            .zip(r)
            .map(|(a, ri)| (x - a).norm_squared() - ri * ri)
            .sum::<f64>()
            / count;
        let discriminant = mean_offset * mean_offset - c;
        let t = mean_offset + side * discriminant.max(0.0).sqrt();
        (self.reference + x + normal * t, discriminant < 0.0)
    }
}

/// First-order covariance of a range-only solution map: `J diag(σᵢ²) Jᵀ` with `J = ∂x/∂r` by
/// central differences (the maps are closed forms, so this costs 2n cheap re-solves).
fn propagate_range_noise(
    observations: &[Observation],
    ranges: &[f64],
    solve: impl Fn(&[f64]) -> Point3<f64>,
) -> Matrix3<f64> {
    let mut covariance = Matrix3::zeros();
    let mut perturbed = ranges.to_vec();
    for (i, o) in observations.iter().enumerate() {
        let h = 1e-6 * ranges[i].max(1.0);
        perturbed[i] = ranges[i] + h;
        let plus = solve(&perturbed);
        perturbed[i] = ranges[i] - h;
        let minus = solve(&perturbed);
        perturbed[i] = ranges[i];
        let column = (plus - minus) / (2.0 * h);
        let sigma = o.range_sigma_m();
        covariance += column * column.transpose() * (sigma * sigma);
    }
    covariance
}

struct Extra {
    condition_number: f64,
    iterations: usize,
    mirror_resolved: bool,
    clamped: bool,
}

/// Packs a range-only solution with its residual diagnostics over the observations used.
fn range_estimate(
    observations: &[Observation],
    used: Vec<usize>,
    position: Point3<f64>,
    covariance: Matrix3<f64>,
    extra: Extra,
) -> Estimate {
    let mut chi2 = 0.0;
    let mut squared = 0.0;
    for i in &used {
        let o = &observations[*i];
        let e = (position - o.sensor_in_world()).norm() - o.range_m();
        let sigma = o.range_sigma_m().max(1e-12);
        chi2 += (e / sigma).powi(2);
        squared += e * e;
    }
    let n = used.len();
    Estimate {
        position,
        covariance,
        diagnostics: Diagnostics {
            residual_rms_m: (squared / n.max(1) as f64).sqrt(),
            chi2,
            dof: (n * Method::Linear.dims_per_sensor()).saturating_sub(3),
            used,
            rejected: Vec::new(),
            condition_number: extra.condition_number,
            iterations: extra.iterations,
            mirror_resolved: extra.mirror_resolved,
            clamped: extra.clamped,
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The χ² quantile matches tabulated values (p = 0.001) within 2 %.
    #[test]
    fn chi2_quantiles_match_tables() {
        for (dof, table) in [
            (1, 10.828),
            (2, 13.816),
            (3, 16.266),
            (6, 22.458),
            (15, 37.697),
            (45, 80.077),
        ] {
            let q = chi2_quantile(dof, 1e-3);
            assert!((q / table - 1.0).abs() < 0.02, "dof {dof}: {q} vs {table}");
        }
    }

    /// Method names round-trip and an unknown one lists the valid names.
    #[test]
    fn method_names() {
        for m in Method::ALL {
            assert_eq!(m.name().parse::<Method>(), Ok(m));
        }
        let err = "kalman".parse::<Method>().unwrap_err();
        assert!(err.to_string().contains("geometric, linear, nls, fusion"));
    }
}
