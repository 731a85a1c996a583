//! The articulated leg model and its fit to the person's points.
//!
//! Each leg is a chain hip → knee → ankle of two straight segments. The person's points below
//! the hip are cut into horizontal bands; every point goes to the leg whose predicted axis
//! (the last fit moved on by its velocity) is nearer at the point's height, so the two legs
//! keep their identities when they pass each other. A band of one leg is a visible arc of a
//! roughly round limb: its centre lies behind the arc's mean, away from the camera, by π/4 of
//! the radius (the mean depth of a half-circle seen from afar), with the radius taken from the
//! band's spread across the view (√3 × the standard deviation of points spread evenly over a
//! width). Two straight lines fitted to the band centres above and below a breakpoint give the
//! thigh and the shank; the breakpoint with the least residual is the knee.

use nalgebra::{Point3, Vector2, Vector3};

/// Width of a band, metres.
pub(crate) const BAND_M: f64 = 0.03;

/// Floor frame: heights along `up`, horizontal coordinates along `e1`, `e2`.
#[derive(Debug, Clone, Copy)]
pub(crate) struct FloorFrame {
    pub up: Vector3<f64>,
    pub e1: Vector3<f64>,
    pub e2: Vector3<f64>,
    pub camera_height_m: f64,
}

impl FloorFrame {
    pub fn new(up: Vector3<f64>, camera_height_m: f64) -> Self {
        let z = Vector3::z();
        let e1 = (z - up * up.dot(&z))
            .try_normalize(1e-9)
            .unwrap_or_else(Vector3::x);
        let e2 = up.cross(&e1);
        Self {
            up,
            e1,
            e2,
            camera_height_m,
        }
    }
    /// (horizontal, height) of a camera-space point.
    pub fn split(&self, p: &Vector3<f64>) -> (Vector2<f64>, f64) {
        (
            Vector2::new(self.e1.dot(p), self.e2.dot(p)),
            self.up.dot(p) + self.camera_height_m,
        )
    }
    pub fn join(&self, horizontal: &Vector2<f64>, h: f64) -> Point3<f64> {
        Point3::from(
            self.e1 * horizontal.x + self.e2 * horizontal.y + self.up * (h - self.camera_height_m),
        )
    }
}

/// One leg's joints in camera space.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct LegPose {
    pub hip: Point3<f64>,
    pub knee: Point3<f64>,
    pub ankle: Point3<f64>,
}

impl LegPose {
    /// The leg axis's horizontal position at height `h`.
    pub fn axis_at(&self, frame: &FloorFrame, h: f64) -> Vector2<f64> {
        let (hh, hip_h) = frame.split(&self.hip.coords);
        let (kh, knee_h) = frame.split(&self.knee.coords);
        let (ah, ankle_h) = frame.split(&self.ankle.coords);
        let lerp = |a: Vector2<f64>, ha: f64, b: Vector2<f64>, hb: f64| {
            if (ha - hb).abs() < 1e-6 {
                return (a + b) / 2.0;
            }
            let t = ((h - ha) / (hb - ha)).clamp(0.0, 1.0);
            a + (b - a) * t
        };
        if h >= knee_h {
            lerp(kh, knee_h, hh, hip_h)
        } else if h >= ankle_h {
            lerp(ah, ankle_h, kh, knee_h)
        } else {
            ah
        }
    }

    pub fn extrapolated(&self, previous: &LegPose) -> LegPose {
        let step = |now: Point3<f64>, before: Point3<f64>| {
            let v = now - before;
            // A joint moves at most ~5 m/s: clamp one frame's step to 15 cm.
            let v = if v.norm() > 0.15 {
                v * (0.15 / v.norm())
            } else {
                v
            };
            now + v
        };
        LegPose {
            hip: step(self.hip, previous.hip),
            knee: step(self.knee, previous.knee),
            ankle: step(self.ankle, previous.ankle),
        }
    }
}

/// Accumulated moments of one leg's points in one band.
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct Band {
    pub n: f64,
    sum: Vector2<f64>,
    sum_sq: [f64; 3],
    sum_h: f64,
}

