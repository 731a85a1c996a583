//! `fake/include/fake_control.h`: the fake USB bus of the fake libfreenect2. When the real
//! library is linked as well (`freenect2` wins), these are no-ops, so code written against the
//! fake still builds; check [`crate::FAKE_LIBRARY`] before relying on them.

#[cfg(fake_library)]
use std::ffi::{c_char, c_int};

#[cfg(fake_library)]
unsafe extern "C" {
    /// Unplugs and forgets every device.
    pub fn tgfake_reset();
    /// Plugs a device in (see the header for the arguments).
    pub fn tgfake_plug(
        serial: *const c_char,
        firmware: *const c_char,
        period_us: u32,
        timestamp0: u32,
        sequence0: u32,
        depth: *const f32,
    );
    /// Unplugs a device: frames stop, it leaves the enumeration.
    pub fn tgfake_unplug(serial: *const c_char);
    /// Frames are captured but not delivered for `ms`.
    pub fn tgfake_stall(serial: *const c_char, ms: u32);
    /// The device's close blocks for `ms`.
    pub fn tgfake_hang_close(serial: *const c_char, ms: u32);
    /// The device cannot be opened (no USB access).
    pub fn tgfake_deny_access(serial: *const c_char, denied: c_int);
    /// Logs through libfreenect2's global logger.
    pub fn tgfake_log(level: c_int, message: *const c_char);
    /// Pipelines built since the last reset.
    pub fn tgfake_pipelines_built() -> c_int;
}

#[cfg(not(fake_library))]
mod stubs {
    #![allow(clippy::missing_safety_doc, missing_docs)]
    use std::ffi::{c_char, c_int};
    pub unsafe fn tgfake_reset() {}
    pub unsafe fn tgfake_plug(
        _: *const c_char,
        _: *const c_char,
        _: u32,
        _: u32,
        _: u32,
        _: *const f32,
    ) {
    }
    pub unsafe fn tgfake_unplug(_: *const c_char) {}
    pub unsafe fn tgfake_stall(_: *const c_char, _: u32) {}
    pub unsafe fn tgfake_hang_close(_: *const c_char, _: u32) {}
    pub unsafe fn tgfake_deny_access(_: *const c_char, _: c_int) {}
    pub unsafe fn tgfake_log(_: c_int, _: *const c_char) {}
    pub unsafe fn tgfake_pipelines_built() -> c_int {
        0
    }
}
#[cfg(not(fake_library))]
pub use stubs::*;
