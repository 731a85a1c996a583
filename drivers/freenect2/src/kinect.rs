//! The libfreenect2 driver, over `libfreenect2-sys`'s shim. The shim owns the hazards (timed
//! waits, serial checks, the watchdog on open and close); this module owns lifetimes: a device
//! holds an `Arc` of its context, so the context (whose destruction deletes its devices) is
//! freed only after the last device is closed.
// The FFI calls need `unsafe`; each block says why it is sound.
#![allow(unsafe_code)]

use std::ffi::{CStr, CString, c_char, c_int};
use std::sync::Arc;
use std::time::Duration;

use libfreenect2_sys as sys;

use crate::frame::Pixels;
use crate::{
    Device, DeviceInfo, Driver, Enumeration, Error, Frame, FrameKind, IrParams, Pipeline, Result,
    Streams,
};

/// How long libfreenect2 may take to open (it retries libusb_open for 1 s and may reset the
/// device and wait another second) or to close a device before the watchdog gives up.
const OPEN_TIMEOUT_MS: c_int = 5_000;
/// Close watchdog.
const CLOSE_TIMEOUT_MS: c_int = 2_000;

struct ContextHandle(*mut sys::tg_context);

// SAFETY: the shim serialises every call on a context with its own mutex, and the pointer is
// only freed in `Drop`, once no device (each holds an `Arc`) uses it.
unsafe impl Send for ContextHandle {}
// SAFETY: as above: concurrent calls are serialised inside the shim.
unsafe impl Sync for ContextHandle {}

impl Drop for ContextHandle {
    fn drop(&mut self) {
        // SAFETY: the pointer came from tg_context_new and is freed once; the shim leaks it
        // instead when a watchdog fired.
        let _ = unsafe { sys::tg_context_free(self.0) };
    }
}

unsafe extern "C" fn forward_log(level: c_int, message: *const c_char, len: usize) {
    if message.is_null() {
        return;
    }
    // SAFETY: the shim passes a pointer to `len` bytes of a live std::string.
    let bytes = unsafe { std::slice::from_raw_parts(message.cast::<u8>(), len) };
    let text = String::from_utf8_lossy(bytes);
    match level {
        1 => tracing::error!(target: "libfreenect2", "{text}"),
        2 => tracing::warn!(target: "libfreenect2", "{text}"),
        3 => tracing::info!(target: "libfreenect2", "{text}"),
        _ => tracing::debug!(target: "libfreenect2", "{text}"),
    }
}

fn install_log() {
    use tracing::level_filters::LevelFilter;
    let level = match LevelFilter::current() {
        LevelFilter::OFF | LevelFilter::ERROR => 1,
        LevelFilter::WARN => 2,
        LevelFilter::INFO => 3,
        _ => 4,
    };
    // SAFETY: `forward_log` is a plain function valid for the whole program.
    unsafe { sys::tg_set_log(Some(forward_log), level) };
}

fn pipeline_bit(p: Pipeline) -> c_int {
    match p {
        Pipeline::Cpu => sys::TG_PIPELINE_CPU,
        Pipeline::OpenGl => sys::TG_PIPELINE_OPENGL,
        Pipeline::OpenCl => sys::TG_PIPELINE_OPENCL,
        Pipeline::Cuda => sys::TG_PIPELINE_CUDA,
    }
}

fn read_string(f: impl FnOnce(*mut c_char, usize) -> c_int) -> Option<String> {
    let mut buf = vec![0u8; 256];
    let n = f(buf.as_mut_ptr().cast(), buf.len());
    if n < 0 {
        return None;
    }
    CStr::from_bytes_until_nul(&buf)
        .ok()
        .map(|s| s.to_string_lossy().into_owned())
}

/// libfreenect2's context: enumerates and opens Kinects.
pub struct Freenect2 {
    ctx: Arc<ContextHandle>,
}

impl std::fmt::Debug for Freenect2 {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Freenect2").finish_non_exhaustive()
    }
}

impl Freenect2 {
    /// A new context, with libfreenect2's log routed to `tracing` (target `libfreenect2`).
    ///
    /// # Errors
    /// [`Error::OpenFailed`] when libfreenect2 cannot create a context (no libusb).
    pub fn new() -> Result<Self> {
        install_log();
        // SAFETY: no preconditions; a null result is handled.
        let ptr = unsafe { sys::tg_context_new() };
        if ptr.is_null() {
            return Err(Error::OpenFailed("libfreenect2 context".into()));
        }
        Ok(Self {
            ctx: Arc::new(ContextHandle(ptr)),
        })
    }

