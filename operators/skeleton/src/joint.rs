use serde::{Deserialize, Serialize};

/// One of the 25 Kinect v2 body joints, numbered as the SDK's `JointType`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
#[allow(missing_docs)] // the names are the SDK's and say what they are
pub enum Joint {
    SpineBase = 0,
    SpineMid = 1,
    Neck = 2,
    Head = 3,
    ShoulderLeft = 4,
    ElbowLeft = 5,
    WristLeft = 6,
    HandLeft = 7,
    ShoulderRight = 8,
    ElbowRight = 9,
    WristRight = 10,
    HandRight = 11,
    HipLeft = 12,
    KneeLeft = 13,
    AnkleLeft = 14,
    FootLeft = 15,
    HipRight = 16,
    KneeRight = 17,
    AnkleRight = 18,
    FootRight = 19,
    SpineShoulder = 20,
    HandTipLeft = 21,
    ThumbLeft = 22,
    HandTipRight = 23,
    ThumbRight = 24,
}

/// Which side of the body a joint is on; the spine and head are [`Side::Centre`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[allow(missing_docs)]
pub enum Side {
    Left,
    Right,
    Centre,
}

impl Joint {
    /// All 25 joints in SDK order.
    pub const ALL: [Joint; 25] = [
        Joint::SpineBase,
        Joint::SpineMid,
        Joint::Neck,
        Joint::Head,
        Joint::ShoulderLeft,
        Joint::ElbowLeft,
        Joint::WristLeft,
        Joint::HandLeft,
        Joint::ShoulderRight,
        Joint::ElbowRight,
        Joint::WristRight,
        Joint::HandRight,
        Joint::HipLeft,
        Joint::KneeLeft,
        Joint::AnkleLeft,
        Joint::FootLeft,
        Joint::HipRight,
        Joint::KneeRight,
        Joint::AnkleRight,
        Joint::FootRight,
        Joint::SpineShoulder,
        Joint::HandTipLeft,
        Joint::ThumbLeft,
        Joint::HandTipRight,
        Joint::ThumbRight,
    ];

    /// The six joints the thesis tracks (§6.4.4): hips, knees and ankles, left then right.
    pub const LEGS: [Joint; 6] = [
        Joint::HipLeft,
        Joint::KneeLeft,
        Joint::AnkleLeft,
        Joint::HipRight,
        Joint::KneeRight,
        Joint::AnkleRight,
    ];

    /// Bones of the Kinect v2 skeleton as (parent, child) pairs, for drawing.
    pub const BONES: [(Joint, Joint); 24] = [
        (Joint::SpineBase, Joint::SpineMid),
        (Joint::SpineMid, Joint::SpineShoulder),
        (Joint::SpineShoulder, Joint::Neck),
        (Joint::Neck, Joint::Head),
        (Joint::SpineShoulder, Joint::ShoulderLeft),
        (Joint::ShoulderLeft, Joint::ElbowLeft),
        (Joint::ElbowLeft, Joint::WristLeft),
        (Joint::WristLeft, Joint::HandLeft),
        (Joint::HandLeft, Joint::HandTipLeft),
        (Joint::WristLeft, Joint::ThumbLeft),
        (Joint::SpineShoulder, Joint::ShoulderRight),
        (Joint::ShoulderRight, Joint::ElbowRight),
        (Joint::ElbowRight, Joint::WristRight),
        (Joint::WristRight, Joint::HandRight),
        (Joint::HandRight, Joint::HandTipRight),
        (Joint::WristRight, Joint::ThumbRight),
        (Joint::SpineBase, Joint::HipLeft),
        (Joint::HipLeft, Joint::KneeLeft),
        (Joint::KneeLeft, Joint::AnkleLeft),
        (Joint::AnkleLeft, Joint::FootLeft),
        (Joint::SpineBase, Joint::HipRight),
        (Joint::HipRight, Joint::KneeRight),
        (Joint::KneeRight, Joint::AnkleRight),
        (Joint::AnkleRight, Joint::FootRight),
    ];

    /// The SDK's `JointType` number.
    #[must_use]
    pub const fn index(self) -> usize {
        self as usize
    }

    /// The joint with SDK number `index`, if there is one.
    #[must_use]
    pub fn from_index(index: usize) -> Option<Joint> {
        Joint::ALL.get(index).copied()
    }

