//! Joint centres from skin markers: the ground truth a perfect Kinect body tracker would report.
//!
//! Methods (all classic gait-lab practice, chosen because they need only the markers our two
//! recordings have):
//!
//! * **Pelvis frame** (Wu et al. 2002, ISB recommendation, J Biomech 35:543–548): origin at the
//!   mid-point of the ASIS markers, Z from left to right ASIS, X anterior in the plane of the ASIS
//!   markers and the PSIS mid-point, Y = Z × X superior. When both PSIS markers are missing from
//!   the file a sacrum marker (`SACR`, `S2`) stands for their mid-point.
//! * **Hip joint centres** by the regression of Harrington et al. 2007 (J Biomech 40:595–602),
//!   in millimetres in that frame, with pelvis width PW (ASIS–ASIS) and depth PD (mid-ASIS to
//!   mid-PSIS): x = −0.24 PD − 9.9, y = −0.30 PW − 10.9, z = ±(0.33 PW + 7.3). It predicts the
//!   MRI hip centre better than Davis/Bell in adults. The CMU file has no ASIS/PSIS markers: its
//!   front and back waist markers (`LFWT`/`RFWT`, `LBWT`/`RBWT`, placed over the ASIS and PSIS in
//!   the Vicon marker set) stand in for them, which makes the hip centres there only as good as
//!   that placement.
//! * **Knee and ankle centres**: the mid-point of the lateral and medial markers when both exist
//!   (epicondyles, malleoli). With a lateral marker only (both our files), the centre lies
//!   (joint width + marker diameter) / 2 medially of the lateral marker, as in Davis et al. 1991
//!   (Hum Mov Sci 10:575–587, the Plug-in Gait model). The medial direction is the pelvis's
//!   left–right axis made perpendicular to the segment (hip centre → knee marker for the knee,
//!   knee centre → ankle marker for the ankle); tibial torsion is ignored, which can shift an
//!   ankle centre by about a centimetre front-to-back.
//! * **SpineBase**: the mid-point of the two hip centres, where the Kinect v2 SDK puts the base of
//!   the spine (between the hips, at hip height).
//! * **Feet**: the toe marker (2nd metatarsal head), near where the Kinect v2 `Foot` joint sits.

use nalgebra::{Point3, Unit, Vector3};
use trigait_skeleton::{Joint, MotionClip};

use crate::{Error, Landmark, MarkerSet, Result};

/// Joint widths and marker size for the lateral-marker offsets.
///
/// The defaults are typical adult values: about 100 mm across the femoral epicondyles, about
/// 70 mm across the malleoli, and the common 14 mm Vicon marker. Neither recording states the
/// subject's widths; Plug-in Gait asks for measured ones, so use them when they are known.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointCentreParams {
    /// Medial–lateral knee width across the epicondyles, metres.
    pub knee_width_m: f64,
    /// Medial–lateral ankle width across the malleoli, metres.
    pub ankle_width_m: f64,
    /// Marker diameter, metres (the marker centre sits this far / 2 off the skin).
    pub marker_diameter_m: f64,
}

impl Default for JointCentreParams {
    fn default() -> Self {
        Self {
            knee_width_m: 0.100,
            ankle_width_m: 0.070,
            marker_diameter_m: 0.014,
        }
    }
}

const LEFT: usize = 0;
const RIGHT: usize = 1;

fn side_letter(side: usize) -> char {
    if side == LEFT { 'l' } else { 'r' }
}

fn find(set: &MarkerSet, landmark: Landmark, side: usize) -> Option<usize> {
    set.landmark(landmark, side_letter(side))
}

/// The accepted names of `landmarks` on `side`, for an error message.
fn candidates(landmarks: &[Landmark], side: usize) -> String {
    landmarks
        .iter()
        .flat_map(|l| {
            if l.sided() {
                l.labels_for(side_letter(side))
            } else {
                l.aliases().iter().map(|a| a.to_string()).collect()
            }
        })
        .collect::<Vec<_>>()
        .join(", ")
}

