//! Floor and person segmentation of one depth frame.
//!
//! Every valid pixel is back-projected to camera space; its height above the floor comes from
//! the rig's floor or a RANSAC plane fit on the lower image rows. Pixels on the floor (within a
//! few centimetres) or above any standing person are dropped, the rest are grouped into
//! connected components whose neighbouring pixels are continuous in depth (a jump larger than
//! the Kinect's noise plus the surface slope between two pixels separates objects). A component
//! is person-like when it stands on the floor, reaches head height and is about as wide as a
//! body; among those the tracker follows the one nearest to where the person was (the largest
//! at the first frame), together with the small pieces beside it that its own occlusion cut off
//! (`cut_off_limbs`).

use nalgebra::{Point3, Vector3};
use trigait_depth::plane::{RansacParams, fit_plane_ransac};
use trigait_depth::{DepthFrame, HEIGHT, PIXELS, WIDTH};

use crate::{Camera, Floor};

/// Summary of one connected component.
#[derive(Debug, Clone, PartialEq)]
pub struct Component {
    /// Label in the label image.
    pub label: u32,
    /// Pixels.
    pub pixels: usize,
    /// Metric area of the pixels' footprint, m².
    pub area_m2: f64,
    /// Lowest and highest height above the floor, metres.
    pub height_range_m: (f64, f64),
    /// Centroid in camera space.
    pub centroid: Point3<f64>,
    /// Largest horizontal distance of a point from the centroid, metres.
    pub radius_m: f64,
    /// Whether it touches the image border.
    pub at_border: bool,
}

/// Points of one frame.
pub(crate) struct Cloud {
    /// Camera-space point per pixel (z = 0: no data).
    pub points: Vec<Point3<f32>>,
    /// Height above the floor per pixel (NaN: no data), once [`components`] has the floor;
    /// empty before.
    pub height: Vec<f32>,
    /// Valid pixels.
    pub valid: usize,
}

pub(crate) fn back_project(frame: &DepthFrame, camera: &Camera, rays: &[(f32, f32)]) -> Cloud {
    let mm = frame.as_mm();
    let (lo, hi) = (camera.min_depth_m as f32, camera.max_depth_m as f32);
    let mut points = vec![Point3::new(0.0_f32, 0.0, 0.0); PIXELS];
    let mut valid = 0;
    for (i, (&d, p)) in mm.iter().zip(points.iter_mut()).enumerate() {
        let z = f32::from(d) * 1e-3;
        if d == 0 || z < lo || z > hi {
            continue;
        }
        let (rx, ry) = rays[i];
        *p = Point3::new(rx * z, ry * z, z);
        valid += 1;
    }
    Cloud {
        points,
        height: Vec::new(),
        valid,
    }
}

/// The floor from the lower half of the image: of the near-horizontal planes found there
/// (normal within 45° of the camera's up), the lowest with enough support. Tables, steps and
/// treadmill belts are horizontal too, but the floor is below them all.
pub(crate) fn fit_floor(cloud: &Cloud) -> Option<Floor> {
    let mut pts = Vec::with_capacity(12000);
    for v in (HEIGHT / 2..HEIGHT).step_by(2) {
        for u in (0..WIDTH).step_by(3) {
            let p = cloud.points[v * WIDTH + u];
            if p.z > 0.0 {
                pts.push(Point3::new(f64::from(p.x), f64::from(p.y), f64::from(p.z)));
            }
        }
    }
    let min_support = (pts.len() / 50).max(80);
    let mut best: Option<(Floor, usize)> = None;
    for round in 0..4_u64 {
        if pts.len() < min_support {
            break;
        }
        let params = RansacParams {
            iterations: 300,
            tolerance_m: 0.02,
            normal_prior: Some((Vector3::y(), 45.0)),
            seed: 0x0066_6c6f_6f72 + round,
        };
        let Ok(fit) = fit_plane_ransac(&pts, &params) else {
            break;
        };
        if fit.inliers < min_support {
            break;
        }
        // Oriented so the camera (origin) is above it.
        let plane = fit.plane.oriented(&Vector3::y());
        let camera_height = -plane.offset;
        // The best-supported plane, or one parallel to it, lower and well supported.
        let lower_parallel = best.is_some_and(|(b, support): (Floor, usize)| {
            camera_height > b.camera_height_m
                && b.up_in_kinect.angle(&plane.normal) < 10f64.to_radians()
                && fit.inliers * 10 >= support * 3
        });
        if camera_height > 0.1 && (best.is_none() || lower_parallel) {
            best = Some((
                Floor {
                    up_in_kinect: plane.normal,
                    camera_height_m: camera_height,
                },
                fit.inliers,
            ));
        }
        pts.retain(|p| fit.plane.distance(p).abs() > 0.05);
    }
    best.map(|b| b.0)
}

