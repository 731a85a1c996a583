//! The sensors' device states from their `status_<sensor>` inputs (`sensor_status`): what each
//! is doing now and for how long it has been degraded in total (stalled, unplugged or failed:
//! no frames), for the report file and the rerun view. A source sends its state on every
//! change and periodically, so a stall is seen while the sensor's frames have stopped.

use std::collections::BTreeMap;

use serde::Serialize;
use trigait_schema::SensorStatus;

/// One sensor's device state and its degraded time so far.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DeviceEntry {
    /// The latest state (`streaming`, `stalled`, `absent`, …).
    pub state: String,
    /// Why, for a person.
    pub detail: String,
    /// Seconds spent degraded, the current spell included up to its latest report.
    pub degraded_secs: f64,
    /// Spells of degraded state begun.
    pub degraded_spells: u64,
    /// Frames the source counted lost.
    pub lost_frames: u64,
    /// Reports received.
    pub reports: u64,
    #[serde(skip)]
    closed_degraded_nanos: i64,
    #[serde(skip)]
    current: Option<(bool, i64)>,
}

/// Every sensor's device state, by sensor id.
#[derive(Debug, Default)]
pub struct Devices {
    entries: BTreeMap<String, DeviceEntry>,
}

impl Devices {
    /// Takes a report; returns whether the state changed (worth a line in the viewer).
    pub fn push(&mut self, s: &SensorStatus) -> bool {
        let e = self
            .entries
            .entry(s.sensor_id.clone())
            .or_insert_with(|| DeviceEntry {
                state: String::new(),
                detail: String::new(),
                degraded_secs: 0.0,
                degraded_spells: 0,
                lost_frames: 0,
                reports: 0,
                closed_degraded_nanos: 0,
                current: None,
            });
        let degraded = s.is_degraded();
        // A report that restates the spell it belongs to (same start) continues it.
        let same_spell = e
            .current
            .is_some_and(|(was, since)| was == degraded && since == s.since_nanos);
        if !same_spell {
            if let Some((true, since)) = e.current {
                // The degraded spell ended when this state began.
                e.closed_degraded_nanos += (s.since_nanos - since).max(0);
            }
            if degraded {
                e.degraded_spells += 1;
            }
            e.current = Some((degraded, s.since_nanos));
        }
        let open = match e.current {
            Some((true, since)) => (s.stamp_nanos - since).max(0),
            _ => 0,
        };
        e.degraded_secs = (e.closed_degraded_nanos + open) as f64 / 1e9;
        let changed = e.state != s.state || !same_spell;
        e.state.clone_from(&s.state);
        e.detail.clone_from(&s.detail);
        e.lost_frames = s.lost_frames;
        e.reports += 1;
        changed
    }

    /// The entries, by sensor id.
    #[must_use]
    pub fn entries(&self) -> &BTreeMap<String, DeviceEntry> {
        &self.entries
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn report(state: &str, since_s: f64, at_s: f64) -> SensorStatus {
        SensorStatus {
            sensor_id: "k2".into(),
            stamp_nanos: (at_s * 1e9) as i64,
            state: state.into(),
            detail: state.into(),
            since_nanos: (since_s * 1e9) as i64,
            lost_frames: 7,
        }
    }

    /// Streaming, a 2 s stall reported three times, streaming, then an unplug still going:
    /// the degraded time is the closed stall plus the open spell up to its latest report, and
    /// only state changes are news.
    #[test]
    fn degraded_time_adds_spells() {
        let mut d = Devices::default();
        assert!(d.push(&report(SensorStatus::STREAMING, 0.0, 0.0)));
        assert!(!d.push(&report(SensorStatus::STREAMING, 0.0, 0.5)));
        assert!(d.push(&report(SensorStatus::STALLED, 1.0, 1.0)));
        assert!(!d.push(&report(SensorStatus::STALLED, 1.0, 1.5)));
        assert!(!d.push(&report(SensorStatus::STALLED, 1.0, 2.5)));
        let e = &d.entries()["k2"];
        assert!((e.degraded_secs - 1.5).abs() < 1e-9, "{e:?}");
        assert!(d.push(&report(SensorStatus::STREAMING, 3.0, 3.0)));
        assert!((d.entries()["k2"].degraded_secs - 2.0).abs() < 1e-9);
        assert!(d.push(&report(SensorStatus::ABSENT, 4.0, 4.0)));
        assert!(!d.push(&report(SensorStatus::ABSENT, 4.0, 4.25)));
        let e = &d.entries()["k2"];
        assert!((e.degraded_secs - 2.25).abs() < 1e-9, "{e:?}");
        assert_eq!(
            (e.degraded_spells, e.reports, e.state.as_str()),
            (2, 8, "absent")
        );
        let json = serde_json::to_value(e).unwrap();
        assert_eq!(json["state"], "absent");
        assert!(json.get("current").is_none());
    }
}
