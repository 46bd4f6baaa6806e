//! The default blueprint: how the viewer lays out a recording (the 2D world beside the log
//! above a grid of metric plots, the space-time diagram when messages flow, a check's verdict),
//! written as blueprint messages with fixed view and container ids so that it is the same in
//! every recording. The SDK's `Blueprint` builder makes the same layout with random ids and
//! wall-clock times.

use rerun::external::re_log_types::{BlueprintActivationCommand, LogMsg, StoreId, StoreKind};
use rerun::log::Chunk;
use rerun::TimeColumn;

use super::layout::{Layout, LANE_GAP, METRICS};
use super::{rerun_err, APP, COLLISION_SECONDS};
use crate::recording::rrd_file::Ids;
use crate::recording::{RecordingError, TRAIL_SECONDS};

/// The blueprint store of the recording `recording_id`.
fn blueprint_store(recording_id: &str) -> StoreId {
    StoreId::new(
        StoreKind::Blueprint,
        APP,
        format!("{recording_id}-blueprint"),
    )
}

/// The fixed UUID of blueprint item `n` (a view or a container).
fn blueprint_uuid(n: u8) -> [u8; 16] {
    let mut bytes = [0u8; 16];
    bytes[6] = 0x40; // version 4
    bytes[8] = 0x80; // RFC 4122 variant
    bytes[15] = n;
    bytes
}

/// The entity path of blueprint item `n` of `kind` (`view`, `container`).
fn blueprint_path(kind: &str, n: u8) -> String {
    let u = blueprint_uuid(n);
    let hex: String = u.iter().map(|b| format!("{b:02x}")).collect();
    format!(
        "{kind}/{}-{}-{}-{}-{}",
        &hex[0..8],
        &hex[8..12],
        &hex[12..16],
        &hex[16..20],
        &hex[20..32]
    )
}

/// One static-free blueprint chunk per `(entity, components)` at blueprint time `time`.
fn blueprint_rows(
    store: &StoreId,
    ids: &mut Ids,
    time: i64,
    rows: Vec<(String, Box<dyn rerun::AsComponents>)>,
) -> Result<Vec<LogMsg>, RecordingError> {
    let mut msgs = Vec::new();
    for (entity, what) in rows {
        let times = [TimeColumn::new_sequence("blueprint", [time])];
        let columns = what
            .as_serialized_batches()
            .into_iter()
            .map(|b| {
                let n = b.array.len();
                b.partitioned([n]).map(|c| (c.descriptor, c.list_array))
            })
            .collect::<Result<_, _>>()
            .map_err(rerun_err)?;
        let chunk = Chunk::from_native_row_ids(
            ids.chunk(),
            entity.as_str().into(),
            Some(true),
            &ids.rows(1),
            times
                .into_iter()
                .map(|c| (*c.timeline().name(), c))
                .collect(),
            columns,
        )
        .map_err(rerun_err)?;
        let arrow = chunk.to_arrow_msg().map_err(rerun_err)?;
        msgs.push(LogMsg::ArrowMsg(store.clone(), arrow));
    }
    Ok(msgs)
}

/// The metric views' numbers in the blueprint: [`METRICS`]' `i`-th is view `3 + i`.
fn metric_view(i: usize) -> u8 {
    3 + i as u8
}