/// Each pixel's height above `floor` (NaN: no data), as [`components`] computes them.
pub(crate) fn heights(cloud: &Cloud, floor: &Floor) -> Vec<f32> {
    let up = floor.up_in_kinect.cast::<f32>();
    let h0 = floor.camera_height_m as f32;
    cloud
        .points
        .iter()
        .map(|p| {
            if p.z > 0.0 {
                up.dot(&p.coords) + h0
            } else {
                f32::NAN
            }
        })
        .collect()
}

/// Valid pixels the lower image half needs for [`floor_share`] to say anything.
const MIN_LOWER_PIXELS: usize = 1000;

/// The share of the lower image half's valid pixels (of `height`, per pixel over a floor)
/// within `tolerance` of that floor, if the half has [`MIN_LOWER_PIXELS`] valid ones.
pub(crate) fn floor_share(height: &[f32], tolerance: f32) -> Option<f64> {
    // Without branches, so that the loop vectorises (NaN is never within the tolerance).
    let (mut valid, mut on) = (0_usize, 0_usize);
    for h in height.get(PIXELS / 2..).unwrap_or_default() {
        valid += usize::from(!h.is_nan());
        on += usize::from(h.abs() < tolerance);
    }
    (valid >= MIN_LOWER_PIXELS).then(|| on as f64 / valid as f64)
}

/// Union–find over pixels.
struct Dsu {
    parent: Vec<u32>,
}

impl Dsu {
    fn find(&mut self, mut i: u32) -> u32 {
        while self.parent[i as usize] != i {
            let p = self.parent[i as usize];
            self.parent[i as usize] = self.parent[p as usize];
            i = p;
        }
        i
    }
    fn union(&mut self, a: u32, b: u32) {
        let (ra, rb) = (self.find(a), self.find(b));
        if ra != rb {
            let (lo, hi) = if ra < rb { (ra, rb) } else { (rb, ra) };
            self.parent[hi as usize] = lo;
        }
    }
}

