//! The shim's functions, constants and structs, one to one with `shim/trigait_freenect2.h`.

use std::ffi::{c_char, c_int};

/// Success.
pub const TG_OK: c_int = 0;
/// A wait ended without a frame.
pub const TG_TIMEOUT: c_int = 1;
/// A null argument.
pub const TG_ERR_NULL: c_int = -1;
/// The serial is not in the enumeration.
pub const TG_ERR_NO_SUCH_SERIAL: c_int = -2;
/// The serial is open already in this process.
pub const TG_ERR_ALREADY_OPEN: c_int = -3;
/// The pipeline was not compiled into libfreenect2.
pub const TG_ERR_PIPELINE_UNAVAILABLE: c_int = -4;
/// libfreenect2 could not open the device.
pub const TG_ERR_OPEN_FAILED: c_int = -5;
/// The streams did not start.
pub const TG_ERR_START_FAILED: c_int = -6;
/// libfreenect2 did not return within the watchdog's timeout (or the context was poisoned so).
pub const TG_ERR_WATCHDOG: c_int = -7;
/// No device at that index.
pub const TG_ERR_INDEX: c_int = -8;
/// The call needs a started device.
pub const TG_ERR_NOT_STARTED: c_int = -9;

/// CPU depth pipeline.
pub const TG_PIPELINE_CPU: c_int = 1;
/// OpenGL depth pipeline.
pub const TG_PIPELINE_OPENGL: c_int = 2;
/// OpenCL depth pipeline.
pub const TG_PIPELINE_OPENCL: c_int = 4;
/// CUDA depth pipeline.
pub const TG_PIPELINE_CUDA: c_int = 8;

/// Colour frames (1920×1080 BGRX).
pub const TG_FRAME_COLOR: c_int = 1;
/// IR frames (512×424 float amplitude).
pub const TG_FRAME_IR: c_int = 2;
/// Depth frames (512×424 float mm).
pub const TG_FRAME_DEPTH: c_int = 4;

/// A libfreenect2 context (opaque).
#[repr(C)]
pub struct tg_context {
    _private: [u8; 0],
}
/// An open device (opaque).
#[repr(C)]
pub struct tg_device {
    _private: [u8; 0],
}
/// A received frame (opaque; free with [`tg_frame_free`]).
#[repr(C)]
pub struct tg_frame {
    _private: [u8; 0],
}

/// Log callback: libfreenect2 level (1 error … 4 debug), message bytes (not NUL-terminated).
pub type tg_log_fn = Option<unsafe extern "C" fn(level: c_int, message: *const c_char, len: usize)>;

/// IR (depth) camera intrinsics and distortion, libfreenect2's `IrCameraParams`.
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct tg_ir_params {
    /// Focal length x, px.
    pub fx: f32,
    /// Focal length y, px.
    pub fy: f32,
    /// Principal point x, px.
    pub cx: f32,
    /// Principal point y, px.
    pub cy: f32,
    /// Radial distortion, 1st order.
    pub k1: f32,
    /// Radial distortion, 2nd order.
    pub k2: f32,
    /// Radial distortion, 3rd order.
    pub k3: f32,
    /// Tangential distortion.
    pub p1: f32,
    /// Tangential distortion.
    pub p2: f32,
}

/// What a frame carries; `data` is valid until the frame is freed.
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct tg_frame_info {
    /// `TG_FRAME_*`.
    pub type_: c_int,
    /// Columns.
    pub width: usize,
    /// Rows.
    pub height: usize,
    /// Bytes per pixel.
    pub bytes_per_pixel: usize,
    /// Pixels.
    pub data: *const u8,
    /// Device time, 0.125 ms ticks.
    pub timestamp: u32,
    /// Device frame sequence number.
    pub sequence: u32,
    /// libfreenect2's status (0 ok).
    pub status: u32,
    /// Host clock (ns since the UNIX epoch) when the frame reached the listener.
    pub host_nanos: i64,
}

unsafe extern "C" {
    /// Bits of the pipelines compiled into the library.
    pub fn tg_pipelines_available() -> u32;
    /// Routes libfreenect2's log to `callback` for levels up to `level`.
    pub fn tg_set_log(callback: tg_log_fn, level: c_int);
    /// A new context (a libusb context inside).
    pub fn tg_context_new() -> *mut tg_context;
    /// Frees a context; `TG_ERR_WATCHDOG` when it had to be leaked.
    pub fn tg_context_free(ctx: *mut tg_context) -> c_int;
    /// Enumerates; returns the count, and whether a device could not be opened (USB access).
    pub fn tg_enumerate(ctx: *mut tg_context, usb_access_denied: *mut c_int) -> c_int;
    /// Serial of device `idx`; its length or an error.
    pub fn tg_serial(ctx: *mut tg_context, idx: c_int, buf: *mut c_char, len: usize) -> c_int;
    /// Opens a device by serial on a watchdog.
    pub fn tg_open(
        ctx: *mut tg_context,
        serial: *const c_char,
        pipeline: c_int,
        frame_types: c_int,
        timeout_ms: c_int,
        out: *mut *mut tg_device,
    ) -> c_int;
    /// Firmware version string; its length.
    pub fn tg_firmware(dev: *mut tg_device, buf: *mut c_char, len: usize) -> c_int;
    /// Starts the streams.
    pub fn tg_start(dev: *mut tg_device) -> c_int;
    /// IR camera parameters (after start).
    pub fn tg_ir_params_get(dev: *mut tg_device, out: *mut tg_ir_params) -> c_int;
    /// Waits up to `timeout_ms` for a frame.
    pub fn tg_wait(dev: *mut tg_device, timeout_ms: c_int, out: *mut *mut tg_frame) -> c_int;
    /// Frames dropped by the full queue.
    pub fn tg_dropped(dev: *mut tg_device) -> u64;
    /// Reads a frame's fields.
    pub fn tg_frame_get(frame: *const tg_frame, out: *mut tg_frame_info);
    /// Frees a frame.
    pub fn tg_frame_free(frame: *mut tg_frame);
    /// Stops and closes on a watchdog.
    pub fn tg_close(dev: *mut tg_device, timeout_ms: c_int) -> c_int;
    /// libfreenect2's `Registration::undistortDepth` and `getPointXYZ` over a whole frame.
    pub fn tg_registration_xyz(
        params: *const tg_ir_params,
        depth: *const f32,
        undistorted: *mut f32,
        xyz: *mut f32,
    ) -> c_int;
}
