//! Depth frame simulator: the ground truth the metrics are tested against.
//!
//! Renders what a Kinect v2 would report for a simple scene — a background plane at a given
//! distance and tilt, with fronto-parallel discs and rectangles in front of it — and corrupts it
//! with exactly the effects the thesis measures: temporal Gaussian noise (§3.3), quantisation
//! (§3.2), a ring-shaped structural bias around the image centre (§3.5) and a band of no-data
//! pixels along object contours (§3.4). Each effect is a parameter, so a metric can be checked
//! to recover it.

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

use crate::frame::{DepthFrame, Intrinsics, Mask, PIXELS, Rays, WIDTH};
use crate::{Error, Result};

/// A fronto-parallel object in front of the background.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Shape {
    /// A disc facing the camera.
    Disc {
        /// Centre x in the camera frame (OpenCV: right), metres.
        x_m: f64,
        /// Centre y in the camera frame (OpenCV: down), metres.
        y_m: f64,
        /// Radius, metres.
        radius_m: f64,
        /// Depth, metres.
        distance_m: f64,
    },
    /// An axis-aligned rectangle facing the camera.
    Rectangle {
        /// Left edge x, metres.
        left_m: f64,
        /// Top edge y, metres.
        top_m: f64,
        /// Right edge x, metres.
        right_m: f64,
        /// Bottom edge y, metres.
        bottom_m: f64,
        /// Depth, metres.
        distance_m: f64,
    },
}

impl Shape {
    fn distance_m(&self) -> f64 {
        match *self {
            Self::Disc { distance_m, .. } | Self::Rectangle { distance_m, .. } => distance_m,
        }
    }

    /// Signed distance of ray (x, y) from the shape's contour in pixels (positive inside).
    fn inside_px(&self, x: f64, y: f64, f: f64) -> f64 {
        let z = self.distance_m();
        let (px, py) = (x * z, y * z);
        let metres = match *self {
            Self::Disc {
                x_m, y_m, radius_m, ..
            } => radius_m - (px - x_m).hypot(py - y_m),
            Self::Rectangle {
                left_m,
                top_m,
                right_m,
                bottom_m,
                ..
            } => (px - left_m)
                .min(right_m - px)
                .min(py - top_m)
                .min(bottom_m - py),
        };
        metres / z * f
    }
}

/// The scene: a background plane and objects in front of it.
#[derive(Debug, Clone, PartialEq)]
pub struct Scene {
    /// Depth of the background plane on the optical axis, metres (`None`: no background).
    pub background_m: Option<f64>,
    /// Rotation of the background about the camera x axis, degrees (top away from the camera
    /// for positive values).
    pub tilt_x_deg: f64,
    /// Rotation of the background about the camera y axis, degrees.
    pub tilt_y_deg: f64,
    /// Objects in front of the background.
    pub shapes: Vec<Shape>,
    /// Further unbounded planes in any orientation (a floor seen from a tripod, a side wall);
    /// every ray sees the nearest surface. Unlike [`Shape`]s they carry no edge band: where two
    /// planes meet there is no depth jump.
    pub planes: Vec<ScenePlane>,
}

/// An unbounded plane `normal · p = offset_m` in the OpenCV camera frame (x right, y down,
/// z out of the lens), `normal` a unit vector and `offset_m` > 0 its distance from the optical
/// centre.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ScenePlane {
    /// Unit normal, pointing away from the camera.
    pub normal: [f64; 3],
    /// Distance of the plane from the optical centre, metres.
    pub offset_m: f64,
}

impl ScenePlane {
    /// Depth (z) at which the ray (x, y, 1) meets the plane, if in front of the camera.
    #[must_use]
    pub fn depth_along(&self, x: f64, y: f64) -> Option<f64> {
        let [a, b, c] = self.normal;
        let den = a * x + b * y + c;
        (den > 1e-9).then(|| self.offset_m / den)
    }
}

impl Scene {
    /// A fronto-parallel wall at `distance_m`.
    #[must_use]
    pub fn wall(distance_m: f64) -> Self {
        Self {
            background_m: Some(distance_m),
            tilt_x_deg: 0.0,
            tilt_y_deg: 0.0,
            shapes: Vec::new(),
            planes: Vec::new(),
        }
    }
}

