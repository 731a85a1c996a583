//! Kinect v2 depth undistortion and back-projection exactly as libfreenect2 does it, so a frame
//! from the driver, a replayed recording and a simulated frame go through one piece of code.
//!
//! libfreenect2 (`Registration`) undistorts by a forward map: for every pixel (u, v) of the
//! undistorted image it distorts the pixel's own coordinates with the IR camera's Brown model
//! (k1 k2 k3 radial, p1 p2 tangential, OpenCV's convention) and copies the nearest raw pixel
//! (rounded by truncating `x + 0.5`, as its C cast does); pixels mapped outside the image get
//! no data. It back-projects pixel centres `(u + 0.5, v + 0.5)` with the depth in metres, in the
//! OpenCV camera frame (x right, y down, z out of the lens). The arithmetic here is the same
//! single-precision arithmetic in the same order, so the two agree to rounding (the driver's
//! feature-gated test checks it against libfreenect2 itself).

use nalgebra::Point3;

use crate::{HEIGHT, Intrinsics, PIXELS, WIDTH};

/// The forward map of undistorted pixel → raw pixel index, built once per camera.
#[derive(Debug, Clone)]
pub struct Undistorter {
    intrinsics: Intrinsics,
    source: Vec<Option<u32>>,
}

impl Undistorter {
    /// Builds the map for a camera (`dist` in OpenCV order k1 k2 p1 p2 k3).
    #[must_use]
    pub fn new(intrinsics: &Intrinsics) -> Self {
        let [k1, k2, p1, p2, k3] = intrinsics.dist.map(|c| c as f32);
        let (fx, fy) = (intrinsics.fx as f32, intrinsics.fy as f32);
        let (cx, cy) = (intrinsics.cx as f32, intrinsics.cy as f32);
        let mut source = Vec::with_capacity(PIXELS);
        for v in 0..HEIGHT {
            for u in 0..WIDTH {
                let dx = (u as f32 - cx) / fx;
                let dy = (v as f32 - cy) / fy;
                let dx2 = dx * dx;
                let dy2 = dy * dy;
                let r2 = dx2 + dy2;
                let dxdy2 = 2.0 * dx * dy;
                let kr = 1.0 + ((k3 * r2 + k2) * r2 + k1) * r2;
                let x = fx * (dx * kr + p2 * (r2 + 2.0 * dx2) + p1 * dxdy2) + cx;
                let y = fy * (dy * kr + p1 * (r2 + 2.0 * dy2) + p2 * dxdy2) + cy;
                // Truncation toward zero, like libfreenect2's `(int)(x + 0.5f)`.
                let ix = (x + 0.5) as i64;
                let iy = (y + 0.5) as i64;
                let inside = (0..WIDTH as i64).contains(&ix) && (0..HEIGHT as i64).contains(&iy);
                source.push(inside.then(|| (iy as u32) * WIDTH as u32 + ix as u32));
            }
        }
        Self {
            intrinsics: *intrinsics,
            source,
        }
    }

    /// The camera.
    #[must_use]
    pub fn intrinsics(&self) -> &Intrinsics {
        &self.intrinsics
    }

    /// Undistorts a raw 512×424 depth image (mm, any value; non-positive or NaN = no data)
    /// into `out`; pixels that map outside the raw image become 0.
    ///
    /// # Errors
    /// [`crate::Error::WrongLength`] when either buffer is not 512×424.
    pub fn undistort_into(&self, raw: &[f32], out: &mut [f32]) -> crate::Result<()> {
        for len in [raw.len(), out.len()] {
            if len != PIXELS {
                return Err(crate::Error::WrongLength {
                    got: len,
                    expected: PIXELS,
                });
            }
        }
        for (o, s) in out.iter_mut().zip(&self.source) {
            *o = s.map_or(0.0, |i| raw[i as usize]);
        }
        Ok(())
    }

    /// The back-projection of pixel (row, col) of an undistorted image, metres, OpenCV camera
    /// frame (x right, y down, z forward); `None` where there is no depth (≤ 1 mm or NaN).
    #[must_use]
    pub fn point_xyz(&self, undistorted: &[f32], row: usize, col: usize) -> Option<[f32; 3]> {
        let z = undistorted.get(row * WIDTH + col)? / 1000.0;
        if z.is_nan() || z <= 0.001 {
            return None;
        }
        let k = &self.intrinsics;
        // libfreenect2 multiplies by 1/f in single precision and mixes in a double 0.5.
        let (inv_fx, inv_fy) = (1.0 / k.fx as f32, 1.0 / k.fy as f32);
        let x =
            ((col as f64 + 0.5 - f64::from(k.cx as f32)) * f64::from(inv_fx) * f64::from(z)) as f32;
        let y =
            ((row as f64 + 0.5 - f64::from(k.cy as f32)) * f64::from(inv_fy) * f64::from(z)) as f32;
        Some([x, y, z])
    }

    /// The same point in Kinect v2 camera space (x left, y up, z out of the lens), metres.
    #[must_use]
    pub fn point_in_kinect(
        &self,
        undistorted: &[f32],
        row: usize,
        col: usize,
    ) -> Option<Point3<f64>> {
        self.point_xyz(undistorted, row, col)
            .map(|[x, y, z]| Point3::new(-f64::from(x), -f64::from(y), f64::from(z)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lens() -> Intrinsics {
        // A Kinect v2 IR camera as libfreenect2 reads it from a device.
        Intrinsics {
            fx: 365.456,
            fy: 365.456,
            cx: 254.878,
            cy: 205.395,
            dist: [0.0905474, -0.26819, 0.0, 0.0, 0.0950862],
        }
    }

    /// Without distortion the map is the identity; with it, the image centre stays put and the
    /// corners pull in from outside the raw image (barrel → no data there).
    #[test]
    fn map_identity_and_corners() {
        let plain = Undistorter::new(&Intrinsics {
            dist: [0.0; 5],
            ..lens()
        });
        let raw: Vec<f32> = (0..PIXELS).map(|i| i as f32).collect();
        let mut out = vec![0.0; PIXELS];
        plain.undistort_into(&raw, &mut out).unwrap();
        assert_eq!(out, raw);
        let u = Undistorter::new(&lens());
        u.undistort_into(&raw, &mut out).unwrap();
        let centre = 205 * WIDTH + 255;
        assert_eq!(out[centre], raw[centre]);
        assert_ne!(out[WIDTH + 1], raw[WIDTH + 1]);
        assert!(u.undistort_into(&raw[1..], &mut out).is_err());
    }

    /// A flat wall 2 m away back-projects to z = 2 m everywhere, with x, y following the pixel
    /// rays: the centre pixel is on the axis, left of centre is +x in Kinect space.
    #[test]
    fn wall_back_projects() {
        let u = Undistorter::new(&lens());
        let wall = vec![2000.0_f32; PIXELS];
        let mut und = vec![0.0; PIXELS];
        u.undistort_into(&wall, &mut und).unwrap();
        let p = u.point_xyz(&und, 205, 254).unwrap();
        assert!((p[2] - 2.0).abs() < 1e-6 && p[0].abs() < 0.005 && p[1].abs() < 0.005);
        let left = u.point_in_kinect(&und, 205, 10).unwrap();
        assert!(left.x > 1.0 && (left.z - 2.0).abs() < 1e-6);
        assert_eq!(u.point_xyz(&vec![0.0; PIXELS], 0, 0), None);
        assert_eq!(u.point_xyz(&vec![f32::NAN; PIXELS], 3, 3), None);
    }
}
