//! Per-sensor state of the `depth-metrics` node, free of dora so it is tested directly: one
//! [`SequenceAnalyzer`] per sensor fed with every good frame, counters of what arrived and what
//! was refused, and the JSON document the node rewrites after each report.

use std::collections::BTreeMap;
use std::path::Path;

use eyre::Context;
use serde::Serialize;
use tracing::warn;
use trigait_depth::{DepthFrame, Intrinsics, MetricsParams, SequenceAnalyzer, SequenceReport};
use trigait_depth_rerun::RecordingStream;
use trigait_schema::{DepthFrameMessage, Message};

/// What happened to one input message.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Pushed {
    /// Analysed; a report is due now (every `report_every` frames).
    ReportDue,
    /// Analysed.
    Analysed,
    /// Refused (malformed message or wrong frame size), counted.
    Refused,
}

/// Counters and the latest report of one sensor (the JSON entry).
#[derive(Debug, Clone, Default, Serialize)]
pub struct SensorEntry {
    /// Messages received on `depth_<sensor>`.
    pub frames_received: u64,
    /// Frames pushed to the metrics.
    pub frames_analysed: u64,
    /// Messages that did not decode as `depth_frame` (skipped).
    pub malformed: u64,
    /// Frames that decoded but are not 512×424 (skipped).
    pub wrong_size: u64,
    /// Sequence number of the first analysed frame (frames sent before this node listened are
    /// not counted as gaps).
    pub first_seq: Option<u64>,
    /// Frames missing between consecutive sequence numbers (lost or dropped upstream).
    pub seq_gaps: u64,
    /// Reports computed (each also logged to rerun when enabled).
    pub reports_written: u64,
    /// Sensor-clock stamp of the first and of the last analysed frame, ns.
    pub first_local_stamp_nanos: Option<i64>,
    /// See `first_local_stamp_nanos`.
    pub last_local_stamp_nanos: Option<i64>,
    /// Host time the first and the last analysed frame arrived, ns since the epoch.
    pub first_arrival_nanos: Option<i64>,
    /// See `first_arrival_nanos`.
    pub last_arrival_nanos: Option<i64>,
    /// Frames per second over the arrivals (`(n − 1) / (last − first)`).
    pub arrival_rate_hz: Option<f64>,
    /// The five metrics over every analysed frame so far (thesis ch. 3, §5.1).
    pub report: Option<SequenceReport>,
    /// Why the last report could not be computed.
    pub error: Option<String>,
    /// The pinhole `[fx, fy, cx, cy]` (px) the source stamped on the frames (undistorted
    /// real frames) and the metrics back-project with; `None`: the nominal camera.
    pub pinhole: Option<[f64; 4]>,
}

struct Sensor {
    analyzer: SequenceAnalyzer,
    /// The camera the analyzer back-projects with (the frames' stamped pinhole or nominal).
    camera: Intrinsics,
    entry: SensorEntry,
    last_seq: Option<u64>,
    reported_at: usize,
    legends: Vec<&'static str>,
}

/// Every sensor's state.
pub struct Sensors {
    params: MetricsParams,
    report_every: usize,
    sensors: BTreeMap<String, Sensor>,
}

/// The JSON document.
#[derive(Debug, Serialize)]
struct Document<'a> {
    tool: &'static str,
    report_every_frames: usize,
    entropy_window: usize,
    target_distance_m: Option<f64>,
    sensors: BTreeMap<&'a str, &'a SensorEntry>,
    /// Device states (`status_<sensor>` inputs), empty when none is wired.
    devices: &'a BTreeMap<String, crate::devices::DeviceEntry>,
}

impl Sensors {
    /// No sensors yet; each appears with its first input.
    #[must_use]
    pub fn new(params: MetricsParams, report_every: usize) -> Self {
        Self {
            params,
            report_every: report_every.max(1),
            sensors: BTreeMap::new(),
        }
    }

    /// The entry of `sensor` (tests; the node reads entries through the JSON).
    #[cfg(test)]
    #[must_use]
    pub fn entry(&self, sensor: &str) -> Option<&SensorEntry> {
        self.sensors.get(sensor).map(|s| &s.entry)
    }

    fn sensor(&mut self, id: &str) -> &mut Sensor {
        let params = self.params;
        self.sensors.entry(id.to_owned()).or_insert_with(|| Sensor {
            analyzer: SequenceAnalyzer::new(params, None),
            camera: params.intrinsics,
            entry: SensorEntry::default(),
            last_seq: None,
            reported_at: 0,
            legends: Vec::new(),
        })
    }