/// Sensor effects of the simulator.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SimParams {
    /// The camera.
    pub intrinsics: Intrinsics,
    /// Temporal Gaussian noise, standard deviation in mm.
    pub noise_sd_mm: f64,
    /// Quantisation step of the output, mm (≥ 1; the Kinect v2 reports whole mm).
    pub quantisation_mm: f64,
    /// Amplitude of the ring bias, mm.
    pub ring_amplitude_mm: f64,
    /// Period of the ring bias, pixels of radius from the principal point.
    pub ring_period_px: f64,
    /// Width of the no-data band inside object contours, pixels.
    pub edge_dropout_px: f64,
    /// Depths outside this range (metres) read as 0 (Kinect v2: 0.5–4.5 m, Table 3.1).
    pub range_m: (f64, f64),
    /// RNG seed.
    pub seed: u64,
}

impl Default for SimParams {
    fn default() -> Self {
        Self {
            intrinsics: Intrinsics::default(),
            noise_sd_mm: 1.0,
            quantisation_mm: 1.0,
            ring_amplitude_mm: 0.0,
            ring_period_px: 40.0,
            edge_dropout_px: 0.0,
            range_m: (0.5, 4.5),
            seed: 1,
        }
    }
}

/// Renders frames of a [`Scene`] with [`SimParams`].
#[derive(Debug, Clone)]
pub struct Simulator {
    params: SimParams,
    /// Noise-free depth including the ring bias, mm (NaN = nothing seen).
    biased_mm: Vec<f64>,
    /// Geometric depth, mm (NaN = nothing seen).
    surface_mm: Vec<f64>,
    dropout: Vec<bool>,
    object: Vec<bool>,
    rays: Rays,
    rng: ChaCha8Rng,
    noise: Normal<f64>,
}

impl Simulator {
    /// Prepares the scene (the geometry is rendered once; frames differ by noise only).
    ///
    /// # Errors
    /// Negative noise, a quantisation step below 1 mm, or a non-positive ring period.
    pub fn new(scene: &Scene, params: SimParams) -> Result<Self> {
        let noise = Normal::new(0.0, params.noise_sd_mm).map_err(|_| Error::BadParameter {
            name: "noise_sd_mm",
            value: params.noise_sd_mm,
            expected: "a finite standard deviation ≥ 0",
        })?;
        if params.quantisation_mm.is_nan() || params.quantisation_mm < 1.0 {
            return Err(Error::BadParameter {
                name: "quantisation_mm",
                value: params.quantisation_mm,
                expected: "a step of at least 1 mm",
            });
        }
        if let Some(p) = scene.planes.iter().find(|p| {
            let norm = p.normal.iter().map(|v| v * v).sum::<f64>().sqrt();
            !(p.offset_m > 0.0 && p.offset_m.is_finite() && (norm - 1.0).abs() < 1e-6)
        }) {
            return Err(Error::BadParameter {
                name: "planes.offset_m",
                value: p.offset_m,
                expected: "a unit normal and a positive, finite distance from the camera",
            });
        }
        if params.ring_period_px.is_nan() || params.ring_period_px <= 0.0 {
            return Err(Error::BadParameter {
                name: "ring_period_px",
                value: params.ring_period_px,
                expected: "a positive period",
            });
        }
        let k = params.intrinsics;
        let rays = k.rays();
        let (tx, ty) = (scene.tilt_x_deg.to_radians(), scene.tilt_y_deg.to_radians());
        // Background normal (tan ty, −tan tx, 1) through (0, 0, d): positive tilt_x moves the
        // top (y < 0 in OpenCV) away from the camera.
        let n = (ty.tan(), -tx.tan(), 1.0);
        let mut surface_mm = vec![f64::NAN; PIXELS];
        let mut biased_mm = vec![f64::NAN; PIXELS];
        let mut dropout = vec![false; PIXELS];
        let mut object = vec![false; PIXELS];
        for i in 0..PIXELS {
            let (x, y) = rays.at(i);
            let mut z = scene.background_m.and_then(|d| {
                let den = n.0 * x + n.1 * y + n.2;
                (den > 1e-9).then(|| n.2 * d / den)
            });
            for p in &scene.planes {
                if let Some(zp) = p.depth_along(x, y)
                    && z.is_none_or(|zz| zp < zz)
                {
                    z = Some(zp);
                }
            }
            for s in &scene.shapes {
                let inside = s.inside_px(x, y, k.fx);
                if inside >= 0.0 && z.is_none_or(|zz| s.distance_m() < zz) {
                    z = Some(s.distance_m());
                    object[i] = true;
                    dropout[i] = inside < params.edge_dropout_px;
                }
            }
            let Some(z) = z else { continue };
            surface_mm[i] = z * 1000.0;
            let (u, v) = ((i % WIDTH) as f64, (i / WIDTH) as f64);
            let r = (u - k.cx).hypot(v - k.cy);
            let ring = params.ring_amplitude_mm
                * (2.0 * std::f64::consts::PI * r / params.ring_period_px).cos();
            biased_mm[i] = z * 1000.0 + ring;
        }
        Ok(Self {
            params,
            biased_mm,
            surface_mm,
            dropout,
            object,
            rays,
            rng: ChaCha8Rng::seed_from_u64(params.seed),
            noise,
        })
    }

