//! Why a lasso violates its temporal property, in the property's terms: what is missing in
//! a state of the cycle, and why the cycle counts.

use nekosim_protocols::codec::with_codecs;
use nekosim_protocols::{Pid, Request};

use super::{Decision, StackFairness};
use crate::adapter::{live, State};
use crate::config::{Action, CheckModel};
use crate::liveness::{Lasso, Liveness};
use crate::property::{decided_all, has_issued, suspects};

/// Why a lasso violates its property, in the property's terms: what is missing, read in a
/// state of the cycle where the predicate is false (the entry, for `eventually`), and why the
/// cycle counts.
pub fn reason(
    model: &CheckModel,
    d: &Decision,
    lasso: &Lasso<State, Action>,
    fairness: StackFairness,
) -> String {
    let p = d.property;
    let states: Vec<&State> = std::iter::once(lasso.entry())
        .chain(lasso.cycle.iter().map(|(_, s)| s))
        .collect();
    let bad = states
        .iter()
        .find(|s| !p.holds_in(model, s, d.pair))
        .copied()
        .unwrap_or(lasso.entry());
    let missing = with_codecs(&model.actors[0].shared.wiring.codecs, || {
        missing(model, p.name, d.pair, bad)
    });
    let fair = match fairness {
        StackFairness::None => "",
        _ => ", and the cycle is fair: every message and timer it keeps enabled it also takes, or disables in one of its states",
    };
    if lasso.cycle.is_empty() {
        return format!(
            "{missing}; the run ends there (nothing is left to happen) and stays for ever"
        );
    }
    let false_in = lasso
        .cycle
        .iter()
        .filter(|(_, s)| !p.holds_in(model, s, d.pair))
        .count();
    match p.kind {
        Liveness::Eventually => format!(
            "{missing}; it is so in every state of the stem and of the cycle of {} steps, which repeats for ever{fair}",
            lasso.cycle.len()
        ),
        Liveness::EventuallyAlways | Liveness::AlwaysEventually => format!(
            "{missing}; the cycle of {} steps repeats for ever and this is so in {false_in} of its states{fair}",
            lasso.cycle.len()
        ),
    }
}

/// What `name`'s predicate misses in `s`.
fn missing(m: &CheckModel, name: &str, pair: Option<(Pid, Pid)>, s: &State) -> String {
    let list = |ps: Vec<usize>| {
        ps.iter()
            .map(|p| format!("p{p}"))
            .collect::<Vec<_>>()
            .join(", ")
    };
    match name {
        "termination" => {
            let undecided: Vec<usize> = live(s).filter(|&i| !decided_all(m, s, i)).collect();
            format!(
                "{} never decide{}",
                list(undecided.clone()),
                if undecided.len() == 1 { "s" } else { "" }
            )
        }
        "validity" => live(s)
            .find_map(|i| {
                let a = &s.actor_states[i];
                (0..a.issued as u64)
                    .find(|&n| {
                        !a.delivered
                            .iter()
                            .any(|(d, _)| d.origin as usize == i && d.n == n)
                    })
                    .map(|n| format!("p{i} never delivers its own broadcast {i}:{n}"))
            })
            .unwrap_or_else(|| "a live process misses its own broadcast".into()),
        "agreement" | "uniform agreement" => {
            for i in live(s) {
                for (j, b) in s.actor_states.iter().enumerate() {
                    if name == "agreement" && s.crashed[j] {
                        continue;
                    }
                    if let Some((id, _)) = b
                        .delivered
                        .iter()
                        .find(|(id, _)| !s.actor_states[i].delivered.iter().any(|(d, _)| d == id))
                    {
                        return format!("p{i} never delivers {id}, which p{j} delivered");
                    }
                }
            }
            "a live process misses a delivery".into()
        }
        "reliable delivery" => m
            .cfg
            .requests
            .iter()
            .enumerate()
            .find_map(|(g, (p, req))| {
                let Request::Send { to, msg } = req else {
                    return None;
                };
                if s.crashed[*p as usize] || !has_issued(m, s, *p, g) {
                    return None;
                }
                to.iter()
                    .find(|&&q| {
                        !s.crashed[q as usize]
                            && !s.actor_states[q as usize]
                                .received
                                .iter()
                                .any(|(f, got)| f == p && got == msg)
                    })
                    .map(|q| format!("p{q} never gets {msg} from p{p}"))
            })
            .unwrap_or_else(|| "a message is never delivered".into()),
        "strong completeness" => {
            let crashed: Vec<usize> = (0..s.crashed.len()).filter(|&i| s.crashed[i]).collect();
            live(s)
                .find_map(|a| {
                    crashed
                        .iter()
                        .find(|&&t| !suspects(s, a, t as Pid))
                        .map(|t| format!("p{a} never suspects p{t}, which crashed"))
                })
                .unwrap_or_else(|| "a crashed process is never suspected".into())
        }
        "eventual trust" => match pair {
            Some((a, b)) => format!("p{a} suspects p{b}, which is live, and never trusts it again"),
            None => "a live process keeps suspecting a live process".into(),
        },
        "stable leader" => {
            let leaders: Vec<String> = live(s)
                .map(|i| match s.actor_states[i].leader {
                    Some(l) => format!("p{i} trusts p{l}"),
                    None => format!("p{i} trusts nobody"),
                })
                .collect();
            format!(
                "the live processes never settle on one live leader ({})",
                leaders.join(", ")
            )
        }
        _ => format!("{name} never holds"),
    }
}
