//! The viewer layout the recording opens with (rerun's *blueprint*), sent once before any data as
//! the application's default, through every sink: the `.rrd` file and a live viewer alike.
//!
//! rerun 0.36's Rust blueprint builder cannot set a view's properties (the 3-D eye, plot legends,
//! axis ranges, 2-D bounds), so the blueprint is written here from its archetypes — the same
//! entities (`viewport`, `container/<id>`, `view/<id>`, `view/<id>/ViewContents`,
//! `view/<id>/<Property>`) the builder writes, plus the properties.
//!
//! The layout (entity paths in [`crate::viz`]):
//! - left: the 3-D walkway above a one-line colour key, the stance/swing timeline per foot and
//!   the heel strikes and toe offs;
//! - right: the gait parameter table, knee and hip flexion over the gait cycle, and tabs with the
//!   joint trajectories per axis (thesis Fig. 6.12), the clock sync offset and error (two
//!   panels: the errors are a thousandth of the offsets) and the latency.

use rerun::RecordingStream;
use rerun::external::re_log_types::{BlueprintActivationCommand, LogMsg};
use rerun::external::re_sdk_types::blueprint::archetypes::{
    Background, ContainerBlueprint, EyeControls3D, LineGrid3D, PanelBlueprint, PlotLegend,
    ScalarAxis, TimePanelBlueprint, ViewBlueprint, ViewContents, ViewportBlueprint, VisualBounds2D,
};
use rerun::external::re_sdk_types::blueprint::components::{
    ActiveTab, AutoLayout, AutoViews, BackgroundKind, ColumnShare, ContainerKind, Corner2D,
    Eye3DKind, IncludedContent, PanelState, PlayState, QueryExpression, RootContainer, RowShare,
    ViewClass,
};
use rerun::external::re_sdk_types::datatypes::{Bool, Float32, Range2D, Uuid};
use rerun::{AsComponents, components};
use trigait_rig::Rig;

use crate::viz;

/// One view of the layout: what [`send`] writes for it.
#[derive(Debug, Clone, PartialEq)]
pub struct View {
    /// rerun's view class (`3D`, `2D`, `TimeSeries`, `StateTimeline`, `TextDocument`).
    pub class: &'static str,
    /// The title shown on the view.
    pub name: String,
    /// The entity the view's contents are relative to.
    pub origin: String,
    /// Content queries (`$origin/**` and the like).
    pub contents: Vec<String>,
}

/// Writes blueprint entities with ids numbered from one seed.
struct Writer {
    rec: RecordingStream,
    seed: [u8; 8],
    next: u64,
    views: Vec<View>,
}

/// A child of a container: its blueprint entity path.
type Child = String;

fn uuid_string(b: &[u8; 16]) -> String {
    let h: String = b.iter().map(|x| format!("{x:02x}")).collect();
    format!(
        "{}-{}-{}-{}-{}",
        &h[0..8],
        &h[8..12],
        &h[12..16],
        &h[16..20],
        &h[20..32]
    )
}

impl Writer {
    fn id(&mut self) -> [u8; 16] {
        self.next += 1;
        let mut b = [0_u8; 16];
        b[..8].copy_from_slice(&self.seed);
        b[8..].copy_from_slice(&self.next.to_be_bytes());
        // A well-formed version-4 UUID.
        b[6] = 0x40 | (b[6] & 0x0f);
        b[8] = 0x80 | (b[8] & 0x3f);
        b
    }

    fn view(
        &mut self,
        class: &'static str,
        name: &str,
        origin: &str,
        contents: &[&str],
        properties: &[(&str, &dyn AsComponents)],
    ) -> eyre::Result<Child> {
        let path = format!("view/{}", uuid_string(&self.id()));
        self.rec.log(
            format!("{path}/ViewContents"),
            &ViewContents::new(contents.iter().map(|q| QueryExpression((*q).into()))),
        )?;
        self.rec.log(
            path.as_str(),
            &ViewBlueprint::new(ViewClass(class.into()))
                .with_display_name(name)
                .with_space_origin(origin),
        )?;
        for (property, archetype) in properties {
            self.rec.log(format!("{path}/{property}"), *archetype)?;
        }
        self.views.push(View {
            class,
            name: name.to_owned(),
            origin: origin.to_owned(),
            contents: contents.iter().map(|q| (*q).to_owned()).collect(),
        });
        Ok(path)
    }