    /// The next frame: noise-free depth + ring bias + fresh noise, quantised, with the
    /// contour band and out-of-range depths set to 0.
    pub fn next_frame(&mut self) -> DepthFrame {
        let q = self.params.quantisation_mm;
        let (lo, hi) = (
            self.params.range_m.0 * 1000.0,
            self.params.range_m.1 * 1000.0,
        );
        let mut frame = DepthFrame::zeros();
        for (i, out) in frame.as_mm_mut().iter_mut().enumerate() {
            let b = self.biased_mm[i];
            if b.is_nan() || self.dropout[i] {
                continue;
            }
            let z = b + self.noise.sample(&mut self.rng);
            let zq = (z / q).round() * q;
            if zq >= lo && zq <= hi {
                *out = zq.round() as u16;
            }
        }
        frame
    }

    /// Geometric depth of each pixel, mm (NaN where nothing is seen).
    #[must_use]
    pub fn surface_mm(&self) -> &[f64] {
        &self.surface_mm
    }

    /// Noise-free depth with the ring bias, mm (NaN where nothing is seen).
    #[must_use]
    pub fn biased_mm(&self) -> &[f64] {
        &self.biased_mm
    }

    /// Pixels zeroed by the edge band.
    #[must_use]
    pub fn dropout(&self) -> &[bool] {
        &self.dropout
    }

    /// The pixels of the objects (ground-truth mask, band included).
    ///
    /// # Errors
    /// Never for a scene built by [`Simulator::new`]; the `Result` comes from [`Mask`].
    pub fn object_mask(&self) -> Result<Mask> {
        Mask::from_bools(self.object.clone())
    }

    /// The rays of the simulated camera.
    #[must_use]
    pub fn rays(&self) -> &Rays {
        &self.rays
    }

    /// The parameters.
    #[must_use]
    pub fn params(&self) -> &SimParams {
        &self.params
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A fronto-parallel wall without noise reads its distance everywhere; a disc with a 2-px
    /// band has zeros only inside its contour.
    #[test]
    fn renders_wall_and_disc() {
        let p = SimParams {
            noise_sd_mm: 0.0,
            edge_dropout_px: 2.0,
            ..SimParams::default()
        };
        let mut scene = Scene::wall(2.0);
        scene.shapes.push(Shape::Disc {
            x_m: 0.0,
            y_m: 0.0,
            radius_m: 0.3,
            distance_m: 1.0,
        });
        let mut sim = Simulator::new(&scene, p).unwrap();
        let f = sim.next_frame();
        assert_eq!(f.at_mm(0, 0), 2000);
        assert_eq!(f.at_mm(256, 212), 1000);
        // Disc radius 0.3 m at 1 m ≈ 109.5 px; the band is radii 107.5..109.5 px.
        let row = 212;
        let cx = 255.5;
        for x in 256..512 {
            let r = x as f64 - cx;
            let z = f.at_mm(x, row);
            if r < 107.0 {
                assert_eq!(z, 1000, "x {x}");
            } else if r > 108.0 && r < 109.0 {
                assert_eq!(z, 0, "x {x}");
            } else if r > 110.0 {
                assert_eq!(z, 2000, "x {x}");
            }
        }
        assert!(
            Simulator::new(
                &scene,
                SimParams {
                    quantisation_mm: 0.5,
                    ..p
                }
            )
            .is_err()
        );
    }
}
