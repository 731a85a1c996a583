//! The depth frame, object masks and the pinhole model that turns pixels into rays.
//!
//! A Kinect v2 depth frame is 512×424 unsigned 16-bit values in millimetres, 0 meaning "no data"
//! (thesis Table 3.1; §5.1.4 reads those zeros as edge noise). The value is the distance along
//! the optical axis (z), not along the ray.

use crate::{Error, Result};

/// Columns of a Kinect v2 depth frame.
pub const WIDTH: usize = 512;
/// Rows of a Kinect v2 depth frame.
pub const HEIGHT: usize = 424;
/// Pixels of a Kinect v2 depth frame.
pub const PIXELS: usize = WIDTH * HEIGHT;

/// One Kinect v2 depth frame: row-major millimetres, 0 = no data.
#[derive(Clone, PartialEq, Eq)]
pub struct DepthFrame {
    depth_mm: Vec<u16>,
}

impl std::fmt::Debug for DepthFrame {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("DepthFrame")
            .field("valid_pixels", &self.valid_count())
            .finish()
    }
}

impl DepthFrame {
    /// Wraps a row-major buffer of 512×424 depths in millimetres.
    ///
    /// # Errors
    /// [`Error::WrongLength`] unless the buffer has exactly [`PIXELS`] values.
    pub fn from_mm(depth_mm: Vec<u16>) -> Result<Self> {
        if depth_mm.len() != PIXELS {
            return Err(Error::WrongLength {
                got: depth_mm.len(),
                expected: PIXELS,
            });
        }
        Ok(Self { depth_mm })
    }

    /// A frame with no data anywhere.
    #[must_use]
    pub fn zeros() -> Self {
        Self {
            depth_mm: vec![0; PIXELS],
        }
    }

    /// The row-major depths in millimetres.
    #[must_use]
    pub fn as_mm(&self) -> &[u16] {
        &self.depth_mm
    }

    /// The row-major depths in millimetres, writable.
    #[must_use]
    pub fn as_mm_mut(&mut self) -> &mut [u16] {
        &mut self.depth_mm
    }

    /// Depth at column `x`, row `y` in millimetres (0 = no data).
    ///
    /// # Panics
    /// If `x >= 512` or `y >= 424` (a programming error, not a data error).
    #[must_use]
    pub fn at_mm(&self, x: usize, y: usize) -> u16 {
        assert!(x < WIDTH && y < HEIGHT, "pixel ({x}, {y}) outside 512x424");
        self.depth_mm[y * WIDTH + x]
    }

    /// Number of pixels with data.
    #[must_use]
    pub fn valid_count(&self) -> usize {
        self.depth_mm.iter().filter(|&&z| z != 0).count()
    }

    /// Share of pixels with data, 0..=1.
    #[must_use]
    pub fn valid_share(&self) -> f64 {
        self.valid_count() as f64 / PIXELS as f64
    }

    /// Checks that at least one pixel has data; `what` names the frame in the error.
    ///
    /// # Errors
    /// [`Error::NoValidPixels`] for an all-zero frame.
    pub fn ensure_valid(&self, what: &str) -> Result<()> {
        if self.depth_mm.iter().any(|&z| z != 0) {
            Ok(())
        } else {
            Err(Error::NoValidPixels {
                what: what.to_owned(),
            })
        }
    }
}

/// A per-pixel object mask (true = the object, e.g. the person in §3.4's edge noise).
#[derive(Clone, PartialEq, Eq)]
pub struct Mask {
    inside: Vec<bool>,
}

impl std::fmt::Debug for Mask {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Mask")
            .field("inside_pixels", &self.count())
            .finish()
    }
}

impl Mask {
    /// Wraps a row-major 512×424 buffer.
    ///
    /// # Errors
    /// [`Error::WrongLength`] unless the buffer has exactly [`PIXELS`] values.
    pub fn from_bools(inside: Vec<bool>) -> Result<Self> {
        if inside.len() != PIXELS {
            return Err(Error::WrongLength {
                got: inside.len(),
                expected: PIXELS,
            });
        }
        Ok(Self { inside })
    }

