//! `BACKEND: body-depth`: a simulated Kinect v2 on Linux, which gives depth and no skeleton.
//! The walker (or `MOTION`) drives a body surface that [`trigait_body_render`] ray-casts into
//! this sensor's 512×424 image from its pose in the rig, with the time-of-flight noise,
//! edge dropout and flying pixels of a real one, in front of the floor and walls of a room.
//! Frames go out on `depth` (`depth_frame`) on the same 30 Hz grid, with the same sensor
//! clock, rig stamp, true stamp and end of stream as a simulated skeleton source's frames, and
//! the rig's first sensor sends the same world-frame ground truth on `ground_truth`. A
//! `leg-tracker` node turns the depth into the skeleton frames `sync` takes.
//!
//! The instants and the truth are those of [`trigait_sim::stream::SimulatedSensor`] (the
//! skeleton it also simulates is not sent), so a depth graph is scored exactly as the skeleton
//! graph is. A frame costs about 20 ms to render on one core, which a real sensor does not
//! spend on its host: a worker thread renders the next instant ahead of time, so the event
//! loop stays free to answer NTP requests at once and a frame goes out at its instant. When
//! the host falls behind, the instants already past are skipped (their seq numbers are missing
//! downstream, as lost frames are; the ground truth of every instant still goes out) instead
//! of rendering a burst of stale frames.

use std::sync::mpsc::{Receiver, Sender, channel};

use eyre::eyre;
use trigait_body_render::{BodyShape, RenderParams, Renderer, Room};
use trigait_depth::{HEIGHT, PIXELS, WIDTH};
use trigait_schema::DepthFrameMessage;
use trigait_sim::stream::{Captured, SensorClock, SimulatedSensor};
use trigait_skeleton::MotionClip;

const NODE: &str = "kinect-source";

/// A rendered instant.
#[derive(Debug)]
struct Rendered {
    t_nanos: i64,
    depth_mm: Vec<u16>,
    /// Why the body could not be built (the empty room was rendered instead).
    failure: Option<String>,
}

/// The worker: renders each instant it is sent (its host time, and where in the lap the
/// body then is) until the sensor is dropped.
fn render_worker(
    mut renderer: Renderer,
    lap: &MotionClip,
    jobs: &Receiver<(i64, f64)>,
    done: &Sender<Rendered>,
) {
    let shape = BodyShape::default();
    while let Ok((t_nanos, secs)) = jobs.recv() {
        let (frame, failure) = match renderer.render_pose(&shape, |j| lap.position_at(j, secs)) {
            Ok(r) => (r, None),
            Err(e) => (renderer.render_bodies(&[], Vec::new()), Some(e.to_string())),
        };
        let rendered = Rendered {
            t_nanos,
            depth_mm: frame.depth.as_mm().to_vec(),
            failure,
        };
        if done.send(rendered).is_err() {
            return;
        }
    }
}

/// One simulated sensor's body depth stream.
#[derive(Debug)]
pub struct BodyDepthSensor {
    sim: SimulatedSensor,
    jobs: Sender<(i64, f64)>,
    done: Receiver<Rendered>,
    /// The instant the worker is rendering or has rendered, not yet taken.
    in_flight: Option<i64>,
    pending: Option<DepthFrameMessage>,
    /// Instants skipped because the host was behind.
    pub skipped: u64,
    /// Of them, those skipped before the first frame went out.
    pub skipped_at_start: u64,
    /// Frames whose pose the body could not be built from (sent as the empty room), or that
    /// the worker could not render (sent empty).
    pub render_failures: u64,
}

