//! Look-Compute-Move robots end to end. The shipped rendezvous tables against a transcription
//! of spin-light's Algorithms.pml; a replay of run traces written apart from the engine (every
//! Look's snapshot against the true positions from the motion records, every destination
//! against the algorithm's own compute mapped through the recorded frame, every phase sequence
//! and light change against the synchrony model); and the closed forms of to-half.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;

use nekosim::lcm::rule_table::{RuleTable, RuleTableConfig};
use nekosim::lcm::settings::{Lights, Movement, Register};
use nekosim::lcm::{Light, LookComputeMove, Multiplicity, Seen, View};
use nekosim::scenario::{RobotEntry, Source};
use nekosim::world::geometry::{Point, Vector};
use serde_json::Value;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// The shipped two-robot rule tables: every examples/lcm file whose robots run `RuleTable`.
fn rendezvous_files() -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(root().join("examples/lcm"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "ron"))
        .filter(|p| {
            std::fs::read_to_string(p)
                .unwrap()
                .contains("algorithm: RuleTable(")
        })
        .collect();
    v.sort();
    v
}

/// A file's rule tables (one per robot entry) and its lights setting, read as the scenario
/// loader reads them.
fn tables(path: &Path) -> (Vec<RuleTable>, Lights) {
    let source = Source::load(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let lights = source.scenario.lcm.clone().unwrap_or_default().lights;
    let tables = source
        .scenario
        .robots
        .iter()
        .map(|r| {
            let spec = match r {
                RobotEntry::Robot { algorithm, .. } | RobotEntry::Group { algorithm, .. } => {
                    algorithm
                }
            };
            assert_eq!(spec.name(), "RuleTable", "{}", path.display());
            let config: RuleTableConfig = spec.read_config().expect("a rule table");
            RuleTable::new(config, lights).expect("a complete table")
        })
        .collect();
    (tables, lights)
}

/// Where a command sends the robot, in Promela's words.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Go {
    Stay,
    ToHalf,
    ToOther,
}

const BLACK: u8 = 0;
const WHITE: u8 = 1;
const RED: u8 = 2;
const YELLOW: u8 = 3;
const GREEN: u8 = 4;
const COL_A: u8 = 0;
const COL_A_P: u8 = 1;
const COL_B: u8 = 2;

/// The palette of each of spin-light's algorithms, by Promela number (Types.pml's colours;
/// the regular algorithms' COL_ numbers).
fn palette(algo: &str) -> Vec<&'static str> {
    let types = ["black", "white", "red", "yellow", "green"];
    match algo {
        "ALGO_NO_MOVE" | "ALGO_TO_HALF" | "ALGO_TO_OTHER" => types[..1].to_vec(),
        "ALGO_VIG_2COLS" | "ALGO_OPTIMAL" => types[..2].to_vec(),
        "ALGO_VIG_3COLS" | "ALGO_FLO_ALGO3EXT" | "ALGO_FLO_ALGO3EXT_PRIME" | "ALGO_3EXT_NONQSS" => {
            types[..3].to_vec()
        }
        "ALGO_WADA_4EXT" | "ALGO_TIXEUIL_EXTRA" => types[..4].to_vec(),
        "ALGO_WADA_5EXT" => types.to_vec(),
        "ALGO_REGULAR4" => vec!["a", "a'", "b", "c"],
        "ALGO_REGULAR5" => vec!["a", "a'", "b", "b'", "c"],
        "ALGO_REGULAR6" => vec!["a", "a'", "b", "b'", "c", "c'"],
        _ => panic!("unknown algorithm {algo}"),
    }
}