    fn container(
        &mut self,
        kind: ContainerKind,
        name: &str,
        children: Vec<Child>,
        shares: &[f32],
    ) -> eyre::Result<(Child, [u8; 16])> {
        let id = self.id();
        let path = format!("container/{}", uuid_string(&id));
        let mut arch = ContainerBlueprint::new(kind)
            .with_display_name(name)
            .with_contents(children.iter().map(|c| IncludedContent(c.as_str().into())));
        if !shares.is_empty() {
            arch = match kind {
                ContainerKind::Horizontal => {
                    arch.with_col_shares(shares.iter().map(|s| ColumnShare(Float32(*s))))
                }
                _ => arch.with_row_shares(shares.iter().map(|s| RowShare(Float32(*s)))),
            };
        }
        if kind == ContainerKind::Tabs
            && let Some(first) = children.first()
        {
            arch = arch.with_active_tab(ActiveTab(first.as_str().into()));
        }
        self.rec.log(path.as_str(), &arch)?;
        Ok((path, id))
    }
}

/// Where the 3-D eye starts: beside the walkway on its −Y side, raised, looking at the middle of
/// everything drawn (sensors and walkway), far enough for all of it to fit.
fn eye(rig: &Rig) -> ([f32; 3], [f32; 3]) {
    let (half_l, half_w) = (viz::WALKWAY_LENGTH_M / 2.0, viz::WALKWAY_WIDTH_M / 2.0);
    let mut lo = nalgebra::Vector3::new(-half_l, -half_w, 0.0);
    let mut hi = nalgebra::Vector3::new(half_l, half_w, 1.0);
    for s in &rig.sensors {
        let p = s.position().coords;
        lo = lo.inf(&p);
        hi = hi.sup(&p);
    }
    let centre = (lo + hi) / 2.0;
    let radius = ((hi - lo) / 2.0).norm().max(1.0);
    let dir = nalgebra::Vector3::new(-0.2, -1.0, 0.6).normalize();
    let eye = centre + dir * radius * 1.5;
    let f = |v: nalgebra::Vector3<f64>| [v.x as f32, v.y as f32, v.z as f32];
    (f(eye), f(centre))
}

/// The 2-D bounds that frame a flexion chart of `degrees` (plus the tick labels around it).
fn chart_bounds(degrees: (f64, f64)) -> VisualBounds2D {
    let (lo, hi) = degrees;
    VisualBounds2D::new(Range2D {
        x_range: [-12.0, 104.0].into(),
        y_range: [
            f64::from(viz::chart_y(hi)) - 3.0,
            f64::from(viz::chart_y(lo)) + 10.0,
        ]
        .into(),
    })
}

/// Sends the layout for `rig` to every sink of `rec`, as the default and active blueprint.
/// Returns the views written, in order.
pub fn send(rec: &RecordingStream, rig: &Rig) -> eyre::Result<Vec<View>> {
    let (msgs, views) = build(rec, rig)?;
    let blueprint_id = msgs
        .iter()
        .find_map(|m| match m {
            LogMsg::SetStoreInfo(info) => Some(info.info.store_id.clone()),
            _ => None,
        })
        .ok_or_else(|| eyre::eyre!("the blueprint stream wrote no store info"))?;
    rec.send_blueprint(
        msgs,
        BlueprintActivationCommand {
            blueprint_id,
            make_active: true,
            make_default: true,
        },
    );
    Ok(views)
}