impl BodyDepthSensor {
    /// `sim` (the timing and truth of `sensor_id` playing `lap`) rendered from the sensor's
    /// pose in `rig`; `seed` seeds the sensor noise. Starts the render worker, idle until
    /// [`Self::begin_at`] or the first capture.
    ///
    /// # Errors
    /// The sensor is not in the rig, the renderer refuses its parameters, or no thread can
    /// be started.
    pub fn new(
        sim: SimulatedSensor,
        lap: MotionClip,
        rig: &trigait_rig::Rig,
        sensor_id: &str,
        seed: u64,
    ) -> eyre::Result<Self> {
        let pose = rig
            .sensors
            .iter()
            .find(|s| s.id == sensor_id)
            .ok_or_else(|| {
                eyre!(
                    "{NODE}: SENSOR_ID={sensor_id:?} is not in the rig {:?}",
                    rig.name
                )
            })?
            .world_from_kinect;
        let renderer = Renderer::new(
            RenderParams {
                seed,
                ..RenderParams::default()
            },
            &pose,
            &Room::default(),
        )
        .map_err(|e| eyre!("{NODE}: body renderer: {e}"))?;
        let (jobs, job_rx) = channel();
        let (done_tx, done) = channel();
        std::thread::Builder::new()
            .name(format!("render {sensor_id}"))
            .spawn(move || render_worker(renderer, &lap, &job_rx, &done_tx))
            .map_err(|e| eyre!("{NODE}: starting the render thread: {e}"))?;
        Ok(Self {
            sim,
            jobs,
            done,
            in_flight: None,
            pending: None,
            skipped: 0,
            skipped_at_start: 0,
            render_failures: 0,
        })
    }

    /// Starts the stream at host time `now` ([`SimulatedSensor::begin_at`]) and has the
    /// worker render its first instant ahead. (Without it the first frame is rendered when
    /// it is captured, late by one render.)
    pub fn begin_at(&mut self, now: i64) {
        self.sim.begin_at(now);
        if self.in_flight.is_none() {
            self.submit(self.sim.next_due());
        }
    }

    /// Starts the lap at host time `epoch_nanos` ([`SimulatedSensor::start_lap_at`]); before
    /// [`Self::begin_at`], which has the first instant rendered.
    pub fn start_lap_at(&mut self, epoch_nanos: i64) {
        if self.in_flight.is_none() {
            self.sim.start_lap_at(epoch_nanos);
        }
    }

    fn submit(&mut self, t_nanos: i64) {
        let job = (t_nanos, self.sim.lap_secs(t_nanos));
        self.in_flight = self.jobs.send(job).is_ok().then_some(t_nanos);
    }

    /// The depth of instant `t_nanos`: the one rendered ahead, or rendered now when the
    /// worker was given another instant (skipped ones). Empty if the worker is gone.
    fn depth_at(&mut self, t_nanos: i64) -> Vec<u16> {
        loop {
            match self.in_flight {
                None => {
                    self.submit(t_nanos);
                    if self.in_flight.is_none() {
                        break;
                    }
                }
                Some(pending) => {
                    let Ok(r) = self.done.recv() else { break };
                    self.in_flight = None;
                    if pending == t_nanos && r.t_nanos == t_nanos {
                        if let Some(e) = r.failure {
                            if self.render_failures == 0 {
                                tracing::warn!("rendering the empty room: {e} (counted)");
                            }
                            self.render_failures += 1;
                        }
                        return r.depth_mm;
                    }
                }
            }
        }
        if self.render_failures == 0 {
            tracing::warn!("the render thread is gone: sending empty depth frames (counted)");
        }
        self.render_failures += 1;
        vec![0; PIXELS]
    }

    /// Host time of the next capture.
    #[must_use]
    pub fn next_due(&self) -> i64 {
        self.sim.next_due()
    }

    /// Captures the latest instant due by `now` (earlier ones still due are skipped, their
    /// truth kept) and takes its depth; the frame waits in [`Self::take_depth`]. The worker
    /// goes on with the next instant.
    pub fn capture(&mut self, now: i64, clock: &mut SensorClock) -> Captured {
        let mut captured = self.sim.capture(clock);
        while self.sim.next_due() <= now {
            let mut later = self.sim.capture(clock);
            let mut truth = std::mem::take(&mut captured.truth);
            truth.append(&mut later.truth);
            later.truth = truth;
            captured = later;
            self.skipped += 1;
            if captured.frame.seq == self.skipped {
                self.skipped_at_start += 1;
            }
        }
        let t = captured.true_stamp_nanos.unwrap_or(now);
        let depth_mm = self.depth_at(t);
        self.submit(self.sim.next_due());
        self.pending = Some(DepthFrameMessage {
            sensor_id: captured.frame.sensor_id.clone(),
            seq: captured.frame.seq,
            local_stamp_nanos: captured.frame.local_stamp_nanos,
            width: WIDTH as u32,
            height: HEIGHT as u32,
            depth_mm,
        });
        captured
    }

    /// The depth frame of the last capture (once).
    pub fn take_depth(&mut self) -> Option<DepthFrameMessage> {
        self.pending.take()
    }
}

