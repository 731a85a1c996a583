//! The thesis's own planar formulas, kept verbatim (with the eq. 4.4 erratum fixed) so its
//! worked numbers can be checked and its set-up reproduced.

use nalgebra::Point2;

/// The three sensor positions of thesis eq. 4.2 from the measured pairwise distances:
/// k1 at the origin, k2 on +x, k3 above the x axis, with k3's height from Heron's formula.
///
/// k3's x uses the law of cosines, `(l12² + l13² − l23²) / 2 l12`, which equals eq. 4.2's
/// `√(l13² − y3²)` when the angle at k1 is acute and keeps the right sign when it is obtuse.
/// `None` when the distances violate the triangle inequality or are not finite and positive.
#[must_use]
pub fn heron_rig(l12: f64, l13: f64, l23: f64) -> Option<[Point2<f64>; 3]> {
    let finite_positive = [l12, l13, l23].iter().all(|l| l.is_finite() && *l > 0.0);
    if !finite_positive {
        return None;
    }
    let s1 = 0.5 * (l12 + l13 + l23);
    let area_sq = s1 * (s1 - l12) * (s1 - l13) * (s1 - l23);
    if area_sq <= 0.0 {
        return None;
    }
    let y3 = 2.0 * area_sq.sqrt() / l12;
    let x3 = (l12 * l12 + l13 * l13 - l23 * l23) / (2.0 * l12);
    Some([Point2::origin(), Point2::new(l12, 0.0), Point2::new(x3, y3)])
}

/// Thesis eq. 4.4 with its erratum fixed: the range of sensor i from its own depth-angle pair,
/// `rᵢ = Dᵢ / sin θ'ᵢ` (the printed equation divides every depth by sin θ'₁).
///
/// `theta_prime_rad` is eq. 4.3's angle between the sensor's baseline and the ray; a ray along
/// the optical axis of a sensor facing the target square-on has θ' = π/2 and r = D.
#[must_use]
pub fn range_from_depth_angle(depth_m: f64, theta_prime_rad: f64) -> f64 {
    depth_m / theta_prime_rad.sin()
}

/// Solves thesis eq. 4.5 in the plane of the sensors (z = 0 for all three, §5.2): the 2-D point
/// at ranges `r` from the [`heron_rig`] vertices, and the height ±z above that plane, returned as
/// `(x, y, z ≥ 0)`; `z` is 0 when the spheres do not quite meet.
#[must_use]
pub fn intersect_planar(rig: &[Point2<f64>; 3], r: [f64; 3]) -> (f64, f64, f64) {
    let [_, k2, k3] = rig;
    let x = (r[0] * r[0] - r[1] * r[1] + k2.x * k2.x) / (2.0 * k2.x);
    let y = (r[0] * r[0] - r[2] * r[2] + k3.x * k3.x + k3.y * k3.y - 2.0 * k3.x * x) / (2.0 * k3.y);
    let z = (r[0] * r[0] - x * x - y * y).max(0.0).sqrt();
    (x, y, z)
}

#[cfg(test)]
mod tests {
    use approx::assert_relative_eq;

    use super::*;

    /// Hand-worked example of §4.2.1: a 3-4-5 triangle (l12 = 4, l13 = 5, l23 = 3), target
    /// O = (2, 1, ∓1). Step 1 (eq. 4.2): S1 = 6, area = √(6·2·1·3) = 6, y3 = 2·6/4 = 3,
    /// x3 = √(25 − 9) = 4. Step 2 (eq. 4.4): the ranges are r1 = r2 = √6 and r3 = 3.
    /// Step 3 (eq. 4.5): x = (6 − 6 + 16)/8 = 2, y = (6 − 9 + 16 + 9 − 16)/6 = 1,
    /// z = √(6 − 4 − 1) = 1.
    #[test]
    fn hand_worked_example_section_4_2_1() {
        let rig = heron_rig(4.0, 5.0, 3.0).unwrap();
        assert_relative_eq!(rig[2].x, 4.0, epsilon = 1e-12);
        assert_relative_eq!(rig[2].y, 3.0, epsilon = 1e-12);
        let (x, y, z) = intersect_planar(&rig, [6f64.sqrt(), 6f64.sqrt(), 3.0]);
        assert_relative_eq!(x, 2.0, epsilon = 1e-12);
        assert_relative_eq!(y, 1.0, epsilon = 1e-12);
        assert_relative_eq!(z, 1.0, epsilon = 1e-12);
    }

    /// Eq. 4.4 with the erratum fixed: each depth is divided by the sine of its own angle.
    /// A depth of 1 m seen 30° off the baseline is 2 m away; with the printed equation it would
    /// have used sensor 1's angle instead.
    #[test]
    fn eq_4_4_uses_each_sensors_own_angle() {
        let angles = [std::f64::consts::FRAC_PI_2, std::f64::consts::FRAC_PI_6];
        let r: Vec<f64> = angles
            .iter()
            .map(|a| range_from_depth_angle(1.0, *a))
            .collect();
        assert_relative_eq!(r[0], 1.0, epsilon = 1e-12);
        assert_relative_eq!(r[1], 2.0, epsilon = 1e-12);
    }

    /// Obtuse triangles keep k3 on the correct side of k1 (eq. 4.2's square root would not).
    #[test]
    fn heron_handles_obtuse_angle_at_k1() {
        let rig = heron_rig(3.0, 2.0, 4.5).unwrap();
        assert!(rig[2].x < 0.0);
        assert_relative_eq!((rig[2] - rig[1]).norm(), 4.5, epsilon = 1e-12);
        assert_relative_eq!(rig[2].coords.norm(), 2.0, epsilon = 1e-12);
        assert!(heron_rig(1.0, 1.0, 3.0).is_none());
        assert!(heron_rig(f64::NAN, 1.0, 1.0).is_none());
    }

    /// Table 5.1's error column recomputed from its coordinates, O_o = (2135, 4000) mm.
    ///
    /// The table prints positions rounded to 0.1 mm, so its errors can only be checked to about
    /// 0.1 mm: every recomputed error agrees within 0.1 mm (largest gap: O'/O'' 25.52 vs the
    /// printed 25.61 mm). The text's "mean measurement error of the three Kinect sensors
    /// (51.22 mm)" is, from the table's own column, (64.23 + 78.99 + 10.66)/3 = 51.29 mm.
    #[test]
    fn table_5_1_error_column() {
        let truth: Point2<f64> = Point2::new(2135.0, 4000.0);
        let rows = [
            ("k1", Point2::new(2197.1, 4016.4), 64.23_f64),
            ("k2", Point2::new(2057.4, 3985.0), 78.99),
            ("k3", Point2::new(2135.0, 3989.4), 10.66),
            ("geometric", Point2::new(2156.4, 4013.9), 25.61),
            ("least squares", Point2::new(2156.4, 4013.9), 25.61),
        ];
        for (name, measured, printed_mm) in rows {
            let error_mm = (measured - truth).norm();
            assert!(
                (error_mm - printed_mm).abs() < 0.1,
                "{name}: recomputed {error_mm:.2} mm, printed {printed_mm} mm"
            );
        }
        let single: f64 = rows[..3].iter().map(|r| (r.1 - truth).norm()).sum::<f64>() / 3.0;
        assert!(
            (single - 51.22).abs() < 0.1,
            "mean single-sensor error {single:.2}"
        );
        // Trilateration beats the mean single sensor, as §5.2 concludes.
        assert!((rows[3].1 - truth).norm() < single);
    }
}
