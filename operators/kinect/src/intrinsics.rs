use nalgebra::{Point2, Point3};
use serde::{Deserialize, Serialize};

/// The Kinect v2 depth camera as a pinhole: image size, focal lengths and principal point.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Intrinsics {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Horizontal focal length in pixels.
    pub fx: f64,
    /// Vertical focal length in pixels.
    pub fy: f64,
    /// Principal point, column.
    pub cx: f64,
    /// Principal point, row.
    pub cy: f64,
}

impl Default for Intrinsics {
    /// 512×424 pixels with a 70.6° × 60° field of view (Microsoft's specification, thesis
    /// Table 6.1), so fx = 256 / tan 35.3° ≈ 361.6 px and fy = 212 / tan 30° ≈ 367.2 px — within
    /// 1 % of the ≈ 365 px that factory calibrations of individual units report.
    fn default() -> Self {
        Self::from_fov(512, 424, 70.6_f64.to_radians(), 60.0_f64.to_radians())
    }
}

impl Intrinsics {
    /// A centred pinhole with the given full horizontal and vertical fields of view (radians).
    #[must_use]
    pub fn from_fov(width: u32, height: u32, horizontal_rad: f64, vertical_rad: f64) -> Self {
        let cx = f64::from(width) / 2.0;
        let cy = f64::from(height) / 2.0;
        Self {
            width,
            height,
            fx: cx / (horizontal_rad / 2.0).tan(),
            fy: cy / (vertical_rad / 2.0).tan(),
            cx,
            cy,
        }
    }

    /// Half the horizontal field of view, radians.
    #[must_use]
    pub fn half_fov_x_rad(&self) -> f64 {
        (self.cx / self.fx).atan()
    }

    /// Half the vertical field of view, radians.
    #[must_use]
    pub fn half_fov_y_rad(&self) -> f64 {
        (self.cy / self.fy).atan()
    }

    /// The same camera as the depth tools' lens model (no distortion), which does every
    /// projection and back-projection.
    #[must_use]
    pub fn lens(&self) -> trigait_camera::Intrinsics {
        trigait_camera::Intrinsics::pinhole(self.fx, self.fy, self.cx, self.cy)
    }

    /// Pixel of a camera-space point (column grows to the sensor's right, row grows down;
    /// column u spans u..u+1), or `None` behind the lens.
    #[must_use]
    pub fn project(&self, point_in_kinect: &Point3<f64>) -> Option<Point2<f64>> {
        self.lens().project_kinect(point_in_kinect)
    }

    /// The ray (x, y, 1) in camera space through the centre of pixel (column, row), so a depth
    /// z along the axis back-projects to (x·z, y·z, z).
    #[must_use]
    pub fn pixel_ray(&self, column: usize, row: usize) -> (f64, f64) {
        self.lens()
            .ray_kinect(column as f64 + 0.5, row as f64 + 0.5)
    }

    /// Whether the point projects inside the image.
    #[must_use]
    pub fn in_view(&self, point_in_kinect: &Point3<f64>) -> bool {
        self.project(point_in_kinect).is_some_and(|px| {
            (0.0..=f64::from(self.width)).contains(&px.x)
                && (0.0..=f64::from(self.height)).contains(&px.y)
        })
    }

    /// Where a point sits in the field of view, as the elliptical radius of thesis §5.1.1's
    /// accuracy cone: 0 on the optical axis, 1 on the ellipse through the edges of the image.
    #[must_use]
    pub fn cone_radius(&self, point_in_kinect: &Point3<f64>) -> f64 {
        if point_in_kinect.z <= 0.0 {
            return f64::INFINITY;
        }
        let ax = (point_in_kinect.x / point_in_kinect.z).atan() / self.half_fov_x_rad();
        let ay = (point_in_kinect.y / point_in_kinect.z).atan() / self.half_fov_y_rad();
        (ax * ax + ay * ay).sqrt()
    }

    /// Footprint of one pixel at `depth_m`, metres.
    #[must_use]
    pub fn pixel_size_m(&self, depth_m: f64) -> f64 {
        depth_m / self.fx
    }
}

#[cfg(test)]
mod tests {
    use approx::assert_relative_eq;

    use super::*;

    /// The default camera has the specified field of view and projects the axis to the centre.
    #[test]
    fn default_matches_specification() {
        let k = Intrinsics::default();
        assert_relative_eq!(2.0 * k.half_fov_x_rad().to_degrees(), 70.6, epsilon = 1e-9);
        assert_relative_eq!(2.0 * k.half_fov_y_rad().to_degrees(), 60.0, epsilon = 1e-9);
        assert!((k.fx - 361.6).abs() < 0.1 && (k.fy - 367.2).abs() < 0.1);
        let c = k.project(&Point3::new(0.0, 0.0, 2.0)).unwrap();
        assert_relative_eq!(c.x, 256.0);
        assert_relative_eq!(c.y, 212.0);
    }

    /// A pixel's ray projects back into that pixel's centre, left columns look to +x.
    #[test]
    fn pixel_ray_round_trips() {
        let k = Intrinsics::default();
        let (x, y) = k.pixel_ray(10, 400);
        assert!(x > 0.0 && y < 0.0);
        let px = k.project(&Point3::new(x * 3.0, y * 3.0, 3.0)).unwrap();
        assert_relative_eq!(px.x, 10.5, epsilon = 1e-9);
        assert_relative_eq!(px.y, 400.5, epsilon = 1e-9);
    }

    /// Points inside the 70.6° × 60° cone are in view, points outside or behind are not, and a
    /// point to the sensor's left (+x) lands at a smaller column than the centre.
    #[test]
    fn view_limits() {
        let k = Intrinsics::default();
        let edge = (35.0_f64).to_radians().tan();
        assert!(k.in_view(&Point3::new(edge * 3.0, 0.0, 3.0)));
        assert!(!k.in_view(&Point3::new(0.76 * 3.0, 0.0, 3.0)));
        assert!(!k.in_view(&Point3::new(0.0, 0.0, -1.0)));
        assert!(k.project(&Point3::new(0.5, 0.2, 2.0)).unwrap().x < 256.0);
        assert_relative_eq!(k.cone_radius(&Point3::new(0.0, 0.0, 1.0)), 0.0);
        let corner = Point3::new(k.half_fov_x_rad().tan(), 0.0, 1.0);
        assert_relative_eq!(k.cone_radius(&corner), 1.0, epsilon = 1e-12);
    }
}