    /// The snake_case name used in files, YAML and JSON (`knee_left`).
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Joint::SpineBase => "spine_base",
            Joint::SpineMid => "spine_mid",
            Joint::Neck => "neck",
            Joint::Head => "head",
            Joint::ShoulderLeft => "shoulder_left",
            Joint::ElbowLeft => "elbow_left",
            Joint::WristLeft => "wrist_left",
            Joint::HandLeft => "hand_left",
            Joint::ShoulderRight => "shoulder_right",
            Joint::ElbowRight => "elbow_right",
            Joint::WristRight => "wrist_right",
            Joint::HandRight => "hand_right",
            Joint::HipLeft => "hip_left",
            Joint::KneeLeft => "knee_left",
            Joint::AnkleLeft => "ankle_left",
            Joint::FootLeft => "foot_left",
            Joint::HipRight => "hip_right",
            Joint::KneeRight => "knee_right",
            Joint::AnkleRight => "ankle_right",
            Joint::FootRight => "foot_right",
            Joint::SpineShoulder => "spine_shoulder",
            Joint::HandTipLeft => "hand_tip_left",
            Joint::ThumbLeft => "thumb_left",
            Joint::HandTipRight => "hand_tip_right",
            Joint::ThumbRight => "thumb_right",
        }
    }

    /// Parses [`Joint::name`] (also accepts the SDK's CamelCase, e.g. `KneeLeft`).
    #[must_use]
    pub fn from_name(name: &str) -> Option<Joint> {
        let wanted: String = name
            .chars()
            .filter(|c| *c != '_' && *c != '-')
            .flat_map(char::to_lowercase)
            .collect();
        Joint::ALL
            .into_iter()
            .find(|j| j.name().replace('_', "") == wanted)
    }

    /// Which side of the body the joint is on.
    #[must_use]
    pub fn side(self) -> Side {
        let name = self.name();
        if name.ends_with("_left") {
            Side::Left
        } else if name.ends_with("_right") {
            Side::Right
        } else {
            Side::Centre
        }
    }

    /// The same joint on the other side of the body (centre joints map to themselves).
    #[must_use]
    pub fn mirrored(self) -> Joint {
        let name = self.name();
        let other = if let Some(stem) = name.strip_suffix("_left") {
            format!("{stem}_right")
        } else if let Some(stem) = name.strip_suffix("_right") {
            format!("{stem}_left")
        } else {
            return self;
        };
        Joint::from_name(&other).unwrap_or(self)
    }
}

impl std::fmt::Display for Joint {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// How the Kinect body tracker rates one joint in one frame (SDK `TrackingState`).
///
/// `Inferred` means the tracker could not see the joint (occluded, out of view) and guessed it
/// from the body model; its error is several times that of a tracked joint.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum TrackingState {
    /// No position reported.
    NotTracked = 0,
    /// Position guessed from the body model.
    Inferred = 1,
    /// Position measured.
    Tracked = 2,
}

impl TrackingState {
    /// The state with SDK number `value`, if there is one.
    #[must_use]
    pub fn from_index(value: u8) -> Option<TrackingState> {
        match value {
            0 => Some(TrackingState::NotTracked),
            1 => Some(TrackingState::Inferred),
            2 => Some(TrackingState::Tracked),
            _ => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `ALL` is in SDK order, so `index` and `from_index` are inverse.
    #[test]
    fn index_round_trips() {
        for (i, j) in Joint::ALL.iter().enumerate() {
            assert_eq!(j.index(), i);
            assert_eq!(Joint::from_index(i), Some(*j));
        }
        assert_eq!(Joint::from_index(25), None);
    }

    /// Names parse back in both snake_case and SDK CamelCase; unknown names are rejected.
    #[test]
    fn names_round_trip() {
        for j in Joint::ALL {
            assert_eq!(Joint::from_name(j.name()), Some(j));
            assert_eq!(Joint::from_name(&format!("{j:?}")), Some(j));
        }
        assert_eq!(Joint::from_name("tail"), None);
    }

    /// Mirroring swaps sides and is an involution.
    #[test]
    fn mirror_is_involution() {
        assert_eq!(Joint::KneeLeft.mirrored(), Joint::KneeRight);
        assert_eq!(Joint::Head.mirrored(), Joint::Head);
        for j in Joint::ALL {
            assert_eq!(j.mirrored().mirrored(), j);
        }
    }

    /// Every bone joins two distinct joints and every joint but the root is some bone's child.
    #[test]
    fn bones_form_a_tree() {
        let mut children: Vec<Joint> = Joint::BONES.iter().map(|b| b.1).collect();
        children.sort();
        children.dedup();
        assert_eq!(children.len(), 24);
        assert!(!children.contains(&Joint::SpineBase));
    }
}