/// What the file holds, for an error message: its skin-marker labels (model outputs left out).
pub(crate) fn found_markers(set: &MarkerSet) -> String {
    let labels = set.marker_labels();
    const SHOWN: usize = 60;
    let mut text = labels
        .iter()
        .take(SHOWN)
        .map(|l| format!("{l:?}"))
        .collect::<Vec<_>>()
        .join(" ");
    if labels.len() > SHOWN {
        text.push_str(&format!(" … ({} more)", labels.len() - SHOWN));
    }
    if text.is_empty() {
        text = "no skin markers".to_string();
    }
    text
}

fn require(
    set: &MarkerSet,
    landmark: Landmark,
    side: usize,
    joint: Joint,
    role: &'static str,
) -> Result<usize> {
    find(set, landmark, side).ok_or_else(|| Error::MissingMarker {
        joint,
        role,
        candidates: candidates(&[landmark], side),
        found: found_markers(set),
    })
}

/// The marker columns the joint centres use.
struct Columns {
    asis: [usize; 2],
    /// Both PSIS markers, or the sacrum as their mid-point.
    psis: PsisColumns,
    knee: [(usize, Option<usize>); 2],
    ankle: [(usize, Option<usize>); 2],
    toe: [Option<usize>; 2],
}

enum PsisColumns {
    Pair([usize; 2]),
    Sacrum(usize),
}

impl Columns {
    fn find(set: &MarkerSet) -> Result<Self> {
        let hip = [Joint::HipLeft, Joint::HipRight];
        let knee = [Joint::KneeLeft, Joint::KneeRight];
        let ankle = [Joint::AnkleLeft, Joint::AnkleRight];
        let asis = [
            require(set, Landmark::Asis, LEFT, hip[LEFT], "left ASIS")?,
            require(set, Landmark::Asis, RIGHT, hip[RIGHT], "right ASIS")?,
        ];
        let psis = match (
            find(set, Landmark::Psis, LEFT),
            find(set, Landmark::Psis, RIGHT),
        ) {
            (Some(l), Some(r)) => PsisColumns::Pair([l, r]),
            _ => match find(set, Landmark::Sacrum, LEFT) {
                Some(s) => PsisColumns::Sacrum(s),
                None => {
                    return Err(Error::MissingMarker {
                        joint: Joint::SpineBase,
                        role: "PSIS or sacrum",
                        candidates: format!(
                            "{}, {}, {}",
                            candidates(&[Landmark::Psis], LEFT),
                            candidates(&[Landmark::Psis], RIGHT),
                            candidates(&[Landmark::Sacrum], LEFT)
                        ),
                        found: found_markers(set),
                    });
                }
            },
        };
        let side_columns = |side: usize| -> Result<_> {
            Ok((
                (
                    require(set, Landmark::KneeLateral, side, knee[side], "lateral knee")?,
                    find(set, Landmark::KneeMedial, side),
                ),
                (
                    require(
                        set,
                        Landmark::AnkleLateral,
                        side,
                        ankle[side],
                        "lateral ankle",
                    )?,
                    find(set, Landmark::AnkleMedial, side),
                ),
                find(set, Landmark::Toe, side),
            ))
        };
        let (knee_l, ankle_l, toe_l) = side_columns(LEFT)?;
        let (knee_r, ankle_r, toe_r) = side_columns(RIGHT)?;
        Ok(Self {
            asis,
            psis,
            knee: [knee_l, knee_r],
            ankle: [ankle_l, ankle_r],
            toe: [toe_l, toe_r],
        })
    }
}

/// The anatomical pelvis frame of one instant (Wu et al. 2002).
#[derive(Debug, Clone, Copy)]
struct Pelvis {
    origin: Point3<f64>,
    /// Anterior.
    x: Unit<Vector3<f64>>,
    /// Superior.
    y: Unit<Vector3<f64>>,
    /// From left to right.
    z: Unit<Vector3<f64>>,
    /// ASIS–ASIS distance, metres.
    width: f64,
    /// Mid-ASIS to mid-PSIS distance, metres.
    depth: f64,
}

impl Pelvis {
    fn new(lasis: Point3<f64>, rasis: Point3<f64>, mid_psis: Point3<f64>) -> Option<Self> {
        let origin = nalgebra::center(&lasis, &rasis);
        let across = rasis - lasis;
        let width = across.norm();
        let z = Unit::try_new(across, 1e-6)?;
        let back_to_front = origin - mid_psis;
        let x = Unit::try_new(back_to_front - z.into_inner() * z.dot(&back_to_front), 1e-6)?;
        let y = Unit::new_normalize(z.cross(&x));
        Some(Self {
            origin,
            x,
            y,
            z,
            width,
            depth: back_to_front.norm(),
        })
    }

