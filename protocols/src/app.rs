//! The application's messages (seed 5.3's `NekoMessage`): what robot algorithms exchange
//! through the stack's top layers, either Neko's dynamic [`AppMsg`] or an algorithm's own
//! serde type, and how hosts render them ([`app_codec`]).

use std::fmt;

use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};

use crate::codec::Codec;
use crate::payload::{decode_bytes, Payload, WireError};
use crate::symmetry::not_renamed;
use crate::wire::{Content, APP};

/// An application message (seed 5.3's `NekoMessage`): Neko's message type name and its
/// content. Robot algorithms exchange these through the stack's top layers.
#[derive(Clone, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
pub struct AppMsg {
    pub kind: String,
    pub content: Content,
}

impl AppMsg {
    /// The application message `kind` with `content`.
    pub fn new(kind: &str, content: Content) -> Self {
        Self {
            kind: kind.to_string(),
            content,
        }
    }

    /// Encoded as the application's payload.
    pub fn payload(&self) -> Payload {
        Payload::encode(APP, &AppWireRef::Dynamic(self))
    }

    /// The application message a payload encodes, if it is the application's and of this form.
    pub fn of(p: &Payload) -> Option<Self> {
        match decode_app(p)? {
            AppWire::Dynamic(m) => Some(m),
            AppWire::Typed(_) => None,
        }
    }
}

impl fmt::Display for AppMsg {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} {}", self.kind, self.content)
    }
}

/// What the application's payloads hold: a dynamic [`AppMsg`], or an algorithm's own typed
/// message as compact RON text (self-describing, so every tool can show it without its type).
#[derive(Deserialize)]
enum AppWire {
    Dynamic(AppMsg),
    Typed(String),
}

/// [`AppWire`] borrowed, for encoding (the same postcard layout).
#[derive(Serialize)]
enum AppWireRef<'a> {
    Dynamic(&'a AppMsg),
    Typed(&'a str),
}

fn decode_app(p: &Payload) -> Option<AppWire> {
    (p.layer() == APP).then(|| p.decode().ok()).flatten()
}

/// An algorithm's own message (any serde type) as the application's payload: compact RON with
/// type names, so the log shows `GOTO(60.2, 31.7)` and its type `GOTO`.
///
/// # Panics
/// If `msg`'s serde form cannot be written as RON (a map with non-string keys can; a type
/// whose `Serialize` fails cannot).
pub fn app_payload<M: Serialize>(msg: &M) -> Payload {
    let text = compact_ron(msg)
        .unwrap_or_else(|e| panic!("an application message cannot be written: {e}"));
    Payload::encode(APP, &AppWireRef::Typed(&text))
}

/// A value as one line of RON with type names (`GOTO(60.2, 31.7)`): how the algorithms' own
/// messages and registered sensors' values travel and show.
pub fn compact_ron<T: Serialize>(value: &T) -> Result<String, ron::Error> {
    let cfg = ron::ser::PrettyConfig::new()
        .struct_names(true)
        .compact_arrays(true)
        .compact_structs(true)
        .compact_maps(true)
        .new_line("")
        .indentor("");
    ron::ser::to_string_pretty(value, cfg)
}

/// The algorithm's own message a payload carries, if it is the application's and reads as an
/// `M`.
pub fn app_decode<M: DeserializeOwned>(p: &Payload) -> Option<M> {
    match decode_app(p)? {
        AppWire::Typed(text) => ron::from_str(&text).ok(),
        AppWire::Dynamic(_) => None,
    }
}

fn render_app(bytes: &[u8], f: &mut fmt::Formatter<'_>) -> Result<fmt::Result, WireError> {
    Ok(match decode_bytes::<AppWire>(bytes)? {
        AppWire::Dynamic(m) => fmt::Display::fmt(&m, f),
        AppWire::Typed(text) => f.write_str(&text),
    })
}

/// How the application's messages render: `KIND content`.
pub fn app_codec() -> Codec {
    Codec {
        protocol: "app",
        render: render_app,
        render_timer: render_app,
        rename: not_renamed,
        rename_timer: not_renamed,
    }
}
