//! Frames and camera parameters.

use trigait_depth::Intrinsics;

/// One device tick, ns (libfreenect2's timestamp unit, 0.125 ms).
pub const TICK_NANOS: i64 = 125_000;

/// Ticks between frames at 30 Hz (266 × 0.125 ms = 33.25 ms).
pub const TICKS_PER_FRAME: u32 = 266;

/// Which stream a frame belongs to.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum FrameKind {
    /// 512×424 float, mm along the optical axis; ≤ 0, NaN or ∞ = no data.
    Depth,
    /// 512×424 float IR amplitude, 0–65535.
    Ir,
    /// 1920×1080 BGRX bytes.
    Color,
}

/// Pixel storage: owned by Rust, or the shim's buffer (freed when the frame drops).
pub(crate) enum Pixels {
    Owned(Vec<f32>),
    #[cfg(any(feature = "freenect2", feature = "fake-freenect2"))]
    Shim(crate::kinect::ShimFrame),
}

/// One frame of one stream, with the device's time and sequence and the host arrival time.
pub struct Frame {
    /// The stream.
    pub kind: FrameKind,
    /// Columns.
    pub width: usize,
    /// Rows.
    pub height: usize,
    /// Device time, 0.125 ms ticks (wraps at 2³²).
    pub timestamp: u32,
    /// Device sequence number (wraps at 2³²).
    pub sequence: u32,
    /// Host clock (ns since the UNIX epoch) when the frame reached the host.
    pub host_nanos: i64,
    pub(crate) pixels: Pixels,
}

impl std::fmt::Debug for Frame {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Frame")
            .field("kind", &self.kind)
            .field("timestamp", &self.timestamp)
            .field("sequence", &self.sequence)
            .field("host_nanos", &self.host_nanos)
            .finish_non_exhaustive()
    }
}

impl Frame {
    /// A frame with owned float pixels (fake devices, tests).
    ///
    /// # Errors
    /// [`crate::Error::BadFrame`] when `pixels` is not `width × height`.
    pub fn owned(
        kind: FrameKind,
        width: usize,
        height: usize,
        timestamp: u32,
        sequence: u32,
        host_nanos: i64,
        pixels: Vec<f32>,
    ) -> crate::Result<Self> {
        if pixels.len() != width * height {
            return Err(crate::Error::BadFrame(format!(
                "{} pixels for {width}×{height}",
                pixels.len()
            )));
        }
        Ok(Self {
            kind,
            width,
            height,
            timestamp,
            sequence,
            host_nanos,
            pixels: Pixels::Owned(pixels),
        })
    }

    /// Float pixels, row-major (depth in mm, IR amplitude); empty for colour.
    #[must_use]
    pub fn as_f32(&self) -> &[f32] {
        match &self.pixels {
            Pixels::Owned(v) => v,
            #[cfg(any(feature = "freenect2", feature = "fake-freenect2"))]
            Pixels::Shim(s) => s.as_f32(),
        }
    }

    /// Depth (or IR) rounded to whole units (half away from zero) as `depth_frame` carries
    /// it: ≤ 0, NaN and ∞ → 0, above 65535 → 65535.
    #[must_use]
    pub fn to_u16(&self) -> Vec<u16> {
        self.as_f32().iter().map(|&v| round_to_u16(v)).collect()
    }
}

/// `v.round()` saturated to `u16`, with no data (≤ 0, NaN, ∞) as 0, written so that it
/// vectorises: `f32::round` is a libm call on baseline x86-64 and was most of the backend's
/// per-frame cost. Truncation and the exact fraction `v - trunc(v)` give the same result.
#[inline]
fn round_to_u16(v: f32) -> u16 {
    if v > 0.0 && v < f32::INFINITY {
        let clamped = v.min(65_535.0);
        // A truncating cast; `clamped - whole` is exact (Sterbenz), so `>= 0.5` is the tie rule.
        let whole = clamped as u16;
        let up = u16::from(clamped - f32::from(whole) >= 0.5);
        whole + up
    } else {
        0
    }
}

/// The IR (depth) camera's intrinsics as libfreenect2 reads them from the device after
/// `start()`.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct IrParams {
    /// Focal length x, px.
    pub fx: f32,
    /// Focal length y, px.
    pub fy: f32,
    /// Principal point x, px.
    pub cx: f32,
    /// Principal point y, px.
    pub cy: f32,
    /// Radial k1.
    pub k1: f32,
    /// Radial k2.
    pub k2: f32,
    /// Radial k3.
    pub k3: f32,
    /// Tangential p1.
    pub p1: f32,
    /// Tangential p2.
    pub p2: f32,
}

impl IrParams {
    /// As `trigait_depth`'s intrinsics (OpenCV order k1 k2 p1 p2 k3), for
    /// [`trigait_depth::Undistorter`].
    #[must_use]
    pub fn intrinsics(&self) -> Intrinsics {
        Intrinsics {
            fx: f64::from(self.fx),
            fy: f64::from(self.fy),
            cx: f64::from(self.cx),
            cy: f64::from(self.cy),
            dist: [self.k1, self.k2, self.p1, self.p2, self.k3].map(f64::from),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::round_to_u16;

    /// The same as `f32::round` saturated to `u16` on every edge and on a sweep through the
    /// whole range of float bit patterns up to 70000.
    #[test]
    fn rounding_matches_f32_round() {
        let reference = |v: f32| -> u16 {
            if v.is_finite() && v > 0.0 {
                v.round().min(65_535.0) as u16
            } else {
                0
            }
        };
        let edges = [
            0.0,
            -0.0,
            f32::MIN_POSITIVE,
            0.499_999_97,
            0.5,
            1.499_999_9,
            1.5,
            2.5,
            65_534.5,
            65_535.0,
            65_535.5,
            65_536.0,
            1e9,
            -3.0,
            f32::NAN,
            f32::INFINITY,
            f32::NEG_INFINITY,
        ];
        for v in edges {
            assert_eq!(round_to_u16(v), reference(v), "{v:?}");
        }
        let top = 70_000.0_f32.to_bits();
        for bits in (0..top).step_by(61) {
            let v = f32::from_bits(bits);
            assert_eq!(round_to_u16(v), reference(v), "{v:?} ({bits:#x})");
        }
    }
}