    /// Harrington et al. 2007 hip centre of `side`.
    fn hip_centre(&self, side: usize) -> Point3<f64> {
        let (pw, pd) = (self.width * 1e3, self.depth * 1e3);
        let x = -0.24 * pd - 9.9;
        let y = -0.30 * pw - 10.9;
        let lateral = 0.33 * pw + 7.3;
        let z = if side == RIGHT { lateral } else { -lateral };
        self.origin
            + (self.x.into_inner() * x + self.y.into_inner() * y + self.z.into_inner() * z) * 1e-3
    }

    /// The unit vector pointing from `side`'s lateral markers toward the body's midline.
    fn medial(&self, side: usize) -> Vector3<f64> {
        if side == RIGHT {
            -self.z.into_inner()
        } else {
            self.z.into_inner()
        }
    }
}

/// The centre of a joint from its lateral (and maybe medial) marker: the mid-point when both are
/// present; else `offset` along `medial` (needed then), made perpendicular to the segment axis
/// toward `proximal` when that centre is known in this frame, used as is when it is not.
fn centre_from_lateral(
    lateral: Point3<f64>,
    medial_marker: Option<Point3<f64>>,
    proximal: Option<Point3<f64>>,
    medial: Option<Vector3<f64>>,
    offset: f64,
) -> Option<Point3<f64>> {
    if let Some(m) = medial_marker {
        return Some(nalgebra::center(&lateral, &m));
    }
    let medial = medial?;
    let direction = match proximal.and_then(|p| Unit::try_new(p - lateral, 1e-6)) {
        Some(axis) => Unit::try_new(medial - axis.into_inner() * axis.dot(&medial), 1e-6)?,
        None => Unit::try_new(medial, 1e-6)?,
    };
    Some(lateral + direction.into_inner() * offset)
}

/// Joint centres of a marker set with [`JointCentreParams::default`]; see
/// [`joint_centres_with`].
///
/// # Errors
/// As [`joint_centres_with`].
pub fn joint_centres(markers: &MarkerSet) -> Result<MotionClip> {
    joint_centres_with(markers, &JointCentreParams::default())
}

