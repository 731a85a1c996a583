//! Where the sensors are: a rig is a list of sensor ids with their poses in the world.
//!
//! Rigs come from YAML files (what a lab edits when it moves a tripod) or are built in:
//!
//! - `thesis` — the thesis's set-up (§5.2, §6.4.4, Fig. 6.8): three sensors on the corners of an
//!   isosceles triangle 4.6 m high around a 3 m walking line, all at one height. The base is
//!   4.27 m wide (k1–k2), the width Table 5.1 implies (its target stands in front of k3 at
//!   x = 2135 mm, half the base). The sensors stand on 1.5 m tripods (Table 6.1: DYNEX
//!   DX-TRP60, 60 inches) pitched down at the middle of the walkway at knee height.
//! - `ring-N` — N sensors evenly on a 3 m circle around the walkway centre, none on the walking
//!   line, at heights alternating 0.7 m and 1.5 m so the rig is not planar (range-only
//!   trilateration needs vertical spread), all aimed at the centre at knee height.
//!
//! World frame: right-handed, Z up, floor at z = 0, walking along +X through the origin.
//!
//! ```
//! let rig = trigait_rig::Rig::from_spec("ring-5").unwrap();
//! assert_eq!(rig.sensors.len(), 5);
//! let err = trigait_rig::Rig::from_yaml_str("sensors: []", "inline").unwrap_err();
//! assert!(err.to_string().contains("no sensors"));
//! ```

#![warn(missing_docs)]

use std::path::Path;

use nalgebra::{Isometry3, Point3, Translation3, UnitQuaternion, Vector3};
use serde::{Deserialize, Serialize};

/// Why a rig could not be loaded.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// The file could not be read.
    #[error("cannot read rig file {path}")]
    Read {
        /// The file.
        path: String,
        /// The I/O error.
        #[source]
        source: std::io::Error,
    },
    /// The YAML is malformed or has unknown keys.
    #[error("rig {origin}: {message}")]
    Yaml {
        /// File name or description of the source.
        origin: String,
        /// The parser's message, with line and column.
        message: String,
    },
    /// A value is out of its domain; names the sensor and the key.
    #[error("rig {origin}: sensor {sensor:?}: `{key}` {problem}")]
    Invalid {
        /// File name or description of the source.
        origin: String,
        /// The sensor id (or its index if it has no id).
        sensor: String,
        /// The offending key.
        key: &'static str,
        /// What is wrong with it.
        problem: String,
    },
    /// The rig has no sensors.
    #[error("rig {origin}: no sensors")]
    Empty {
        /// File name or description of the source.
        origin: String,
    },
    /// Neither a built-in rig name nor an existing file.
    #[error(
        "unknown rig {spec:?}: {}expected `thesis`, `ring-N` (3 ≤ N ≤ 64) or a YAML rig file",
        if looks_like_a_file(spec) { not_found(spec) } else { String::new() }
    )]
    Unknown {
        /// What was asked for.
        spec: String,
    },
}

/// A parser's message cut to a few lines' worth: serde quotes a whole document that is not a
/// mapping (a file that is not a rig at all) into its message.
fn shortened(message: &str) -> String {
    const MAX_CHARS: usize = 240;
    if message.chars().count() <= MAX_CHARS {
        return message.to_owned();
    }
    let head: String = message.chars().take(MAX_CHARS).collect();
    format!("{head}… (cut)")
}

/// Where a relative rig path was looked for: a dataflow's nodes run in the folder of its YAML
/// file, not where `dora run` was typed.
fn not_found(spec: &str) -> String {
    let path = std::path::Path::new(spec);
    match std::env::current_dir() {
        Ok(dir) if path.is_relative() => format!(
            "no such file (looked for {}: a relative path starts from the folder the node runs \
             in, a dataflow's own folder); ",
            dir.join(path).display()
        ),
        _ => "no such file; ".to_owned(),
    }
}

/// Whether a rig spec names a file (a YAML extension or a path separator) rather than a
/// built-in rig.
fn looks_like_a_file(spec: &str) -> bool {
    spec.contains(std::path::MAIN_SEPARATOR)
        || spec.contains('/')
        || [".yml", ".yaml"]
            .iter()
            .any(|ext| spec.to_ascii_lowercase().ends_with(ext))
}

/// Result alias of this crate.
pub type Result<T> = std::result::Result<T, Error>;

