//! Simulated Kinect v2 depth frames of a walking body, with the joint centres that made them.
//!
//! A depth-based body tracker needs depth images with known joints to be tested without a
//! sensor. This crate renders them: joint centres (the parametric walker or mocap) drive a body
//! surface ([`body`]: tapered, non-circular ellipsoid chains for pelvis, thighs, shanks, feet,
//! torso and head), which is ray-cast into one sensor's 512×424 image from its pose in the rig,
//! in front of the floor and the walls of a room ([`Room`]). The image is then corrupted the way
//! a Kinect v2 corrupts it:
//!
//! - **time-of-flight noise per pixel**, growing with distance and with the incidence angle of
//!   the ray on the surface ([`trigait_kinect::NoiseModel::tof_sigma_m`], Fankhauser et al.
//!   2015), so limb silhouettes, seen at grazing angles, are noisier than their centre lines;
//! - **edge dropout** and **flying pixels** along depth discontinuities: the pixel footprint
//!   straddles two surfaces, and the sensor reports either nothing (thesis §3.4, §5.1.4: a 1–2
//!   pixel no-data band along contours) or a depth between them (mixed pixels);
//! - no return at grazing incidence (beyond 80°) and outside the 0.5–8 m range.
//!
//! Each frame also carries the ground-truth joint centres in the sensor's camera space and the
//! body's label image, so a tracker can be scored per joint and a segmentation per pixel.
//!
//! Pixel convention: that of [`trigait_kinect::Intrinsics::project`] (camera space x left, y up,
//! z out of the lens; the column grows to the sensor's right, the row grows down); pixel (u, v)
//! covers [u, u+1) × [v, v+1).
//!
//! Speed: the room is cast once per sensor, with its time-of-flight σ and its depth
//! discontinuities; per frame only the pixels inside each ellipsoid's silhouette box (from the
//! tangent planes through the camera centre) are ray-tested, and only pixels on or next to the
//! body are sensed from scratch, so a frame costs little more than one normal draw per pixel
//! (see `benches/render.rs`; the tests hold the brute-force renderer as the reference).

pub mod body;

use nalgebra::{Isometry3, Matrix3, Point3, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use trigait_depth::{DepthFrame, HEIGHT, PIXELS, WIDTH};
use trigait_kinect::{Intrinsics, NoiseModel};
use trigait_skeleton::Joint;

pub use body::{Body, BodyShape, Ellipsoid, Part};

/// Errors of the renderer.
#[derive(Debug, thiserror::Error, PartialEq)]
#[non_exhaustive]
pub enum Error {
    /// A joint the body needs is absent, not finite, or makes a degenerate segment.
    #[error("the body needs joint {0:?} at a finite position with non-degenerate segments")]
    MissingJoint(Joint),
    /// A parameter out of its range.
    #[error("{name} = {value} is invalid: expected {expected}")]
    BadParameter {
        /// Parameter name.
        name: &'static str,
        /// Its value.
        value: f64,
        /// What was expected.
        expected: &'static str,
    },
    /// The intrinsics are not the 512×424 depth camera.
    #[error("the camera must be {WIDTH}×{HEIGHT} pixels")]
    BadCamera,
}

/// Result alias of the renderer.
pub type Result<T> = std::result::Result<T, Error>;

/// The room behind the walker: floor at world z = 0, four walls and a ceiling of a box.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Room {
    /// World x of the walls across the walkway, metres.
    pub x_range_m: (f64, f64),
    /// World y of the side walls, metres.
    pub y_range_m: (f64, f64),
    /// Ceiling height, metres.
    pub height_m: f64,
}

impl Default for Room {
    /// A 12 m × 7 m gait lab, 3 m high, centred on the walkway (room for the thesis rig's
    /// 4.6 m triangle and the walk beyond it).
    fn default() -> Self {
        Self {
            x_range_m: (-6.0, 6.0),
            y_range_m: (-3.5, 3.5),
            height_m: 3.0,
        }
    }
}