/// Joint centres of a marker set: hips, knees, ankles, `SpineBase`, and feet when toe markers
/// exist, by the methods in this module's documentation.
///
/// A joint whose markers are missing in a frame is a gap in that frame (nothing is interpolated):
/// hips need all pelvis markers; a knee or ankle needs its lateral marker and either its medial
/// marker or the pelvis (for the medial direction). If only the proximal joint centre is
/// missing, the pelvis axis is used without making it perpendicular to the segment.
///
/// # Errors
/// [`Error::MissingMarker`] when the file has no marker for a required landmark (ASIS, PSIS or
/// sacrum, lateral knee, lateral ankle on either side); [`Error::BadParameter`] for negative or
/// non-finite widths.
pub fn joint_centres_with(markers: &MarkerSet, params: &JointCentreParams) -> Result<MotionClip> {
    for (name, value) in [
        ("knee_width_m", params.knee_width_m),
        ("ankle_width_m", params.ankle_width_m),
        ("marker_diameter_m", params.marker_diameter_m),
    ] {
        if !(value.is_finite() && value >= 0.0) {
            return Err(Error::BadParameter {
                name,
                value,
                reason: "must be a finite length ≥ 0 m",
            });
        }
    }
    let columns = Columns::find(markers)?;
    let knee_offset = (params.knee_width_m + params.marker_diameter_m) / 2.0;
    let ankle_offset = (params.ankle_width_m + params.marker_diameter_m) / 2.0;
    let with_feet = columns.toe.iter().all(Option::is_some);

    let mut joints = vec![
        Joint::SpineBase,
        Joint::HipLeft,
        Joint::KneeLeft,
        Joint::AnkleLeft,
        Joint::HipRight,
        Joint::KneeRight,
        Joint::AnkleRight,
    ];
    if with_feet {
        joints.extend([Joint::FootLeft, Joint::FootRight]);
    }

    let at = |frame: usize, column: usize| markers.position_at_column(frame, column);
    let frames = (0..markers.frame_count())
        .map(|f| {
            let mid_psis = match columns.psis {
                PsisColumns::Pair([l, r]) => at(f, l)
                    .zip(at(f, r))
                    .map(|(l, r)| nalgebra::center(&l, &r)),
                PsisColumns::Sacrum(s) => at(f, s),
            };
            let pelvis = match (
                at(f, columns.asis[LEFT]),
                at(f, columns.asis[RIGHT]),
                mid_psis,
            ) {
                (Some(l), Some(r), Some(p)) => Pelvis::new(l, r, p),
                _ => None,
            };
            let mut hip = [None; 2];
            let mut knee = [None; 2];
            let mut ankle = [None; 2];
            let mut foot = [None; 2];
            for side in [LEFT, RIGHT] {
                hip[side] = pelvis.map(|p| p.hip_centre(side));
                let medial = pelvis.map(|p| p.medial(side));
                let (knee_lat, knee_med) = columns.knee[side];
                knee[side] = at(f, knee_lat).and_then(|lat| {
                    centre_from_lateral(
                        lat,
                        knee_med.and_then(|m| at(f, m)),
                        hip[side],
                        medial,
                        knee_offset,
                    )
                });
                let (ankle_lat, ankle_med) = columns.ankle[side];
                ankle[side] = at(f, ankle_lat).and_then(|lat| {
                    centre_from_lateral(
                        lat,
                        ankle_med.and_then(|m| at(f, m)),
                        knee[side],
                        medial,
                        ankle_offset,
                    )
                });
                foot[side] = columns.toe[side].and_then(|t| at(f, t));
            }
            let spine_base = hip[LEFT]
                .zip(hip[RIGHT])
                .map(|(l, r)| nalgebra::center(&l, &r));
            let mut row = vec![
                spine_base,
                hip[LEFT],
                knee[LEFT],
                ankle[LEFT],
                hip[RIGHT],
                knee[RIGHT],
                ankle[RIGHT],
            ];
            if with_feet {
                row.extend([foot[LEFT], foot[RIGHT]]);
            }
            row
        })
        .collect();
    Ok(MotionClip::new(
        markers.name().to_string(),
        markers.rate_hz(),
        joints,
        frames,
    )?)
}

/// The skin markers gait events are read from, as gait labs use them (Zeni et al. 2008): a
/// pelvis point, the heels (calcaneus) and the toes, each one trajectory per frame (`None` =
/// gap), in metres, Z up.
#[derive(Debug, Clone, PartialEq)]
pub struct FootMarkers {
    /// Pelvis point: the mean of the ASIS mid-point and the PSIS mid-point (or sacrum) when
    /// all are there, else the sacrum or PSIS mid-point alone, else the ASIS mid-point.
    pub pelvis: Vec<Option<Point3<f64>>>,
    /// Heel markers, left then right.
    pub heel: [Vec<Option<Point3<f64>>>; 2],
    /// Toe markers, left then right; `None` throughout when the file has none.
    pub toe: [Option<Vec<Option<Point3<f64>>>>; 2],
    /// The labels used, as written in the file: pelvis markers, then heels, then toes.
    pub labels: Vec<String>,
}