impl Band {
    pub fn add(&mut self, p: &Vector2<f64>, h: f64) {
        self.n += 1.0;
        self.sum += p;
        self.sum_sq[0] += p.x * p.x;
        self.sum_sq[1] += p.x * p.y;
        self.sum_sq[2] += p.y * p.y;
        self.sum_h += h;
    }
    /// Axis centre (horizontal) and mean height of the band, with the limb radius.
    pub fn centre(&self, min_points: f64) -> Option<(Vector2<f64>, f64, f64)> {
        if self.n < min_points {
            return None;
        }
        let mean = self.sum / self.n;
        let view = mean.try_normalize(1e-9)?;
        let lateral = Vector2::new(-view.y, view.x);
        let cxx = self.sum_sq[0] / self.n - mean.x * mean.x;
        let cxy = self.sum_sq[1] / self.n - mean.x * mean.y;
        let cyy = self.sum_sq[2] / self.n - mean.y * mean.y;
        let var = lateral.x * lateral.x * cxx
            + 2.0 * lateral.x * lateral.y * cxy
            + lateral.y * lateral.y * cyy;
        let radius = (3.0 * var.max(0.0)).sqrt().clamp(0.025, 0.12);
        Some((
            mean + view * (std::f64::consts::FRAC_PI_4 * radius),
            self.sum_h / self.n,
            radius,
        ))
    }
}

/// A 3-D line through band centres, parametrised by height: c(h) = c0 + (h − h0)·slope.
#[derive(Debug, Clone, Copy)]
pub(crate) struct HeightLine {
    pub h0: f64,
    pub c0: Vector2<f64>,
    pub slope: Vector2<f64>,
    pub residual: f64,
}

impl HeightLine {
    /// Weighted least squares of horizontal position against height.
    pub fn fit(points: &[(Vector2<f64>, f64, f64)]) -> Option<Self> {
        let w: f64 = points.iter().map(|p| p.2).sum();
        if points.len() < 2 || w <= 0.0 {
            return None;
        }
        let h0 = points.iter().map(|p| p.1 * p.2).sum::<f64>() / w;
        let c0 = points.iter().map(|p| p.0 * p.2).sum::<Vector2<f64>>() / w;
        let shh: f64 = points.iter().map(|p| p.2 * (p.1 - h0).powi(2)).sum();
        if shh < 1e-6 {
            return None;
        }
        let slope = points
            .iter()
            .map(|p| (p.0 - c0) * (p.2 * (p.1 - h0)))
            .sum::<Vector2<f64>>()
            / shh;
        let residual = points
            .iter()
            .map(|p| p.2 * (p.0 - (c0 + slope * (p.1 - h0))).norm_squared())
            .sum();
        Some(Self {
            h0,
            c0,
            slope,
            residual,
        })
    }
    pub fn at(&self, h: f64) -> Vector2<f64> {
        self.c0 + self.slope * (h - self.h0)
    }
    /// Unit direction (downwards) in camera space.
    pub fn down(&self, frame: &FloorFrame) -> Vector3<f64> {
        let a = frame.join(&self.at(0.0), 0.0);
        let b = frame.join(&self.at(1.0), 1.0);
        (a - b).normalize()
    }
}

/// What one leg's fit found in this frame.
#[derive(Debug, Clone, Copy)]
pub(crate) struct LegFit {
    pub pose: LegPose,
    /// Share of the thigh bands seen (0–1).
    pub thigh_seen: f64,
    /// Share of the shank bands seen.
    pub shank_seen: f64,
    /// Foot: centre of the points below the ankle, if enough.
    pub foot: Option<Point3<f64>>,
    /// Horizontal distance between the thigh and the shank lines at the knee, metres.
    pub knee_gap_m: f64,
    /// Hip→knee as found by the breakpoint, if the knee was bent enough to place it.
    pub thigh_measured: Option<f64>,
    /// Knee (at `FitInput::thigh_for_shank` from the hip) → ankle over the sole.
    pub shank_measured: Option<f64>,
    /// The thigh's axis.
    pub thigh: HeightLine,
}

