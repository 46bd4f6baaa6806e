//! Symmetry reduction, against brute force: stateright's own breadth-first checker lists every
//! reachable state; the reachable set must be closed under the renamings (each image of a
//! reachable state is reachable), and the reduced search must explore exactly one state per
//! class of that set (the number of orbits, counted here from the full set).

use std::collections::{BTreeSet, HashSet};
use std::hash::{DefaultHasher, Hash, Hasher};

use nekosim_models::State;
use nekosim_models::{build, find, run, Exploration, ModelError, NetworkKind, Options};
use stateright::{Checker, Model, StateRecorder};

fn hash(s: &State) -> u64 {
    let mut h = DefaultHasher::new();
    s.hash(&mut h);
    h.finish()
}

/// Symmetry reduction alone: forgetting spent messages would merge states further.
fn symmetric(opts: &Options) -> Options {
    Options {
        symmetry: true,
        reduction: false,
        ..opts.clone()
    }
}

#[test]
fn reliable_broadcast_explores_one_state_per_class() {
    let def = find("reliable-broadcast").unwrap();
    let opts = Options {
        requests: 3,
        ..Options::default()
    };
    let model = build(&def.target(), &symmetric(&opts), |_, _| {}).unwrap();
    let sym = model
        .cfg
        .symmetry
        .clone()
        .expect("reliable broadcast is symmetric");
    assert_eq!(
        sym.perms.len(),
        5,
        "one request each: every renaming but the identity"
    );

    // Every reachable state, by stateright itself (the model's own symmetry is not used by
    // stateright's checker).
    let (recorder, states) = StateRecorder::new_with_accessor();
    let full = build(&def.target(), &opts, |_, _| {})
        .unwrap()
        .checker()
        .visitor(recorder)
        .spawn_bfs()
        .join();
    let states = states();
    assert_eq!(states.len(), full.unique_state_count());
    assert_eq!(states.len(), 5_756);
    let reachable: HashSet<u64> = states.iter().map(hash).collect();

    let mut classes: BTreeSet<u64> = BTreeSet::new();
    for s in &states {
        let images = sym.images(s);
        assert_eq!(images.len(), 5);
        for image in &images {
            assert!(reachable.contains(&hash(image)), "an image is unreachable");
        }
        let least = images.iter().map(hash).chain([hash(s)]).min().unwrap();
        classes.insert(least);
    }

    let reduced = run(model, Exploration::default());
    assert!(reduced.all_hold(), "{:?}", reduced.verdicts);
    assert_eq!(reduced.unique_states, classes.len());
    assert_eq!(reduced.unique_states, 968);
}

#[test]
fn a_counterexample_found_with_symmetry_is_a_real_path_of_the_same_length() {
    let def = find("reliable-broadcast").unwrap();
    let opts = Options {
        requests: 3,
        network: NetworkKind::Lossy,
        ..Options::default()
    };
    let plain = Options {
        reduction: false,
        ..opts.clone()
    };
    let plain = run(
        build(&def.target(), &plain, |_, _| {}).unwrap(),
        Exploration::default(),
    );
    let model = build(&def.target(), &symmetric(&opts), |_, _| {}).unwrap();
    let reduced = run(model.clone(), Exploration::default());
    assert!(reduced.unique_states < plain.unique_states);
    let steps = |o: &nekosim_models::Outcome| {
        let v = o.verdict("agreement").unwrap();
        assert!(!v.holds);
        v.path.clone().unwrap()
    };
    let path = steps(&reduced);
    assert_eq!(
        path.clone().into_actions().len(),
        steps(&plain).into_actions().len()
    );
    // Replayed step by step in the model, it ends in a state that breaks agreement at rest.
    let mut state = model.init_states().remove(0);
    for action in path.into_actions() {
        state = model
            .next_state(&state, action)
            .expect("a step of the model");
    }
    let delivered: Vec<BTreeSet<_>> = state
        .actor_states
        .iter()
        .map(|a| a.delivered.iter().map(|(id, _)| *id).collect())
        .collect();
    assert!(
        delivered.iter().any(|d| *d != delivered[0]),
        "{delivered:?}"
    );
    assert_eq!(state.network.len(), 0, "at rest: nothing left in flight");
}

#[test]
fn asymmetric_stacks_and_staged_multicasts_are_refused() {
    let refused = |name: &str, opts: Options| match build(
        &find(name).unwrap().target(),
        &symmetric(&opts),
        |_, _| {},
    ) {
        Err(ModelError::Symmetry(why)) => why,
        Err(other) => panic!("{name}: {other}"),
        Ok(_) => panic!("{name}: symmetry accepted"),
    };
    let why = refused("lamport-abcast", Options::default());
    assert!(why.contains("layer \"abcast\""), "{why}");
    let why = refused(
        "reliable-broadcast",
        Options {
            crashes: 1,
            ..Options::default()
        },
    );
    assert!(why.contains("with crashes"), "{why}");
}
