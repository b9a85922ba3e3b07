//! Every output file of the project is written the same way: to a
//! temporary sibling, flushed and fsynced, then renamed over the target.
//!
//! ```text
//! create   PATH.tmp  (truncated)
//! write    … through a buffer
//! commit   flush → fsync → rename PATH.tmp → PATH
//! drop     without commit (a failed run): PATH.tmp removed, PATH untouched
//! ```
//! A rename within one directory is atomic, so a reader sees the old file
//! or the complete new one, and a failed or interrupted run never leaves a
//! partial file under the target's name.

use std::fs::File;
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};

/// The temporary sibling of `path` used while writing: `PATH.tmp`.
pub fn temporary_path(path: &Path) -> PathBuf {
    let mut name = path.file_name().unwrap_or_default().to_os_string();
    name.push(".tmp");
    path.with_file_name(name)
}

/// A file being written under its temporary name (see the module docs).
#[derive(Debug)]
pub struct AtomicFile {
    path: PathBuf,
    tmp: PathBuf,
    writer: Option<BufWriter<File>>,
}

impl AtomicFile {
    /// Starts writing `path` (through `PATH.tmp`; the parent directory must
    /// exist).
    pub fn create(path: &Path) -> io::Result<AtomicFile> {
        let tmp = temporary_path(path);
        let file = File::create(&tmp)?;
        Ok(AtomicFile {
            path: path.to_path_buf(),
            tmp,
            writer: Some(BufWriter::new(file)),
        })
    }

    /// The target path.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Flushes, fsyncs and renames the file into place. On failure the
    /// temporary file is removed and the target is left as it was.
    pub fn commit(mut self) -> io::Result<()> {
        let Some(writer) = self.writer.take() else {
            return Err(io::Error::other("already committed"));
        };
        let result = writer
            .into_inner()
            .map_err(io::IntoInnerError::into_error)
            .and_then(|file| file.sync_all())
            .and_then(|()| std::fs::rename(&self.tmp, &self.path));
        if result.is_err() {
            let _ = std::fs::remove_file(&self.tmp);
        }
        result
    }
}

impl Write for AtomicFile {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        match &mut self.writer {
            Some(w) => w.write(buf),
            None => Err(io::Error::other("already committed")),
        }
    }

    fn flush(&mut self) -> io::Result<()> {
        match &mut self.writer {
            Some(w) => w.flush(),
            None => Ok(()),
        }
    }
}

impl Drop for AtomicFile {
    /// An uncommitted file is abandoned: its temporary is removed.
    fn drop(&mut self) {
        if self.writer.take().is_some() {
            let _ = std::fs::remove_file(&self.tmp);
        }
    }
}

/// Writes `bytes` to `path` atomically (see the module docs).
pub fn write_atomically(path: &Path, bytes: &[u8]) -> io::Result<()> {
    let mut file = AtomicFile::create(path)?;
    file.write_all(bytes)?;
    file.commit()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scratch(name: &str) -> PathBuf {
        let dir =
            std::env::temp_dir().join(format!("hyperpbd-atomic-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).expect("scratch dir");
        dir
    }

    #[test]
    fn commit_replaces_and_drop_abandons() {
        let dir = scratch("commit");
        let path = dir.join("out.txt");
        write_atomically(&path, b"first").expect("write");
        assert_eq!(std::fs::read(&path).expect("read"), b"first");
        let mut file = AtomicFile::create(&path).expect("create");
        file.write_all(b"second, never committed").expect("write");
        drop(file);
        assert_eq!(std::fs::read(&path).expect("read"), b"first");
        assert!(!temporary_path(&path).exists());
        let names: Vec<_> = std::fs::read_dir(&dir).expect("list").collect();
        assert_eq!(names.len(), 1);
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn a_missing_directory_is_an_error_and_leaves_nothing() {
        let dir = scratch("missing");
        let path = dir.join("no-such-dir").join("out.txt");
        assert!(write_atomically(&path, b"x").is_err());
        assert!(!path.exists() && !temporary_path(&path).exists());
        let _ = std::fs::remove_dir_all(&dir);
    }
}