/// spin-light's Algorithms.pml, transcribed branch by branch: the command (move, new colour)
/// for my colour, the other's and whether we share a point. Every algorithm starts from
/// Promela's `command.move = STAY; command.new_color = obs.color.me`. A Promela `if` with no
/// true guard blocks; those cases lie outside the palette and panic here.
fn promela(algo: &str, me: u8, other: u8, same: bool) -> (Go, u8) {
    let blocks = || panic!("{algo} blocks on ({me}, {other})");
    let (mut go, mut c) = (Go::Stay, me);
    match algo {
        "ALGO_NO_MOVE" => c = BLACK,
        "ALGO_TO_HALF" => (go, c) = (Go::ToHalf, BLACK),
        "ALGO_TO_OTHER" => (go, c) = (Go::ToOther, BLACK),
        "ALGO_VIG_2COLS" => match me {
            BLACK => match other {
                BLACK => c = WHITE,
                WHITE => {}
                _ => blocks(),
            },
            WHITE => match other {
                BLACK => go = Go::ToOther,
                WHITE => (go, c) = (Go::ToHalf, BLACK),
                _ => blocks(),
            },
            _ => c = BLACK,
        },
        "ALGO_VIG_3COLS" => match me {
            BLACK => match other {
                BLACK => (go, c) = (Go::ToHalf, WHITE),
                WHITE => go = Go::ToOther,
                RED => {}
                _ => blocks(),
            },
            WHITE => match other {
                BLACK => {}
                WHITE => c = RED,
                RED => go = Go::ToOther,
                _ => blocks(),
            },
            RED => match other {
                BLACK => go = Go::ToOther,
                WHITE => {}
                RED => c = BLACK,
                _ => blocks(),
            },
            _ => c = BLACK,
        },
        "ALGO_FLO_ALGO3EXT" => match other {
            BLACK => (go, c) = (Go::ToHalf, WHITE),
            WHITE => c = RED,
            RED => (go, c) = (Go::ToOther, BLACK),
            _ => c = BLACK,
        },
        "ALGO_FLO_ALGO3EXT_PRIME" => match other {
            BLACK => (go, c) = (Go::ToHalf, WHITE),
            WHITE => (go, c) = (Go::ToOther, RED),
            RED => c = BLACK,
            _ => c = BLACK,
        },
        "ALGO_3EXT_NONQSS" => match other {
            BLACK => (go, c) = (Go::ToHalf, WHITE),
            WHITE => c = RED,
            RED => (go, c) = (Go::ToOther, WHITE),
            _ => c = BLACK,
        },
        "ALGO_WADA_4EXT" => match other {
            BLACK => (go, c) = (Go::ToHalf, WHITE),
            WHITE => c = RED,
            RED => (go, c) = (Go::ToOther, YELLOW),
            YELLOW => c = BLACK,
            _ => c = BLACK,
        },
        "ALGO_WADA_5EXT" => match other {
            BLACK => (go, c) = (Go::ToHalf, WHITE),
            WHITE => c = RED,
            RED => (go, c) = (Go::ToOther, YELLOW),
            YELLOW => c = GREEN,
            GREEN => c = BLACK,
            _ => c = BLACK,
        },
        "ALGO_OPTIMAL" => match me {
            BLACK => match other {
                BLACK => c = WHITE,
                WHITE => {}
                _ => blocks(),
            },
            WHITE if same => {}
            WHITE => match other {
                BLACK => go = Go::ToOther,
                WHITE => (go, c) = (Go::ToHalf, BLACK),
                _ => blocks(),
            },
            _ => c = BLACK,
        },
        "ALGO_TIXEUIL_EXTRA" => {
            // COLMTWHITE is YELLOW, COLMTBLACK is RED.
            let (mt_white, mt_black) = (YELLOW, RED);
            match me {
                BLACK => {
                    if other == BLACK || other == mt_black {
                        c = mt_white;
                    } else if other == WHITE || other == mt_white {
                    } else {
                        blocks();
                    }
                }
                WHITE if same => {}
                WHITE => {
                    if other == BLACK {
                        go = Go::ToOther;
                    } else if other == WHITE || other == mt_black {
                        (go, c) = (Go::ToHalf, mt_black);
                    } else if other == mt_white {
                        go = Go::ToOther;
                    } else {
                        blocks();
                    }
                }
                m if m == mt_black => c = BLACK,
                m if m == mt_white => (go, c) = (Go::ToOther, WHITE),
                _ => c = BLACK,
            }
        }
        "ALGO_REGULAR4" | "ALGO_REGULAR5" | "ALGO_REGULAR6" => {
            let n = palette(algo).len() as u8;
            // Each variant's COL_ numbers: REGULAR4 has no B' (its C is 3), REGULAR6 adds C'.
            let (b_p, col_c, c_p) = match n {
                4 => (None, 3, None),
                5 => (Some(3), 4, None),
                _ => (Some(3), 4, Some(5)),
            };
            if me == COL_A_P {
                c = COL_B;
            } else if Some(me) == b_p {
                c = col_c;
            } else if Some(me) == c_p {
                c = COL_A;
            } else if me == COL_A {
                if other == COL_A {
                    (go, c) = (Go::ToHalf, COL_A_P);
                } else if other == COL_B {
                    go = Go::ToOther;
                }
            } else if me == COL_B {
                if other == COL_B {
                    // REGULAR4's B goes straight to C.
                    c = b_p.unwrap_or(col_c);
                } else if other == col_c {
                    go = Go::ToOther;
                }
            } else if me == col_c {
                if other == col_c {
                    c = c_p.unwrap_or(COL_A);
                } else if other == COL_A {
                    go = Go::ToOther;
                }
            } else {
                c = COL_A;
            }
        }
        _ => panic!("unknown algorithm {algo}"),
    }
    (go, c)
}

/// The spin-light algorithm a file's header names (`ALGO_...`).
fn algo_of(path: &Path) -> String {
    let text = std::fs::read_to_string(path).unwrap();
    let header: String = text
        .lines()
        .take_while(|l| l.starts_with("//"))
        .collect::<Vec<_>>()
        .join(" ");
    let i = header
        .find("(ALGO_")
        .unwrap_or_else(|| panic!("{}: no ALGO_ name", path.display()));
    header[i + 1..]
        .chars()
        .take_while(|c| c.is_ascii_uppercase() || c.is_ascii_digit() || *c == '_')
        .collect()
}

/// The view a robot's runtime gives the table: lights only where the scenario's lights make
/// them visible and the palette has more than one colour, the other at `at` (the origin when
/// they share a point).
fn table_view(lights: Lights, colours: usize, me: u8, other: u8, at: Point) -> View {
    let lit = colours > 1;
    View {
        light: (lit && lights.own_visible()).then_some(me),
        others: vec![Seen {
            at,
            light: (lit && lights.others_visible()).then_some(other),
            multiplicity: Multiplicity::Unknown,
        }],
        visibility: None,
    }
}

