//! One frame's two leg chains: which points go to which chain, each chain's fit, and the
//! corrections made where the legs pass or hide each other. The tracker ([`crate::LegTracker`])
//! carries the fits from frame to frame; everything here sees one frame and the chains as they
//! were at the last.

use nalgebra::{Vector2, Vector3};

use crate::legs::{BAND_M, Band, FitInput, FloorFrame, LegFit, LegPose, fit_leg};
use crate::{LegTrack, segment};

/// Which leg chain a point (horizontal position, height) belongs to, if any.
pub(crate) type Assign = dyn Fn(&Vector2<f64>, f64) -> Option<usize>;

/// Each chain's points by height band, and its points low enough to be its foot.
pub(crate) type Split = ([Vec<Band>; 2], [Vec<(Vector2<f64>, f64)>; 2]);

/// An ankle that moved less than this since the last frame stands (0.45 m/s at 30 Hz), metres.
const STILL_ANKLE_M: f64 = 0.015;

/// A standing foot's sole (the centre of its lowest band seen) that moved less than this since
/// the last frame has not moved: the band's points go to the nearer predicted leg axis, which
/// shifts the centre by up to 2 cm on an unchanged image, metres.
const STILL_SOLE_M: f64 = 0.03;

/// How much better (summed gap between thigh and shank lines at the knees, metres) the
/// exchanged lower legs must join up to be taken.
const SWAP_MARGIN_M: f64 = 0.04;

/// Hips nearer than this across the walk do not tell the legs' sides, metres.
const SIDES_APART_M: f64 = 0.08;

/// Points lower than this may be a foot (a swinging ankle stays below 0.3 m), metres.
const FOOT_REGION_M: f64 = 0.35;

/// Predicted leg axes nearer than this at some height below the knees cross there, metres.
const CROSSING_M: f64 = 0.08;

/// Lower legs whose point centres lie farther apart than this may be two legs, metres: one
/// leg's points split in two lie up to about a leg's width apart, and a far leg coming out
/// from behind the near one, seen from the side, shows its lower leg 0.16 m from the other's.
/// A split is kept only when its hips lie [`HIPS_APART_M`] apart as well.
const TWO_LEGS_M: f64 = 0.15;

/// Legs split afresh whose hips lie nearer than this are one leg cut in two, metres (the hip
/// joint centres lie about 0.18 m apart).
const HIPS_APART_M: f64 = 0.1;

/// Frames a chain may go without a fit before the legs are split afresh (0.1 s at 30 Hz): a
/// leg that passes behind the other for a frame or two coasts through rather than being split
/// off the leg in front.
const MISSED_BEFORE_SPLIT: usize = 3;

/// A knee this near the other leg's, on a leg whose thigh is mostly unseen, was fitted to the
/// other leg's points, metres (walking knees pass as close as 14 cm, so the thigh must be
/// mostly unseen as well).
const HIDDEN_KNEE_M: f64 = 0.15;

/// Both chains' fits of one frame, and what each fit's foot showed: whether it stands on the
/// floor and where its sole (the centre of its lowest band seen) lies.
#[derive(Debug, Clone, Copy)]
pub(crate) struct ChainFits {
    pub fit: [Option<LegFit>; 2],
    pub on_floor: [bool; 2],
    pub sole: [Option<Vector2<f64>>; 2],
}

impl ChainFits {
    /// The two chains' fits exchanged.
    fn swap(&mut self) {
        self.fit.swap(0, 1);
        self.on_floor.swap(0, 1);
        self.sole.swap(0, 1);
    }
}

/// A frame's points below the hips: horizontal position and height in the floor's frame, and
/// the cut-off limb each is on (0: the person's component).
pub(crate) struct LegPoints {
    pub pts: Vec<(Vector2<f64>, f64)>,
    limb_of: Vec<u8>,
    n_bands: usize,
}

impl LegPoints {
    /// The points of `piece` (0: not the person; else 1 + the limb) lower than `hip_h`.
    pub fn gather(cloud: &segment::Cloud, piece: &[u8], ff: &FloorFrame, hip_h: f64) -> Self {
        let mut pts = Vec::with_capacity(8000);
        let mut limb_of = Vec::with_capacity(8000);
        for (i, &m) in piece.iter().enumerate() {
            if m == 0 {
                continue;
            }
            let h = f64::from(cloud.height[i]);
            if h >= hip_h {
                continue;
            }
            let p = cloud.points[i].coords.cast::<f64>();
            pts.push((Vector2::new(ff.e1.dot(&p), ff.e2.dot(&p)), h));
            limb_of.push(m - 1);
        }
        Self {
            pts,
            limb_of,
            n_bands: (hip_h / BAND_M).ceil() as usize + 1,
        }
    }