/// Sensor effects.
#[derive(Debug, Clone, PartialEq)]
pub struct RenderParams {
    /// The depth camera.
    pub intrinsics: Intrinsics,
    /// Time-of-flight noise model (only [`NoiseModel::tof_sigma_m`] and the range are used).
    pub noise: NoiseModel,
    /// A pixel is on a discontinuity when a 4-neighbour's depth differs by more than this, m.
    pub edge_jump_m: f64,
    /// Share of discontinuity pixels on the near side that read 0 (thesis §5.1.4).
    pub edge_dropout: f64,
    /// Share of discontinuity pixels on the near side that read a depth between the two
    /// surfaces (flying pixels).
    pub flying_pixels: f64,
    /// Add noise, dropout and flying pixels (off: the noise-free geometry, for tests).
    pub noisy: bool,
    /// RNG seed.
    pub seed: u64,
}

impl Default for RenderParams {
    fn default() -> Self {
        Self {
            intrinsics: Intrinsics::default(),
            noise: NoiseModel::default(),
            edge_jump_m: 0.05,
            edge_dropout: 0.5,
            flying_pixels: 0.25,
            noisy: true,
            seed: 1,
        }
    }
}

/// One rendered frame.
#[derive(Debug, Clone)]
pub struct Rendered {
    /// What the sensor reports, mm (0 = no data).
    pub depth: DepthFrame,
    /// Which body [`Part`] each pixel's surface belongs to ([`Part::label`]; 0 = room), before
    /// dropout.
    pub labels: Vec<u8>,
    /// Ground-truth joint centres in camera space (x left, y up, z out), metres.
    pub joints_in_kinect: Vec<(Joint, Point3<f64>)>,
}

impl Rendered {
    /// The ground-truth camera-space position of `joint`, if the pose had it.
    #[must_use]
    pub fn joint(&self, joint: Joint) -> Option<Point3<f64>> {
        self.joints_in_kinect
            .iter()
            .find(|(j, _)| *j == joint)
            .map(|(_, p)| *p)
    }

    /// Pixels whose surface is the body.
    #[must_use]
    pub fn body_mask(&self) -> Vec<bool> {
        self.labels.iter().map(|&l| l != 0).collect()
    }
}

/// Renders one sensor's frames.
#[derive(Debug, Clone)]
pub struct Renderer {
    params: RenderParams,
    kinect_from_world: Isometry3<f64>,
    /// Ray direction (z = 1) of every pixel centre in camera space.
    rays: Vec<Vector3<f64>>,
    /// Depth of the room per pixel, metres (∞ = nothing).
    room_z: Vec<f64>,
    /// Incidence angle on the room per pixel, radians.
    room_incidence: Vec<f64>,
    /// What the sensor makes of each room pixel, computed once.
    room: Vec<RoomPixel>,
    /// Scratch depth and incidence of the frame being rendered: the room, with the body
    /// written over it and put back after each frame.
    z: Vec<f64>,
    incidence: Vec<f64>,
    rng: ChaCha8Rng,
}