#[test]
fn every_shipped_rendezvous_table_is_its_promela_algorithm() {
    let files = rendezvous_files();
    let mut seen: Vec<String> = Vec::new();
    for f in &files {
        let algo = algo_of(f);
        let (tables, lights) = tables(f);
        let names = palette(&algo);
        let n = names.len();
        for table in &tables {
            assert_eq!(table.lights, names, "{}: the palette", f.display());
            for me in 0..n as u8 {
                for other in 0..n as u8 {
                    for same in [false, true] {
                        let at = if same {
                            Point::origin()
                        } else {
                            Point::new(3.0, -4.0)
                        };
                        let d = table.compute(&table_view(lights, n, me, other, at));
                        let (go, c) = promela(&algo, me, other, same);
                        let to = match go {
                            Go::Stay => None,
                            Go::ToHalf => Some(Point::from(at.coords / 2.0)),
                            Go::ToOther => Some(at),
                        };
                        let case = format!(
                            "{} ({algo}): me {me}, other {other}, same {same}",
                            f.display()
                        );
                        assert_eq!(d.to, to, "{case}: the move");
                        assert_eq!(d.light.unwrap_or(me), c, "{case}: the new colour");
                    }
                }
            }
        }
        seen.push(algo);
    }
    seen.sort();
    let mut all = vec![
        "ALGO_NO_MOVE",
        "ALGO_TO_HALF",
        "ALGO_TO_OTHER",
        "ALGO_VIG_2COLS",
        "ALGO_VIG_3COLS",
        "ALGO_OPTIMAL",
        "ALGO_FLO_ALGO3EXT",
        "ALGO_FLO_ALGO3EXT_PRIME",
        "ALGO_3EXT_NONQSS",
        "ALGO_WADA_4EXT",
        "ALGO_WADA_5EXT",
        "ALGO_TIXEUIL_EXTRA",
        "ALGO_REGULAR4",
        "ALGO_REGULAR5",
        "ALGO_REGULAR6",
    ];
    all.sort();
    assert_eq!(seen, all, "one file per spin-light algorithm");
}

/// The oracle itself, on cases read straight off Algorithms.pml.
#[test]
fn the_promela_transcription_reads_as_the_source() {
    assert_eq!(
        promela("ALGO_VIG_2COLS", WHITE, WHITE, false),
        (Go::ToHalf, BLACK)
    );
    assert_eq!(
        promela("ALGO_OPTIMAL", WHITE, WHITE, true),
        (Go::Stay, WHITE)
    );
    assert_eq!(
        promela("ALGO_TIXEUIL_EXTRA", BLACK, RED, false),
        (Go::Stay, YELLOW)
    );
    assert_eq!(
        promela("ALGO_TIXEUIL_EXTRA", YELLOW, BLACK, true),
        (Go::ToOther, WHITE)
    );
    assert_eq!(promela("ALGO_REGULAR4", 2, 2, false), (Go::Stay, 3));
    assert_eq!(promela("ALGO_REGULAR5", 2, 2, false), (Go::Stay, 3));
    assert_eq!(promela("ALGO_REGULAR5", 4, 4, false), (Go::Stay, 0));
    assert_eq!(promela("ALGO_REGULAR6", 4, 4, false), (Go::Stay, 5));
    assert_eq!(promela("ALGO_REGULAR6", 4, 0, false), (Go::ToOther, 4));
    assert_eq!(promela("ALGO_REGULAR6", 0, 4, false), (Go::Stay, 0));
}

// ---------------------------------------------------------------------------------------------
// Running scenarios and reading their traces.

/// Runs scenario `text` and returns its trace's records.
fn trace_of(text: &str) -> Vec<Value> {
    let dir = tempfile::tempdir().unwrap();
    let (file, trace) = (dir.path().join("s.ron"), dir.path().join("t.jsonl"));
    std::fs::write(&file, text).unwrap();
    let o = Command::new(env!("CARGO_BIN_EXE_nekosim"))
        .args(["run", file.to_str().unwrap(), "--quiet", "--trace"])
        .arg(&trace)
        .output()
        .expect("nekosim runs");
    assert_eq!(
        o.status.code(),
        Some(0),
        "{}\n{text}",
        String::from_utf8_lossy(&o.stderr)
    );
    std::fs::read_to_string(trace)
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(&numbers_as_text(l)).unwrap())
        .collect()
}

/// A JSON line with every number turned into a string of its text, so that the replay reads
/// each one with Rust's correctly rounded `str::parse` (serde_json's default parser may land
/// an ulp off, and the replay compares coordinates exactly).
fn numbers_as_text(line: &str) -> String {
    let mut out = String::with_capacity(line.len() + 64);
    let (mut in_string, mut escaped, mut in_number) = (false, false, false);
    for ch in line.chars() {
        if in_number && !(ch.is_ascii_digit() || matches!(ch, '.' | 'e' | 'E' | '+' | '-')) {
            out.push('"');
            in_number = false;
        }
        if in_string {
            escaped = !escaped && ch == '\\';
            in_string = escaped || ch != '"';
        } else if ch == '"' {
            in_string = true;
        } else if !in_number && (ch.is_ascii_digit() || ch == '-') {
            out.push('"');
            in_number = true;
        }
        out.push(ch);
    }
    if in_number {
        out.push('"');
    }
    out
}

/// A two-robot scenario with `lcm` settings and a `RuleTable(...)` algorithm text.
fn two_robots(seed: u64, until: f64, lcm: &str, at: [(f64, f64); 2], table: &str) -> String {
    format!(
        "Scenario(name: \"replay\", seed: {seed}, until: {until:?},
    world: (size: Infinite, ghost_mode: true),
    lcm: ({lcm}),
    robots: [Group(count: 2, radius: 0.5, born: Points([({:?}, {:?}), ({:?}, {:?})]),
        algorithm: {table})])",
        at[0].0, at[0].1, at[1].0, at[1].1
    )
}