/// Labels connected components of the candidate pixels; returns the label image (u32::MAX for
/// none) and the components.
#[allow(clippy::needless_range_loop)] // pixel indices address several parallel images
pub(crate) fn components(
    cloud: &mut Cloud,
    floor: &Floor,
    params: &crate::SegmentParams,
    fx: f64,
) -> (Vec<u32>, Vec<Component>) {
    cloud.height = heights(cloud, floor);
    let (floor_tol, ceiling) = (params.floor_tolerance_m as f32, params.max_height_m as f32);
    // No data (NaN) is no candidate.
    let candidate: Vec<bool> = cloud
        .height
        .iter()
        .map(|&h| h > floor_tol && h < ceiling)
        .collect();
    let mut dsu = Dsu {
        parent: (0..PIXELS as u32).collect(),
    };
    let (jump_a, jump_b) = (params.jump_m as f32, params.jump_per_m as f32);
    let close = |a: f32, b: f32| (a - b).abs() < jump_a + jump_b * a.min(b);
    for v in 0..HEIGHT {
        for u in 0..WIDTH {
            let i = v * WIDTH + u;
            if !candidate[i] {
                continue;
            }
            let z = cloud.points[i].z;
            if u + 1 < WIDTH && candidate[i + 1] && close(z, cloud.points[i + 1].z) {
                dsu.union(i as u32, (i + 1) as u32);
            }
            if v + 1 < HEIGHT && candidate[i + WIDTH] && close(z, cloud.points[i + WIDTH].z) {
                dsu.union(i as u32, (i + WIDTH) as u32);
            }
        }
    }
    // Accumulate per root.
    #[derive(Clone)]
    struct Acc {
        n: usize,
        area: f64,
        hmin: f32,
        hmax: f32,
        sum: Vector3<f64>,
        border: bool,
    }
    let mut labels = vec![u32::MAX; PIXELS];
    let mut root_to_comp = vec![u32::MAX; PIXELS];
    let mut accs: Vec<(u32, Acc)> = Vec::new();
    let inv_f2 = 1.0 / (fx * fx);
    for i in 0..PIXELS {
        if !candidate[i] {
            continue;
        }
        let r = dsu.find(i as u32);
        let mut c = root_to_comp[r as usize];
        if c == u32::MAX {
            c = accs.len() as u32;
            root_to_comp[r as usize] = c;
            accs.push((
                c,
                Acc {
                    n: 0,
                    area: 0.0,
                    hmin: f32::INFINITY,
                    hmax: f32::NEG_INFINITY,
                    sum: Vector3::zeros(),
                    border: false,
                },
            ));
        }
        labels[i] = c;
        let a = &mut accs[c as usize].1;
        let p = cloud.points[i];
        a.n += 1;
        a.area += f64::from(p.z * p.z) * inv_f2;
        a.hmin = a.hmin.min(cloud.height[i]);
        a.hmax = a.hmax.max(cloud.height[i]);
        a.sum += p.coords.cast::<f64>();
        let (u, v) = (i % WIDTH, i / WIDTH);
        a.border |= u == 0 || v == 0 || u + 1 == WIDTH || v + 1 == HEIGHT;
    }
    let min_pixels = params.min_pixels;
    let mut comps: Vec<Component> = accs
        .into_iter()
        .filter(|(_, a)| {
            a.n >= min_pixels || a.n >= SMALL_LIMB_MIN_PIXELS && a.area >= SMALL_LIMB_MIN_AREA_M2
        })
        .map(|(label, a)| Component {
            label,
            pixels: a.n,
            area_m2: a.area,
            height_range_m: (f64::from(a.hmin), f64::from(a.hmax)),
            centroid: Point3::from(a.sum / a.n as f64),
            radius_m: 0.0,
            at_border: a.border,
        })
        .collect();
    // Horizontal radius of each kept component.
    if !comps.is_empty() {
        let mut index = vec![usize::MAX; root_to_comp.len().min(PIXELS)];
        for (k, c) in comps.iter().enumerate() {
            index[c.label as usize] = k;
        }
        let upd = floor.up_in_kinect;
        let mut radius = vec![0.0_f64; comps.len()];
        for i in 0..PIXELS {
            let l = labels[i];
            if l == u32::MAX {
                continue;
            }
            let k = index[l as usize];
            if k == usize::MAX {
                continue;
            }
            let d = cloud.points[i].coords.cast::<f64>() - comps[k].centroid.coords;
            let horizontal = d - upd * upd.dot(&d);
            radius[k] = radius[k].max(horizontal.norm());
        }
        for (c, r) in comps.iter_mut().zip(radius) {
            c.radius_m = r;
        }
    }
    (labels, comps)
}

impl Component {
    /// Whether it looks like a standing or walking person (also partly out of view).
    #[must_use]
    pub fn person_like(&self, params: &crate::SegmentParams) -> bool {
        let (lo, hi) = self.height_range_m;
        lo < params.max_foot_height_m
            && (hi > params.min_person_height_m || self.at_border && hi > 0.5)
            && self.person_sized(params)
    }

    /// Whether it is as wide and as large as a person (and not one of the small pieces kept
    /// only as possible limbs, [`SMALL_LIMB_MIN_AREA_M2`]).
    fn person_sized(&self, params: &crate::SegmentParams) -> bool {
        self.pixels >= params.min_pixels
            && self.radius_m < params.max_person_radius_m
            && (params.min_person_area_m2..params.max_person_area_m2).contains(&self.area_m2)
    }
}

/// Something cut off by the image's lower edge shows at least this much of its height when it
/// is a body too close to the sensor, metres (a tabletop or a shelf shows less).
const TOO_CLOSE_SPAN_M: f64 = 0.3;