/// Finds the pelvis, heel and toe markers of a marker set by [`crate::MARKER_NAMES`].
///
/// # Errors
/// [`Error::MissingMarker`] without a heel marker on either side, or without any pelvis marker
/// (ASIS pair, PSIS pair or sacrum); the error lists what the file holds.
pub fn foot_markers(set: &MarkerSet) -> Result<FootMarkers> {
    let asis = find(set, Landmark::Asis, LEFT).zip(find(set, Landmark::Asis, RIGHT));
    let back = match (
        find(set, Landmark::Psis, LEFT),
        find(set, Landmark::Psis, RIGHT),
    ) {
        (Some(l), Some(r)) => Some(vec![l, r]),
        _ => find(set, Landmark::Sacrum, LEFT).map(|s| vec![s]),
    };
    if asis.is_none() && back.is_none() {
        return Err(Error::MissingMarker {
            joint: Joint::SpineBase,
            role: "pelvis (ASIS pair, PSIS pair or sacrum)",
            candidates: candidates(&[Landmark::Asis, Landmark::Psis, Landmark::Sacrum], LEFT),
            found: found_markers(set),
        });
    }
    let heel_joint = [Joint::AnkleLeft, Joint::AnkleRight];
    let heel = [LEFT, RIGHT].map(|side| {
        require(
            set,
            Landmark::Heel,
            side,
            heel_joint[side],
            if side == LEFT {
                "left heel"
            } else {
                "right heel"
            },
        )
    });
    let [heel_l, heel_r] = heel;
    let heel = [heel_l?, heel_r?];
    let toe = [LEFT, RIGHT].map(|side| find(set, Landmark::Toe, side));
    let at = |frame: usize, column: usize| set.position_at_column(frame, column);
    let mid = |frame: usize, columns: &[usize]| -> Option<Point3<f64>> {
        let points: Option<Vec<Point3<f64>>> = columns.iter().map(|c| at(frame, *c)).collect();
        let points = points?;
        let sum = points.iter().fold(Vector3::zeros(), |a, p| a + p.coords);
        Some(Point3::from(sum / points.len() as f64))
    };
    let pelvis = (0..set.frame_count())
        .map(|f| {
            let front = asis.and_then(|(l, r)| mid(f, &[l, r]));
            let rear = back.as_ref().and_then(|b| mid(f, b));
            match (asis.is_some(), back.is_some()) {
                (true, true) => front.zip(rear).map(|(a, b)| nalgebra::center(&a, &b)),
                (false, true) => rear,
                _ => front,
            }
        })
        .collect();
    let mut labels: Vec<String> = asis
        .map(|(l, r)| vec![l, r])
        .unwrap_or_default()
        .into_iter()
        .chain(back.clone().unwrap_or_default())
        .chain(heel)
        .chain(toe.iter().flatten().copied())
        .map(|c| set.labels()[c].clone())
        .collect();
    labels.dedup();
    Ok(FootMarkers {
        pelvis,
        heel: heel.map(|c| set.trajectory(c)),
        toe: toe.map(|c| c.map(|c| set.trajectory(c))),
        labels,
    })
}

#[cfg(test)]
mod tests {
    use approx::assert_relative_eq;

    use super::*;

    /// A standing subject facing +X, +Y left, with textbook marker positions.
    fn standing(medial: bool) -> MarkerSet {
        let mut labels: Vec<String> = [
            "LASI", "RASI", "LPSI", "RPSI", "LKNE", "RKNE", "LANK", "RANK", "LTOE", "RTOE",
        ]
        .map(String::from)
        .to_vec();
        let p = |x, y, z| Some(Point3::new(x, y, z));
        let mut row = vec![
            p(0.0, 0.125, 1.0),
            p(0.0, -0.125, 1.0),
            p(-0.16, 0.05, 1.0),
            p(-0.16, -0.05, 1.0),
            p(0.0, 0.057 + 0.1, 0.5),
            p(0.0, -0.157, 0.5),
            p(0.0, 0.042 + 0.1, 0.08),
            p(0.0, -0.142, 0.08),
            p(0.2, 0.1, 0.03),
            p(0.2, -0.1, 0.03),
        ];
        if medial {
            labels.extend(["L.Knee.Medial", "R.Knee.Medial"].map(String::from));
            row.extend([p(0.0, 0.03, 0.5), p(0.0, -0.03, 0.5)]);
        }
        MarkerSet::new("standing", 100.0, labels, vec![row.clone(), row]).unwrap()
    }

    /// Harrington's regression puts the hips below, behind and inside the ASIS by the published
    /// amounts; lateral-only knees and ankles are offset medially by half the joint width plus
    /// the marker radius.
    #[test]
    fn textbook_pose() {
        let clip = joint_centres(&standing(false)).unwrap();
        let hl = clip.position(0, Joint::HipLeft).unwrap();
        let hr = clip.position(0, Joint::HipRight).unwrap();
        // PW = 250 mm, PD = 160 mm.
        assert_relative_eq!(hl.x, (-0.24 * 160.0 - 9.9) * 1e-3, epsilon = 1e-9);
        assert_relative_eq!(hl.z, 1.0 + (-0.30 * 250.0 - 10.9) * 1e-3, epsilon = 1e-9);
        assert_relative_eq!(hl.y, 0.0 + (0.33 * 250.0 + 7.3) * 1e-3, epsilon = 1e-9);
        assert_relative_eq!(hr.y, -hl.y, epsilon = 1e-12);
        let sb = clip.position(0, Joint::SpineBase).unwrap();
        assert_relative_eq!(sb.y, 0.0, epsilon = 1e-12);
        // Knee marker at y = 0.157, offset (0.1 + 0.014) / 2 = 0.057 toward the midline, along
        // the pelvis axis made perpendicular to the (slightly inclined) thigh.
        let kl = clip.position(0, Joint::KneeLeft).unwrap();
        assert!((kl.y - 0.1).abs() < 0.005, "{kl}");
        let kr = clip.position(0, Joint::KneeRight).unwrap();
        assert_relative_eq!(kr.y, -kl.y, epsilon = 1e-12);
        let al = clip.position(0, Joint::AnkleLeft).unwrap();
        assert!((al.y - 0.1).abs() < 0.005, "{al}");
        assert_eq!(
            clip.position(0, Joint::FootLeft),
            Some(Point3::new(0.2, 0.1, 0.03))
        );
    }