    /// Replaces a context a watchdog poisoned (the old one is leaked by the shim).
    fn renew(&mut self) {
        if let Ok(fresh) = Self::new() {
            *self = fresh;
        }
    }

    fn watchdog(&mut self, what: &str, millis: c_int) -> Error {
        self.renew();
        Error::Watchdog {
            what: what.into(),
            millis: u64::try_from(millis).unwrap_or(0),
        }
    }
}

impl Driver for Freenect2 {
    fn enumerate(&mut self) -> Result<Enumeration> {
        let mut denied: c_int = 0;
        // SAFETY: the context is live (we hold the Arc); `denied` outlives the call.
        let n = unsafe { sys::tg_enumerate(self.ctx.0, &mut denied) };
        if n == sys::TG_ERR_WATCHDOG {
            return Err(self.watchdog("enumerating", 5_000));
        }
        let mut serials = Vec::new();
        for i in 0..n.max(0) {
            // SAFETY: the buffer pointer and length come from `read_string`'s own Vec.
            if let Some(s) =
                read_string(|buf, len| unsafe { sys::tg_serial(self.ctx.0, i, buf, len) })
            {
                serials.push(s);
            }
        }
        Ok(Enumeration {
            serials,
            usb_access_denied: denied != 0,
        })
    }

    fn open(
        &mut self,
        serial: &str,
        pipeline: Pipeline,
        streams: Streams,
    ) -> Result<Box<dyn Device>> {
        let c_serial = CString::new(serial).map_err(|_| Error::NoSuchSerial {
            serial: serial.into(),
            available: "a serial without NUL bytes".into(),
        })?;
        let types = (if streams.depth {
            sys::TG_FRAME_DEPTH
        } else {
            0
        }) | (if streams.ir { sys::TG_FRAME_IR } else { 0 })
            | (if streams.color {
                sys::TG_FRAME_COLOR
            } else {
                0
            });
        let mut dev: *mut sys::tg_device = std::ptr::null_mut();
        // SAFETY: live context, NUL-terminated serial, `dev` outlives the call.
        let rc = unsafe {
            sys::tg_open(
                self.ctx.0,
                c_serial.as_ptr(),
                pipeline_bit(pipeline),
                types,
                OPEN_TIMEOUT_MS,
                &mut dev,
            )
        };
        match rc {
            sys::TG_OK => {}
            sys::TG_ERR_NO_SUCH_SERIAL => {
                let e = self.enumerate()?;
                return Err(if e.usb_access_denied {
                    Error::UsbAccessDenied
                } else {
                    Error::NoSuchSerial {
                        serial: serial.into(),
                        available: if e.serials.is_empty() {
                            "none".into()
                        } else {
                            e.serials.join(", ")
                        },
                    }
                });
            }
            sys::TG_ERR_ALREADY_OPEN => return Err(Error::AlreadyOpen(serial.into())),
            sys::TG_ERR_PIPELINE_UNAVAILABLE => {
                return Err(Error::PipelineUnavailable(pipeline.name().into()));
            }
            sys::TG_ERR_WATCHDOG => return Err(self.watchdog("opening", OPEN_TIMEOUT_MS)),
            _ => return Err(Error::OpenFailed(serial.into())),
        }
        // SAFETY (all three): `dev` is the live device tg_open just returned.
        let firmware =
            read_string(|buf, len| unsafe { sys::tg_firmware(dev, buf, len) }).unwrap_or_default();
        let mut kinect = Kinect {
            _ctx: Arc::clone(&self.ctx),
            dev,
            info: DeviceInfo {
                serial: serial.into(),
                firmware,
                pipeline,
            },
            ir: IrParams::default(),
        };
        // SAFETY: as above.
        if unsafe { sys::tg_start(dev) } != sys::TG_OK {
            let _ = Box::new(kinect).close();
            return Err(Error::StartFailed(serial.into()));
        }
        let mut p = sys::tg_ir_params::default();
        // SAFETY: started device, `p` outlives the call.
        if unsafe { sys::tg_ir_params_get(dev, &mut p) } == sys::TG_OK {
            kinect.ir = IrParams {
                fx: p.fx,
                fy: p.fy,
                cx: p.cx,
                cy: p.cy,
                k1: p.k1,
                k2: p.k2,
                k3: p.k3,
                p1: p.p1,
                p2: p.p2,
            };
        }
        Ok(Box::new(kinect))
    }

    fn pipelines(&self) -> Vec<Pipeline> {
        // SAFETY: no preconditions.
        let bits = unsafe { sys::tg_pipelines_available() };
        Pipeline::ALL
            .into_iter()
            .filter(|p| bits & pipeline_bit(*p) as u32 != 0)
            .collect()
    }
}