/// One sensor of a rig.
#[derive(Debug, Clone, PartialEq)]
pub struct SensorPose {
    /// Unique id, as used for dataflow node ids and in outputs.
    pub id: String,
    /// Camera space (Kinect: x left, y up, z forward) → world.
    pub world_from_kinect: Isometry3<f64>,
}

impl SensorPose {
    /// The optical centre in the world.
    #[must_use]
    pub fn position(&self) -> Point3<f64> {
        Point3::from(self.world_from_kinect.translation.vector)
    }
}

/// A named set of sensor poses.
#[derive(Debug, Clone, PartialEq)]
pub struct Rig {
    /// Name (built-in name or file stem).
    pub name: String,
    /// The sensors, in file order.
    pub sensors: Vec<SensorPose>,
}

/// The YAML form of a rig file.
///
/// ```yaml
/// name: lab-a            # optional
/// sensors:
///   - id: k1
///     position: [-2.3, 2.135, 1.5]    # metres, world frame
///     look_at: [0.0, 0.0, 0.5]         # aim the optical axis here (camera up stays up) ...
///   - id: k2
///     position: [-2.3, -2.135, 1.5]
///     yaw_pitch_roll_deg: [45, -20, 0] # ... or give the orientation (yaw about Z from +X,
///                                      # pitch up positive, roll about the optical axis)
/// ```
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RigFile {
    /// Optional rig name.
    #[serde(default)]
    pub name: Option<String>,
    /// The sensors.
    pub sensors: Vec<SensorEntry>,
}

/// One sensor in a rig file.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SensorEntry {
    /// Unique id.
    pub id: String,
    /// Optical centre in the world, metres.
    pub position: [f64; 3],
    /// A world point the optical axis goes through.
    #[serde(default)]
    pub look_at: Option<[f64; 3]>,
    /// Orientation as yaw, pitch, roll in degrees.
    #[serde(default)]
    pub yaw_pitch_roll_deg: Option<[f64; 3]>,
}

/// Most sensors a rig may have (the built-in rings stop at 64).
pub const MAX_SENSORS: usize = 256;

/// Largest rig file read: 256 sensors take about 40 kB of YAML.
pub const MAX_RIG_FILE_BYTES: usize = 256 << 10;

/// Sensors closer together than this cannot both stand there.
pub const MIN_SEPARATION_M: f64 = 0.05;

impl Rig {
    /// A built-in rig name (`thesis`, `ring-N`) or the path of a YAML rig file.
    ///
    /// # Errors
    /// [`Error::Unknown`] for anything else, or the file's own errors.
    pub fn from_spec(spec: &str) -> Result<Rig> {
        if let Some(rig) = Rig::builtin(spec) {
            return Ok(rig);
        }
        let path = Path::new(spec);
        if path.exists() {
            return Rig::from_file(path);
        }
        Err(Error::Unknown {
            spec: spec.to_owned(),
        })
    }

    /// A built-in rig by name.
    #[must_use]
    pub fn builtin(name: &str) -> Option<Rig> {
        if name == "thesis" {
            return Some(thesis());
        }
        let n: usize = name.strip_prefix("ring-")?.parse().ok()?;
        (3..=64).contains(&n).then(|| ring(n))
    }

    /// Reads and validates a YAML rig file.
    ///
    /// # Errors
    /// [`Error::Read`], [`Error::Yaml`], [`Error::Invalid`] or [`Error::Empty`].
    pub fn from_file(path: &Path) -> Result<Rig> {
        let text =
            trigait_input_limits::read_bounded_text(path, MAX_RIG_FILE_BYTES as u64, "rig file")
                .map_err(|source| Error::Read {
                    path: path.display().to_string(),
                    source,
                })?;
        let mut rig = Rig::from_yaml_str(&text, &path.display().to_string())?;
        if rig.name.is_empty() {
            rig.name = path
                .file_stem()
                .map_or_else(String::new, |s| s.to_string_lossy().into_owned());
        }
        Ok(rig)
    }