impl Renderer {
    /// A renderer for the sensor at `world_from_kinect` in `room`.
    ///
    /// # Errors
    /// [`Error::BadCamera`] for intrinsics other than 512×424; [`Error::BadParameter`] for
    /// shares outside 0–1 or their sum above 1, or a non-positive edge jump.
    pub fn new(
        params: RenderParams,
        world_from_kinect: &Isometry3<f64>,
        room: &Room,
    ) -> Result<Self> {
        let k = params.intrinsics;
        if k.width as usize != WIDTH || k.height as usize != HEIGHT {
            return Err(Error::BadCamera);
        }
        for (name, v) in [
            ("edge_dropout", params.edge_dropout),
            ("flying_pixels", params.flying_pixels),
        ] {
            if !(0.0..=1.0).contains(&v) {
                return Err(Error::BadParameter {
                    name,
                    value: v,
                    expected: "a share within 0–1",
                });
            }
        }
        if params.edge_dropout + params.flying_pixels > 1.0 {
            return Err(Error::BadParameter {
                name: "edge_dropout + flying_pixels",
                value: params.edge_dropout + params.flying_pixels,
                expected: "at most 1",
            });
        }
        if !(params.edge_jump_m > 0.0 && params.edge_jump_m.is_finite()) {
            return Err(Error::BadParameter {
                name: "edge_jump_m",
                value: params.edge_jump_m,
                expected: "a positive depth step in metres",
            });
        }
        let mut rays = Vec::with_capacity(PIXELS);
        for v in 0..HEIGHT {
            for u in 0..WIDTH {
                rays.push(Vector3::new(
                    (k.cx - (u as f64 + 0.5)) / k.fx,
                    (k.cy - (v as f64 + 0.5)) / k.fy,
                    1.0,
                ));
            }
        }
        // Room planes in world: n·p = d with n pointing into the room.
        let planes = [
            (Vector3::z(), 0.0),
            (-Vector3::z(), -room.height_m),
            (Vector3::x(), room.x_range_m.0),
            (-Vector3::x(), -room.x_range_m.1),
            (Vector3::y(), room.y_range_m.0),
            (-Vector3::y(), -room.y_range_m.1),
        ];
        let origin = world_from_kinect.translation.vector;
        let rot = world_from_kinect.rotation;
        let mut room_z = vec![f64::INFINITY; PIXELS];
        let mut room_incidence = vec![0.0; PIXELS];
        for (i, ray) in rays.iter().enumerate() {
            let dir = rot * ray;
            for (n, d) in &planes {
                let den = n.dot(&dir);
                if den >= -1e-12 {
                    continue;
                }
                let t = (d - n.dot(&origin)) / den;
                if t > 0.0 && t < room_z[i] {
                    room_z[i] = t;
                    room_incidence[i] = (-den / dir.norm()).clamp(-1.0, 1.0).acos();
                }
            }
        }
        let grazing = trigait_kinect::MAX_INCIDENCE_RAD;
        let room = (0..PIXELS)
            .map(|i| {
                let (z, inc) = (room_z[i], room_incidence[i]);
                let far = neighbours_far(&room_z, i);
                RoomPixel {
                    z,
                    sigma: if z.is_finite() && inc <= grazing {
                        params.noise.tof_sigma_m(z, inc)
                    } else {
                        -1.0
                    },
                    edge_far: if far - z > params.edge_jump_m {
                        far
                    } else {
                        f64::NAN
                    },
                }
            })
            .collect();
        Ok(Self {
            rng: ChaCha8Rng::seed_from_u64(params.seed),
            params,
            kinect_from_world: world_from_kinect.inverse(),
            rays,
            z: room_z.clone(),
            incidence: room_incidence.clone(),
            room_z,
            room_incidence,
            room,
        })
    }

    /// The camera's pose inverse: world → camera space.
    #[must_use]
    pub fn kinect_from_world(&self) -> &Isometry3<f64> {
        &self.kinect_from_world
    }

    /// Renders the body of the pose `joint` (world positions); `None` renders the empty room.
    ///
    /// # Errors
    /// As [`Body::from_joints`].
    pub fn render_pose(
        &mut self,
        shape: &BodyShape,
        joint: impl Fn(Joint) -> Option<Point3<f64>>,
    ) -> Result<Rendered> {
        let body = Body::from_joints(shape, &joint)?;
        let joints_in_kinect = Joint::ALL
            .iter()
            .filter_map(|j| joint(*j).map(|p| (*j, self.kinect_from_world * p)))
            .collect();
        Ok(self.render_bodies(&[body], joints_in_kinect))
    }

    /// Renders any number of bodies (none: the empty room) and attaches `joints_in_kinect` as
    /// the truth.
    pub fn render_bodies(
        &mut self,
        bodies: &[Body],
        joints_in_kinect: Vec<(Joint, Point3<f64>)>,
    ) -> Rendered {
        let mut labels = vec![0_u8; PIXELS];
        let mut z = std::mem::take(&mut self.z);
        let mut incidence = std::mem::take(&mut self.incidence);
        let mut drawn: Option<PixelBox> = None;
        for e in bodies.iter().flat_map(|b| &b.ellipsoids) {
            if let Some(b) = self.cast(e, &mut z, &mut incidence, &mut labels) {
                drawn = Some(drawn.map_or(b, |d| d.union(&b)));
            }
        }
        let depth = self.sense(&z, &incidence, &labels, drawn);
        // Only body pixels were written over the room.
        for (i, _) in labels.iter().enumerate().filter(|(_, l)| **l != 0) {
            z[i] = self.room_z[i];
            incidence[i] = self.room_incidence[i];
        }
        self.z = z;
        self.incidence = incidence;
        Rendered {
            depth,
            labels,
            joints_in_kinect,
        }
    }

