//! The default layout of a recording, decided from the run's setting before it starts: which
//! metrics are plotted, whether robots are named, how the 2D view frames the world, and the
//! geometry of the space-time diagram (one lane per process, time running down).
//! [`super::blueprint`] turns it into the viewer's blueprint.

use nekosim_actors::world::geometry::Point;
use nekosim_actors::world::RobotId;

/// Runs with more robots than this draw their markers without labels unless the scenario asks
/// for them (`animation: (labels: true)`): by 40 s of the seed's 100-robot example the labels
/// cover the middle of the world.
pub const LABELLED_ROBOTS: usize = 20;

/// The margin around the world in the 2D view, as a fraction of its larger side.
pub const WORLD_MARGIN: f64 = 0.03;

/// The metric entities, in the order of [`Metrics`](crate::recording::Metrics)' fields.
pub const METRICS: [&str; 4] = [
    "metrics/collisions",
    "metrics/messages_in_flight",
    "metrics/deliveries",
    "metrics/events_per_second",
];

/// What the default layout shows, decided from the run's setting before it starts.
#[derive(Clone, Debug, PartialEq)]
pub struct Layout {
    /// The world's bounds, which the 2D view frames with a small margin ([`WORLD_MARGIN`];
    /// `None`: an infinite world, framed by the viewer).
    pub world: Option<(Point, Point)>,
    /// The metric entities of [`METRICS`] that can change in this run: one plot each, and
    /// only these are logged.
    pub metrics: Vec<&'static str>,
    /// Whether robot markers carry labels.
    pub labels: bool,
    /// The space-time diagram, for runs whose robots can exchange messages and for check
    /// recordings.
    pub spacetime: Option<SpaceTime>,
    /// Draw world message arrows between the markers' rims rather than their centres: each
    /// starts and ends this far from the centres, and is shifted by half of it to the right
    /// of its direction so the two directions between a pair of processes stay apart (check
    /// recordings, where the markers are large beside the distances). `None`: centre to centre.
    pub inset: Option<f64>,
}

/// The space-time diagram's geometry: one vertical lane per process, `LANE_GAP` apart, time
/// running down from 0 to `span` over [`SpaceTime::height`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpaceTime {
    pub lanes: usize,
    /// The simulated time (or checker steps) the diagram spans.
    pub span: f64,
    /// Label messages with their whole rendering (`FIFO#0(LAMPORT(ts 1, 1:0, M 1))`) rather
    /// than their type, and show each lane's delivered sequence (check recordings).
    pub full: bool,
}

/// Distance between two lanes of the space-time diagram.
pub const LANE_GAP: f64 = 10.0;

impl SpaceTime {
    /// The diagram's height: one and a half times its width (at least two lanes wide).
    pub fn height(&self) -> f64 {
        LANE_GAP * self.lanes.max(2) as f64 * 1.5
    }

    /// Where `(robot, t)` is drawn.
    pub fn at(&self, robot: RobotId, t: f64) -> [f32; 2] {
        let scale = self.height() / self.span.max(1e-9);
        [(LANE_GAP * f64::from(robot)) as f32, (t * scale) as f32]
    }
}

impl Layout {
    /// The layout of a simulated run of `robots` robots in a world of `world`: collisions
    /// and the event rate always, messages in flight when the run has a network or a stack
    /// (`messages`), deliveries when it has a stack (`deliveries`); labels up to
    /// [`LABELLED_ROBOTS`] robots unless `labels` says.
    pub fn run(
        world: Option<(Point, Point)>,
        robots: usize,
        (messages, deliveries): (bool, bool),
        labels: Option<bool>,
        until: f64,
    ) -> Self {
        let metrics = METRICS
            .iter()
            .copied()
            .filter(|m| match *m {
                "metrics/messages_in_flight" => messages,
                "metrics/deliveries" => deliveries,
                _ => true,
            })
            .collect();
        Self {
            world,
            metrics,
            labels: labels.unwrap_or(robots <= LABELLED_ROBOTS),
            spacetime: messages.then_some(SpaceTime {
                lanes: robots,
                span: until,
                full: false,
            }),
            inset: None,
        }
    }

    /// The layout of a model checker's path of `processes` lanes in `world`: messages only
    /// (no collisions, and an event rate means nothing there), labelled, arrows between the
    /// rims of markers of radius `radius`.
    pub fn check(world: (Point, Point), processes: usize, steps: usize, radius: f64) -> Self {
        Self {
            world: Some(world),
            metrics: vec!["metrics/messages_in_flight", "metrics/deliveries"],
            labels: true,
            spacetime: Some(SpaceTime {
                lanes: processes,
                span: steps.max(1) as f64,
                full: true,
            }),
            inset: Some(radius),
        }
    }

    /// The 2D view's bounds: the world with its margin, `[x_min, x_max, y_min, y_max]`.
    pub fn view_bounds(&self) -> Option<[f64; 4]> {
        let (min, max) = self.world?;
        let m = WORLD_MARGIN * (max.x - min.x).max(max.y - min.y);
        Some([min.x - m, max.x + m, min.y - m, max.y + m])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_layout_plots_what_can_move_and_labels_small_runs() {
        let world = Some((Point::new(0.0, 0.0), Point::new(800.0, 400.0)));
        let quiet = Layout::run(world, 100, (false, false), None, 10.0);
        assert_eq!(
            quiet.metrics,
            ["metrics/collisions", "metrics/events_per_second"]
        );
        assert!(!quiet.labels);
        assert!(Layout::run(world, 100, (false, false), Some(true), 10.0).labels);
        assert!(Layout::run(world, 20, (true, true), None, 10.0).labels);
        assert!(!Layout::run(world, 21, (true, true), None, 10.0).labels);
        assert!(!Layout::run(world, 5, (true, true), Some(false), 10.0).labels);
        assert_eq!(
            Layout::run(world, 5, (true, true), None, 10.0).metrics,
            METRICS
        );
        // A 3 % margin of the larger side (800) on every side.
        assert_eq!(quiet.view_bounds(), Some([-24.0, 824.0, -24.0, 424.0]));
        assert_eq!(
            Layout::run(None, 5, (true, true), None, 10.0).view_bounds(),
            None
        );
        assert_eq!(quiet.spacetime, None);
        // Messages over a network without a stack: nothing is ever delivered.
        assert_eq!(
            Layout::run(world, 5, (true, false), None, 10.0).metrics,
            [
                "metrics/collisions",
                "metrics/messages_in_flight",
                "metrics/events_per_second"
            ]
        );
        let check = Layout::check(
            (Point::new(-10.0, -10.0), Point::new(30.0, 10.0)),
            3,
            8,
            1.0,
        );
        assert_eq!(
            check.metrics,
            ["metrics/messages_in_flight", "metrics/deliveries"]
        );
        // Three lanes 10 apart over 8 steps, 45 high (1.5 times the width of three lanes).
        let st = check.spacetime.unwrap();
        assert!(st.full);
        assert_eq!(st.at(2, 8.0), [20.0, 45.0]);
        assert_eq!(st.at(1, 4.0), [10.0, 22.5]);
    }
}