    /// Each chain's points by height band, and its points low enough to be its foot (for the
    /// `Foot` joint), as `assign` gives them out.
    pub fn split(&self, assign: &Assign) -> Split {
        let n_bands = self.n_bands;
        let mut bands = [
            vec![Band::default(); n_bands],
            vec![Band::default(); n_bands],
        ];
        let mut low: [Vec<(Vector2<f64>, f64)>; 2] = [Vec::new(), Vec::new()];
        // A cut-off limb is one leg's: all of it goes to the chain most of its points go to
        // (point by point, a limb passing the other leg's predicted axis would be cut in two).
        let mut votes =
            vec![[0_usize; 2]; usize::from(self.limb_of.iter().copied().max().unwrap_or(0)) + 1];
        for ((p, h), &l) in self.pts.iter().zip(&self.limb_of) {
            if l > 0
                && let Some(k) = assign(p, *h)
            {
                votes[usize::from(l)][k] += 1;
            }
        }
        for ((p, h), &l) in self.pts.iter().zip(&self.limb_of) {
            let [a, b] = votes[usize::from(l)];
            let chain = if l == 0 || a == b {
                assign(p, *h)
            } else {
                Some(usize::from(b > a))
            };
            if let Some(k) = chain {
                let b = ((h / BAND_M).floor().max(0.0) as usize).min(n_bands - 1);
                bands[k][b].add(p, *h);
                if *h < FOOT_REGION_M {
                    low[k].push((*p, *h));
                }
            }
        }
        (bands, low)
    }
}

/// Fits a frame's chains: the floor frame, the fit's parameters and the chains as they were at
/// the last frame (`None` at start-up).
pub(crate) struct ChainFitter<'a> {
    pub ff: &'a FloorFrame,
    pub input: FitInput,
    pub last: Option<&'a [LegTrack; 2]>,
    /// Hips and knees of both legs still since the last frame: someone standing still.
    pub body_still: bool,
    /// The floor cut (points lower than this are floor): a foot whose lowest band lies within
    /// a band above it may stand on the floor, metres.
    pub floor_tolerance_m: f64,
    /// Across the walk: up × the walking direction while the person walks; in the first
    /// frames after the person is found, before a walk could be told, the horizontal line
    /// through the two hips if both were seen.
    pub lateral: Option<Vector3<f64>>,
}

