//! .rrd files written by nekosim with Rerun's own encoder, so that the same run gives the same
//! bytes.
//!
//! Rerun's `FileSink` and the SDK's blueprint builder stamp messages with ids from the wall
//! clock and a random generator. Here every message is built with ids that are a function of
//! the run: the recording id comes from [`super::rerun_canvas`], and rows and chunks are
//! numbered in the order they are sent ([`Ids`]). The file is encoded as the SDK encodes it
//! (LZ4-compressed Arrow IPC) on a thread of its own; [`RrdFile::finish`] writes Rerun's footer
//! and returns the first error.
//!
//! Every message up to the footer is a function of the run. The footer (an index of the chunks,
//! for random access) is not byte for byte: Rerun's encoder orders its columns by a hash map
//! seeded per process. docs/visualization.md says so.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::mpsc::{sync_channel, SyncSender};
use std::thread::JoinHandle;

use rerun::external::re_build_info::CrateVersion;
use rerun::external::re_log_encoding::{Encoder, EncodingOptions};
use rerun::external::re_log_types::{LogMsg, SetStoreInfo, StoreId, StoreInfo, StoreSource};
use rerun::log::{Chunk, ChunkId, RowId};

/// The timestamp half of row and chunk ids (Rerun's ids are a time and a counter): a constant,
/// so ids are the counter alone. 2020-01-01 in nanoseconds since 1970.
const ID_EPOCH_NANOS: u128 = 1_577_836_800_000_000_000;

/// Messages queued for the writer thread before the recorder waits for it.
const QUEUE: usize = 64;

/// Row and chunk ids numbered from 0 in the order they are handed out.
#[derive(Debug, Default)]
pub struct Ids {
    rows: u64,
    chunks: u64,
}

impl Ids {
    fn id(n: u64) -> u128 {
        (ID_EPOCH_NANOS << 64) | u128::from(n)
    }

    /// The ids of the next `n` rows.
    pub fn rows(&mut self, n: usize) -> Vec<RowId> {
        let first = self.rows;
        self.rows += n as u64;
        (first..self.rows)
            .map(|i| RowId::from_u128(Self::id(i)))
            .collect()
    }

    /// The next chunk id.
    pub fn chunk(&mut self) -> ChunkId {
        self.chunks += 1;
        ChunkId::from_u128(Self::id(self.chunks - 1))
    }

    /// A header message (`SetStoreInfo`) with the next row id.
    pub fn store_info(&mut self, store_id: StoreId) -> LogMsg {
        let row_id = self.rows(1)[0];
        LogMsg::SetStoreInfo(SetStoreInfo {
            row_id: *row_id,
            info: StoreInfo::new(store_id, StoreSource::Other("nekosim".into())),
        })
    }
}

/// An .rrd file being written.
#[derive(Debug)]
pub struct RrdFile {
    store: StoreId,
    tx: Option<SyncSender<LogMsg>>,
    thread: Option<JoinHandle<Result<(), String>>>,
}

impl RrdFile {
    /// Creates the file at `path` for the recording `store`; it starts with `prelude` (the
    /// blueprint: header, chunks, activation).
    pub fn create(
        path: &Path,
        store: StoreId,
        prelude: &[LogMsg],
        ids: &mut Ids,
    ) -> std::io::Result<Self> {
        let file = std::fs::File::create(path)?;
        let (tx, rx) = sync_channel::<LogMsg>(QUEUE);
        let thread = std::thread::Builder::new()
            .name("rrd-writer".into())
            .spawn(move || {
                let e = |e: &dyn std::fmt::Display| e.to_string();
                let mut enc = Encoder::new_eager(
                    CrateVersion::LOCAL,
                    EncodingOptions::PROTOBUF_COMPRESSED,
                    std::io::BufWriter::with_capacity(1 << 20, file),
                )
                .map_err(|x| e(&x))?;
                for msg in rx {
                    enc.append(&msg).map_err(|x| e(&x))?;
                }
                enc.finish().map_err(|x| e(&x))?;
                let mut w = enc.into_inner().map_err(|x| e(&x))?;
                w.flush().map_err(|x| e(&x))?;
                Ok(())
            })?;
        let file = Self {
            store: store.clone(),
            tx: Some(tx),
            thread: Some(thread),
        };
        file.send(ids.store_info(store));
        file.messages(prelude.iter().cloned());
        Ok(file)
    }

    fn send(&self, msg: LogMsg) {
        if let Some(tx) = &self.tx {
            // A closed channel means the writer failed; `finish` reports why.
            let _ = tx.send(msg);
        }
    }

    /// Appends a chunk of the recording.
    pub fn chunk(&self, chunk: &Chunk) -> Result<(), String> {
        let msg = chunk.to_arrow_msg().map_err(|e| e.to_string())?;
        self.send(LogMsg::ArrowMsg(self.store.clone(), msg));
        Ok(())
    }

    /// Appends messages as they are (e.g. the blueprint's).
    pub fn messages(&self, msgs: impl IntoIterator<Item = LogMsg>) {
        for msg in msgs {
            self.send(msg);
        }
    }

    /// Ends the stream: Rerun's footer is written and the file synced. The first error of the
    /// writer, if any, is returned.
    pub fn finish(&mut self) -> Result<(), String> {
        drop(self.tx.take());
        match self.thread.take().map(JoinHandle::join) {
            None => Ok(()),
            Some(Ok(r)) => r,
            Some(Err(_)) => Err("the .rrd writer thread panicked".into()),
        }
    }
}

impl Drop for RrdFile {
    fn drop(&mut self) {
        let _ = self.finish();
    }
}

/// Where the .rrd file for `target` is written until it is complete: a hidden name beside it,
/// so a reader never sees half a recording under the target's name and a rename publishes it.
pub fn temp_path(target: &Path) -> std::io::Result<PathBuf> {
    let dir = target
        .parent()
        .filter(|d| !d.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    if target.is_dir() {
        return Err(std::io::Error::new(
            std::io::ErrorKind::InvalidInput,
            "is a directory; expected a file name such as run.rrd",
        ));
    }
    let name = target.file_name().ok_or_else(|| {
        std::io::Error::new(
            std::io::ErrorKind::InvalidInput,
            "output path has no file name",
        )
    })?;
    std::fs::create_dir_all(dir)?;
    Ok(dir.join(format!(
        ".{}.partial-{}",
        name.to_string_lossy(),
        std::process::id()
    )))
}