/// Point on the line `p(h)` at 3-D distance `len` below `from` (the lower intersection of the
/// sphere with the line), or along the line's direction when it misses.
fn at_distance_below(
    frame: &FloorFrame,
    line: &HeightLine,
    from: &Point3<f64>,
    len: f64,
) -> Point3<f64> {
    let (_, from_h) = frame.split(&from.coords);
    let mut best = None;
    // Bisection over height: distance from `from` grows as h goes down along the line.
    let (mut lo, mut hi) = (from_h - 2.0 * len, from_h);
    let dist = |h: f64| (frame.join(&line.at(h), h) - from).norm();
    if dist(lo) >= len {
        for _ in 0..40 {
            let mid = 0.5 * (lo + hi);
            if dist(mid) > len {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        best = Some(frame.join(&line.at(lo), lo));
    }
    best.unwrap_or_else(|| from + line.down(frame) * len)
}

/// A foot taken to stand on the floor has its heel raised when its ankle, hung at the held
/// shank length from the knee, lies this much higher than over a flat sole, metres: in
/// pre-swing the toes stay on the floor while the heel rises, and the ankle with it (the
/// rendered walker's rear ankle reaches 0.19 m in double support, 0.07 m over a flat foot). More
/// than twice the 3–4 cm median knee and ankle errors on the rendered walks, so that a flat
/// foot's hung ankle, off by its length and the knee's error, is not taken for a raised heel
/// (at 4 and 5 cm the rendered CMU walk had a frame's legs swapped).
pub(crate) const HEEL_RAISED_M: f64 = 0.08;

/// Parameters of the leg fit.
#[derive(Debug, Clone, Copy)]
pub(crate) struct FitInput {
    pub hip_h: f64,
    /// Ankle centre above the sole, metres.
    pub ankle_above_sole_m: f64,
    /// Held segment lengths, if learned.
    pub lengths: Option<(f64, f64)>,
    /// While learning: the thigh length so far, to measure the shank from.
    pub thigh_for_shank: Option<f64>,
    pub min_band_points: f64,
}

/// Fits one leg to its bands (index k covers heights [k·BAND_M, (k+1)·BAND_M)).
pub(crate) fn fit_leg(
    frame: &FloorFrame,
    bands: &[Band],
    sole_h: f64,
    on_floor: bool,
    foot_acc: (Vector3<f64>, f64),
    input: &FitInput,
) -> Option<LegFit> {
    let centres: Vec<Option<(Vector2<f64>, f64, f64)>> = bands
        .iter()
        .map(|b| b.centre(input.min_band_points))
        .collect();
    let ankle_h = sole_h + input.ankle_above_sole_m;
    // Thigh region stops below the crotch, where the legs and the hands merge with the pelvis.
    let thigh_top = input.hip_h - 0.10;
    let shank_bottom = ankle_h + 0.03;
    let pts = |lo: f64, hi: f64| -> Vec<(Vector2<f64>, f64, f64)> {
        centres
            .iter()
            .flatten()
            .filter(|c| c.1 >= lo && c.1 < hi)
            .map(|c| (c.0, c.1, 1.0))
            .collect()
    };
    let all = pts(shank_bottom, thigh_top);
    if all.len() < 4 {
        return None;
    }
    // Breakpoint search: the knee height between 35 % and 75 % of the hip height.
    let mut best: Option<(f64, HeightLine, HeightLine)> = None;
    let (k_lo, k_hi) = (
        (0.35 * input.hip_h).max(shank_bottom + 2.0 * BAND_M),
        (0.75 * input.hip_h).min(thigh_top - 2.0 * BAND_M),
    );
    let mut kh = k_lo;
    while kh <= k_hi {
        let upper = pts(kh, thigh_top);
        let lower = pts(shank_bottom, kh);
        if let (Some(t), Some(s)) = (HeightLine::fit(&upper), HeightLine::fit(&lower)) {
            let r = t.residual + s.residual;
            if best
                .as_ref()
                .is_none_or(|b| r < b.1.residual + b.2.residual)
            {
                best = Some((kh, t, s));
            }
        }
        kh += BAND_M;
    }
    let (knee_h, thigh, shank) = match best {
        Some(b) => b,
        None => {
            // Too few bands on one side: one line through everything (a straight leg).
            let line = HeightLine::fit(&all)?;
            (0.5 * (input.hip_h + ankle_h), line, line)
        }
    };
    let hip = frame.join(&thigh.at(input.hip_h), input.hip_h);
    // Knee where the two lines pass closest near the breakpoint: mean of the two at its height.
    let knee_free = frame.join(&((thigh.at(knee_h) + shank.at(knee_h)) / 2.0), knee_h);
    let ankle_free = frame.join(&shank.at(ankle_h), ankle_h);
    let bend = thigh.down(frame).angle(&shank.down(frame));
    // Thigh from the breakpoint (only a bent knee places it); shank from the knee as the held
    // thigh length places it down to the ankle over the sole, so the two agree at run time.
    let thigh_measured = (bend > 25f64.to_radians()).then(|| (knee_free - hip).norm());
    let shank_measured = input
        .thigh_for_shank
        .map(|lt| (ankle_free - at_distance_below(frame, &thigh, &hip, lt)).norm());
    let (knee, ankle) = match input.lengths {
        Some((lt, ls)) => {
            let knee = at_distance_below(frame, &thigh, &hip, lt);
            // A foot flat on the floor places the ankle over it. A lifted one (pitched, the
            // sole no reference) hangs at the shank length, and so does one standing on its
            // toes with the heel raised (pre-swing), which counts as on the floor but whose
            // ankle the shank length puts well above a flat foot's ([`HEEL_RAISED_M`]). Not
            // through the floor: an ankle hung below it is on a foot that is down, at its
            // height over the floor on the shank line.
            let hung = at_distance_below(frame, &shank, &knee, ls);
            let hung_h = frame.split(&hung.coords).1;
            let ankle = if on_floor && hung_h <= ankle_h + HEEL_RAISED_M {
                ankle_free
            } else if hung_h < 0.0 {
                let h = input.ankle_above_sole_m;
                frame.join(&shank.at(h), h)
            } else {
                hung
            };
            (knee, ankle)
        }
        None => (knee_free, ankle_free),
    };
    let seen = |lo: f64, hi: f64| {
        let (a, b) = (
            (lo / BAND_M).floor().max(0.0) as usize,
            (hi / BAND_M).ceil().max(0.0) as usize,
        );
        let b = b.min(centres.len());
        if b <= a {
            return 0.0;
        }
        centres[a..b].iter().filter(|c| c.is_some()).count() as f64 / (b - a) as f64
    };
    let (_, knee_h_now) = frame.split(&knee.coords);
    let foot = (foot_acc.1 >= input.min_band_points * 2.0).then(|| {
        let mean = foot_acc.0 / foot_acc.1;
        Point3::from(mean)
    });
    Some(LegFit {
        pose: LegPose { hip, knee, ankle },
        thigh_seen: seen(knee_h_now + BAND_M, thigh_top),
        shank_seen: seen(shank_bottom, knee_h_now - BAND_M),
        foot,
        knee_gap_m: (thigh.at(knee_h_now) - shank.at(knee_h_now)).norm(),
        thigh_measured,
        shank_measured,
        thigh,
    })
}

/// Minimum points on the forefoot to place the `Foot` joint from them.
const MIN_FOREFOOT_POINTS: usize = 10;

/// The `Foot` joint (second metatarsal head) of a leg whose ankle is at `ankle`: `length` from
/// the ankle along `forward` (horizontal, camera space: the foot points where the person walks),
/// pitched towards the visible forefoot — the leg's points below the ankle, ahead of it and
/// between 0.6 and 1.4 `length` from it. The foot is rigid, so its pitch (flat, heel off, toe
/// off) is the direction of those points from the ankle. `None` when too few are seen.
pub(crate) fn place_foot(
    frame: &FloorFrame,
    ankle: &Point3<f64>,
    points: &[(Vector2<f64>, f64)],
    forward: &Vector3<f64>,
    length: f64,
) -> Option<Point3<f64>> {
    let (mut sum, mut n) = (Vector3::zeros(), 0_usize);
    for (p, h) in points {
        let d = frame.join(p, *h) - ankle;
        let r = d.norm();
        if forward.dot(&d) > 0.0
            && frame.up.dot(&d) < 0.0
            && (0.6 * length..1.4 * length).contains(&r)
        {
            sum += d;
            n += 1;
        }
    }
    // Their mean lies off the foot's long axis, towards the sensor (only the near side of the
    // foot is seen): the foot points along `forward`, pitched as they are.
    let along = forward * forward.dot(&sum) + frame.up * frame.up.dot(&sum);
    (n >= MIN_FOREFOOT_POINTS)
        .then(|| along.try_normalize(1e-9).map(|d| ankle + d * length))
        .flatten()
}

/// Height at which two thigh axes cross seen from the side, that is projected on the upright
/// plane through `walking` (horizontal, camera space). Each thigh turns about its hip, and
/// the hips sit side by side at nearly one height, so in a stride, one thigh forward and the
/// other back, the axes cross at the hips' height: the hip joint centre as the pivot of the
/// thigh's motion (the functional method, Cappozzo 1984). The pelvis turning by a few degrees
/// puts the forward leg's hip a centimetre or two ahead, which moves the crossing by that over
/// the opening. `None` unless the thighs open by at least `min_tan` (the difference of their
/// slopes along `walking`, about the sum of the tangents of their angles off the vertical).
pub(crate) fn thighs_cross_at(
    a: &HeightLine,
    b: &HeightLine,
    frame: &FloorFrame,
    walking: &Vector3<f64>,
    min_tan: f64,
) -> Option<f64> {
    let forward = Vector2::new(frame.e1.dot(walking), frame.e2.dot(walking)).try_normalize(1e-6)?;
    let opening = forward.dot(&(a.slope - b.slope));
    if opening.abs() < min_tan {
        return None;
    }
    // forward·(c_a + s_a (h − h_a)) = forward·(c_b + s_b (h − h_b))
    let gap = forward.dot(&((b.c0 - b.slope * b.h0) - (a.c0 - a.slope * a.h0)));
    Some(gap / opening)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A line through `at` (horizontal, height) with `slope` per metre of height.
    fn line(at: (Vector2<f64>, f64), slope: Vector2<f64>) -> HeightLine {
        HeightLine {
            h0: at.1,
            c0: at.0,
            slope,
            residual: 0.0,
        }
    }

    #[test]
    fn thighs_cross_at_the_hips_seen_from_the_side() {
        let frame = FloorFrame::new(Vector3::new(0.0, 1.0, 0.0), 1.0);
        // Walking along e1; the hips 0.18 m apart across it, both at 0.9 m; one thigh 25°
        // forward, the other 15° back (the thigh goes down from the hip: forward of the hip
        // below it means a negative slope along e1 with height).
        let walking = frame.e1;
        let hip_h = 0.9;
        let fwd = line(
            (Vector2::new(0.3, 0.09), hip_h),
            Vector2::new(-(25f64.to_radians().tan()), 0.02),
        );
        let back = line(
            (Vector2::new(0.3, -0.09), hip_h),
            Vector2::new(15f64.to_radians().tan(), -0.02),
        );
        // Fitted over the thigh, not at the hip: move each line's reference point down it.
        let moved = |l: HeightLine, h: f64| line((l.at(h), h), l.slope);
        let (fwd, back) = (moved(fwd, 0.7), moved(back, 0.6));
        let h = thighs_cross_at(&fwd, &back, &frame, &walking, 0.5).unwrap();
        assert!((h - hip_h).abs() < 1e-9, "{h}");
        // Seen along the walk instead of across it, the hips' line is in view: no crossing
        // there, and the thighs hardly open.
        assert!(thighs_cross_at(&fwd, &back, &frame, &frame.e2, 0.5).is_none());
        // Thighs that barely open (standing) give none.
        let still = line((Vector2::new(0.3, -0.09), 0.6), Vector2::new(-0.1, 0.0));
        let still_b = line((Vector2::new(0.3, 0.09), 0.6), Vector2::new(0.1, 0.0));
        assert!(thighs_cross_at(&still, &still_b, &frame, &walking, 0.5).is_none());
        // A hip 2 cm ahead of the other, the thighs open by 0.73: the crossing moves by
        // 2 cm / 0.73 = 2.7 cm (above the hips: the forward thigh starts further forward).
        let ahead = line(
            (Vector2::new(0.32, 0.09), hip_h),
            Vector2::new(-(25f64.to_radians().tan()), 0.02),
        );
        let h = thighs_cross_at(&ahead, &back, &frame, &walking, 0.5).unwrap();
        let opening = 25f64.to_radians().tan() + 15f64.to_radians().tan();
        assert!((h - (hip_h + 0.02 / opening)).abs() < 1e-9, "{h}");
    }
}