#[cfg(test)]
mod tests {
    use trigait_node_testing::lookup;

    use crate::backend::{Source, sensor_clock};
    use crate::config::Config;

    use super::*;

    /// A body-depth source captures on the skeleton source's grid: each depth frame has the
    /// capture's seq and sensor-clock stamp, the body stands nearer than the room behind it
    /// where the walker is, k1 sends the ground truth; a host behind by two periods skips
    /// two instants (seq jumps by 3) and keeps their truth. A source begun late skips none.
    #[test]
    fn renders_the_walker_on_the_frame_grid() {
        let c =
            Config::from_lookup(lookup(&[("SENSOR_ID", "k1"), ("BACKEND", "body-depth")])).unwrap();
        let mut source = Source::new(&c, 0).unwrap();
        let mut clock = sensor_clock(&c, 0);
        let due = source.next_due().unwrap();
        let first = source.capture(due, &mut clock).unwrap();
        let depth = source.take_depth().unwrap();
        assert!(source.take_depth().is_none(), "a depth frame is taken once");
        assert_eq!(
            (depth.sensor_id.as_str(), depth.seq, depth.local_stamp_nanos),
            ("k1", first.frame.seq, first.frame.local_stamp_nanos)
        );
        assert_eq!(depth.depth_mm.len(), WIDTH * HEIGHT);
        assert!(!first.truth.is_empty(), "k1 sends the ground truth");

        let pose = c.rig.sensors[0].world_from_kinect;
        let mut room =
            trigait_body_render::Renderer::new(RenderParams::default(), &pose, &Room::default())
                .unwrap();
        let empty = room.render_bodies(&[], Vec::new());
        let body_pixels = depth
            .depth_mm
            .iter()
            .zip(empty.depth.as_mm())
            .filter(|(b, r)| **b > 0 && (**r == 0 || u32::from(**b) + 300 < u32::from(**r)))
            .count();
        assert!(body_pixels > 1000, "{body_pixels} body pixels");

        let period = c.period_nanos();
        let next = source.next_due().unwrap();
        let later = source.capture(next + 2 * period, &mut clock).unwrap();
        let depth = source.take_depth().unwrap();
        assert_eq!(depth.seq, first.frame.seq + 3);
        assert_eq!(later.true_stamp_nanos, Some(next + 2 * period));
        let Source::BodyDepth(s) = &source else {
            panic!("not a body-depth source");
        };
        assert_eq!(s.skipped, 2);
        assert!(
            later.truth.first().map(|g| g.true_stamp_nanos) <= Some(next),
            "the skipped instants' truth is sent"
        );

        // Made, then begun half a second later (a motion to load, the daemon to reach): the
        // first frame is due then and nothing is skipped; without the begin, the instants in
        // between are skipped, counted as before the first frame.
        let late = 500_000_000;
        let mut begun = Source::new(&c, 0).unwrap();
        begun.begin_at(late);
        let due = begun.next_due().unwrap();
        assert!(due >= late && due < late + period, "{due}");
        let first = begun.capture(due, &mut sensor_clock(&c, 0)).unwrap();
        assert_eq!(first.frame.seq, 0);
        let mut unbegun = Source::new(&c, 0).unwrap();
        let late_first = unbegun.capture(due, &mut sensor_clock(&c, 0)).unwrap();
        let (Source::BodyDepth(b), Source::BodyDepth(u)) = (&begun, &unbegun) else {
            panic!("not body-depth sources");
        };
        assert_eq!((b.skipped, b.skipped_at_start), (0, 0));
        assert_eq!(
            (u.skipped, u.skipped_at_start),
            (late_first.frame.seq, late_first.frame.seq)
        );
        assert!(u.skipped >= 14, "{} skipped", u.skipped);
        assert_eq!(
            begun.take_depth().unwrap().depth_mm,
            unbegun.take_depth().unwrap().depth_mm
        );

        // Its depth is sent on `depth`: the lab-target depth stream cannot be set with it.
        let err = Config::from_lookup(lookup(&[
            ("SENSOR_ID", "k1"),
            ("BACKEND", "body-depth"),
            ("DEPTH_RATE_HZ", "30"),
        ]))
        .unwrap_err();
        assert!(err.to_string().contains("DEPTH_RATE_HZ"), "{err}");
    }
}
