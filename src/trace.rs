//! The JSON Lines trace: one object per observation, schema in docs/trace.md. Every object has
//! `t` (seconds), `seq` (strictly increasing) and `kind`, in that order. The objects are the
//! records projected by serde ([`Record`]'s and [`Observation`]'s `Serialize`): one definition
//! of what a run records, shared with the log and the recording.
//!
//! [`Observation`]: nekosim_actors::world::observation::Observation

use nekosim_actors::world::observation::Record;
use serde_json::Value;

/// The trace object of a record.
pub fn to_json(r: &Record) -> Value {
    serde_json::to_value(r).unwrap_or_else(|e| serde_json::json!({ "error": e.to_string() }))
}

/// The trace line of a record (without the newline).
pub fn to_line(r: &Record) -> String {
    serde_json::to_string(r)
        .unwrap_or_else(|e| serde_json::json!({ "error": e.to_string() }).to_string())
}

#[cfg(test)]
mod tests {
    use super::*;
    use nekosim_actors::world::geometry::{Point, Vector};
    use nekosim_actors::world::motion::{
        Kinematics, Motion, MotionError, MotionPattern, MotionSpec, Pose, Progress, StepKind,
    };
    use nekosim_actors::world::observation::Observation;
    use nekosim_actors::world::sensor::SensorQuery;
    use nekosim_actors::world::{MotionOutcome, Obstacle};

    fn line(t: f64, seq: u64, obs: Observation) -> String {
        to_line(&Record { t, seq, obs })
    }

    fn state() -> Kinematics {
        Kinematics {
            pos: Point::new(1.5, -2.0),
            angle: 90.0,
            vel: Vector::new(0.0, 3.0),
            omega: 0.0,
        }
    }

    /// A custom pattern whose parameters include a reserved name, which the trace leaves out.
    #[derive(Debug)]
    struct ArcSpec;

    impl MotionSpec for ArcSpec {
        fn name(&self) -> &str {
            "arc"
        }
        fn params(&self) -> Vec<(String, f64)> {
            vec![("radius".into(), 4.0), ("robot".into(), 9.0)]
        }
        fn begin(&self, _: f64, _: Pose) -> Result<Box<dyn MotionPattern>, MotionError> {
            unreachable!("only traced")
        }
    }

    /// Records the example scenarios rarely produce, against the forms docs/trace.md
    /// documents, written out by hand.
    #[test]
    fn records_project_to_the_documented_trace_objects() {
        let cases = [
            (
                Observation::MotionRequest {
                    robot: 2,
                    ticket: 7,
                    motion: Motion::Custom(std::sync::Arc::new(ArcSpec)),
                },
                r#"{"t":0.5,"seq":3,"kind":"motion_request","robot":2,"ticket":7,"motion":"arc","radius":4.0}"#,
            ),
            (
                Observation::MotionStep {
                    step: StepKind::Custom("arc_half".into()),
                    robot: 2,
                    state: state(),
                    progress: Progress::default(),
                },
                r#"{"t":0.5,"seq":3,"kind":"arc_half","robot":2,"pos":[1.5,-2.0],"angle":90.0,"vel":[0.0,3.0],"omega":0.0}"#,
            ),
            (
                Observation::MotionFinish {
                    robot: 1,
                    state: state(),
                    outcome: MotionOutcome::Rejected("speed is 0".into()),
                },
                r#"{"t":0.5,"seq":3,"kind":"motion_finish","robot":1,"pos":[1.5,-2.0],"angle":90.0,"outcome":"rejected","reason":"speed is 0"}"#,
            ),
            (
                Observation::MotionFinish {
                    robot: 1,
                    state: state(),
                    outcome: MotionOutcome::Collided {
                        with: Obstacle::Boundary,
                    },
                },
                r#"{"t":0.5,"seq":3,"kind":"motion_finish","robot":1,"pos":[1.5,-2.0],"angle":90.0,"outcome":"collided","other":"boundary"}"#,
            ),
            (
                Observation::Suspect {
                    robot: 0,
                    layer: "fd".into(),
                    process: 2,
                },
                r#"{"t":0.5,"seq":3,"kind":"suspect","robot":0,"layer":"fd","process":2}"#,
            ),
            (
                Observation::Leader {
                    robot: 0,
                    layer: "omega".into(),
                    process: 1,
                },
                r#"{"t":0.5,"seq":3,"kind":"leader","robot":0,"layer":"omega","process":1}"#,
            ),
            (
                Observation::Crash {
                    robot: 3,
                    state: state(),
                },
                r#"{"t":0.5,"seq":3,"kind":"crash","robot":3,"pos":[1.5,-2.0],"angle":90.0}"#,
            ),
            (
                Observation::SensorRequest {
                    robot: 3,
                    query: SensorQuery::off("Crowd"),
                    plan: None,
                },
                r#"{"t":0.5,"seq":3,"kind":"sensor_request","robot":3,"sensor":"Crowd","value":{"query":"deactivate"}}"#,
            ),
        ];
        for (obs, want) in cases {
            assert_eq!(line(0.5, 3, obs), want);
        }
    }
}