    /// Ray-casts one ellipsoid into the pixels of its projected bounding box, which it returns
    /// (`None`: too near the camera, not drawn).
    fn cast(
        &self,
        e: &Ellipsoid,
        z: &mut [f64],
        incidence: &mut [f64],
        labels: &mut [u8],
    ) -> Option<PixelBox> {
        let c = self.kinect_from_world * e.centre;
        let r = e.bounding_radius_m();
        if c.z - r < 0.05 {
            return None;
        }
        let q = Quadric::new(&self.kinect_from_world, e);
        let ((u0, u1), (v0, v1)) = self.pixel_box(&c, r, &q.m_mat);
        for v in v0..v1 {
            for u in u0..u1 {
                let i = v * WIDTH + u;
                if let Some((t, inc)) = q.hit(&self.rays[i], z[i]) {
                    z[i] = t;
                    incidence[i] = inc;
                    labels[i] = e.part.label();
                }
            }
        }
        Some(PixelBox { u0, u1, v0, v1 })
    }

    /// Columns and rows (half-open) whose pixel centres may see the ellipsoid centred at `c`
    /// (camera space) with shape matrix `m` and bounding radius `r`, in front of the camera
    /// (`c.z > r`): the tangent planes through the camera centre bound its silhouette
    /// exactly, a pixel of margin absorbs rounding; the projected bounding sphere's square
    /// where that has no solution.
    fn pixel_box(
        &self,
        c: &Point3<f64>,
        r: f64,
        m: &Matrix3<f64>,
    ) -> ((usize, usize), (usize, usize)) {
        let k = &self.params.intrinsics;
        // A plane x − q·z = 0 touches the ellipsoid where (cₓ − q c_z)² = M₀₀ − 2q M₀₂ + q² M₂₂:
        // a quadratic in q (the ray slope x/z), whose roots bound the silhouette.
        let slopes = |ca: f64, m_aa: f64, m_az: f64| {
            let a = c.z * c.z - m[(2, 2)];
            let b = ca * c.z - m_az;
            let cc = ca * ca - m_aa;
            let disc = b * b - a * cc;
            (a > 0.0 && disc >= 0.0).then(|| {
                let s = disc.sqrt();
                ((b - s) / a, (b + s) / a)
            })
        };
        let near = c.z - r;
        let clamp = |x: f64, hi: usize| x.max(0.0).min(hi as f64) as usize;
        // Pixel p's centre p + ½ is at cx − fx·q: centres strictly inside [lo, hi] in pixels.
        let range = |centre: f64, f: f64, slopes: Option<(f64, f64)>, extent: f64, hi: usize| {
            let (lo, up) = slopes.map_or_else(
                || {
                    let half = f * r / near + 1.0;
                    (
                        centre - f * extent / c.z - half,
                        centre - f * extent / c.z + half,
                    )
                },
                |(q_lo, q_hi)| (centre - f * q_hi - 0.5, centre - f * q_lo - 0.5),
            );
            (clamp((lo - 1.0).floor(), hi), clamp((up + 2.0).floor(), hi))
        };
        (
            range(k.cx, k.fx, slopes(c.x, m[(0, 0)], m[(0, 2)]), c.x, WIDTH),
            range(k.cy, k.fy, slopes(c.y, m[(1, 1)], m[(1, 2)]), c.y, HEIGHT),
        )
    }

