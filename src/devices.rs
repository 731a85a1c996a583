//! `trigait devices`: the Kinect v2 sensors libfreenect2 sees — serial (what a dataflow's
//! `FREENECT2_SERIAL` names), firmware, and the depth pipelines this libfreenect2 was built
//! with — or why there are none: a build without the `freenect2` feature, no device on the bus,
//! or a device the user may not open (the udev rule is missing).

use std::fmt::Write as _;

use eyre::bail;
use trigait_freenect2::{Driver, Error, Pipeline, Streams};

/// Arguments of `trigait devices` (none).
#[derive(Debug, clap::Args)]
pub struct Args {}

/// Lists the devices on stdout.
///
/// # Errors
/// No libfreenect2 in this build, no device, or no permission to open one.
pub fn run(_args: &Args) -> eyre::Result<()> {
    let mut driver = driver()?;
    crate::stdout::print(&report(driver.as_mut())?)?;
    Ok(())
}

#[cfg(feature = "freenect2")]
fn driver() -> eyre::Result<Box<dyn Driver>> {
    Ok(Box::new(trigait_freenect2::Freenect2::new()?))
}

#[cfg(not(feature = "freenect2"))]
fn driver() -> eyre::Result<Box<dyn Driver>> {
    Err(Error::NotBuilt.into())
}

/// The listing of every device a driver enumerates (each is opened briefly for its firmware).
///
/// # Errors
/// No device, or devices that cannot be opened for lack of USB permission.
pub fn report(driver: &mut dyn Driver) -> eyre::Result<String> {
    let found = driver.enumerate()?;
    if found.serials.is_empty() {
        if found.usb_access_denied {
            bail!(Error::UsbAccessDenied);
        }
        bail!(
            "no Kinect v2 found: is it on a USB 3 port with its power supply on? \
             (`lsusb` lists it as 045e:02d8 or 045e:02c4)"
        );
    }
    let pipelines: Vec<&str> = driver.pipelines().into_iter().map(Pipeline::name).collect();
    let mut out = String::new();
    let _ = writeln!(out, "{:<16} {:<28} pipelines", "serial", "firmware");
    for serial in &found.serials {
        let firmware = match driver.open(serial, Pipeline::Cpu, Streams::default()) {
            Ok(device) => {
                let fw = device.info().firmware.clone();
                if let Err(e) = device.close() {
                    eprintln!("warning: {e}");
                }
                fw
            }
            Err(e) => format!("(cannot open: {e})"),
        };
        let _ = writeln!(out, "{serial:<16} {firmware:<28} {}", pipelines.join(", "));
    }
    if found.usb_access_denied {
        let _ = writeln!(
            out,
            "and at least one more that cannot be opened: {}",
            Error::UsbAccessDenied
        );
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use trigait_freenect2::fake::{FakeDriver, FakeKinect};

    use super::*;

    /// Two fake sensors are listed with serial, firmware and the CPU pipeline; an empty bus and
    /// a bus with only an unopenable sensor give the two clear errors.
    #[test]
    fn lists_or_explains() {
        let frames = vec![vec![1000.0; 512 * 424]];
        let mut bus = FakeDriver::new(vec![
            FakeKinect::new("003726334247", frames.clone()),
            FakeKinect::new("011054343347", frames.clone()),
        ]);
        let text = report(&mut bus).unwrap();
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines.len(), 3, "{text}");
        assert!(
            lines[1].starts_with("003726334247")
                && lines[1].contains("(fake)")
                && lines[1].ends_with("cpu")
        );
        assert!(lines[2].starts_with("011054343347"));
        let err = report(&mut FakeDriver::new(vec![])).unwrap_err();
        assert!(err.to_string().contains("no Kinect v2 found"), "{err}");
        let mut denied = FakeKinect::new("X", frames);
        denied.access_denied = true;
        let err = report(&mut FakeDriver::new(vec![denied])).unwrap_err();
        assert!(err.to_string().contains("udev"), "{err}");
        #[cfg(not(feature = "freenect2"))]
        assert!(
            driver()
                .err()
                .unwrap()
                .to_string()
                .contains("--features freenect2")
        );
    }
}