    /// Parses and validates rig YAML; `origin` names the source in errors.
    ///
    /// # Errors
    /// [`Error::Yaml`], [`Error::Invalid`] or [`Error::Empty`].
    pub fn from_yaml_str(text: &str, origin: &str) -> Result<Rig> {
        // libyaml's cost grows with the square of the nesting depth: measure it first.
        trigait_input_limits::check_config_text(text, MAX_RIG_FILE_BYTES).map_err(|message| {
            Error::Yaml {
                origin: origin.to_owned(),
                message,
            }
        })?;
        let file: RigFile = serde_yaml::from_str(text).map_err(|e| Error::Yaml {
            origin: origin.to_owned(),
            message: shortened(&e.to_string()),
        })?;
        Rig::from_rig_file(file, origin)
    }

    /// Validates a parsed rig file.
    ///
    /// # Errors
    /// [`Error::Invalid`] naming the sensor and key, or [`Error::Empty`].
    pub fn from_rig_file(file: RigFile, origin: &str) -> Result<Rig> {
        if file.sensors.is_empty() {
            return Err(Error::Empty {
                origin: origin.to_owned(),
            });
        }
        if file.sensors.len() > MAX_SENSORS {
            return Err(Error::Yaml {
                origin: origin.to_owned(),
                message: format!(
                    "{} sensors, more than the {MAX_SENSORS} a rig may have",
                    file.sensors.len()
                ),
            });
        }
        let invalid = |sensor: &str, key, problem: String| Error::Invalid {
            origin: origin.to_owned(),
            sensor: sensor.to_owned(),
            key,
            problem,
        };
        let mut sensors: Vec<SensorPose> = Vec::with_capacity(file.sensors.len());
        for (index, entry) in file.sensors.iter().enumerate() {
            let label = if entry.id.trim().is_empty() {
                format!("#{index}")
            } else {
                entry.id.clone()
            };
            if entry.id.trim().is_empty() {
                return Err(invalid(&label, "id", "must not be empty".into()));
            }
            if sensors.iter().any(|s| s.id == entry.id) {
                return Err(invalid(&label, "id", "is used by another sensor".into()));
            }
            if entry.position.iter().any(|v| !v.is_finite()) {
                return Err(invalid(
                    &label,
                    "position",
                    "must be three finite numbers".into(),
                ));
            }
            let position = Point3::from(entry.position);
            let rotation = match (entry.look_at, entry.yaw_pitch_roll_deg) {
                (Some(_), Some(_)) => {
                    return Err(invalid(
                        &label,
                        "look_at",
                        "and `yaw_pitch_roll_deg` are both given; use one".into(),
                    ));
                }
                (None, None) => {
                    return Err(invalid(
                        &label,
                        "look_at",
                        "or `yaw_pitch_roll_deg` is required".into(),
                    ));
                }
                (Some(target), None) => {
                    let target = Point3::from(target);
                    if target.coords.iter().any(|v| !v.is_finite()) {
                        return Err(invalid(&label, "look_at", "must be finite".into()));
                    }
                    let forward = target - position;
                    if forward.norm() < 1e-6 {
                        return Err(invalid(&label, "look_at", "equals `position`".into()));
                    }
                    if forward.normalize().cross(&Vector3::z()).norm() < 1e-6 {
                        return Err(invalid(
                            &label,
                            "look_at",
                            "is straight above or below the sensor; give `yaw_pitch_roll_deg`"
                                .into(),
                        ));
                    }
                    looking_at(&position, &target).rotation
                }
                (None, Some(angles)) => {
                    if angles.iter().any(|v| !v.is_finite()) {
                        return Err(invalid(
                            &label,
                            "yaw_pitch_roll_deg",
                            "must be finite".into(),
                        ));
                    }
                    from_yaw_pitch_roll(angles)
                }
            };
            if let Some(other) = sensors
                .iter()
                .find(|s| (s.position() - position).norm() < MIN_SEPARATION_M)
            {
                return Err(invalid(
                    &label,
                    "position",
                    format!("is within {MIN_SEPARATION_M} m of sensor {:?}", other.id),
                ));
            }
            sensors.push(SensorPose {
                id: entry.id.clone(),
                world_from_kinect: Isometry3::from_parts(Translation3::from(position), rotation),
            });
        }
        Ok(Rig {
            name: file.name.unwrap_or_default(),
            sensors,
        })
    }