/// The `RuleTable(...)` text of a shipped example.
fn table_text(example: &str) -> String {
    let source = Source::load(&root().join("examples/lcm").join(example)).unwrap();
    match &source.scenario.robots[0] {
        RobotEntry::Robot { algorithm, .. } | RobotEntry::Group { algorithm, .. } => {
            algorithm.text().to_string()
        }
    }
}

/// The rule table of a scenario text's first robot entry, as a scenario writes it.
fn table_config(text: &str) -> RuleTableConfig {
    match &Source::parse("replay.ron", text).unwrap().scenario.robots[0] {
        RobotEntry::Robot { algorithm, .. } | RobotEntry::Group { algorithm, .. } => {
            algorithm.read_config().unwrap()
        }
    }
}

fn t(r: &Value) -> f64 {
    num(&r["t"])
}
fn kind(r: &Value) -> &str {
    r["kind"].as_str().unwrap()
}
fn int(v: &Value) -> Option<u64> {
    v.as_str()
        .map(|s| s.parse().unwrap_or_else(|_| panic!("an integer: {v}")))
}
fn robot(r: &Value) -> usize {
    int(&r["robot"]).unwrap() as usize
}
fn num(v: &Value) -> f64 {
    v.as_str()
        .and_then(|s| s.parse().ok())
        .unwrap_or_else(|| panic!("a number: {v}"))
}
fn point(v: &Value) -> Point {
    Point::new(num(&v[0]), num(&v[1]))
}
fn opt_point(v: &Value) -> Option<Point> {
    (!v.is_null()).then(|| point(v))
}
fn light(v: &Value) -> Option<Light> {
    int(v).map(|l| l as Light)
}

/// Equal to within 1e-9 of the larger of 1 and `b`'s size.
fn close(a: Point, b: Point, what: &str) {
    let scale = b.coords.norm().max(a.coords.norm()).max(1.0);
    assert!(
        (a - b).norm() <= 1e-9 * scale,
        "{what}: {a} against {b} (off by {:e})",
        (a - b).norm()
    );
}

/// One straight glide from the motion records: from `from` at `t0` to `to` at `t1`.
#[derive(Clone, Copy, Debug)]
struct Glide {
    t0: f64,
    from: Point,
    t1: f64,
    to: Point,
}

/// Every robot's position over time, rebuilt from the spawn, motion_request and start_glide
/// records alone: at rest where it last stopped, in a glide by linear interpolation.
struct Paths {
    born: Vec<Point>,
    glides: Vec<Vec<Glide>>,
}

impl Paths {
    fn of(trace: &[Value]) -> Self {
        let mut born = Vec::new();
        let mut glides: Vec<Vec<Glide>> = Vec::new();
        let mut requested: BTreeMap<usize, (Point, f64)> = BTreeMap::new();
        for r in trace {
            match kind(r) {
                "spawn" => {
                    assert_eq!(robot(r), born.len());
                    born.push(point(&r["pos"]));
                    glides.push(Vec::new());
                }
                "motion_request" => {
                    assert_eq!(r["motion"], "glide", "{r}");
                    let to = Point::new(num(&r["to_x"]), num(&r["to_y"]));
                    requested.insert(robot(r), (to, num(&r["duration"])));
                }
                "start_glide" => {
                    let (to, duration) = requested.remove(&robot(r)).expect("a request");
                    glides[robot(r)].push(Glide {
                        t0: t(r),
                        from: point(&r["pos"]),
                        t1: t(r) + duration,
                        to,
                    });
                }
                _ => {}
            }
        }
        Self { born, glides }
    }

    /// Whether `robot` is in mid-glide at `time`.
    fn gliding(&self, robot: usize, time: f64) -> bool {
        self.glides[robot]
            .iter()
            .any(|g| g.t0 < time && time < g.t1)
    }

    fn at(&self, robot: usize, time: f64) -> Point {
        let gs = &self.glides[robot];
        match gs.iter().rev().find(|g| g.t0 <= time) {
            None => self.born[robot],
            Some(g) if time >= g.t1 => g.to,
            Some(g) => g.from + (g.to - g.from) * ((time - g.t0) / (g.t1 - g.t0)),
        }
    }
}

/// A world displacement in a recorded frame (`rotation` degrees anticlockwise, `mirrored`,
/// `unit` world units per local unit), and back.
#[derive(Clone, Copy, Debug)]
struct RecordedFrame {
    rotation: f64,
    mirrored: bool,
    unit: f64,
}

impl RecordedFrame {
    fn of(v: &Value) -> Self {
        Self {
            rotation: num(&v["rotation"]),
            mirrored: v["mirrored"].as_bool().unwrap(),
            unit: num(&v["unit"]),
        }
    }
    /// The world axes seen from the robot: the local x axis is the world's turned by
    /// `rotation`, the local y axis a quarter turn further (or back, mirrored).
    fn axes(&self) -> (Vector, Vector) {
        let a = self.rotation.to_radians();
        let x = Vector::new(a.cos(), a.sin());
        let y = Vector::new(-a.sin(), a.cos());
        (x, if self.mirrored { -y } else { y })
    }
    fn local(&self, v: Vector) -> Vector {
        let (x, y) = self.axes();
        Vector::new(v.dot(&x), v.dot(&y)) / self.unit
    }
    fn world(&self, l: Vector) -> Vector {
        let (x, y) = self.axes();
        (x * l.x + y * l.y) * self.unit
    }
}