    /// The row-major flags.
    #[must_use]
    pub fn as_slice(&self) -> &[bool] {
        &self.inside
    }

    /// Number of pixels inside.
    #[must_use]
    pub fn count(&self) -> usize {
        self.inside.iter().filter(|&&b| b).count()
    }
}

/// Pinhole intrinsics of the depth camera with OpenCV's Brown–Conrady distortion.
///
/// Pixel (u, v) with u along the row; normalised image coordinates x = (u − cx)/fx,
/// y = (v − cy)/fy describe the ray (x, y, 1) in the OpenCV camera frame (x right, y down,
/// z out of the lens).
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
    /// Nominal Kinect v2 depth camera: f = 365 px (70.1°×60.3° field of view, Table 3.1),
    /// principal point at the image centre, no distortion.
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

    /// Undistorted normalised coordinates of every pixel centre, row-major.
    #[must_use]
    pub fn rays(&self) -> Rays {
        let mut xy = Vec::with_capacity(PIXELS);
        for v in 0..HEIGHT {
            for u in 0..WIDTH {
                let xd = (u as f64 - self.cx) / self.fx;
                let yd = (v as f64 - self.cy) / self.fy;
                xy.push(self.undistort(xd, yd));
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

/// Whether a ray lies inside the elliptical cone of the thesis' accuracy map (§5.1.1, Fig. 5.2):
/// `horizontal_deg` full angle across, `vertical_deg` full angle up-down (70° × 60°).
#[must_use]
pub fn in_elliptical_cone(x: f64, y: f64, horizontal_deg: f64, vertical_deg: f64) -> bool {
    let ax = x.atan() / (horizontal_deg.to_radians() / 2.0);
    let ay = y.atan() / (vertical_deg.to_radians() / 2.0);
    ax * ax + ay * ay <= 1.0
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Undistortion inverts distortion for Panoptic-like coefficients over the whole image.
    #[test]
    fn undistort_inverts_distort() {
        let k = Intrinsics {
            dist: [0.0956, -0.272, 9.65e-5, -1.33e-4, 0.0925],
            ..Intrinsics::default()
        };
        for &(x, y) in &[(0.0, 0.0), (0.3, -0.2), (-0.69, 0.57), (0.7, 0.58)] {
            let (xd, yd) = k.distort(x, y);
            let (xu, yu) = k.undistort(xd, yd);
            assert!(
                (xu - x).abs() < 1e-9 && (yu - y).abs() < 1e-9,
                "{x},{y} -> {xu},{yu}"
            );
        }
    }

    /// The nominal field of view matches Table 3.1 (70° × 60°): the image-edge midpoints lie on
    /// the cone, the corners outside, the centre inside.
    #[test]
    fn nominal_cone_touches_image_edges() {
        let k = Intrinsics::default();
        let edge_x = (WIDTH as f64 / 2.0) / k.fx;
        assert!((2.0 * edge_x.atan().to_degrees() - 70.0).abs() < 0.5);
        assert!(in_elliptical_cone(0.0, 0.0, 70.0, 60.0));
        assert!(!in_elliptical_cone(edge_x, 212.0 / k.fy, 70.0, 60.0));
        assert!(in_elliptical_cone(
            0.95 * 35f64.to_radians().tan(),
            0.0,
            70.0,
            60.0
        ));
    }

    /// Constructors reject buffers of the wrong size instead of panicking later.
    #[test]
    fn wrong_length_is_an_error() {
        assert!(matches!(
            DepthFrame::from_mm(vec![1; 10]),
            Err(Error::WrongLength { got: 10, .. })
        ));
        assert!(DepthFrame::zeros().ensure_valid("z").is_err());
    }
}