impl ChainFitter<'_> {
    /// How far the knees and ankles of `fits` lie on the wrong side of each other, across the
    /// walk, against the side the hips give: walking legs keep to their sides (the ankles
    /// 5-15 cm apart across the walk), so lower legs given to the wrong chains cross over,
    /// metres (0 with no line across the walk, for legs on their sides, or hips too near to
    /// tell).
    fn crossed_over(&self, fits: &ChainFits) -> f64 {
        let (Some(lat), [Some(a), Some(b)]) = (self.lateral, &fits.fit) else {
            return 0.0;
        };
        let hips = lat.dot(&(a.pose.hip - b.pose.hip));
        if hips.abs() < SIDES_APART_M {
            return 0.0;
        }
        let side = hips.signum();
        [a.pose.knee - b.pose.knee, a.pose.ankle - b.pose.ankle]
            .iter()
            .map(|d| (-side * lat.dot(d)).max(0.0))
            .sum()
    }

    /// Each chain fitted to its bands.
    pub fn fit(&self, bands: &[Vec<Band>; 2]) -> ChainFits {
        let ff = self.ff;
        let min_pts = self.input.min_band_points;
        let mut fits = ChainFits {
            fit: [None, None],
            on_floor: [false; 2],
            sole: [None, None],
        };
        for k in 0..2 {
            let Some(sole_band) = bands[k].iter().position(|b| b.n >= min_pts) else {
                continue;
            };
            // The floor cut hides the lowest centimetres: a foot whose lowest band sits just
            // above the cut stands on the floor ...
            let sole = bands[k][sole_band].centre(min_pts);
            let lowest = sole.map_or(0.0, |c| c.1);
            fits.sole[k] = sole.map(|c| c.0);
            // ... and a foot in stance is still (a swing foot skims the floor toes first): its
            // reported ankle stood still, or, for a person standing still (hips and knees
            // still), it stood on the floor and its sole has not moved since. The second keeps
            // a foot down whose ankle the decision itself moved (from hung at the shank length
            // to over the floor), which would otherwise flip it back up the next frame, and
            // on, every few frames.
            let still = self.last.is_none_or(|l| {
                (l[k].pose.ankle - l[k].previous.ankle).norm() < STILL_ANKLE_M
                    || self.body_still
                        && l[k]
                            .sole
                            .zip(fits.sole[k])
                            .is_some_and(|((was, down), now)| {
                                down && (now - was).norm() < STILL_SOLE_M
                            })
            });
            let on_floor = lowest < self.floor_tolerance_m + BAND_M && still;
            let sole_h = if on_floor { 0.0 } else { lowest - 0.5 * BAND_M };
            // Foot: the points below the ankle.
            let (mut sum, mut n) = (Vector3::zeros(), 0.0);
            for b in bands[k]
                .iter()
                .take(((sole_h + self.input.ankle_above_sole_m) / BAND_M).ceil() as usize)
            {
                if let Some((c, h, _)) = b.centre(1.0) {
                    sum += ff.join(&c, h).coords * b.n;
                    n += b.n;
                }
            }
            fits.on_floor[k] = on_floor;
            fits.fit[k] = fit_leg(ff, &bands[k], sole_h, on_floor, (sum, n), &self.input);
        }
        fits
    }

    /// Where the legs pass each other the lower legs may have gone to the wrong chains: a
    /// leg's thigh and shank lines meet at its knee, a thigh and the other leg's shank do not.
    /// Tries the lower legs exchanged below the predicted knees and keeps what joins up. The
    /// assignment to the nearer predicted axis flips where the two predicted axes cross, so a
    /// wrong prediction (lower legs crossed) mixes the lower legs below that height: the
    /// exchange is tried below the crossing too. An exchange taken moves the foot points with
    /// it.
    pub fn exchange_lower_legs(
        &self,
        predicted: &[LegPose; 2],
        (bands, low): &mut Split,
        fits: &mut ChainFits,
    ) {
        let [Some(a), Some(b)] = fits.fit else {
            return;
        };
        let ff = self.ff;
        let n_bands = bands[0].len();
        let knee_h =
            0.5 * (ff.split(&predicted[0].knee.coords).1 + ff.split(&predicted[1].knee.coords).1);
        let knee_split = ((knee_h / BAND_M).floor().max(0.0) as usize).min(n_bands);
        let mut splits = vec![knee_split];
        if let Some(cross) = (1..knee_split)
            .map(|k| {
                let h = (k as f64 + 0.5) * BAND_M;
                (
                    k,
                    (predicted[0].axis_at(ff, h) - predicted[1].axis_at(ff, h)).norm(),
                )
            })
            .min_by(|x, y| x.1.total_cmp(&y.1))
            .filter(|(k, d)| *d < CROSSING_M && k + 2 <= knee_split)
        {
            splits.push(cross.0);
        }
        let mut best_gap = a.knee_gap_m + b.knee_gap_m + self.crossed_over(fits) - SWAP_MARGIN_M;
        let mut taken = None;
        for split in splits {
            let mut swapped = bands.clone();
            let (lo0, lo1) = swapped.split_at_mut(1);
            lo0[0][..split].swap_with_slice(&mut lo1[0][..split]);
            let alt = self.fit(&swapped);
            let crossed = self.crossed_over(&alt);
            if let [Some(c), Some(d)] = &alt.fit
                && c.knee_gap_m + d.knee_gap_m + crossed < best_gap
            {
                best_gap = c.knee_gap_m + d.knee_gap_m + crossed;
                taken = Some((split, alt));
            }
        }
        if let Some((split, alt)) = taken {
            *fits = alt;
            let below = split as f64 * BAND_M;
            let [l0, l1] = low;
            let (keep0, move0): (Vec<_>, Vec<_>) = l0.iter().partition(|p| p.1 >= below);
            let (keep1, move1): (Vec<_>, Vec<_>) = l1.iter().partition(|p| p.1 >= below);
            *l0 = keep0.into_iter().chain(move1).collect();
            *l1 = keep1.into_iter().chain(move0).collect();
        }
    }

    /// A chain that has had no fit for a few frames while two legs stand apart has lost its
    /// leg: its prediction went off the body (after a sharp turn, both legs fell to the other
    /// chain) and it would coast, wrong, until it is dropped. Splits the legs afresh, as at the
    /// start, and keeps the split when it shows two thighs (at least `share` of each) whose
    /// hips lie apart as two hips do: the fitted chain takes the leg nearer its fit, the lost
    /// chain the other. A leg hidden behind the other shows no second thigh, so it keeps
    /// coasting with the pelvis.
    pub fn resplit_lost_chain(
        &self,
        points: &LegPoints,
        share: f64,
        split: &mut Split,
        fits: &mut ChainFits,
    ) {
        let lost = match &fits.fit {
            [Some(_), None] => 1,
            [None, Some(_)] => 0,
            _ => return,
        };
        let hip_h = self.input.hip_h;
        let Some(kept) = fits.fit[1 - lost] else {
            return;
        };
        if self
            .last
            .is_some_and(|l| l[lost].missed >= MISSED_BEFORE_SPLIT)
            && let Some((c0, c1)) = two_means(&points.pts, 0.1 * hip_h, 0.6 * hip_h)
            && (c0 - c1).norm() > TWO_LEGS_M
        {
            let (bands, mut low) = points.split(&nearer_mean(c0, c1));
            let mut alt = self.fit(&bands);
            if let [Some(a), Some(b)] = &alt.fit
                && a.thigh_seen >= share
                && b.thigh_seen >= share
                && (a.pose.hip - b.pose.hip).norm() >= HIPS_APART_M
            {
                // The new fits come as (a, b); `a` goes to the kept chain if its hip is the
                // nearer one, else to the lost chain.
                let a_nearer =
                    (a.pose.hip - kept.pose.hip).norm() <= (b.pose.hip - kept.pose.hip).norm();
                let a_chain = if a_nearer { 1 - lost } else { lost };
                if a_chain == 1 {
                    alt.swap();
                    low.swap(0, 1);
                }
                *fits = alt;
                split.1 = low;
            }
        }
    }
}