    /// Decodes and analyses one message of `sensor` that arrived at `arrival_nanos`, taken by
    /// `camera` (`trigait_node_config::depth_camera` of its metadata: the source's stamped
    /// pinhole of an undistorted frame, or the nominal camera). Bad input is counted and
    /// skipped; the reason is returned for the log. A frame of another camera than the
    /// sensor's frames so far starts its analysis afresh (statistics over two cameras mean
    /// nothing).
    pub fn push(
        &mut self,
        sensor: &str,
        array: &dyn trigait_schema::Array,
        camera: Intrinsics,
        arrival_nanos: i64,
    ) -> (Pushed, Option<String>) {
        let report_every = self.report_every;
        let params = self.params;
        let s = self.sensor(sensor);
        s.entry.frames_received += 1;
        let message = match DepthFrameMessage::decode(array) {
            Ok(m) => m,
            Err(e) => {
                s.entry.malformed += 1;
                return (Pushed::Refused, Some(format!("malformed depth_frame: {e}")));
            }
        };
        let frame = match DepthFrame::from_mm(message.depth_mm) {
            Ok(f) if (message.width, message.height) == (512, 424) => f,
            Ok(_) | Err(_) => {
                s.entry.wrong_size += 1;
                return (
                    Pushed::Refused,
                    Some(format!(
                        "frame of {}x{} pixels, the depth metrics need 512x424",
                        message.width, message.height
                    )),
                );
            }
        };
        if let Some(last) = s.last_seq {
            s.entry.seq_gaps += message.seq.saturating_sub(last + 1);
        }
        s.last_seq = Some(message.seq);
        s.entry.first_seq.get_or_insert(message.seq);
        if s.camera != camera {
            if s.analyzer.frames() > 0 {
                warn!(%sensor, "the depth camera changed: starting the analysis afresh");
            }
            s.analyzer = SequenceAnalyzer::new(
                MetricsParams {
                    intrinsics: camera,
                    ..params
                },
                None,
            );
            s.camera = camera;
            s.reported_at = 0;
        }
        s.entry.pinhole = (camera != Intrinsics::default())
            .then_some([camera.fx, camera.fy, camera.cx, camera.cy]);
        s.analyzer.push(&frame);
        let e = &mut s.entry;
        e.frames_analysed += 1;
        e.first_local_stamp_nanos
            .get_or_insert(message.local_stamp_nanos);
        e.last_local_stamp_nanos = Some(message.local_stamp_nanos);
        let first = *e.first_arrival_nanos.get_or_insert(arrival_nanos);
        e.last_arrival_nanos = Some(arrival_nanos);
        if e.frames_analysed > 1 && arrival_nanos > first {
            e.arrival_rate_hz =
                Some((e.frames_analysed - 1) as f64 / ((arrival_nanos - first) as f64 * 1e-9));
        }
        if s.analyzer.frames() - s.reported_at >= report_every {
            (Pushed::ReportDue, None)
        } else {
            (Pushed::Analysed, None)
        }
    }

    /// Recomputes `sensor`'s report (and logs its maps to `rec`), unless no frame arrived
    /// since the last one. Returns whether a report was made.
    ///
    /// # Errors
    /// Logging to rerun failed (the sink is gone).
    pub fn report(&mut self, sensor: &str, rec: Option<&RecordingStream>) -> eyre::Result<bool> {
        let params = self.params;
        let Some(s) = self.sensors.get_mut(sensor) else {
            return Ok(false);
        };
        if s.analyzer.frames() == s.reported_at || s.analyzer.frames() == 0 {
            return Ok(false);
        }
        s.reported_at = s.analyzer.frames();
        match s.analyzer.report_and_maps() {
            Ok((report, maps)) => {
                if let Some(rec) = rec {
                    trigait_depth_rerun::log_report(
                        rec,
                        sensor,
                        &report,
                        &maps,
                        &params,
                        &mut s.legends,
                    )
                    .context("depth-metrics: logging to rerun")?;
                }
                s.entry.report = Some(report);
                s.entry.error = None;
            }
            Err(e) => s.entry.error = Some(e.to_string()),
        }
        s.entry.reports_written += 1;
        Ok(true)
    }

    /// Reports every sensor with frames not reported yet (end of the run).
    ///
    /// # Errors
    /// As [`Sensors::report`].
    pub fn report_all(&mut self, rec: Option<&RecordingStream>) -> eyre::Result<()> {
        let ids: Vec<String> = self.sensors.keys().cloned().collect();
        for id in ids {
            self.report(&id, rec)?;
        }
        Ok(())
    }

    /// Writes the JSON document to `path` atomically (a temporary file renamed over it), so a
    /// reader never sees half a file.
    ///
    /// # Errors
    /// The file cannot be written.
    pub fn write_json(&self, path: &Path, devices: &crate::devices::Devices) -> eyre::Result<()> {
        let doc = Document {
            tool: "trigait depth-metrics node",
            report_every_frames: self.report_every,
            entropy_window: self.params.entropy_window,
            target_distance_m: self.params.accuracy.target_distance_m,
            sensors: self
                .sensors
                .iter()
                .map(|(k, s)| (k.as_str(), &s.entry))
                .collect(),
            devices: devices.entries(),
        };
        let text = serde_json::to_string_pretty(&doc).context("serialising the report")?;
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir)
                .with_context(|| format!("depth-metrics: creating {}", dir.display()))?;
        }
        let tmp = path.with_extension("json.tmp");
        std::fs::write(&tmp, text + "\n")
            .with_context(|| format!("depth-metrics: writing {}", tmp.display()))?;
        std::fs::rename(&tmp, path)
            .with_context(|| format!("depth-metrics: renaming onto {}", path.display()))
    }
}