/// One robot's cycle as the trace tells it.
#[derive(Clone, Debug, Default)]
struct Cycle {
    look: f64,
    compute_end: f64,
    move_end: f64,
    round: Option<u64>,
    looked: Option<f64>,
    computed: Option<Option<Light>>,
    /// Where the robot stands for its Look, and where its Move stops.
    from: Option<Point>,
    stop: Option<Point>,
    waited: Option<f64>,
}

/// What a replay knows of the run's settings.
#[derive(Clone, Copy, Debug)]
struct Setup<'a> {
    synchrony: &'a str,
    delta: Option<f64>,
    lights: Lights,
    register: Register,
    cycle: f64,
    until: f64,
}

/// What a replay checked: Looks, sightings of a robot in mid-glide, and reads of a light
/// being written.
#[derive(Clone, Copy, Debug, Default)]
struct Tally {
    looks: usize,
    mid_glide: usize,
    mid_write: usize,
}

/// Replays `trace` against `table` under `setup`.
fn replay(trace: &[Value], table: &RuleTable, setup: Setup) -> Tally {
    let paths = Paths::of(trace);
    let n = paths.born.len();
    let colours = table.lights.len();
    let mut cycles: Vec<Vec<Cycle>> = vec![Vec::new(); n];
    // Every robot's light as the light records set it: (shown, being written).
    let mut lamp: Vec<(Option<Light>, Option<Light>)> = vec![(None, None); n];
    let mut last_look: Vec<Option<&Value>> = vec![None; n];
    let mut light_changes: Vec<(usize, f64, Light, Option<Light>)> = Vec::new();
    let mut tally = Tally::default();
    let mut strict_since: Option<(usize, u64)> = None;
    for r in trace {
        let me = robot(r);
        if let Some((who, _)) = strict_since {
            assert_eq!(
                who, me,
                "another robot acts inside a strict Look-Compute: {r}"
            );
        }
        match kind(r) {
            "activate" => {
                let c = int(&r["cycle"]).unwrap() as usize;
                assert_eq!(c, cycles[me].len(), "cycles count from 0: {r}");
                cycles[me].push(Cycle {
                    look: num(&r["look"]),
                    compute_end: num(&r["compute_end"]),
                    move_end: num(&r["move_end"]),
                    round: int(&r["round"]),
                    ..Cycle::default()
                });
            }
            "light" => {
                let (l, p) = (light(&r["light"]).unwrap(), light(&r["pending"]));
                assert!(usize::from(l) < colours && p.is_none_or(|p| usize::from(p) < colours));
                lamp[me] = (Some(l), p);
                light_changes.push((me, t(r), l, p));
                if strict_since.is_some_and(|(_, _)| p.is_none()) {
                    strict_since = None;
                }
            }
            "look" => {
                tally.looks += 1;
                let c = int(&r["cycle"]).unwrap() as usize;
                let cy = &mut cycles[me][c];
                assert_eq!(
                    t(r),
                    cy.look,
                    "the Look happens when the adversary said: {r}"
                );
                cy.looked = Some(t(r));
                let at = point(&r["me"]);
                cy.from = Some(at);
                close(at, paths.at(me, t(r)), "where the robot Looks from");
                assert_eq!(light(&r["light"]), lamp[me].0, "its own light: {r}");
                let seen = r["seen"].as_array().unwrap();
                assert_eq!(seen.len(), n - 1, "it sees every other robot: {r}");
                for s in seen {
                    let other = robot(s);
                    assert_ne!(other, me);
                    close(point(&s["at"]), paths.at(other, t(r)), &format!("{r}"));
                    tally.mid_glide += usize::from(paths.gliding(other, t(r)));
                    let (shown, pending) = lamp[other];
                    tally.mid_write += usize::from(pending.is_some());
                    let read = light(&s["light"]);
                    let ok = match (pending, setup.register) {
                        (None, _) | (Some(_), Register::Atomic) => read == shown,
                        (Some(p), Register::Regular) => read == shown || read == Some(p),
                        (Some(_), Register::Safe) => read.is_some_and(|l| usize::from(l) < colours),
                    };
                    assert!(
                        ok,
                        "a {:?} register read {read:?} of {:?}: {r}",
                        setup.register, lamp[other]
                    );
                }
                last_look[me] = Some(r);
                if setup.synchrony == "AsyncLcStrict" {
                    strict_since = Some((me, c as u64));
                }
            }
            "compute" => {
                let c = int(&r["cycle"]).unwrap() as usize;
                let look = last_look[me].take().expect("a Look before its Compute");
                assert_eq!(look["cycle"], r["cycle"]);
                assert_eq!(t(r), t(look), "the decision is taken at the Look");
                let new = check_compute(look, r, table, setup.lights);
                cycles[me][c].computed = Some(new);
                if strict_since.is_some() && new.is_none() {
                    strict_since = None;
                }
            }
            "move" => {
                let c = int(&r["cycle"]).unwrap() as usize;
                let cy = &mut cycles[me][c];
                assert_eq!(
                    t(r),
                    cy.compute_end,
                    "the Move starts when the Compute ends: {r}"
                );
                assert_eq!(num(&r["end"]), cy.move_end);
                let (from, to, stop) = (point(&r["from"]), point(&r["to"]), point(&r["stop"]));
                assert_eq!(Some(from), cy.from, "it moves from where it Looked: {r}");
                cy.stop = Some(stop);
                let (length, went) = ((to - from).norm(), (stop - from).norm());
                match setup.delta {
                    None => assert_eq!(stop, to, "a rigid move reaches its destination"),
                    Some(delta) => {
                        assert!(went <= length * (1.0 + 1e-12), "{r}");
                        assert!(
                            went >= delta.min(length) * (1.0 - 1e-12),
                            "stops before δ: {r}"
                        );
                        let off = (stop - from).perp(&(to - from)).abs();
                        assert!(
                            off <= 1e-9 * length.max(1.0) * length.max(1.0),
                            "off the path: {r}"
                        );
                    }
                }
            }
            "wait" => {
                let c = int(&r["cycle"]).unwrap() as usize;
                let cy = &mut cycles[me][c];
                assert_eq!(t(r), cy.move_end, "the cycle ends when the Move does: {r}");
                cy.waited = Some(t(r));
                let at = point(&r["at"]);
                close(at, paths.at(me, t(r)), "where the cycle ends");
                assert_eq!(
                    Some(at),
                    cy.stop.or(cy.from),
                    "it ends where its Move stops: {r}"
                );
            }
            _ => {}
        }
    }
    check_phases(&cycles, &light_changes, setup);
    tally
}

