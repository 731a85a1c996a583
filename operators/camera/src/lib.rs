//! The Kinect v2 depth camera as one model: a pinhole with OpenCV's Brown–Conrady distortion,
//! the projection of camera-space points to pixels, the back-projection of pixels with a depth
//! to points, and libfreenect2's own undistortion of a raw frame ([`Undistorter`]).
//!
//! Why one crate: a simulated frame (rendered along these rays), a replayed frame (measured
//! along them) and a frame from a real sensor (undistorted by the same arithmetic libfreenect2
//! uses) must agree on where a pixel looks, or a depth metric or a tracker tested on one path
//! would be wrong on another. Every pixel ↔ point conversion of the depth tools and the sensor
//! model goes through [`Intrinsics`].
//!
//! Two frames appear: OpenCV's camera frame (x right, y down, z out of the lens), in which
//! calibrations and libfreenect2 state their parameters, and Kinect v2 camera space (x left,
//! y up, z out of the lens), the project's sensor frame; they differ by the sign of x and y.
//! A depth is the distance along the optical axis (z), not along the ray.

mod undistort;

use nalgebra::{Point2, Point3};

pub use undistort::Undistorter;

/// Columns of a Kinect v2 depth frame.
pub const WIDTH: usize = 512;
/// Rows of a Kinect v2 depth frame.
pub const HEIGHT: usize = 424;
/// Pixels of a Kinect v2 depth frame.
pub const PIXELS: usize = WIDTH * HEIGHT;

/// What can go wrong with the camera model's inputs.
#[derive(Debug, thiserror::Error, PartialEq, Eq)]
#[non_exhaustive]
pub enum Error {
    /// A buffer does not have 512×424 values.
    #[error("expected {expected} values (512x424), got {got}")]
    WrongLength {
        /// Values found.
        got: usize,
        /// Values expected.
        expected: usize,
    },
}

/// The crate's result.
pub type Result<T> = std::result::Result<T, Error>;

/// Pinhole intrinsics of the depth camera with OpenCV's Brown–Conrady distortion.
///
/// Pixel (u, v) with u along the row; normalised image coordinates x = (u − cx)/fx,
/// y = (v − cy)/fy describe the ray (x, y, 1) in the OpenCV camera frame (x right, y down,
/// z out of the lens). [`rays`](Self::rays) evaluates pixel index u at u (OpenCV's and CMU
/// Panoptic's convention, centre cx = 255.5 for the nominal camera); callers whose principal
/// point counts pixel centres at u + 0.5 (libfreenect2's `getPointXYZ`, the sensor model's
/// cx = 256) pass `u + 0.5` to [`ray_kinect`](Self::ray_kinect).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Intrinsics {
    /// Focal length along u, pixels.
    pub fx: f64,
    /// Focal length along v, pixels.
    pub fy: f64,
    /// Principal point u, pixels.
    pub cx: f64,
    /// Principal point v, pixels.
    pub cy: f64,
    /// Distortion in OpenCV order k1, k2, p1, p2, k3.
    pub dist: [f64; 5],
}

impl Default for Intrinsics {
    /// Nominal Kinect v2 depth camera: f = 365 px (70.1°×60.3° field of view, thesis
    /// Table 3.1), principal point at the image centre, no distortion.
    fn default() -> Self {
        Self {
            fx: 365.0,
            fy: 365.0,
            cx: (WIDTH as f64 - 1.0) / 2.0,
            cy: (HEIGHT as f64 - 1.0) / 2.0,
            dist: [0.0; 5],
        }
    }
}

impl Intrinsics {
    /// A distortion-free pinhole.
    #[must_use]
    pub fn pinhole(fx: f64, fy: f64, cx: f64, cy: f64) -> Self {
        Self {
            fx,
            fy,
            cx,
            cy,
            dist: [0.0; 5],
        }
    }