    /// The rig as a YAML rig file (positions and `look_at` points 1 m along each axis).
    #[must_use]
    pub fn to_rig_file(&self) -> RigFile {
        RigFile {
            name: Some(self.name.clone()),
            sensors: self
                .sensors
                .iter()
                .map(|s| {
                    let p = s.position();
                    let target = s.world_from_kinect * Point3::new(0.0, 0.0, 1.0);
                    SensorEntry {
                        id: s.id.clone(),
                        position: [p.x, p.y, p.z],
                        look_at: Some([target.x, target.y, target.z]),
                        yaw_pitch_roll_deg: None,
                    }
                })
                .collect(),
        }
    }

    /// A short text that two rigs share exactly when they hold the same sensor ids at the same
    /// poses (to 0.1 mm and 1 µrad; the name does not count): nodes of one graph that read the
    /// rig each from their own `RIG` compare it to find out they were given different rigs.
    #[must_use]
    pub fn fingerprint(&self) -> String {
        // FNV-1a over the ids and the rounded pose coordinates: stable across builds and
        // platforms, unlike `std`'s hasher.
        let mut hash: u64 = 0xcbf2_9ce4_8422_2325;
        let mut eat = |bytes: &[u8]| {
            for b in bytes {
                hash ^= u64::from(*b);
                hash = hash.wrapping_mul(0x0100_0000_01b3);
            }
        };
        for s in &self.sensors {
            eat(s.id.as_bytes());
            eat(&[0]);
            let t = s.world_from_kinect.translation.vector;
            // A quaternion and its negative are one rotation: fix the sign first.
            let q = s.world_from_kinect.rotation.coords;
            let q = if q.w < 0.0 { -q } else { q };
            let rounded = t
                .iter()
                .map(|v| (v * 1e4).round() as i64)
                .chain(q.iter().map(|v| (v * 1e6).round() as i64));
            for v in rounded {
                eat(&v.to_le_bytes());
            }
        }
        format!("{}:{hash:016x}", self.sensors.len())
    }

    /// Largest distance between two sensors (the thesis recommends ≤ 10 m, §6.4.4).
    #[must_use]
    pub fn span_m(&self) -> f64 {
        let mut span: f64 = 0.0;
        for (i, a) in self.sensors.iter().enumerate() {
            for b in &self.sensors[i + 1..] {
                span = span.max((a.position() - b.position()).norm());
            }
        }
        span
    }
}

/// Camera pose at `eye` with the optical axis through `target` and the camera's up as close to
/// world +Z as the axis allows (Kinect axes: x left, y up, z forward).
#[must_use]
pub fn looking_at(eye: &Point3<f64>, target: &Point3<f64>) -> Isometry3<f64> {
    Isometry3::face_towards(eye, target, &Vector3::z())
}

/// Orientation from yaw (about world Z, from +X towards +Y), pitch (optical axis up positive)
/// and roll (about the optical axis), in degrees.
fn from_yaw_pitch_roll([yaw, pitch, roll]: [f64; 3]) -> UnitQuaternion<f64> {
    let (yaw, pitch, roll) = (yaw.to_radians(), pitch.to_radians(), roll.to_radians());
    let forward = Vector3::new(
        yaw.cos() * pitch.cos(),
        yaw.sin() * pitch.cos(),
        pitch.sin(),
    );
    let level = looking_at(&Point3::origin(), &Point3::from(forward)).rotation;
    level * UnitQuaternion::from_axis_angle(&Vector3::z_axis(), roll)
}

/// Walkway point the built-in rigs aim at: its centre at knee height.
const AIM: Point3<f64> = Point3::new(0.0, 0.0, 0.5);

fn thesis() -> Rig {
    // Triangle height 4.6 m along the walking line, base 4.27 m; the walking line's 3 m middle
    // part runs from x = -1.5 to 1.5 between the base (x = -2.3) and the apex (x = +2.3).
    let half_base = 2.135;
    let height = 1.5;
    let corners = [
        ("k1", Point3::new(-2.3, half_base, height)),
        ("k2", Point3::new(-2.3, -half_base, height)),
        ("k3", Point3::new(2.3, 0.0, height)),
    ];
    Rig {
        name: "thesis".into(),
        sensors: corners
            .into_iter()
            .map(|(id, p)| SensorPose {
                id: id.into(),
                world_from_kinect: looking_at(&p, &AIM),
            })
            .collect(),
    }
}