/// A Compute record against the table's own compute on the Look's snapshot, mapped through
/// the recorded frame; returns the new light it recorded.
fn check_compute(
    look: &Value,
    compute: &Value,
    table: &RuleTable,
    lights: Lights,
) -> Option<Light> {
    let frame = RecordedFrame::of(&look["frame"]);
    let me = point(&look["me"]);
    let other = &look["seen"][0];
    let there = point(&other["at"]);
    let same = there == me;
    let colours = table.lights.len();
    let lit = colours > 1;
    let own = light(&look["light"]);
    let view = View {
        light: own.filter(|_| lit && lights.own_visible()),
        others: vec![Seen {
            at: if same {
                Point::origin()
            } else {
                Point::from(frame.local(there - me))
            },
            light: light(&other["light"]).filter(|_| lit && lights.others_visible()),
            multiplicity: Multiplicity::Unknown,
        }],
        visibility: None,
    };
    let d = table.compute(&view);
    let local_to = opt_point(&compute["local_to"]);
    match (d.to, local_to) {
        (None, None) => {}
        (Some(want), Some(got)) => close(got, want, &format!("the local decision {compute}")),
        _ => panic!(
            "decided {:?} where the table says {:?}: {compute}",
            local_to, d.to
        ),
    }
    // The point the decision names, on its exact coordinates (the midpoint rounded once):
    // none when it is where the robot stands.
    let local_other = view.others[0].at;
    let named = d.to.map(|l| {
        if l == local_other {
            there
        } else {
            assert_eq!(l, Point::from(local_other.coords / 2.0), "{compute}");
            Point::from((me.coords + there.coords) / 2.0)
        }
    });
    let to = opt_point(&compute["to"]);
    match named.filter(|&p| p != me) {
        Some(p) => {
            assert_eq!(to, Some(p), "the destination: {compute}");
            let mapped = me + frame.world(d.to.unwrap().coords);
            close(
                p,
                mapped,
                &format!("the local destination mapped back {compute}"),
            );
        }
        None => assert_eq!(to, None, "moves where the table stays: {compute}"),
    }
    let new = light(&compute["light"]);
    let want = d.light.filter(|&l| lit && Some(l) != own);
    assert_eq!(new, want, "the new light: {compute}");
    new
}

/// Every robot's phases, and every light change, against the synchrony model.
fn check_phases(cycles: &[Vec<Cycle>], lights: &[(usize, f64, Light, Option<Light>)], s: Setup) {
    let done = |c: &Cycle| c.waited.is_some();
    for (r, cs) in cycles.iter().enumerate() {
        assert!(
            cs.iter().filter(|c| done(c)).count() >= 3,
            "robot {r} cycles: {cs:?}"
        );
        for (k, c) in cs.iter().enumerate() {
            assert!(
                c.look <= c.compute_end && c.compute_end <= c.move_end,
                "{c:?}"
            );
            if let Some(next) = cs.get(k + 1) {
                assert!(c.move_end <= next.look, "robot {r}: {c:?} then {next:?}");
            }
            if c.look < s.until {
                assert_eq!(c.looked, Some(c.look), "robot {r} Looks: {c:?}");
                assert!(c.computed.is_some());
            }
            if k + 1 < cs.len() {
                assert_eq!(
                    c.waited,
                    Some(c.move_end),
                    "robot {r} ends its cycle: {c:?}"
                );
            }
            let lc = matches!(s.synchrony, "AsyncLcAtomic" | "AsyncLcStrict");
            if lc {
                assert_eq!(c.compute_end, c.look, "a Look and Compute atomic: {c:?}");
            }
            match s.synchrony {
                "Fsync" | "Ssync" | "Centralized" => {
                    let k = c.round.expect("a round");
                    assert_eq!(c.look, k as f64 * s.cycle, "a round's Looks at its start");
                    assert!(
                        c.move_end <= (k + 1) as f64 * s.cycle,
                        "inside its round: {c:?}"
                    );
                    if s.synchrony == "Fsync" {
                        assert_eq!(k, cs.iter().position(|x| x.look == c.look).unwrap() as u64);
                    }
                }
                _ => assert_eq!(c.round, None),
            }
        }
    }
    if matches!(s.synchrony, "Fsync" | "Ssync" | "Centralized") {
        let rounds = (s.until / s.cycle).floor() as u64;
        let mut sizes = Vec::new();
        for k in 0..rounds {
            let active = cycles
                .iter()
                .filter(|cs| cs.iter().any(|c| c.round == Some(k)))
                .count();
            sizes.push(active);
        }
        match s.synchrony {
            "Fsync" => assert!(sizes.iter().all(|&a| a == cycles.len()), "{sizes:?}"),
            "Centralized" => assert!(sizes.iter().all(|&a| a == 1), "{sizes:?}"),
            _ => {
                assert!(sizes.iter().all(|&a| a >= 1), "{sizes:?}");
                assert!(
                    sizes.contains(&1) && sizes.contains(&cycles.len()),
                    "{sizes:?}"
                );
            }
        }
    }
    // A light changes at time 0 (the adversary's first colour), at a Look (the new colour
    // being written) and at the end of a Compute (the new colour shown), to what was decided;
    // under a safe register a Compute that keeps its colour writes it too.
    let kept = |c: &Cycle| s.register == Register::Safe && c.computed == Some(None);
    for (k, &(r, t, l, pending)) in lights.iter().enumerate() {
        let cs = &cycles[r];
        let ok = match pending {
            Some(p) => cs
                .iter()
                .any(|c| c.look == t && (c.computed == Some(Some(p)) || (kept(c) && p == l))),
            None if t == 0.0 && !lights[..k].iter().any(|x| x.0 == r) => true,
            None => cs
                .iter()
                .any(|c| c.compute_end == t && (c.computed == Some(Some(l)) || kept(c))),
        };
        assert!(
            ok,
            "robot {r}'s light changes to {l} (writing {pending:?}) at {t}"
        );
    }
    for (r, cs) in cycles.iter().enumerate() {
        for c in cs {
            if let Some(Some(l)) = c.computed {
                if c.compute_end < s.until {
                    assert!(
                        lights.contains(&(r, c.compute_end, l, None)),
                        "robot {r} shows {l} at {}",
                        c.compute_end
                    );
                }
            }
        }
    }
}

