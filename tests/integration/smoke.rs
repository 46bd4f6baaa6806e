use crate::common::*;
use nekosim::algorithm::ScriptStep;
use nekosim::world::observation::Observation;

#[test]
fn head_on_robots_collide_at_the_closed_form_instant() {
    let out = run(
        infinite(),
        100.0,
        vec![
            (
                spec(0.0, 0.0, 0.0, 1.0),
                script(vec![ScriptStep::Forward {
                    distance: 50.0,
                    move_speed: 2.0,
                }]),
            ),
            (
                spec(20.0, 0.0, 180.0, 1.0),
                script(vec![ScriptStep::Forward {
                    distance: 50.0,
                    move_speed: 3.0,
                }]),
            ),
        ],
    );
    for r in &out.records {
        println!("{:.3} {:?}", r.t, r.obs);
    }
    let c: Vec<_> = out
        .records
        .iter()
        .filter(|r| matches!(r.obs, Observation::Collision { .. }))
        .collect();
    assert_eq!(c.len(), 1);
    // Gap 18 closed at 5 units/s.
    assert!((c[0].t - 3.6).abs() < 1e-12, "{}", c[0].t);
}

/// docs/extending.md's doc tests include the `Redundant` protocol from a file; the page shows
/// the same code.
#[test]
fn the_extending_page_shows_the_protocol_its_snippets_include() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let page = std::fs::read_to_string(root.join("docs/extending.md")).unwrap();
    let start = page.find("```rust\n").unwrap() + "```rust\n".len();
    let block = &page[start..start + page[start..].find("```").unwrap()];
    let shown = block.replace("# fn main() {}\n", "");
    let included = std::fs::read_to_string(root.join("docs/extending_redundant.rs")).unwrap();
    let included = included.split_once('\n').unwrap().1;
    assert_eq!(shown, included);
}