    /// Turns geometric depth into what the sensor reports. Pixels of the room away from the
    /// body (outside `drawn`, the box of all body pixels, grown by one) take σ and the
    /// discontinuity test from the table made once; the draws from the RNG, pixel by pixel
    /// in row-major order, are the same as for the direct computation.
    fn sense(
        &mut self,
        z: &[f64],
        incidence: &[f64],
        labels: &[u8],
        drawn: Option<PixelBox>,
    ) -> DepthFrame {
        let p = &self.params;
        let range = (p.noise.min_depth_m, p.noise.max_depth_m);
        let mut frame = DepthFrame::zeros();
        let out = frame.as_mm_mut();
        let grazing = trigait_kinect::MAX_INCIDENCE_RAD;
        for v in 0..HEIGHT {
            let row = v * WIDTH;
            let (a, b) = match drawn {
                Some(d) if v + 1 >= d.v0 && v <= d.v1 => {
                    (row + d.u0.saturating_sub(1), row + (d.u1 + 1).min(WIDTH))
                }
                _ => (row + WIDTH, row + WIDTH),
            };
            sense_room(&self.room[row..a], &mut self.rng, p, &mut out[row..a]);
            for i in a..b {
                let (u, v) = (i % WIDTH, i / WIDTH);
                let body_near = labels[i] != 0
                    || (u > 0 && labels[i - 1] != 0)
                    || (u + 1 < WIDTH && labels[i + 1] != 0)
                    || (v > 0 && labels[i - WIDTH] != 0)
                    || (v + 1 < HEIGHT && labels[i + WIDTH] != 0);
                if !body_near {
                    sense_room(&self.room[i..=i], &mut self.rng, p, &mut out[i..=i]);
                    continue;
                }
                let zi = z[i];
                if !zi.is_finite() || incidence[i] > grazing {
                    continue;
                }
                let mut zm = zi;
                if p.noisy {
                    // Depth along the axis scales with the range; the noise model is for the
                    // range.
                    let n: f64 = StandardNormal.sample(&mut self.rng);
                    zm += n * p.noise.tof_sigma_m(zi, incidence[i]);
                    // Discontinuity: the pixel on the near side mixes the two surfaces.
                    let far = neighbours_far(z, i);
                    if far - zi > p.edge_jump_m {
                        match edge_pixel(&mut self.rng, p, zi, far) {
                            Edge::Dropped => continue,
                            Edge::Flying(mixed) => zm = mixed,
                            Edge::Kept => {}
                        }
                    }
                }
                out[i] = to_mm(zm, range);
            }
            sense_room(
                &self.room[b..row + WIDTH],
                &mut self.rng,
                p,
                &mut out[b..row + WIDTH],
            );
        }
        frame
    }
}

/// One room pixel as the sensor sees it with no body in front.
#[derive(Debug, Clone, Copy)]
struct RoomPixel {
    /// Depth, metres (∞: nothing).
    z: f64,
    /// Time-of-flight σ, metres; negative where the room returns nothing (no surface, or
    /// grazing incidence).
    sigma: f64,
    /// The farthest 4-neighbour when the pixel is on the near side of a discontinuity (more
    /// than `edge_jump_m` in front of it), NaN when it is not.
    edge_far: f64,
}

/// Pixels `u0..u1` × `v0..v1`.
#[derive(Debug, Clone, Copy)]
struct PixelBox {
    u0: usize,
    u1: usize,
    v0: usize,
    v1: usize,
}

impl PixelBox {
    fn union(&self, o: &Self) -> Self {
        Self {
            u0: self.u0.min(o.u0),
            u1: self.u1.max(o.u1),
            v0: self.v0.min(o.v0),
            v1: self.v1.max(o.v1),
        }
    }
}

/// What the sensor reports for pixels of the room whose neighbours are room too.
fn sense_room(room: &[RoomPixel], rng: &mut ChaCha8Rng, p: &RenderParams, out: &mut [u16]) {
    let range = (p.noise.min_depth_m, p.noise.max_depth_m);
    for (px, out) in room.iter().zip(out) {
        if px.sigma < 0.0 {
            continue;
        }
        let mut zm = px.z;
        if p.noisy {
            let n: f64 = StandardNormal.sample(rng);
            zm += n * px.sigma;
            if !px.edge_far.is_nan() {
                match edge_pixel(rng, p, px.z, px.edge_far) {
                    Edge::Dropped => continue,
                    Edge::Flying(mixed) => zm = mixed,
                    Edge::Kept => {}
                }
            }
        }
        *out = to_mm(zm, range);
    }
}

