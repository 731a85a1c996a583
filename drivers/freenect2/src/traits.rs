//! What a Kinect must offer the capture state machine.

use std::time::Duration;

use crate::{Frame, IrParams, Result};

/// libfreenect2's depth pipelines.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Pipeline {
    /// CPU (always built).
    Cpu,
    /// OpenGL.
    OpenGl,
    /// OpenCL.
    OpenCl,
    /// CUDA.
    Cuda,
}

impl Pipeline {
    /// Every pipeline, in libfreenect2's bit order.
    pub const ALL: [Pipeline; 4] = [
        Pipeline::Cpu,
        Pipeline::OpenGl,
        Pipeline::OpenCl,
        Pipeline::Cuda,
    ];

    /// The YAML name (`cpu`, `opengl`, `opencl`, `cuda`).
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Pipeline::Cpu => "cpu",
            Pipeline::OpenGl => "opengl",
            Pipeline::OpenCl => "opencl",
            Pipeline::Cuda => "cuda",
        }
    }

    /// From the YAML name.
    #[must_use]
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|p| p.name() == name.trim())
    }
}

impl std::fmt::Display for Pipeline {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// Which streams to start.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Streams {
    /// Depth frames.
    pub depth: bool,
    /// IR frames.
    pub ir: bool,
    /// Colour frames.
    pub color: bool,
}

impl Default for Streams {
    fn default() -> Self {
        Self {
            depth: true,
            ir: true,
            color: false,
        }
    }
}

/// An enumeration of the bus.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Enumeration {
    /// Serials of the devices that can be opened, in libfreenect2's order.
    pub serials: Vec<String>,
    /// A Kinect was seen that could not be opened (USB permissions: the udev rule).
    pub usb_access_denied: bool,
}

/// An open device's identity.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct DeviceInfo {
    /// Serial number.
    pub serial: String,
    /// Firmware version.
    pub firmware: String,
    /// The pipeline it was opened with.
    pub pipeline: Pipeline,
}

/// An open, started Kinect.
pub trait Device: Send {
    /// Who it is.
    fn info(&self) -> &DeviceInfo;
    /// IR camera parameters.
    fn ir_params(&self) -> IrParams;
    /// The next frame, or `None` after `timeout` without one (the device may be stalled or
    /// unplugged: libfreenect2 has no unplug event, frames just stop).
    ///
    /// # Errors
    /// The device failed in a way a wait can tell.
    fn wait(&mut self, timeout: Duration) -> Result<Option<Frame>>;
    /// Frames the driver dropped because nobody took them in time.
    fn dropped(&self) -> u64;
    /// Stops and closes, bounded in time.
    ///
    /// # Errors
    /// [`crate::Error::Watchdog`] when the library did not return in time.
    fn close(self: Box<Self>) -> Result<()>;
}

/// Finds and opens Kinects.
pub trait Driver: Send {
    /// Lists the devices on the bus.
    ///
    /// # Errors
    /// The bus could not be read.
    fn enumerate(&mut self) -> Result<Enumeration>;
    /// Opens and starts one device.
    ///
    /// # Errors
    /// Unknown serial, already open, pipeline unavailable, or the library failed.
    fn open(
        &mut self,
        serial: &str,
        pipeline: Pipeline,
        streams: Streams,
    ) -> Result<Box<dyn Device>>;
    /// Pipelines compiled into the library.
    fn pipelines(&self) -> Vec<Pipeline>;
}

impl std::fmt::Debug for dyn Device {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Device")
            .field("info", self.info())
            .finish_non_exhaustive()
    }
}
