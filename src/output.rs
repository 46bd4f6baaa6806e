//! Output files that are either complete or absent: written to a temporary file beside the
//! target and renamed over it only when the run succeeded. A failed run leaves any earlier file
//! at the target untouched and no partial file behind.

use std::fs::File;
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};

/// A file being written; [`AtomicFile::commit`] publishes it, dropping it discards it.
#[derive(Debug)]
pub struct AtomicFile {
    target: PathBuf,
    temp: PathBuf,
    out: Option<BufWriter<File>>,
    error: Option<io::Error>,
}

impl AtomicFile {
    /// Starts writing `target` (through a hidden temporary file in the same directory, which
    /// is created if missing).
    pub fn create(target: &Path) -> io::Result<Self> {
        let dir = target
            .parent()
            .filter(|d| !d.as_os_str().is_empty())
            .unwrap_or(Path::new("."));
        let name = target.file_name().ok_or_else(|| {
            io::Error::new(io::ErrorKind::InvalidInput, "output path has no file name")
        })?;
        std::fs::create_dir_all(dir)?;
        let temp = dir.join(format!(
            ".{}.partial-{}",
            name.to_string_lossy(),
            std::process::id()
        ));
        let file = File::create(&temp)?;
        Ok(Self {
            target: target.to_path_buf(),
            temp,
            out: Some(BufWriter::new(file)),
            error: None,
        })
    }

    /// Appends a line; the first write error is kept and reported by `commit`.
    pub fn line(&mut self, s: &str) {
        if self.error.is_some() {
            return;
        }
        if let Some(out) = self.out.as_mut() {
            if let Err(e) = out
                .write_all(s.as_bytes())
                .and_then(|_| out.write_all(b"\n"))
            {
                self.error = Some(e);
            }
        }
    }

    /// Flushes, syncs and renames the file into place.
    pub fn commit(mut self) -> io::Result<()> {
        if let Some(e) = self.error.take() {
            return Err(e);
        }
        let out = self.out.take().expect("not committed twice");
        let file = out.into_inner().map_err(|e| e.into_error())?;
        file.sync_all()?;
        std::fs::rename(&self.temp, &self.target)
    }
}

impl Drop for AtomicFile {
    fn drop(&mut self) {
        if self.out.is_some() || self.error.is_some() || self.temp.exists() {
            self.out.take();
            let _ = std::fs::remove_file(&self.temp);
        }
    }
}

/// Writes `content` to `target` whole, or leaves the target as it was.
pub fn write_whole(target: &Path, content: &[u8]) -> io::Result<()> {
    let mut f = AtomicFile::create(target)?;
    if let Some(out) = f.out.as_mut() {
        out.write_all(content)?;
    }
    f.commit()
}
