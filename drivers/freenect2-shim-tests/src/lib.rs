//! Empty: this crate exists for its tests (`tests/`), which build libfreenect2-sys's C++ shim
//! against the fake libfreenect2 and drive it through `trigait-freenect2`, so the path a real
//! Kinect takes is compiled and exercised in CI without the device library.
