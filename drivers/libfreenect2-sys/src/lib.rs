//! Raw bindings to `shim/trigait_freenect2.h`, the C ABI trigait puts over libfreenect2's C++
//! API (the header and `shim/shim.cpp` say what each call guards against). Everything here is
//! `unsafe` and unchecked; use the safe `trigait-freenect2` crate instead.
//!
//! Without a feature this crate is empty, so default builds need no device library. With
//! `freenect2` it links the real libfreenect2 (pkg-config `freenect2`); with `fake` it links the
//! same shim against the fake libfreenect2 in `fake/`, whose controls ([`fake`]) let tests plug,
//! stall and unplug devices.

// FFI declarations are unsafe by nature; this crate is only declarations.
#![allow(unsafe_code)]
// The C names of the shim are kept as they are.
#![allow(non_camel_case_types)]

#[cfg(any(feature = "freenect2", feature = "fake"))]
mod ffi;
#[cfg(any(feature = "freenect2", feature = "fake"))]
pub use ffi::*;

/// Controls of the fake libfreenect2 (no-ops when the real library is linked instead).
#[cfg(feature = "fake")]
pub mod fake;

/// Whether the linked library is the fake one (`fake` feature without `freenect2`).
pub const FAKE_LIBRARY: bool = cfg!(fake_library);