/// A point of the legs farther than this from both fitted leg axes is explained by neither
/// chain, metres (a leg is about 0.15 m across, its axis runs down its middle).
const UNEXPLAINED_M: f64 = 0.12;

/// Both chains on one leg leave the other leg's points unexplained: when at least this share
/// of the points below the hips (and at least [`MIN_UNEXPLAINED`]) are, the legs are split
/// afresh.
const UNEXPLAINED_SHARE: f64 = 0.15;

/// See [`UNEXPLAINED_SHARE`].
const MIN_UNEXPLAINED: usize = 50;

impl ChainFitter<'_> {
    /// The points of `points` (between 0.1 of the hip height and the hip) that lie farther than
    /// [`UNEXPLAINED_M`] from both chains' fitted axes, and all of them counted.
    fn unexplained(&self, points: &LegPoints, fits: &ChainFits) -> (usize, usize) {
        let [Some(a), Some(b)] = fits.fit else {
            return (0, 0);
        };
        let lo = 0.1 * self.input.hip_h;
        let (mut far, mut all) = (0, 0);
        for (p, h) in points.pts.iter().filter(|p| p.1 >= lo) {
            all += 1;
            let d = (p - a.pose.axis_at(self.ff, *h))
                .norm()
                .min((p - b.pose.axis_at(self.ff, *h)).norm());
            far += usize::from(d > UNEXPLAINED_M);
        }
        (far, all)
    }

    /// Both chains fitted to one leg (a start from a frame whose other lower leg was out of
    /// view, both taken from one inclined leg) leave the other leg's points to neither: with
    /// many such points, the legs are split afresh by their points between 0.1 and 0.9 of the
    /// hip height (thighs included), and the split is kept when it shows two thighs and leaves
    /// at most half as many points unexplained. The new fits go to the chains whose hips they
    /// lie nearer (summed).
    pub fn resplit_merged_chains(
        &self,
        points: &LegPoints,
        share: f64,
        split: &mut Split,
        fits: &mut ChainFits,
    ) {
        let (far, all) = self.unexplained(points, fits);
        if far < MIN_UNEXPLAINED || (far as f64) < UNEXPLAINED_SHARE * all as f64 {
            return;
        }
        let hip_h = self.input.hip_h;
        let Some((c0, c1)) = two_means(&points.pts, 0.1 * hip_h, 0.9 * hip_h) else {
            return;
        };
        let (mut bands, mut low) = points.split(&nearer_mean(c0, c1));
        let mut alt = self.fit(&bands);
        let [Some(a), Some(b)] = alt.fit else {
            return;
        };
        if a.thigh_seen < share
            || b.thigh_seen < share
            || self.unexplained(points, &alt).0 * 2 > far
        {
            return;
        }
        let [Some(x), Some(y)] = fits.fit else {
            return;
        };
        let d = |p: &LegFit, q: &LegFit| (p.pose.hip - q.pose.hip).norm();
        if d(&a, &y) + d(&b, &x) < d(&a, &x) + d(&b, &y) {
            alt.swap();
            bands.swap(0, 1);
            low.swap(0, 1);
        }
        *fits = alt;
        *split = (bands, low);
    }
}

