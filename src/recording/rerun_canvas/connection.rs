//! The connection to a running Rerun viewer (`--connect`): the URL checked, a gRPC sink that
//! answered before the run starts, the recording stream over it, and its end.
//!
//! Waiting on the wall clock here is about the network, never about the simulation: what is
//! sent is the same whether or not a viewer is connected.

use rerun::external::re_log_types::{BlueprintActivationCommand, LogMsg};
use rerun::sink::GrpcSink;
use rerun::{RecordingStream, RecordingStreamBuilder};

use super::{rerun_err, APP};
use crate::recording::RecordingError;

/// How long a viewer has to answer `--connect`, and to take the rest of the stream at the end.
pub const VIEWER_TIMEOUT: std::time::Duration = std::time::Duration::from_secs(5);

/// The viewer that `connect` names (`Some(None)`: the SDK's default URL), connected, with its
/// URL; `None` when no viewer is asked for. A bad URL or a viewer that does not answer is the
/// user's input, refused before anything is written.
pub fn open(
    connect: Option<&Option<String>>,
) -> Result<Option<(String, GrpcSink)>, RecordingError> {
    let Some(url) = connect else {
        return Ok(None);
    };
    let url = url
        .clone()
        .unwrap_or_else(|| rerun::DEFAULT_CONNECT_URL.to_string());
    let uri = match url.parse::<rerun::external::re_uri::RedapUri>() {
        Ok(rerun::external::re_uri::RedapUri::Proxy(uri)) => uri,
        Ok(_) => {
            return Err(RecordingError::Url {
                url,
                message: "not a /proxy endpoint".into(),
            })
        }
        Err(e) => {
            return Err(RecordingError::Url {
                url,
                message: e.to_string(),
            })
        }
    };
    // A viewer must answer before the run starts: the SDK would otherwise queue the
    // recording and block once its queue is full.
    let sink = connect_sink(&url, uri)?;
    Ok(Some((url, sink)))
}

/// A gRPC sink connected to the viewer at `url`, or why there is none.
fn connect_sink(
    url: &str,
    uri: rerun::external::re_uri::ProxyUri,
) -> Result<GrpcSink, RecordingError> {
    use rerun::sink::GrpcSinkConnectionState as State;
    let sink = GrpcSink::new(uri);
    let start = std::time::Instant::now();
    loop {
        match sink.status() {
            State::Connected => return Ok(sink),
            State::Disconnected(r) => {
                return Err(RecordingError::Unreachable {
                    url: url.to_string(),
                    message: match r {
                        Err(e) => e.to_string(),
                        Ok(()) => "disconnected".into(),
                    },
                })
            }
            State::Connecting { .. } if start.elapsed() > VIEWER_TIMEOUT => {
                return Err(RecordingError::Unreachable {
                    url: url.to_string(),
                    message: format!("no answer in {} s", VIEWER_TIMEOUT.as_secs()),
                })
            }
            State::Connecting { .. } => std::thread::sleep(std::time::Duration::from_millis(20)),
        }
    }
}

/// The recording stream `recording_id` to the viewer behind `sink`, which gets the default
/// blueprint first.
pub fn stream(
    recording_id: String,
    sink: GrpcSink,
    blueprint: Vec<LogMsg>,
    activation: BlueprintActivationCommand,
) -> Result<RecordingStream, RecordingError> {
    let rec = RecordingStreamBuilder::new(APP)
        .recording_id(recording_id)
        .set_sinks(vec![Box::new(sink) as Box<dyn rerun::sink::LogSink>])
        .map_err(rerun_err)?;
    rec.send_blueprint(blueprint, activation);
    Ok(rec)
}

/// Hands the rest of the stream to the viewer at `url`, waiting at most [`VIEWER_TIMEOUT`].
pub fn close(rec: RecordingStream, url: &str) -> Result<(), RecordingError> {
    match rec.flush_with_timeout(VIEWER_TIMEOUT) {
        Ok(()) => {
            drop(rec);
            Ok(())
        }
        Err(e) => {
            // The viewer went away during the run. The SDK's sending thread may be blocked
            // on it for good, and dropping the stream would wait for that thread: the stream
            // is leaked instead, on this error path only.
            std::mem::forget(rec);
            Err(RecordingError::Unreachable {
                url: url.to_string(),
                message: e.to_string(),
            })
        }
    }
}