/// The default layout of `layout` for the recording `recording_id`, as blueprint messages
/// (header and chunks) and its activation, with the next row and chunk ids of `ids`.
pub fn default_blueprint(
    recording_id: &str,
    ids: &mut Ids,
    layout: &Layout,
) -> Result<(Vec<LogMsg>, BlueprintActivationCommand), RecordingError> {
    use rerun::external::re_sdk_types::blueprint::archetypes::{
        ContainerBlueprint, PanelBlueprint, PlotLegend, ViewBlueprint, ViewContents,
        ViewportBlueprint, VisibleTimeRanges, VisualBounds2D,
    };
    use rerun::external::re_sdk_types::blueprint::components::{
        ColumnShare, ContainerKind, IncludedContent, PanelState, QueryExpression, RootContainer,
        RowShare, ViewClass,
    };
    use rerun::external::re_sdk_types::datatypes::{
        Range1D, Range2D, TimeInt, TimeRange, TimeRangeBoundary, VisibleTimeRange,
    };

    let store = blueprint_store(recording_id);
    let uuid = blueprint_uuid;
    let path = blueprint_path;
    // Views 1-2 and 3.. (one per metric, so that each plot has its own scale: events per
    // second run to thousands while collisions count in tens), containers from 10.
    let (world, log, root, right, plots) = (1, 2, 10, 11, 12);
    let (spacetime, verdict) = (7, 8);
    let full = layout.spacetime.is_some_and(|s| s.full);
    let metric_views: Vec<(u8, &str)> = METRICS
        .iter()
        .enumerate()
        .filter(|(_, m)| layout.metrics.contains(*m))
        .map(|(i, m)| (metric_view(i), *m))
        .collect();
    let mut rows: Vec<(String, Box<dyn rerun::AsComponents>)> = Vec::new();
    let views = [
        (world, "2D", "world", "/world".to_owned()),
        (log, "TextLog", "log", "/log".to_owned()),
    ]
    .into_iter()
    .chain(
        layout
            .spacetime
            .map(|_| (spacetime, "2D", "space-time", "/spacetime".to_owned())),
    )
    .chain(full.then(|| (verdict, "TextDocument", "verdict", "/verdict".to_owned())))
    .chain(metric_views.iter().map(|(n, entity)| {
        let name = entity.rsplit('/').next().unwrap_or(entity);
        (*n, "TimeSeries", name, format!("/{entity}"))
    }));
    for (n, class, name, origin) in views {
        rows.push((
            format!("{}/ViewContents", path("view", n)),
            Box::new(ViewContents::new([QueryExpression("$origin/**".into())])),
        ));
        rows.push((
            path("view", n),
            Box::new(
                ViewBlueprint::new(ViewClass(class.into()))
                    .with_display_name(name)
                    .with_space_origin(origin.as_str()),
            ),
        ));
    }
    // Legs of the robots' paths stay drawn for the last TRAIL_SECONDS of simulated time (a
    // per-entity visible time range, where the Python SDK's `overrides=` puts it).
    let trail = VisibleTimeRange {
        timeline: "sim_time".into(),
        range: TimeRange {
            start: TimeRangeBoundary::CursorRelative(TimeInt(-(TRAIL_SECONDS * 1e9) as i64)),
            end: TimeRangeBoundary::CursorRelative(TimeInt(0)),
        },
    };
    rows.push((
        format!(
            "{}/ViewContents/overrides/world/paths/visualizers",
            path("view", world)
        ),
        Box::new(VisibleTimeRanges::new([
            rerun::external::re_sdk_types::blueprint::components::VisibleTimeRange(trail),
        ])),
    ));
    // Collision markers stay for COLLISION_SECONDS after their instant.
    let collisions = VisibleTimeRange {
        timeline: "sim_time".into(),
        range: TimeRange {
            start: TimeRangeBoundary::CursorRelative(TimeInt(-(COLLISION_SECONDS * 1e9) as i64)),
            end: TimeRangeBoundary::CursorRelative(TimeInt(0)),
        },
    };
    rows.push((
        format!(
            "{}/ViewContents/overrides/world/collisions/visualizers",
            path("view", world)
        ),
        Box::new(VisibleTimeRanges::new([
            rerun::external::re_sdk_types::blueprint::components::VisibleTimeRange(collisions),
        ])),
    ));
    // The space-time diagram keeps every arrow and mark from its instant on, and frames its
    // lanes.
    if let Some(st) = layout.spacetime {
        let always = VisibleTimeRange {
            timeline: "sim_time".into(),
            range: TimeRange {
                start: TimeRangeBoundary::Infinite,
                end: TimeRangeBoundary::CursorRelative(TimeInt(0)),
            },
        };
        for entity in ["messages", "marks"] {
            rows.push((
                format!(
                    "{}/ViewContents/overrides/spacetime/{entity}/visualizers",
                    path("view", spacetime)
                ),
                Box::new(VisibleTimeRanges::new([
                    rerun::external::re_sdk_types::blueprint::components::VisibleTimeRange(
                        always.clone(),
                    ),
                ])),
            ));
        }
        let right_edge = LANE_GAP * st.lanes.max(2) as f64;
        rows.push((
            format!("{}/VisualBounds2D", path("view", spacetime)),
            Box::new(VisualBounds2D::new(Range2D {
                x_range: Range1D([-LANE_GAP, right_edge]),
                y_range: Range1D([-LANE_GAP, st.height() + 2.0 * LANE_GAP]),
            })),
        ));
    }
    // The 2D view frames the world, not whatever was drawn so far.
    if let Some([x0, x1, y0, y1]) = layout.view_bounds() {
        rows.push((
            format!("{}/VisualBounds2D", path("view", world)),
            Box::new(VisualBounds2D::new(Range2D {
                x_range: Range1D([x0, x1]),
                y_range: Range1D([y0, y1]),
            })),
        ));
    }
    // The log shows time, level and text: its entity path is always `/log`.
    {
        use rerun::external::re_sdk_types::blueprint::archetypes::TextLogColumns;
        use rerun::external::re_sdk_types::blueprint::datatypes::{
            TextLogColumn, TextLogColumnKind, TimelineColumn,
        };
        rows.push((
            format!("{}/TextLogColumns", path("view", log)),
            Box::new(
                TextLogColumns::new()
                    .with_timeline_columns([
                        TimelineColumn {
                            visible: true.into(),
                            timeline: "sim_time".into(),
                        },
                        TimelineColumn {
                            visible: false.into(),
                            timeline: "event".into(),
                        },
                    ])
                    .with_text_log_columns([
                        TextLogColumn {
                            kind: TextLogColumnKind::EntityPath,
                            visible: false.into(),
                        },
                        TextLogColumn {
                            kind: TextLogColumnKind::LogLevel,
                            visible: true.into(),
                        },
                        TextLogColumn {
                            kind: TextLogColumnKind::Body,
                            visible: true.into(),
                        },
                    ]),
            ),
        ));
    }
    // One series per plot: no legend over the data.
    for (n, _) in &metric_views {
        rows.push((
            format!("{}/PlotLegend", path("view", *n)),
            Box::new(PlotLegend::new().with_visible(false)),
        ));
    }
    // The world gets the window: the blueprint and selection panels start collapsed, and the
    // time panel to its bar (play, speed and the time cursor stay, for scrubbing).
    for panel in ["blueprint_panel", "selection_panel"] {
        rows.push((
            panel.into(),
            Box::new(PanelBlueprint::new().with_state(PanelState::Collapsed)),
        ));
    }
    rows.push((
        "time_panel".into(),
        Box::new(
            rerun::external::re_sdk_types::blueprint::archetypes::TimePanelBlueprint::new()
                .with_state(PanelState::Collapsed)
                .with_timeline("sim_time")
                .with_play_state(
                    rerun::external::re_sdk_types::blueprint::components::PlayState::Playing,
                ),
        ),
    ));
    let contents = |children: &[(&str, u8)]| -> Vec<IncludedContent> {
        children
            .iter()
            .map(|(kind, n)| IncludedContent(format!("/{}", path(kind, *n)).into()))
            .collect()
    };
    let plot_views: Vec<(&str, u8)> = metric_views.iter().map(|(n, _)| ("view", *n)).collect();
    rows.push((
        path("container", plots),
        Box::new(ContainerBlueprint::new(ContainerKind::Grid).with_contents(contents(&plot_views))),
    ));
    // A run: the world (two thirds), then the space-time diagram when messages flow, then
    // the log above the plots. A check: the space-time diagram is the main view; the verdict,
    // the lanes' world and the log above the plots beside it.
    let share = |v: &[f32]| v.iter().map(|s| RowShare((*s).into())).collect::<Vec<_>>();
    let col_share = |v: &[f32]| {
        v.iter()
            .map(|s| ColumnShare((*s).into()))
            .collect::<Vec<_>>()
    };
    let (right_children, right_shares): (Vec<(&str, u8)>, Vec<f32>) = if full {
        (
            vec![
                ("view", verdict),
                ("view", log),
                ("view", world),
                ("container", plots),
            ],
            vec![0.8, 1.5, 0.8, 0.8],
        )
    } else {
        (vec![("view", log), ("container", plots)], vec![1.0, 1.0])
    };
    rows.push((
        path("container", right),
        Box::new(
            ContainerBlueprint::new(ContainerKind::Vertical)
                .with_contents(contents(&right_children))
                .with_row_shares(share(&right_shares)),
        ),
    ));
    let (root_children, root_shares): (Vec<(&str, u8)>, Vec<f32>) = match layout.spacetime {
        Some(_) if full => (
            vec![("view", spacetime), ("container", right)],
            vec![2.0, 1.0],
        ),
        Some(_) => (
            vec![("view", world), ("view", spacetime), ("container", right)],
            vec![2.0, 1.0, 1.0],
        ),
        None => (vec![("view", world), ("container", right)], vec![2.0, 1.0]),
    };
    rows.push((
        path("container", root),
        Box::new(
            ContainerBlueprint::new(ContainerKind::Horizontal)
                .with_contents(contents(&root_children))
                .with_col_shares(col_share(&root_shares)),
        ),
    ));
    rows.push((
        "viewport".into(),
        Box::new(ViewportBlueprint::new().with_root_container(RootContainer(uuid(root).into()))),
    ));

    let mut msgs = vec![ids.store_info(store.clone())];
    msgs.extend(blueprint_rows(&store, ids, 0, rows)?);
    let activation = BlueprintActivationCommand {
        blueprint_id: store,
        make_active: true,
        make_default: true,
    };
    Ok((msgs, activation))
}