fn ring(n: usize) -> Rig {
    let radius = 3.0;
    Rig {
        name: format!("ring-{n}"),
        sensors: (0..n)
            .map(|i| {
                let az = std::f64::consts::TAU * (i as f64 + 0.5) / n as f64;
                let height = if i % 2 == 0 { 0.7 } else { 1.5 };
                let p = Point3::new(radius * az.cos(), radius * az.sin(), height);
                SensorPose {
                    id: format!("k{}", i + 1),
                    world_from_kinect: looking_at(&p, &AIM),
                }
            })
            .collect(),
    }
}

#[cfg(test)]
mod tests {
    use approx::assert_relative_eq;

    use super::*;

    /// A missing rig file is said to be missing; a file that is not a rig is named without
    /// being quoted whole.
    #[test]
    fn unknown_rigs_and_foreign_files() {
        let e = Rig::from_spec("nonexist.yml").unwrap_err().to_string();
        assert!(e.contains("no such file"), "{e}");
        // A relative path says where it was looked for.
        let cwd = std::env::current_dir().unwrap();
        assert!(
            e.contains(&cwd.join("nonexist.yml").display().to_string()),
            "{e}"
        );
        let e = Rig::from_spec("ring-x").unwrap_err().to_string();
        assert!(!e.contains("no such file"), "{e}");
        let text = "word ".repeat(1000);
        let e = Rig::from_yaml_str(&text, "notes.txt")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("notes.txt") && e.len() < 400,
            "{} chars: {e}",
            e.len()
        );
    }

    /// The fingerprint tells rigs apart by poses and ids, not by name: a rig written to YAML and
    /// read back (another name, rounded look-at points) keeps it; moving one sensor 1 mm or
    /// renaming one changes it.
    #[test]
    fn fingerprint_follows_poses_and_ids() {
        let thesis = Rig::from_spec("thesis").unwrap();
        let yaml = serde_yaml::to_string(&thesis.to_rig_file()).unwrap();
        let mut copy = Rig::from_yaml_str(&yaml, "copy").unwrap();
        copy.name = "lab-a".into();
        assert_eq!(copy.fingerprint(), thesis.fingerprint());
        assert_ne!(
            thesis.fingerprint(),
            Rig::from_spec("ring-3").unwrap().fingerprint()
        );
        let mut moved = thesis.clone();
        moved.sensors[1].world_from_kinect.translation.vector.x += 0.001;
        assert_ne!(moved.fingerprint(), thesis.fingerprint());
        let mut renamed = thesis.clone();
        renamed.sensors[2].id = "k9".into();
        assert_ne!(renamed.fingerprint(), thesis.fingerprint());
        assert!(
            thesis.fingerprint().starts_with("3:"),
            "{}",
            thesis.fingerprint()
        );
    }

    /// The thesis rig: isosceles triangle 4.6 m high, base 4.27 m, sensors ≤ 10 m apart, every
    /// point of the 3 m walking line within the 0.5–4.5 m working range of every sensor.
    #[test]
    fn thesis_rig_geometry() {
        let rig = Rig::from_spec("thesis").unwrap();
        let p: Vec<Point3<f64>> = rig.sensors.iter().map(SensorPose::position).collect();
        assert_relative_eq!((p[0] - p[1]).norm(), 4.27, epsilon = 1e-12);
        assert_relative_eq!((p[0] - p[2]).norm(), (p[1] - p[2]).norm(), epsilon = 1e-12);
        assert_relative_eq!(p[2].x - p[0].x, 4.6, epsilon = 1e-12);
        assert!(rig.span_m() <= 10.0);
        for x in [-1.5, 0.0, 1.5] {
            for s in &p {
                let d = (Point3::new(x, 0.0, 0.5) - s).norm();
                assert!((0.5..=4.5).contains(&d), "{x}: {d}");
            }
        }
    }

    /// Ring rigs have N sensors on a 3 m circle at two heights, all aimed at the centre.
    #[test]
    fn ring_rigs() {
        for n in [3, 6, 16] {
            let rig = Rig::builtin(&format!("ring-{n}")).unwrap();
            assert_eq!(rig.sensors.len(), n);
            for s in &rig.sensors {
                let p = s.position();
                assert_relative_eq!(p.xy().coords.norm(), 3.0, epsilon = 1e-12);
                let axis = s.world_from_kinect.rotation * Vector3::z();
                assert_relative_eq!(axis.dot(&(AIM - p).normalize()), 1.0, epsilon = 1e-12);
                // Camera up (+y) has no sideways tilt: it lies in the vertical plane of the axis.
                let up = s.world_from_kinect.rotation * Vector3::y();
                assert!(up.z > 0.0);
                assert_relative_eq!(
                    up.dot(&axis.cross(&Vector3::z()).normalize()),
                    0.0,
                    epsilon = 1e-12
                );
            }
        }
        assert!(Rig::builtin("ring-2").is_none());
        assert!(Rig::builtin("ring-x").is_none());
    }

    /// A YAML rig round-trips through its file form, and yaw/pitch/roll agree with look_at.
    #[test]
    fn yaml_round_trip() {
        let rig = Rig::builtin("ring-4").unwrap();
        let text = serde_yaml::to_string(&rig.to_rig_file()).unwrap();
        let back = Rig::from_yaml_str(&text, "test").unwrap();
        for (a, b) in rig.sensors.iter().zip(&back.sensors) {
            assert_eq!(a.id, b.id);
            assert!(
                (a.world_from_kinect.to_homogeneous() - b.world_from_kinect.to_homogeneous())
                    .amax()
                    < 1e-12
            );
        }
        let ypr = Rig::from_yaml_str(
            "sensors:\n  - id: a\n    position: [0, 0, 1]\n    yaw_pitch_roll_deg: [90, -45, 0]\n",
            "test",
        )
        .unwrap();
        let axis = ypr.sensors[0].world_from_kinect.rotation * Vector3::z();
        assert_relative_eq!(
            axis,
            Vector3::new(0.0, 1.0, -1.0).normalize(),
            epsilon = 1e-12
        );
    }

    /// The shipped example rig file is the built-in thesis rig.
    #[test]
    fn example_file_is_the_builtin() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../rigs/thesis.yml");
        let file = Rig::from_spec(path.to_str().unwrap()).unwrap();
        let builtin = thesis();
        assert_eq!(file.name, builtin.name);
        for (a, b) in file.sensors.iter().zip(&builtin.sensors) {
            assert_eq!(a.id, b.id);
            let diff = a.world_from_kinect.to_homogeneous() - b.world_from_kinect.to_homogeneous();
            assert!(diff.amax() < 1e-12);
        }
    }

    /// Malformed rigs are errors that name the sensor and the key.
    #[test]
    fn invalid_rigs_name_sensor_and_key() {
        let cases = [
            ("sensors: []", "no sensors"),
            (
                "sensors:\n  - id: a\n    position: [0, 0]\n    look_at: [1, 0, 0]",
                "position",
            ),
            (
                "sensors:\n  - id: a\n    position: [0, 0, 1]\n    look_at: [0, 0, 1]",
                "sensor \"a\": `look_at` equals",
            ),
            (
                "sensors:\n  - id: a\n    position: [0, 0, 1]",
                "`look_at` or `yaw_pitch_roll_deg` is required",
            ),
            (
                "sensors:\n  - id: a\n    position: [0, 0, 1]\n    look_at: [1, 0, 1]\n  - id: a\n    position: [2, 0, 1]\n    look_at: [1, 0, 1]",
                "sensor \"a\": `id` is used",
            ),
            (
                "sensors:\n  - id: a\n    position: [0, 0, 1]\n    look_at: [1, 0, 1]\n  - id: b\n    position: [0.01, 0, 1]\n    look_at: [1, 0, 1]",
                "within 0.05 m",
            ),
            (
                "sensors:\n  - id: a\n    position: [0, 0, 1]\n    look_at: [1, 0, 1]\n    colour: red",
                "unknown field `colour`",
            ),
            (
                "sensors:\n  - id: a\n    position: [0, 0, .nan]\n    look_at: [1, 0, 1]",
                "finite",
            ),
            (
                "sensors:\n  - id: a\n    position: [0, 0, 1]\n    look_at: [0, 0, 0]",
                "straight above or below",
            ),
        ];
        for (yaml, expected) in cases {
            let err = Rig::from_yaml_str(yaml, "lab.yml").unwrap_err().to_string();
            assert!(err.contains(expected), "{yaml:?}: {err}");
            assert!(err.contains("lab.yml"), "{err}");
        }
        let unknown = Rig::from_spec("triangle").unwrap_err().to_string();
        assert!(unknown.contains("ring-N"), "{unknown}");
    }
}