fn build(rec: &RecordingStream, rig: &Rig) -> eyre::Result<(Vec<LogMsg>, Vec<View>)> {
    let app = rec
        .store_info()
        .map_or_else(|| "trigait".into(), |i| i.application_id().clone());
    let seed: [u8; 8] = {
        let nanos = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.as_nanos() as u64);
        (nanos ^ u64::from(std::process::id()).rotate_left(40)).to_be_bytes()
    };
    let (bp, storage) = rerun::RecordingStreamBuilder::new(app)
        .recording_id(format!(
            "trigait-blueprint-{:016x}",
            u64::from_be_bytes(seed)
        ))
        .blueprint()
        .memory()?;
    bp.set_time_sequence("blueprint", 0);
    let mut w = Writer {
        rec: bp,
        seed,
        next: 0,
        views: Vec::new(),
    };
    let (position, target) = eye(rig);
    let legend_top_left = PlotLegend::new()
        .with_corner(Corner2D::LeftTop)
        .with_visible(true);

    let scene = w.view(
        "3D",
        "walkway (world frame, Z up, m)",
        "world",
        &["$origin/**"],
        &[
            (
                "EyeControls3D",
                &EyeControls3D::new()
                    .with_kind(Eye3DKind::Orbital)
                    .with_position(position)
                    .with_look_target(target)
                    .with_eye_up([0.0_f32, 0.0, 1.0]),
            ),
            (
                "Background",
                &Background::new(BackgroundKind::SolidColor).with_color([18_u8, 18, 22]),
            ),
            (
                "LineGrid3D",
                &LineGrid3D::new().with_visible(true).with_spacing(0.5_f32),
            ),
        ],
    )?;
    let key = w.view("TextDocument", "colour key", viz::KEY, &["$origin"], &[])?;
    let phases = w.view(
        "StateTimeline",
        "stance and swing per foot",
        viz::PHASE,
        &["$origin/**"],
        &[],
    )?;
    let events = w.view(
        "TimeSeries",
        "heel strikes ▼ and toe offs ▲ (ankle height, m)",
        viz::EVENTS,
        &["$origin/**"],
        &[("PlotLegend", &legend_top_left)],
    )?;
    let (left, _) = w.container(
        ContainerKind::Vertical,
        "walkway and gait events",
        vec![scene, key, phases, events],
        &[6.0, 0.9, 1.5, 2.0],
    )?;

    let table = w.view(
        "TextDocument",
        "gait parameters (updated as strides complete)",
        viz::PARAMETERS,
        &["$origin"],
        &[],
    )?;
    let knee = w.view(
        "2D",
        "knee flexion (°) per gait cycle (%)",
        viz::KNEE,
        &["$origin/**"],
        &[("VisualBounds2D", &chart_bounds(viz::KNEE_RANGE_DEG))],
    )?;
    let hip = w.view(
        "2D",
        "hip flexion (°) per gait cycle (%)",
        viz::HIP,
        &["$origin/**"],
        &[("VisualBounds2D", &chart_bounds(viz::HIP_RANGE_DEG))],
    )?;
    let (flexion, _) = w.container(
        ContainerKind::Horizontal,
        "flexion per gait cycle",
        vec![knee, hip],
        &[],
    )?;

    // One legend (on x) for the three panels, which share the joint colours: three would not
    // fit their six entries each.
    let no_legend = PlotLegend::new().with_visible(false);
    let mut axes = Vec::new();
    for (i, (axis, what)) in viz::AXES.into_iter().enumerate() {
        let (name, legend) = if i == 0 {
            (format!("joint {axis} (m): {what}"), &legend_top_left)
        } else {
            (
                format!("joint {axis} (m): {what} (colours as in x)"),
                &no_legend,
            )
        };
        axes.push(w.view(
            "TimeSeries",
            &name,
            &format!("{}/{axis}", viz::TRAJECTORIES),
            &["$origin/**"],
            &[("PlotLegend", legend)],
        )?);
    }
    let (trajectories, _) = w.container(
        ContainerKind::Vertical,
        "joint trajectories per axis",
        axes,
        &[2.1, 1.0, 1.0],
    )?;
    let offset = w.view(
        "TimeSeries",
        "clock offset per sensor (ms)",
        viz::SYNC_OFFSET,
        &["$origin/**"],
        &[("PlotLegend", &legend_top_left)],
    )?;
    let error = w.view(
        "TimeSeries",
        "clock sync error bound per sensor (ms)",
        viz::SYNC_ERROR,
        &["$origin/**"],
        &[
            ("PlotLegend", &legend_top_left),
            (
                "ScalarAxis",
                &ScalarAxis::new().with_range(components::Range1D::new(0.0, 1.0)),
            ),
        ],
    )?;
    let (sync, _) = w.container(
        ContainerKind::Vertical,
        "clock sync",
        vec![offset, error],
        &[],
    )?;
    let latency = w.view(
        "TimeSeries",
        "latency: frame sent → pose recorded (ms)",
        viz::LATENCY_ROOT,
        &["$origin/**"],
        &[("PlotLegend", &legend_top_left)],
    )?;
    let (tabs, _) = w.container(
        ContainerKind::Tabs,
        "trajectories, sync, latency",
        vec![trajectories, sync, latency],
        &[],
    )?;
    let (right, _) = w.container(
        ContainerKind::Vertical,
        "gait parameters and curves",
        vec![table, flexion, tabs],
        &[3.1, 2.3, 4.8],
    )?;
    let (_, root) = w.container(
        ContainerKind::Horizontal,
        "trigait",
        vec![left, right],
        &[1.15, 1.0],
    )?;

    w.rec.log(
        "viewport",
        &ViewportBlueprint::new()
            .with_root_container(RootContainer(Uuid { bytes: root }))
            .with_auto_layout(AutoLayout(Bool(false)))
            .with_auto_views(AutoViews(Bool(false))),
    )?;
    w.rec.log(
        "blueprint_panel",
        &PanelBlueprint::new().with_state(PanelState::Collapsed),
    )?;
    w.rec.log(
        "selection_panel",
        &PanelBlueprint::new().with_state(PanelState::Collapsed),
    )?;
    w.rec.log(
        "time_panel",
        &TimePanelBlueprint::new()
            .with_state(PanelState::Collapsed)
            .with_timeline(viz::TIME)
            // At the newest data: the end of a file, the present of a live stream.
            .with_play_state(PlayState::Following),
    )?;
    w.rec.flush_blocking().ok();
    Ok((storage.take(), w.views))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The layout holds the gait lab's views once each, ids are well-formed UUIDs, and the
    /// messages start with the blueprint store's info (what the activation names).
    #[test]
    fn layout_has_every_view_once() {
        let rec = rerun::RecordingStreamBuilder::new("trigait-test")
            .buffered()
            .unwrap();
        let rig = Rig::from_spec("ring-5").unwrap();
        let (msgs, views) = build(&rec, &rig).unwrap();
        assert!(matches!(msgs.first(), Some(LogMsg::SetStoreInfo(_))));
        let origins: Vec<(&str, &str)> =
            views.iter().map(|v| (v.class, v.origin.as_str())).collect();
        for want in [
            ("3D", "world"),
            ("TextDocument", viz::KEY),
            ("StateTimeline", viz::PHASE),
            ("TimeSeries", viz::EVENTS),
            ("TextDocument", viz::PARAMETERS),
            ("2D", viz::KNEE),
            ("2D", viz::HIP),
            ("TimeSeries", "trajectories/x"),
            ("TimeSeries", "trajectories/y"),
            ("TimeSeries", "trajectories/z"),
            ("TimeSeries", viz::SYNC_OFFSET),
            ("TimeSeries", viz::SYNC_ERROR),
            ("TimeSeries", viz::LATENCY_ROOT),
        ] {
            assert_eq!(
                origins.iter().filter(|o| **o == want).count(),
                1,
                "{want:?} in {origins:?}"
            );
        }
        assert_eq!(views.len(), 13);
        let id = uuid_string(&[0xab; 16]);
        assert_eq!(id.len(), 36);
        assert_eq!(id.matches('-').count(), 4);
        // Every sensor of the rig is inside the eye's view: the eye is farther from the target
        // than any sensor.
        let (eye, target) = eye(&rig);
        let d = |p: [f64; 3]| {
            let v: Vec<f64> = p
                .iter()
                .zip(target)
                .map(|(a, b)| a - f64::from(b))
                .collect();
            v.iter().map(|x| x * x).sum::<f64>().sqrt()
        };
        let eye_d = d(eye.map(f64::from));
        for s in &rig.sensors {
            let p = s.position();
            assert!(d([p.x, p.y, p.z]) < eye_d, "{} is behind the eye", s.id);
        }
    }
}