    /// With medial markers the knee is the epicondyle mid-point.
    #[test]
    fn medial_markers_give_midpoints() {
        let clip = joint_centres(&standing(true)).unwrap();
        let kl = clip.position(0, Joint::KneeLeft).unwrap();
        assert_relative_eq!(kl.y, (0.157 + 0.03) / 2.0, epsilon = 1e-12);
        let al = clip.position(0, Joint::AnkleLeft).unwrap();
        assert!((al.y - 0.1).abs() < 0.005);
    }

    /// Gaps propagate only to the joints that need the missing marker.
    #[test]
    fn gaps_stay_local() {
        let set = standing(false);
        let knee = set.marker("LKNE").unwrap();
        let asis = set.marker("RASI").unwrap();
        let frames = (0..3)
            .map(|f| {
                (0..set.labels().len())
                    .map(|c| {
                        let gap = (f == 1 && c == knee) || (f == 2 && c == asis);
                        if gap {
                            None
                        } else {
                            set.position_at_column(0, c)
                        }
                    })
                    .collect()
            })
            .collect();
        let gappy = MarkerSet::new("g", 100.0, set.labels().to_vec(), frames).unwrap();
        let clip = joint_centres(&gappy).unwrap();
        let full = joint_centres(&set).unwrap();
        // Frame 1: only the left knee is missing; the ankle falls back to the pelvis axis.
        assert!(clip.position(1, Joint::KneeLeft).is_none());
        assert_eq!(
            clip.position(1, Joint::HipLeft),
            full.position(0, Joint::HipLeft)
        );
        let ankle = clip.position(1, Joint::AnkleLeft).unwrap();
        assert!((ankle - full.position(0, Joint::AnkleLeft).unwrap()).norm() < 0.005);
        // Frame 2: no pelvis, so no hips, knees, ankles or spine base; the feet are still there.
        for j in [
            Joint::SpineBase,
            Joint::HipRight,
            Joint::KneeLeft,
            Joint::AnkleRight,
        ] {
            assert!(clip.position(2, j).is_none(), "{j}");
        }
        assert!(clip.position(2, Joint::FootRight).is_some());
        assert_eq!(clip.missing_frames(Joint::HipLeft), 1);
    }

    /// No pelvis markers → a typed error naming what was looked for.
    #[test]
    fn missing_pelvis_is_an_error() {
        let set = standing(false);
        let labels: Vec<String> = set
            .labels()
            .iter()
            .map(|l| {
                if l == "LASI" {
                    "LFOO".into()
                } else {
                    l.clone()
                }
            })
            .collect();
        let frames = (0..set.frame_count())
            .map(|f| {
                (0..labels.len())
                    .map(|c| set.position_at_column(f, c))
                    .collect()
            })
            .collect();
        let renamed = MarkerSet::new("x", 100.0, labels, frames).unwrap();
        match joint_centres(&renamed) {
            Err(Error::MissingMarker {
                joint,
                role,
                candidates,
                found,
            }) => {
                assert!(
                    found.contains("\"LFOO\"") || found.contains("\"RASI\""),
                    "{found}"
                );
                assert_eq!(joint, Joint::HipLeft);
                assert_eq!(role, "left ASIS");
                assert!(candidates.contains("lasis"));
            }
            other => panic!("expected MissingMarker, got {other:?}"),
        }
    }
}