/// An open, started Kinect v2.
pub struct Kinect {
    _ctx: Arc<ContextHandle>,
    dev: *mut sys::tg_device,
    info: DeviceInfo,
    ir: IrParams,
}

// SAFETY: the device is used through `&mut self` (one thread at a time); the shim's frame queue,
// which libfreenect2's threads fill, is behind its own mutex. Not `Sync`.
unsafe impl Send for Kinect {}

impl Drop for Kinect {
    fn drop(&mut self) {
        if !self.dev.is_null() {
            // SAFETY: live device, closed once (the pointer is nulled by `close`).
            let _ = unsafe { sys::tg_close(self.dev, CLOSE_TIMEOUT_MS) };
        }
    }
}

impl Device for Kinect {
    fn info(&self) -> &DeviceInfo {
        &self.info
    }

    fn ir_params(&self) -> IrParams {
        self.ir
    }

    fn wait(&mut self, timeout: Duration) -> Result<Option<Frame>> {
        let ms = c_int::try_from(timeout.as_millis()).unwrap_or(c_int::MAX);
        let mut f: *mut sys::tg_frame = std::ptr::null_mut();
        // SAFETY: live device; `f` outlives the call.
        let rc = unsafe { sys::tg_wait(self.dev, ms, &mut f) };
        if rc == sys::TG_TIMEOUT {
            return Ok(None);
        }
        if rc != sys::TG_OK || f.is_null() {
            return Err(Error::Disconnected(self.info.serial.clone()));
        }
        let shim = ShimFrame::new(f);
        let info = shim.info;
        let kind = match info.type_ {
            sys::TG_FRAME_DEPTH => FrameKind::Depth,
            sys::TG_FRAME_IR => FrameKind::Ir,
            _ => FrameKind::Color,
        };
        if kind != FrameKind::Color && info.bytes_per_pixel != 4 {
            return Err(Error::BadFrame(format!(
                "{kind:?} frame with {} bytes per pixel",
                info.bytes_per_pixel
            )));
        }
        Ok(Some(Frame {
            kind,
            width: info.width,
            height: info.height,
            timestamp: info.timestamp,
            sequence: info.sequence,
            host_nanos: info.host_nanos,
            pixels: Pixels::Shim(shim),
        }))
    }

    fn dropped(&self) -> u64 {
        // SAFETY: live device.
        unsafe { sys::tg_dropped(self.dev) }
    }

    fn close(mut self: Box<Self>) -> Result<()> {
        let dev = std::mem::replace(&mut self.dev, std::ptr::null_mut());
        // SAFETY: live device, closed once.
        match unsafe { sys::tg_close(dev, CLOSE_TIMEOUT_MS) } {
            sys::TG_OK => Ok(()),
            _ => Err(Error::Watchdog {
                what: format!("closing {}", self.info.serial),
                millis: u64::try_from(CLOSE_TIMEOUT_MS).unwrap_or(0),
            }),
        }
    }
}

/// A frame the shim allocated; freed on drop.
pub(crate) struct ShimFrame {
    ptr: *mut sys::tg_frame,
    info: sys::tg_frame_info,
}

// SAFETY: the frame is a heap buffer owned solely by this value (the listener gave it away),
// independent of the device and its threads.
unsafe impl Send for ShimFrame {}

impl ShimFrame {
    fn new(ptr: *mut sys::tg_frame) -> Self {
        let mut info = sys::tg_frame_info {
            type_: 0,
            width: 0,
            height: 0,
            bytes_per_pixel: 0,
            data: std::ptr::null(),
            timestamp: 0,
            sequence: 0,
            status: 0,
            host_nanos: 0,
        };
        // SAFETY: `ptr` is a live frame from tg_wait; `info` outlives the call.
        unsafe { sys::tg_frame_get(ptr, &mut info) };
        Self { ptr, info }
    }

    pub(crate) fn as_f32(&self) -> &[f32] {
        if self.info.data.is_null()
            || self.info.bytes_per_pixel != 4
            || self.info.type_ == sys::TG_FRAME_COLOR
        {
            return &[];
        }
        // SAFETY: libfreenect2 frames are 64-byte aligned buffers of width×height×4 bytes,
        // alive until `Drop` frees them; the borrow is tied to `&self`.
        unsafe {
            std::slice::from_raw_parts(
                self.info.data.cast::<f32>(),
                self.info.width * self.info.height,
            )
        }
    }
}