/// The image's lower edge, in rows: a component with pixels there is cut off by it (the sensor
/// drops pixels along the image's edges, so a body cut off there may not reach the last row).
const LOWER_EDGE_ROWS: usize = 8;

/// Whether one of `comps` (none of them person-like) is a body too close to the sensor: of a
/// person's size, cut off by the image's lower edge, with its lowest point above where feet
/// are (the legs go on below the image) and at least [`TOO_CLOSE_SPAN_M`] of its height in
/// view.
pub(crate) fn too_close(
    labels: &[u32],
    comps: &[Component],
    params: &crate::SegmentParams,
) -> bool {
    let lower_edge = &labels[(HEIGHT - LOWER_EDGE_ROWS) * WIDTH..];
    comps.iter().any(|c| {
        let (lo, hi) = c.height_range_m;
        lo >= params.max_foot_height_m
            && hi - lo >= TOO_CLOSE_SPAN_M
            && c.person_sized(params)
            && lower_edge.contains(&c.label)
    })
}

/// A component of fewer than `min_pixels` is still kept when it covers at least this area, m²
/// (a shoe and the lowest centimetres of a shank seen from the side, about 0.25 m × 0.06 m).
/// The pixel count that leaves out sensor specks also leaves out a lower leg seen past the
/// other leg far from the sensor: at 3.7 m a shank and foot of 0.019 m² are 183 pixels. Such a
/// piece can only be taken in as one of [`cut_off_limbs`]: it is never person-sized (nor
/// someone too close), and nearer than about 3 m (where 0.014 m² is 200 pixels) nothing
/// changes.
const SMALL_LIMB_MIN_AREA_M2: f64 = 0.014;
/// ... and at least this many pixels (0.014 m² is 50 pixels at 6.1 m).
const SMALL_LIMB_MIN_PIXELS: usize = 50;

/// A cut-off limb stays below this share of the person's top height (the knee is at 0.285 H,
/// Winter 2009; a piece may hold the lower thigh too).
const LIMB_TOP_SHARE: f64 = 0.45;
/// A cut-off limb reaches above this, metres: a lower leg does, while a piece lying lower is a
/// shoe's sole or clutter on the floor, as likely someone else's as the person's.
const LIMB_MIN_TOP_M: f64 = 0.15;
/// Largest visible area of a cut-off limb, m² (a shank and foot seen from the side ≈ 0.06 m²).
const MAX_LIMB_AREA_M2: f64 = 0.15;
/// A limb touches the person in the image within this many pixels.
const LIMB_TOUCH_PX: usize = 2;
/// A cut-off leg reaches above this share of the person's top height (above the knee, 0.285 H:
/// its thigh shows) ...
const LEG_MIN_TOP_SHARE: f64 = 0.3;
/// ... and stays below this one (the hip joint is at 0.53 H, the buttock's lower edge lower).
const LEG_MAX_TOP_SHARE: f64 = 0.6;
/// A cut-off leg comes within this depth of the person's pixels it touches, metres: the
/// other leg crossing in front of it, or the buttock behind a thigh swung back, lie about
/// 10-20 cm off, where a neighbouring object is usually farther.
const LEG_GAP_M: f32 = 0.2;
/// A cut-off leg touches the person in the image within this many pixels: the sensor drops
/// the pixels along a depth step, a band up to 3 pixels wide.
const LEG_TOUCH_PX: usize = 4;

