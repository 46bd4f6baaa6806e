//! A scenario's communication settings: its network, its protocol stack and its faults,
//! checked against the robots, and errors placed inside a spec's or a layer's text.

use std::sync::Arc;

use nekosim_actors::registry::Setting;
use nekosim_actors::world::network::Partition;
use nekosim_actors::{Comms, Fault};
use nekosim_protocols::codec::Codecs;
use nekosim_protocols::{FieldError, Spec, SpecError, StackError, Wiring};

use super::{FaultSpec, Pos, Registry, ScenarioError, Source};

impl Source {
    /// Network, stack and faults, checked against `n` robots.
    pub(super) fn comms(
        &self,
        n: usize,
        registry: &Registry,
    ) -> Result<(Comms, Arc<Codecs>, Setting), ScenarioError> {
        let s = &self.scenario;
        let network = s
            .network
            .clone()
            .unwrap_or_else(|| Spec::new("Reliable(delay: 1.0)"));
        registry
            .networks
            .build(&network)
            .map_err(|e| self.spec_err("network", &e))?;
        let (wiring, _) =
            Wiring::check(&s.stack, &registry.protocols).map_err(|e| self.stack_err(&e))?;
        let mut faults = Vec::new();
        let robot_ok = |path: String, r: u32| -> Result<u32, ScenarioError> {
            if (r as usize) < n {
                Ok(r)
            } else {
                Err(self.err(FieldError::new(
                    &path,
                    format!("robot {r} does not exist"),
                    format!("an id in 0..={}", n.saturating_sub(1)),
                )))
            }
        };
        for (i, f) in s.faults.iter().enumerate() {
            let p = format!("faults[{i}]");
            match f {
                FaultSpec::Crash { robot, at } => {
                    let robot = robot_ok(format!("{p}.robot"), *robot)?;
                    self.finite(&format!("{p}.at"), "crash time", *at)?;
                    if *at < 0.0 {
                        return Err(self.err(FieldError::new(
                            &format!("{p}.at"),
                            format!("crash time is {at}"),
                            "a time >= 0",
                        )));
                    }
                    faults.push(Fault::Crash { robot, at: *at });
                }
                FaultSpec::Partition { groups, from, to } => {
                    for (g, group) in groups.iter().enumerate() {
                        for (k, r) in group.iter().enumerate() {
                            robot_ok(format!("{p}.groups[{g}][{k}]"), *r)?;
                        }
                    }
                    self.finite(&format!("{p}.from"), "partition start", *from)?;
                    self.finite(&format!("{p}.to"), "partition end", *to)?;
                    if to < from {
                        return Err(self.err(FieldError::new(
                            &format!("{p}.to"),
                            format!("partition ends at {to} before it starts at {from}"),
                            "from <= to",
                        )));
                    }
                    faults.push(Fault::Partition(Partition {
                        groups: groups.clone(),
                        from: *from,
                        to: *to,
                    }));
                }
            }
        }
        Ok((
            Comms {
                network,
                networks: registry.networks.clone(),
                stack: s.stack.clone(),
                faults,
                protocols: registry.protocols.clone(),
            },
            wiring.codecs.clone(),
            Setting {
                layers: wiring
                    .ids
                    .iter()
                    .cloned()
                    .zip(wiring.provides.iter().copied())
                    .collect(),
                lcm: Arc::new(self.lcm()?),
            },
        ))
    }

    /// The scenario's Look-Compute-Move settings, checked (the defaults without an `lcm`).
    fn lcm(&self) -> Result<nekosim_actors::lcm::LcmSettings, ScenarioError> {
        let settings = self.scenario.lcm.clone().unwrap_or_default();
        settings.check().map_err(|e| {
            self.err(FieldError::new(
                &format!("lcm.{}", e.field),
                e.message,
                e.expected,
            ))
        })?;
        Ok(settings)
    }

    /// A stack error at its place: inside a layer's protocol text when it says where, else at
    /// the offending field.
    pub(super) fn stack_err(&self, e: &StackError) -> ScenarioError {
        let path = format!("stack[{}].protocol", e.layer);
        match (e.at, e.field.strip_prefix("protocol")) {
            (Some(at), _) => self.err_in(&path, at, &e.message),
            (None, Some(rest)) => self.place(&format!("{path}{rest}"), e.message.clone()),
            (None, None) => self.place(
                &format!("stack[{}].{}", e.layer, e.field),
                e.message.clone(),
            ),
        }
    }

    /// An error about the spec (a name and its configuration) at `path`: inside its text when
    /// it says where, else at the offending field.
    pub(super) fn spec_err(&self, path: &str, e: &SpecError) -> ScenarioError {
        match (e.at, &e.field) {
            (Some(at), None) => self.err_in(path, at, &e.message),
            (Some(at), Some(f)) => self.err_in(&format!("{path}.{f}"), at, &e.message),
            (None, Some(f)) if f.starts_with('[') => {
                self.place(&format!("{path}{f}"), e.message.clone())
            }
            (None, Some(f)) => self.place(&format!("{path}.{f}"), e.message.clone()),
            (None, None) => self.place(path, e.message.clone()),
        }
    }

    /// An error at `(line, col)` of the value at `path` (1-based, within the value's text).
    fn err_in(&self, path: &str, (line, col): (usize, usize), message: &str) -> ScenarioError {
        let Some(base) = self.spans.get(path) else {
            return self.place(path, message);
        };
        ScenarioError {
            file: self.file.clone(),
            pos: Some(if line == 1 {
                Pos {
                    line: base.line,
                    col: base.col + col - 1,
                }
            } else {
                Pos {
                    line: base.line + line - 1,
                    col,
                }
            }),
            message: message.to_string(),
        }
    }
}
