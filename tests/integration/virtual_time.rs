//! Virtual time jumps from event to event: a long simulated horizon costs only its events.

use std::time::Instant;

use crate::common::*;
use nekosim::algorithm::ScriptStep;
use nekosim::world::observation::Observation;

#[test]
fn a_billion_simulated_seconds_take_well_under_a_wall_clock_second() {
    // The wall clock is read here, in the test, only to show the engine never waits on it.
    let started = Instant::now();
    let out = run(
        infinite(),
        2e9,
        vec![
            (
                spec(0.0, 0.0, 0.0, 1.0),
                script(vec![
                    ScriptStep::Wait(1e8),
                    ScriptStep::Forward {
                        distance: 100.0,
                        move_speed: 1e-7,
                    },
                    ScriptStep::Turn {
                        angle: 180.0,
                        turn_speed: 1e-6,
                    },
                ]),
            ),
            (spec(0.0, 50.0, 0.0, 1.0), idle()),
        ],
    );
    let wall = started.elapsed().as_secs_f64();
    assert!(wall < 1.0, "took {wall} s of wall-clock time");
    let last = out.records.last().unwrap();
    // 1e8 s waiting, 1e9 s moving, 1.8e8 s turning.
    assert!((last.t - 1.28e9).abs() < 1e-3, "{}", last.t);
    assert_eq!(out.stats.end_time, last.t);
    assert!(matches!(last.obs, Observation::MotionFinish { .. }));
    assert!(out.stats.events < 1_000, "{} events", out.stats.events);
}