/// A leg whose thigh shows less than the tracked share (`share`) while the other leg is seen
/// whole is mostly behind that other leg when its shank shows little too, or when its knee came
/// out beside the other's: the few points the nearest predicted axis gives it fit a leg that
/// drifts onto the one in front, and the chains then exchange lower legs. Its fit is dropped,
/// so it coasts with the pelvis, as an unseen leg does.
pub(crate) fn drop_legs_behind(fits: &mut [Option<LegFit>; 2], share: f64) {
    let whole =
        |f: &Option<LegFit>| f.is_some_and(|f| f.thigh_seen >= share && f.shank_seen >= share);
    let behind = |f: &Option<LegFit>, other: &Option<LegFit>| match (f, other) {
        (Some(f), Some(o)) => {
            f.thigh_seen < share
                && (f.shank_seen < share || (f.pose.knee - o.pose.knee).norm() < HIDDEN_KNEE_M)
        }
        _ => false,
    };
    for k in 0..2 {
        if whole(&fits[1 - k]) && behind(&fits[k], &fits[1 - k]) {
            fits[k] = None;
        }
    }
}

/// The assignment of a point to the nearer of two means (0 or 1), whatever its height.
pub(crate) fn nearer_mean(
    c0: Vector2<f64>,
    c1: Vector2<f64>,
) -> impl Fn(&Vector2<f64>, f64) -> Option<usize> {
    move |p: &Vector2<f64>, _h: f64| Some(usize::from((p - c1).norm() < (p - c0).norm()))
}

/// Two-means of the horizontal positions of the points between heights `lo` and `hi`, started
/// from the extremes along the main axis.
pub(crate) fn two_means(
    pts: &[(Vector2<f64>, f64)],
    lo: f64,
    hi: f64,
) -> Option<(Vector2<f64>, Vector2<f64>)> {
    let sel: Vec<Vector2<f64>> = pts
        .iter()
        .filter(|p| p.1 >= lo && p.1 < hi)
        .map(|p| p.0)
        .collect();
    if sel.len() < 20 {
        return None;
    }
    let mean = sel.iter().sum::<Vector2<f64>>() / sel.len() as f64;
    let (mut sxx, mut sxy, mut syy) = (0.0, 0.0, 0.0);
    for p in &sel {
        let d = p - mean;
        sxx += d.x * d.x;
        sxy += d.x * d.y;
        syy += d.y * d.y;
    }
    let angle = 0.5 * (2.0 * sxy).atan2(sxx - syy);
    let axis = Vector2::new(angle.cos(), angle.sin());
    let proj = |p: &Vector2<f64>| axis.dot(&(p - mean));
    let mut c0 = *sel.iter().min_by(|a, b| proj(a).total_cmp(&proj(b)))?;
    let mut c1 = *sel.iter().max_by(|a, b| proj(a).total_cmp(&proj(b)))?;
    for _ in 0..10 {
        let (mut s0, mut n0, mut s1, mut n1) = (Vector2::zeros(), 0.0, Vector2::zeros(), 0.0);
        for p in &sel {
            if (p - c0).norm() <= (p - c1).norm() {
                s0 += p;
                n0 += 1.0;
            } else {
                s1 += p;
                n1 += 1.0;
            }
        }
        if n0 == 0.0 || n1 == 0.0 {
            return None;
        }
        c0 = s0 / n0;
        c1 = s1 / n1;
    }
    Some((c0, c1))
}