/// The replay on every synchrony model the simulator runs, rigid and non-rigid, with lights
/// (a four-colour table read through every register) and without (to-half).
#[test]
fn a_replay_apart_from_the_engine_agrees_with_every_run() {
    let lit = table_text("tixeuil_extra.ron");
    let plain = table_text("to_half.ron");
    let (until, cycle) = (30.0, 1.0);
    let mut runs = 0;
    // Under ASYNC a Look sees robots in mid-glide, and lights being written.
    let mut total = Tally::default();
    for (i, synchrony) in [
        "Centralized",
        "Fsync",
        "Ssync",
        "Async",
        "AsyncLcAtomic",
        "AsyncLcStrict",
    ]
    .into_iter()
    .enumerate()
    {
        let mut mid_glide = 0;
        for delta in [None, Some(2.5)] {
            for (table, register) in [
                (&lit, Register::Atomic),
                (&lit, Register::Regular),
                (&lit, Register::Safe),
                (&plain, Register::Atomic),
            ] {
                let movement =
                    delta.map_or("Rigid".to_string(), |d| format!("NonRigid(delta: {d:?})"));
                let lcm =
                    format!("synchrony: {synchrony}, movement: {movement}, register: {register:?}");
                let text = two_robots(
                    7 + i as u64,
                    until,
                    &lcm,
                    [(0.25, -3.5), (41.0 / 3.0, 17.125)],
                    table,
                );
                let trace = trace_of(&text);
                let table = RuleTable::new(table_config(&text), Lights::Full).unwrap();
                let setup = Setup {
                    synchrony,
                    delta,
                    lights: Lights::Full,
                    register,
                    cycle,
                    until,
                };
                let tally = replay(&trace, &table, setup);
                assert!(tally.looks >= 6, "{lcm}: {tally:?}");
                mid_glide += tally.mid_glide;
                total.mid_write += tally.mid_write;
                runs += 1;
            }
        }
        if synchrony.starts_with("Async") {
            assert!(
                mid_glide > 0,
                "{synchrony}: no Look saw a robot in mid-glide"
            );
        }
    }
    assert_eq!(runs, 48);
    assert!(total.mid_write > 0, "{total:?}");
}

/// Every shipped rendezvous example runs, and its trace replays under the example's own
/// settings.
#[test]
fn every_shipped_rendezvous_example_replays() {
    for f in rendezvous_files() {
        let text = std::fs::read_to_string(&f).unwrap();
        let until: f64 = 12.0;
        let trace = trace_of(&text.replacen("until: 60.0", "until: 12.0", 1));
        let source = Source::load(&f).unwrap();
        let settings = source.scenario.lcm.clone().unwrap_or_default();
        let (tables, _) = tables(&f);
        let synchrony = format!("{:?}", settings.synchrony);
        let setup = Setup {
            synchrony: &synchrony,
            delta: match settings.movement {
                Movement::Rigid => None,
                Movement::NonRigid { delta } => Some(delta),
            },
            lights: settings.lights,
            register: settings.register,
            cycle: settings.cycle,
            until: until.min(source.scenario.until),
        };
        let tally = replay(&trace, &tables[0], setup);
        assert!(tally.looks >= 6, "{}: {tally:?}", f.display());
    }
}