    /// Applies the lens distortion to undistorted normalised coordinates.
    #[must_use]
    pub fn distort(&self, x: f64, y: f64) -> (f64, f64) {
        let [k1, k2, p1, p2, k3] = self.dist;
        let r2 = x * x + y * y;
        let radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3));
        let dx = 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x);
        let dy = p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y;
        (x * radial + dx, y * radial + dy)
    }

    /// Removes the lens distortion from distorted normalised coordinates by fixed-point
    /// iteration, as OpenCV's `undistortPoints` does (converges to < 1e-12 for Kinect lenses).
    #[must_use]
    pub fn undistort(&self, xd: f64, yd: f64) -> (f64, f64) {
        if self.dist == [0.0; 5] {
            return (xd, yd);
        }
        let [k1, k2, p1, p2, k3] = self.dist;
        let (mut x, mut y) = (xd, yd);
        for _ in 0..50 {
            let r2 = x * x + y * y;
            let radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3));
            let dx = 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x);
            let dy = p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y;
            let nx = (xd - dx) / radial;
            let ny = (yd - dy) / radial;
            let change = (nx - x).abs() + (ny - y).abs();
            x = nx;
            y = ny;
            if change < 1e-13 {
                break;
            }
        }
        (x, y)
    }

    /// The undistorted ray (x, y, 1), OpenCV frame, through image position (u, v).
    #[must_use]
    pub fn ray_opencv(&self, u: f64, v: f64) -> (f64, f64) {
        self.undistort((u - self.cx) / self.fx, (v - self.cy) / self.fy)
    }

    /// The undistorted ray (x, y, 1), Kinect camera space (x left, y up), through image
    /// position (u, v).
    #[must_use]
    pub fn ray_kinect(&self, u: f64, v: f64) -> (f64, f64) {
        let (x, y) = self.ray_opencv(u, v);
        (-x, -y)
    }

    /// The point at axial depth `z_m` (metres) seen at image position (u, v), OpenCV frame.
    #[must_use]
    pub fn back_project_opencv(&self, u: f64, v: f64, z_m: f64) -> Point3<f64> {
        let (x, y) = self.ray_opencv(u, v);
        Point3::new(x * z_m, y * z_m, z_m)
    }

    /// The point at axial depth `z_m` (metres) seen at image position (u, v), Kinect camera
    /// space.
    #[must_use]
    pub fn back_project_kinect(&self, u: f64, v: f64, z_m: f64) -> Point3<f64> {
        let (x, y) = self.ray_kinect(u, v);
        Point3::new(x * z_m, y * z_m, z_m)
    }

    /// Image position (u, v) of a Kinect camera-space point, distortion applied, or `None`
    /// behind the lens.
    #[must_use]
    pub fn project_kinect(&self, point_in_kinect: &Point3<f64>) -> Option<Point2<f64>> {
        (point_in_kinect.z > 0.0).then(|| {
            let (x, y) = self.distort(
                -point_in_kinect.x / point_in_kinect.z,
                -point_in_kinect.y / point_in_kinect.z,
            );
            Point2::new(self.cx + self.fx * x, self.cy + self.fy * y)
        })
    }

    /// Undistorted normalised coordinates of every pixel index, row-major (OpenCV frame).
    #[must_use]
    pub fn rays(&self) -> Rays {
        let mut xy = Vec::with_capacity(PIXELS);
        for v in 0..HEIGHT {
            for u in 0..WIDTH {
                xy.push(self.ray_opencv(u as f64, v as f64));
            }
        }
        Rays { xy }
    }
}

/// Undistorted normalised coordinates (x, y) per pixel: the ray through a pixel is (x, y, 1),
/// so a depth z (along the axis) back-projects to (x·z, y·z, z).
#[derive(Debug, Clone)]
pub struct Rays {
    xy: Vec<(f64, f64)>,
}

impl Rays {
    /// The ray of pixel `index` (row-major).
    #[must_use]
    pub fn at(&self, index: usize) -> (f64, f64) {
        self.xy[index]
    }

    /// All rays, row-major.
    #[must_use]
    pub fn as_slice(&self) -> &[(f64, f64)] {
        &self.xy
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn panoptic_like() -> Intrinsics {
        Intrinsics {
            dist: [0.0956, -0.272, 9.65e-5, -1.33e-4, 0.0925],
            ..Intrinsics::default()
        }
    }

    /// Undistortion inverts distortion for Panoptic-like coefficients over the whole image.
    #[test]
    fn undistort_inverts_distort() {
        let k = panoptic_like();
        for &(x, y) in &[(0.0, 0.0), (0.3, -0.2), (-0.69, 0.57), (0.7, 0.58)] {
            let (xd, yd) = k.distort(x, y);
            let (xu, yu) = k.undistort(xd, yd);
            assert!(
                (xu - x).abs() < 1e-9 && (yu - y).abs() < 1e-9,
                "{x},{y} -> {xu},{yu}"
            );
        }
    }

    /// Projection and back-projection are inverse over the image, with distortion, in both
    /// frames; a point to the sensor's left (+x in Kinect space) lands left of centre.
    #[test]
    fn project_inverts_back_project() {
        let k = panoptic_like();
        for &(u, v) in &[(0.0, 0.0), (100.5, 300.25), (255.5, 211.5), (511.0, 423.0)] {
            let p = k.back_project_kinect(u, v, 2.5);
            assert!((p.z - 2.5).abs() < 1e-12);
            let px = k.project_kinect(&p).unwrap();
            assert!(
                (px.x - u).abs() < 1e-6 && (px.y - v).abs() < 1e-6,
                "{u},{v} -> {px}"
            );
            let q = k.back_project_opencv(u, v, 2.5);
            assert!((q.x + p.x).abs() < 1e-12 && (q.y + p.y).abs() < 1e-12);
        }
        assert!(k.project_kinect(&Point3::new(0.5, 0.0, 2.0)).unwrap().x < k.cx);
        assert!(k.project_kinect(&Point3::new(0.0, 0.0, -1.0)).is_none());
        let r = k.rays();
        assert_eq!(r.as_slice().len(), PIXELS);
        assert_eq!(r.at(7 * WIDTH + 9), k.ray_opencv(9.0, 7.0));
    }
}
