//! The depth frame and object masks; the pinhole model that turns pixels into rays is
//! `trigait_camera`'s, re-exported here.
//!
//! A Kinect v2 depth frame is 512×424 unsigned 16-bit values in millimetres, 0 meaning "no data"
//! (thesis Table 3.1; §5.1.4 reads those zeros as edge noise). The value is the distance along
//! the optical axis (z), not along the ray.

use crate::{Error, Result};

pub use trigait_camera::{HEIGHT, Intrinsics, PIXELS, Rays, WIDTH};

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