/// Millimetres of a depth within `range` (metres), 0 outside it. Rounds half away from zero
/// like `f64::round`, which for values of at least ½ is adding ½ and truncating (exactly:
/// the sum can only round up to the integer it reaches), at a fraction of a libm call's cost.
fn to_mm(z_m: f64, range: (f64, f64)) -> u16 {
    if !(range.0..=range.1).contains(&z_m) {
        return 0;
    }
    let mm = z_m * 1000.0;
    if mm >= 0.5 {
        (mm + 0.5) as u16
    } else {
        mm.round() as u16
    }
}

/// An ellipsoid in camera space as the quadric (p − c)ᵀ A (p − c) = 1, for intersecting the
/// pixel rays with it.
struct Quadric {
    centre: Point3<f64>,
    a_mat: Matrix3<f64>,
    /// A's inverse, the shape matrix: the ellipsoid's extent along n is √(nᵀ M n).
    m_mat: Matrix3<f64>,
    ac: Vector3<f64>,
    c_term: f64,
}

impl Quadric {
    fn new(kinect_from_world: &Isometry3<f64>, e: &Ellipsoid) -> Self {
        let centre = kinect_from_world * e.centre;
        let axes: Matrix3<f64> = kinect_from_world.rotation.to_rotation_matrix().matrix() * e.axes;
        let inv_sq = Matrix3::from_diagonal(&e.semi_m.map(|s| 1.0 / (s * s)));
        let a_mat = axes * inv_sq * axes.transpose();
        let m_mat = axes * Matrix3::from_diagonal(&e.semi_m.map(|s| s * s)) * axes.transpose();
        let ac = a_mat * centre.coords;
        let c_term = centre.coords.dot(&ac) - 1.0;
        Self {
            centre,
            a_mat,
            m_mat,
            ac,
            c_term,
        }
    }

    /// The ray `d`'s first hit nearer than `nearer_than` (in units of the ray, metres of
    /// depth for the renderer's rays), with its angle of incidence.
    fn hit(&self, d: &Vector3<f64>, nearer_than: f64) -> Option<(f64, f64)> {
        let a = d.dot(&(self.a_mat * d));
        let b = -2.0 * self.ac.dot(d);
        let disc = b * b - 4.0 * a * self.c_term;
        if disc < 0.0 {
            return None;
        }
        let t = (-b - disc.sqrt()) / (2.0 * a);
        if t <= 0.0 || t >= nearer_than {
            return None;
        }
        let normal = self.a_mat * (d * t - self.centre.coords);
        let incidence = (normal.dot(d).abs() / (normal.norm() * d.norm()))
            .clamp(0.0, 1.0)
            .acos();
        Some((t, incidence))
    }
}

/// The farthest depth among pixel `i` and its 4-neighbours.
fn neighbours_far(z: &[f64], i: usize) -> f64 {
    let (u, v) = (i % WIDTH, i / WIDTH);
    let mut far = z[i];
    if u > 0 {
        far = far.max(z[i - 1]);
    }
    if u + 1 < WIDTH {
        far = far.max(z[i + 1]);
    }
    if v > 0 {
        far = far.max(z[i - WIDTH]);
    }
    if v + 1 < HEIGHT {
        far = far.max(z[i + WIDTH]);
    }
    far
}

/// What a pixel on the near side of a discontinuity reads.
enum Edge {
    /// Nothing (edge dropout).
    Dropped,
    /// A depth between the two surfaces (a flying pixel).
    Flying(f64),
    /// Its own surface, with its noise.
    Kept,
}

/// The pixel at depth `near` on the near side of a discontinuity to `far` (∞: nothing behind,
/// then a metre behind it is mixed in).
fn edge_pixel(rng: &mut ChaCha8Rng, p: &RenderParams, near: f64, far: f64) -> Edge {
    let roll: f64 = rng.random();
    if roll < p.edge_dropout {
        Edge::Dropped
    } else if roll < p.edge_dropout + p.flying_pixels {
        let far = if far.is_finite() { far } else { near + 1.0 };
        Edge::Flying(near + rng.random::<f64>() * (far - near))
    } else {
        Edge::Kept
    }
}

#[cfg(test)]
mod tests;