impl Drop for ShimFrame {
    fn drop(&mut self) {
        // SAFETY: freed once, here.
        unsafe { sys::tg_frame_free(self.ptr) };
    }
}

/// libfreenect2's own `Registration::undistortDepth` + `getPointXYZ` over a frame: the
/// undistorted depth (mm) and the points (m, OpenCV camera frame, NaN where no depth). The
/// reference for [`trigait_depth::Undistorter`].
///
/// # Errors
/// [`Error::NotBuilt`] with the fake library (it has no `Registration`), [`Error::BadFrame`] on
/// a frame that is not 512×424.
pub fn registration_xyz(params: &IrParams, depth_mm: &[f32]) -> Result<(Vec<f32>, Vec<[f32; 3]>)> {
    const N: usize = 512 * 424;
    if depth_mm.len() != N {
        return Err(Error::BadFrame(format!("{} depth pixels", depth_mm.len())));
    }
    let p = sys::tg_ir_params {
        fx: params.fx,
        fy: params.fy,
        cx: params.cx,
        cy: params.cy,
        k1: params.k1,
        k2: params.k2,
        k3: params.k3,
        p1: params.p1,
        p2: params.p2,
    };
    let mut undistorted = vec![0.0f32; N];
    let mut xyz = vec![0.0f32; 3 * N];
    // SAFETY: all buffers have the sizes the shim documents.
    let rc = unsafe {
        sys::tg_registration_xyz(
            &p,
            depth_mm.as_ptr(),
            undistorted.as_mut_ptr(),
            xyz.as_mut_ptr(),
        )
    };
    if rc != sys::TG_OK {
        return Err(Error::NotBuilt);
    }
    Ok((
        undistorted,
        xyz.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect(),
    ))
}

/// The fake libfreenect2's USB bus: plug, stall and unplug devices the shim then sees. No-ops
/// when the real library is linked (check [`available`]).
#[cfg(feature = "fake-freenect2")]
pub mod fake_bus {
    use std::ffi::CString;

    use libfreenect2_sys::fake as f;

    /// Whether the fake library is the one linked.
    #[must_use]
    pub fn available() -> bool {
        libfreenect2_sys::FAKE_LIBRARY
    }

    fn c(s: &str) -> CString {
        CString::new(s.replace('\0', "")).unwrap_or_default()
    }

    /// Forgets every device.
    pub fn reset() {
        // SAFETY: no preconditions.
        unsafe { f::tgfake_reset() }
    }

    /// Plugs a device in: frames every `period_us` from device time `timestamp0` and sequence
    /// `sequence0`, playing `depth` (512×424 mm; IR = depth / 10).
    pub fn plug(
        serial: &str,
        firmware: &str,
        period_us: u32,
        timestamp0: u32,
        sequence0: u32,
        depth: &[f32],
    ) {
        let mut d = depth.to_vec();
        d.resize(512 * 424, 0.0);
        // SAFETY: NUL-terminated strings and a 512×424 buffer, all alive for the call (copied).
        unsafe {
            f::tgfake_plug(
                c(serial).as_ptr(),
                c(firmware).as_ptr(),
                period_us,
                timestamp0,
                sequence0,
                d.as_ptr(),
            )
        }
    }

    /// Frames stop and the device leaves the enumeration.
    pub fn unplug(serial: &str) {
        // SAFETY: NUL-terminated string.
        unsafe { f::tgfake_unplug(c(serial).as_ptr()) }
    }

    /// Frames are captured but not delivered for `ms`.
    pub fn stall(serial: &str, ms: u32) {
        // SAFETY: NUL-terminated string.
        unsafe { f::tgfake_stall(c(serial).as_ptr(), ms) }
    }

    /// The device's close blocks for `ms`.
    pub fn hang_close(serial: &str, ms: u32) {
        // SAFETY: NUL-terminated string.
        unsafe { f::tgfake_hang_close(c(serial).as_ptr(), ms) }
    }

    /// The device cannot be opened (no udev rule).
    pub fn deny_access(serial: &str, denied: bool) {
        // SAFETY: NUL-terminated string.
        unsafe { f::tgfake_deny_access(c(serial).as_ptr(), i32::from(denied)) }
    }

    /// Logs through libfreenect2's global logger.
    pub fn log(level: i32, message: &str) {
        // SAFETY: NUL-terminated string.
        unsafe { f::tgfake_log(level, c(message).as_ptr()) }
    }

    /// Pipelines built since the last reset.
    #[must_use]
    pub fn pipelines_built() -> i32 {
        // SAFETY: no preconditions.
        unsafe { f::tgfake_pipelines_built() }
    }
}
