//! Composition by name (seed 3.5, 6.2): a scenario's `stack: [Layer(id, protocol, below,
//! uses)]` read as [`LayerSpec`]s and checked into a [`Wiring`] and a process's fresh
//! [`Stack`] before anything runs. Neko composed protocol stacks in Java initializer code;
//! here the registry ([`Protocols`]) maps each layer's protocol name to its type.

use std::collections::BTreeMap;
use std::sync::Arc;

use serde::{Deserialize, Serialize};

use crate::app::app_codec;
use crate::codec::Codecs;
use crate::registry::{ProtocolSpec, Protocols};
use crate::service::{LayerIx, Service, NET};
use crate::stack::{Stack, Wiring};

/// One layer of a scenario's stack: `Layer(id: "abcast", protocol: LamportAbcast, below: "fifo")`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, rename = "Layer")]
pub struct LayerSpec {
    pub id: String,
    pub protocol: ProtocolSpec,
    /// `"net"` or the id of another layer.
    pub below: String,
    #[serde(default)]
    pub uses: Vec<String>,
}

impl LayerSpec {
    /// A layer `id` running `protocol` (its RON text, `"Retransmit(period: 1.0)"`) on `below`,
    /// using `uses`.
    pub fn new(id: &str, protocol: &str, below: &str, uses: &[&str]) -> Self {
        Self {
            id: id.to_string(),
            protocol: ProtocolSpec::new(protocol),
            below: below.to_string(),
            uses: uses.iter().map(|u| u.to_string()).collect(),
        }
    }
}

/// A wiring or configuration mistake; `layer` is the index in the stack list, `field` the
/// offending field (`"below"`, `"protocol"`, `"protocol.period"`, ...) and `at`, for an error
/// inside the protocol's RON text, the 1-based line and column in that text.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{message}")]
pub struct StackError {
    pub layer: usize,
    pub field: String,
    pub at: Option<(usize, usize)>,
    pub message: String,
}

impl Wiring {
    /// Checks a stack and builds one process's fresh instances: unique ids, known protocols
    /// whose configurations read and are accepted, `below`/`uses` naming layers, no cycles,
    /// every layer served by what it sits on and uses.
    pub fn check(
        specs: &[LayerSpec],
        protocols: &Protocols,
    ) -> Result<(Wiring, Stack), StackError> {
        let err = |layer, field: &str, message: String| StackError {
            layer,
            field: field.to_string(),
            at: None,
            message,
        };
        let mut index: BTreeMap<&str, usize> = BTreeMap::new();
        for (i, s) in specs.iter().enumerate() {
            if s.id == "net" || s.id.is_empty() {
                return Err(err(
                    i,
                    "id",
                    format!(
                        "layer id {:?} is reserved or empty; expected another name",
                        s.id
                    ),
                ));
            }
            if let Some(j) = index.insert(&s.id, i) {
                return Err(err(
                    i,
                    "id",
                    format!(
                        "duplicate layer id {:?} (also layer {j}); expected unique ids",
                        s.id
                    ),
                ));
            }
        }
        let mut shapes = Vec::new();
        let mut layers = Vec::new();
        let mut codecs = Vec::new();
        for (i, s) in specs.iter().enumerate() {
            let (shape, layer) = protocols.build(&s.protocol).map_err(|e| StackError {
                layer: i,
                field: match &e.field {
                    Some(f) => format!("protocol.{f}"),
                    None => "protocol".into(),
                },
                at: e.at,
                message: e.message,
            })?;
            codecs.push(protocols.codec(&s.protocol).expect("built"));
            shapes.push(shape);
            layers.push(layer);
        }
        let resolve = |i: usize, field: &'static str, name: &str| -> Result<LayerIx, StackError> {
            if name == "net" {
                return Ok(NET);
            }
            index.get(name).map(|&j| j as LayerIx).ok_or_else(|| {
                // A layer never sits on or uses itself: it is no candidate.
                let known: Vec<&str> = std::iter::once("net")
                    .chain(
                        (specs.iter().enumerate())
                            .filter_map(|(j, s)| (j != i).then_some(s.id.as_str())),
                    )
                    .collect();
                err(
                    i,
                    field,
                    format!(
                        "unknown layer {name:?} in `{field}`; expected one of {}",
                        known.join(", ")
                    ),
                )
            })
        };
        let provides = |ix: LayerIx| {
            if ix == NET {
                Service::P2P
            } else {
                shapes[ix as usize].provides
            }
        };
        let mut below = Vec::new();
        let mut uses = Vec::new();
        for (i, s) in specs.iter().enumerate() {
            let b = resolve(i, "below", &s.below)?;
            if b as usize == i {
                return Err(err(i, "below", format!("layer {:?} sits on itself", s.id)));
            }
            let need = shapes[i].needs_below;
            if !provides(b).serves(need) {
                return Err(err(
                    i,
                    "below",
                    format!(
                        "layer {:?} ({:?}) needs {} below it, but {:?} provides {}",
                        s.id,
                        s.protocol,
                        need.what,
                        s.below,
                        provides(b).what
                    ),
                ));
            }
            let needs = &shapes[i].needs_uses;
            if s.uses.len() != needs.len() {
                return Err(err(
                    i,
                    "uses",
                    format!(
                        "layer {:?} ({:?}) uses {} layer(s) ({}), got {}",
                        s.id,
                        s.protocol,
                        needs.len(),
                        needs.iter().map(|n| n.what).collect::<Vec<_>>().join(", "),
                        s.uses.len()
                    ),
                ));
            }
            let mut us = Vec::new();
            for (u, need) in s.uses.iter().zip(needs) {
                let ix = resolve(i, "uses", u)?;
                if ix == NET || !provides(ix).serves(*need) {
                    return Err(err(
                        i,
                        "uses",
                        format!(
                            "layer {:?} needs {} from {u:?}, which provides {}",
                            s.id,
                            need.what,
                            provides(ix).what
                        ),
                    ));
                }
                us.push(ix);
            }
            below.push(b);
            uses.push(us);
        }
        // Cycles through below/uses.
        fn visit(
            i: usize,
            below: &[LayerIx],
            uses: &[Vec<LayerIx>],
            state: &mut [u8],
        ) -> Option<usize> {
            if state[i] == 2 {
                return None;
            }
            if state[i] == 1 {
                return Some(i);
            }
            state[i] = 1;
            for &j in std::iter::once(&below[i]).chain(uses[i].iter()) {
                if j != NET {
                    if let Some(c) = visit(j as usize, below, uses, state) {
                        return Some(c);
                    }
                }
            }
            state[i] = 2;
            None
        }
        let mut state = vec![0u8; specs.len()];
        for i in 0..specs.len() {
            if let Some(c) = visit(i, &below, &uses, &mut state) {
                return Err(err(c, "below", format!("layer {:?} is part of a cycle of layers; expected layers to stack without loops", specs[c].id)));
            }
        }
        let mut above = vec![Vec::new(); specs.len()];
        for i in 0..specs.len() {
            for &j in std::iter::once(&below[i]).chain(uses[i].iter()) {
                if j != NET {
                    above[j as usize].push(i as LayerIx);
                }
            }
        }
        let app_hears = above.iter().map(|a| a.is_empty()).collect();
        let wiring = Wiring {
            ids: specs.iter().map(|s| s.id.clone()).collect(),
            below,
            uses,
            above,
            app_hears,
            provides: shapes.iter().map(|s| s.provides).collect(),
            codecs: Arc::new(Codecs {
                layers: codecs,
                app: app_codec(),
            }),
        };
        Ok((wiring, Stack { layers }))
    }
}
