//! Writing a file so that its final name only ever holds a complete file: a temporary file
//! with a random name is created exclusively (`O_EXCL`: a symbolic link planted in the
//! directory cannot redirect it) beside the target, written, synced to disk, renamed over
//! the target, and the directory is synced. On every error path the temporary file is
//! removed (its guard's drop); a second SIGINT/SIGTERM removes it too
//! ([`super::interrupt`]).

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use mshbm::model::excerpt::{escape_controls, LineBreaks};
use tempfile::NamedTempFile;

use super::finite::check_csv_line;
use super::interrupt;
use super::plan::{check_target, directory_of, OutputKind};

/// A file being written under a temporary name; [`AtomicFile::commit`] puts it in place,
/// dropping it removes it.
pub struct AtomicFile {
    /// The path the user gave (for messages).
    path: PathBuf,
    /// The path that is replaced (the file a symbolic link points to, or `path`).
    target: PathBuf,
    temporary: PathBuf,
    writer: Option<BufWriter<NamedTempFile>>,
}

impl AtomicFile {
    /// Check `path` as an output of `kind` ([`check_target`]) and create its temporary
    /// file in the same directory.
    pub fn create(path: &Path, kind: OutputKind) -> Result<Self> {
        let target = check_target("", path, kind)?;
        let dir = directory_of(&target);
        let name = target
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        let prefix = format!(".{name}.");
        let mut builder = tempfile::Builder::new();
        builder.prefix(&prefix).suffix(".tmp");
        #[cfg(unix)]
        let permissions = {
            use std::os::unix::fs::PermissionsExt;
            // the mode a plain `File::create` gives (the umask applies)
            std::fs::Permissions::from_mode(0o666)
        };
        #[cfg(unix)]
        builder.permissions(permissions);
        let file = builder.tempfile_in(dir).with_context(|| {
            format!(
                "{}: cannot create a temporary file in {}",
                path.display(),
                dir.display()
            )
        })?;
        let temporary = file.path().to_path_buf();
        interrupt::register(&temporary);
        Ok(AtomicFile {
            path: path.to_path_buf(),
            target,
            temporary,
            writer: Some(BufWriter::new(file)),
        })
    }

    /// The path the user gave.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Append `bytes`; an error names the file.
    pub fn write_all(&mut self, bytes: &[u8]) -> Result<()> {
        let path = &self.path;
        self.writer
            .as_mut()
            .expect("not committed")
            .write_all(bytes)
            .with_context(|| format!("{}: cannot write", path.display()))
    }

    /// Push what is buffered to the temporary file (so that a reader sees it).
    pub fn flush(&mut self) -> Result<()> {
        let path = &self.path;
        self.writer
            .as_mut()
            .expect("not committed")
            .flush()
            .with_context(|| format!("{}: cannot write", path.display()))
    }

    /// Sync the temporary file, rename it over the target, sync the directory.
    pub fn commit(mut self) -> Result<()> {
        let path = self.path.clone();
        let cannot = || format!("{}: cannot write", path.display());
        let writer = self.writer.take().expect("committed once");
        let file = writer
            .into_inner()
            .map_err(|e| e.into_error())
            .with_context(cannot)?;
        file.as_file().sync_all().with_context(cannot)?;
        file.persist(&self.target)
            .map_err(|e| e.error)
            .with_context(cannot)?;
        interrupt::unregister(&self.temporary);
        // make the rename durable; some file systems cannot sync a directory (ignored)
        if let Ok(dir) = File::open(directory_of(&self.target)) {
            let _ = dir.sync_all();
        }
        Ok(())
    }
}

impl Drop for AtomicFile {
    fn drop(&mut self) {
        if self.writer.take().is_some() {
            // the NamedTempFile's own drop removes the file
            interrupt::unregister(&self.temporary);
        }
    }
}

/// Write `contents` to `path` atomically (an output of `kind`); refused, with nothing
/// written, when a signal asked the run to stop.
pub fn write_atomic(path: &Path, contents: &[u8], kind: OutputKind) -> Result<()> {
    interrupt::check(&format!("{} was not written", path.display()))?;
    let mut file = AtomicFile::create(path, kind)?;
    file.write_all(contents)?;
    file.commit()
}

/// Write a CSV text to `path` atomically, after checking that it holds no NaN or infinity
/// (the first line is the header naming the columns; `#` lines are comments), with control
/// characters other than line breaks and tabs escaped.
pub fn write_csv_atomic(path: &Path, text: &str) -> Result<()> {
    let mut lines = text.lines();
    let header = lines.next().unwrap_or_default();
    for (row, line) in lines.enumerate() {
        check_csv_line(path, header, row + 1, line)?;
    }
    // a name or message in a comment line cannot carry terminal escapes into the file
    let text = escape_controls(text, LineBreaks::Keep);
    write_atomic(path, text.as_bytes(), OutputKind::Data)
}