/// Labels of the components that are the `person`'s limbs cut off from it by a depth jump.
///
/// A leg seen past the other leg may show its lower part only, its knee hidden behind the near
/// leg: the depth jump at the near leg's edge then separates it from the person's component,
/// and the person's mask loses a shank and foot. Such a piece (of at least `min_pixels`, or
/// [`SMALL_LIMB_MIN_AREA_M2`] far from the sensor, for this case and the next) is not
/// person-like itself, stands on the floor, stays below [`LIMB_TOP_SHARE`] of the person's
/// height and reaches above [`LIMB_MIN_TOP_M`], is smaller than [`MAX_LIMB_AREA_M2`], has its
/// centroid within `max_person_radius_m` of the person's (horizontally), and touches the
/// person's pixels in the image where it lies behind them (the person hides its connection).
///
/// A whole leg can be cut off as well: where the other leg crosses in front of it and the step
/// at its top (a thigh swung back stands proud of the buttock) is lined with dropped pixels.
/// The person's mask then loses a leg, and both leg chains are fitted to the other one. Such a
/// piece reaches above [`LEG_MIN_TOP_SHARE`] of the person's height and stays below
/// [`LEG_MAX_TOP_SHARE`], stands on the floor or is cut by the image's edge and reaches below
/// [`LEG_MIN_TOP_SHARE`] (near the sensor the lower edge cuts the foot off, and the piece may
/// then look like someone partly out of view), is smaller than [`MAX_LIMB_AREA_M2`], lies
/// within `max_person_radius_m` of the person, and comes within [`LEG_GAP_M`] in depth of the
/// person's pixels it touches in the image.
pub(crate) fn cut_off_limbs(
    labels: &[u32],
    cloud: &Cloud,
    comps: &[Component],
    person: &Component,
    floor: &Floor,
    params: &crate::SegmentParams,
) -> Vec<u32> {
    let up = floor.up_in_kinect;
    let horizontal = |d: Vector3<f64>| (d - up * up.dot(&d)).norm();
    let top = person.height_range_m.1;
    // Each candidate with whether it may be a limb behind the person and whether a leg.
    let mut candidates: Vec<(u32, bool, bool)> = comps
        .iter()
        .filter(|c| {
            c.label != person.label
                && c.height_range_m.1 > LIMB_MIN_TOP_M
                && c.area_m2 < MAX_LIMB_AREA_M2
                && horizontal(c.centroid - person.centroid) < params.max_person_radius_m
        })
        .map(|c| {
            let (lo, hi) = c.height_range_m;
            let behind = !c.person_like(params)
                && lo < params.max_foot_height_m
                && hi < LIMB_TOP_SHARE * top;
            // Cut by the image's edge, it need not reach the floor in view, but it must reach
            // below the knee (a hand or forearm cut off by a side edge does not).
            let leg = (LEG_MIN_TOP_SHARE * top..LEG_MAX_TOP_SHARE * top).contains(&hi)
                && (lo < params.max_foot_height_m || c.at_border && lo < LEG_MIN_TOP_SHARE * top);
            (c.label, behind, leg)
        })
        .filter(|&(_, behind, leg)| behind || leg)
        .collect();
    // The pieces are small: look around their pixels for the person's, nearer the camera (a
    // limb behind) or within `LEG_GAP_M` in depth either way (a leg).
    let mut touching = Vec::new();
    for j in 0..PIXELS {
        if candidates.is_empty() {
            break;
        }
        let l = labels[j];
        let Some(c) = candidates.iter().position(|&(c, _, _)| c == l) else {
            continue;
        };
        let (_, behind, leg) = candidates[c];
        let r = if leg { LEG_TOUCH_PX } else { LIMB_TOUCH_PX };
        let (u, v) = (j % WIDTH, j / WIDTH);
        let z = cloud.points[j].z;
        let joined = (v.saturating_sub(r)..(v + r + 1).min(HEIGHT)).any(|vv| {
            (u.saturating_sub(r)..(u + r + 1).min(WIDTH)).any(|uu| {
                let i = vv * WIDTH + uu;
                let zp = cloud.points[i].z;
                labels[i] == person.label && (behind && zp < z || leg && (zp - z).abs() < LEG_GAP_M)
            })
        });
        if joined {
            touching.push(candidates.swap_remove(c).0);
        }
    }
    touching
}

/// Intersection over union of two person masks, pixel by pixel (an empty `found` is no pixel;
/// two empty masks score 0).
#[must_use]
pub fn mask_iou(found: &[bool], truth: &[bool]) -> f64 {
    let (mut inter, mut union) = (0_usize, 0_usize);
    for (i, t) in truth.iter().enumerate() {
        let f = found.get(i).copied().unwrap_or(false);
        inter += usize::from(f && *t);
        union += usize::from(f || *t);
    }
    if union == 0 {
        0.0
    } else {
        inter as f64 / union as f64
    }
}