/// External lights hide a robot's own light from itself; the replay then reads the table
/// without it.
#[test]
fn the_replay_holds_with_external_lights() {
    let text = two_robots(
        3,
        30.0,
        "synchrony: AsyncLcAtomic, lights: External, frames: (changes: Fixed)",
        [(-2.0, 1.0), (5.5, 9.25)],
        &table_text("wada_4ext.ron"),
    );
    let trace = trace_of(&text);
    let table = RuleTable::new(table_config(&text), Lights::External).unwrap();
    let setup = Setup {
        synchrony: "AsyncLcAtomic",
        delta: None,
        lights: Lights::External,
        register: Register::Atomic,
        cycle: 1.0,
        until: 30.0,
    };
    assert!(replay(&trace, &table, setup).looks >= 6);
    // Fixed frames: one frame per robot for the whole run.
    for r in 0..2 {
        let frames: Vec<&Value> = trace
            .iter()
            .filter(|x| kind(x) == "look" && robot(x) == r)
            .map(|x| &x["frame"])
            .collect();
        assert!(frames.len() > 2 && frames.iter().all(|f| *f == frames[0]));
    }
}

// ---------------------------------------------------------------------------------------------
// Closed forms.

/// Where each robot ends each cycle: `wait` records by (robot, cycle).
fn ends(trace: &[Value]) -> BTreeMap<(usize, u64), (f64, Point)> {
    trace
        .iter()
        .filter(|r| kind(r) == "wait")
        .map(|r| {
            (
                (robot(r), int(&r["cycle"]).unwrap()),
                (t(r), point(&r["at"])),
            )
        })
        .collect()
}

/// FSYNC to-half gathers two robots in exactly one round, on the exact midpoint, whatever
/// frames the adversary gives them.
#[test]
fn fsync_to_half_gathers_in_one_round() {
    let table = table_text("to_half.ron");
    for (seed, a, b) in [
        (1, (0.1, 0.7), (3.3, -2.2)),
        (2, (1000.0 / 3.0, -2.9), (-7.3, 1e-3)),
        (3, (12345.678, 0.0), (0.0, 98765.4321)),
        (4, (-1.0 / 7.0, 2.0 / 3.0), (5.0 / 9.0, -11.0 / 13.0)),
    ] {
        let trace = trace_of(&two_robots(seed, 5.0, "synchrony: Fsync", [a, b], &table));
        let ends = ends(&trace);
        let mid = Point::from((Point::new(a.0, a.1).coords + Point::new(b.0, b.1).coords) / 2.0);
        for r in 0..2 {
            assert_eq!(
                ends[&(r, 0)],
                (0.75, mid),
                "seed {seed}: robot {r} after round 0"
            );
            for k in 1..5 {
                assert_eq!(ends[&(r, k)].1, mid, "seed {seed}: it stays gathered");
            }
        }
        // The adversary changed the frames: rotations differ between robots and rounds.
        let frames: Vec<(f64, bool, f64)> = trace
            .iter()
            .filter(|r| kind(r) == "look")
            .map(|r| {
                let f = RecordedFrame::of(&r["frame"]);
                (f.rotation, f.mirrored, f.unit)
            })
            .collect();
        assert!(frames.len() >= 10, "{frames:?}");
        for (i, f) in frames.iter().enumerate() {
            assert!(
                frames[i + 1..].iter().all(|g| g.0 != f.0 && g.2 != f.2),
                "{frames:?}"
            );
        }
    }
}

/// Suzuki and Yamashita's impossibility: an SSYNC adversary that activates one robot at a
/// time keeps to-half from ever gathering; each activation halves the distance exactly.
#[test]
fn a_scripted_ssync_adversary_keeps_to_half_from_gathering() {
    let activations = 40;
    let script: Vec<String> = (0..activations)
        .map(|k| {
            let k0 = k as f64;
            format!(
                "(robot: {}, look: {k0:?}, compute: {:?}, move: {:?})",
                k % 2,
                k0 + 0.25,
                k0 + 0.75
            )
        })
        .collect();
    let lcm = format!(
        "synchrony: Ssync, adversary: Scripted([{}])",
        script.join(", ")
    );
    let (a, b) = ((0.5, -0.25), (0.5 + 1048576.0, -0.25 + 786432.0));
    let trace = trace_of(&two_robots(
        1,
        50.0,
        &lcm,
        [a, b],
        &table_text("to_half.ron"),
    ));
    let ends = ends(&trace);
    let mut at = [Point::new(a.0, a.1), Point::new(b.0, b.1)];
    let d0 = at[1] - at[0];
    for k in 0..activations {
        let r = k % 2;
        let mid = Point::from((at[0].coords + at[1].coords) / 2.0);
        let (t_end, end) = ends[&(r, (k / 2) as u64)];
        assert_eq!(t_end, k as f64 + 0.75);
        assert_eq!(end, mid, "activation {k}: robot {r} moves to the midpoint");
        at[r] = end;
        let d = at[1] - at[0];
        let scale = 2f64.powi(k as i32 + 1);
        assert_eq!(d, d0 / scale, "activation {k}: the distance halves");
        assert!((d.norm() - d0.norm() / scale).abs() <= 1e-12 * d.norm());
        assert!(d.norm() > 0.0, "activation {k}: gathered");
    }
    assert_eq!(ends.len(), activations, "no other activation");
    // The run's Looks are the script's, one robot at a time.
    let looks: Vec<(f64, usize)> = trace
        .iter()
        .filter(|r| kind(r) == "look")
        .map(|r| (t(r), robot(r)))
        .collect();
    let want: Vec<(f64, usize)> = (0..activations).map(|k| (k as f64, k % 2)).collect();
    assert_eq!(looks, want);
}