/// The blueprint's last word, once the run is over: each plotted metric that kept one value
/// `v` (`extent`: each metric's least and greatest value, in [`METRICS`]' order) gets the y
/// range `[v - 1, v + 1]`, clamped at 0 for counts, so its plot reads as a flat line on a
/// scale, followed by the blueprint's activation again.
pub fn flat_axes(
    store: &StoreId,
    ids: &mut Ids,
    extent: &[Option<(f64, f64)>; 4],
) -> Result<Vec<LogMsg>, RecordingError> {
    use rerun::external::re_sdk_types::blueprint::archetypes::ScalarAxis;
    use rerun::external::re_sdk_types::datatypes::Range1D;
    let rows: Vec<(String, Box<dyn rerun::AsComponents>)> = extent
        .iter()
        .enumerate()
        .filter_map(|(i, extent)| {
            let (lo, hi) = (*extent)?;
            (lo == hi).then(|| {
                let range = Range1D([(lo - 1.0).max(0.0_f64.min(lo)), hi + 1.0]);
                (
                    format!("{}/ScalarAxis", blueprint_path("view", metric_view(i))),
                    Box::new(ScalarAxis::new().with_range(range)) as Box<dyn rerun::AsComponents>,
                )
            })
        })
        .collect();
    if rows.is_empty() {
        return Ok(Vec::new());
    }
    let mut msgs = blueprint_rows(store, ids, 1, rows)?;
    msgs.push(LogMsg::BlueprintActivationCommand(
        BlueprintActivationCommand {
            blueprint_id: store.clone(),
            make_active: true,
            make_default: true,
        },
    ));
    Ok(msgs)
}
