//! The files a model file refers to (Matrix Market matrices, load vectors, coordinates):
//! resolved relative to the model file's directory, confined to that directory tree unless
//! the caller allows otherwise, read with the bounds of [`crate::limits::read_text_file`]
//! (regular files only, size limit, UTF-8), and recorded by canonical path so that a caller
//! can refuse to overwrite an input ([`crate::Model::input_files`]).

use std::path::{Component, Path, PathBuf};

use crate::error::{Error, Result};
use crate::limits::{read_binary_file, read_text_file, Limits};
use crate::model::excerpt::excerpt;

/// How a model file is read.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct LoadOptions {
    /// Memory budget and largest input file.
    pub limits: Limits,
    /// Allow paths in the model file that leave the model file's directory tree (`..`,
    /// absolute paths, symbolic links pointing out). Off by default, so that a model file
    /// from elsewhere cannot make the program read (and quote) arbitrary files.
    pub allow_outside_paths: bool,
}

/// Reads the files a model file names and records them.
pub(crate) struct InputFiles<'a> {
    model_file: &'a Path,
    options: &'a LoadOptions,
    /// Canonical paths of every file read, in reading order.
    pub(crate) read: Vec<PathBuf>,
}

impl<'a> InputFiles<'a> {
    pub(crate) fn new(model_file: &'a Path, options: &'a LoadOptions) -> Self {
        InputFiles {
            model_file,
            options,
            read: Vec::new(),
        }
    }

    /// The limits of this load.
    pub(crate) fn limits(&self) -> &Limits {
        &self.options.limits
    }

    /// The directory the model file's paths are relative to.
    fn directory(&self) -> &Path {
        match self.model_file.parent() {
            Some(d) if !d.as_os_str().is_empty() => d,
            _ => Path::new("."),
        }
    }

    /// Read the file `name` of field `field`: returns the path as the user knows it (the
    /// model file's directory joined with `name`, for messages) and the text.
    pub(crate) fn read(&mut self, field: &str, name: &str) -> Result<(PathBuf, String)> {
        self.read_with(field, name, read_text_file)
    }

    /// [`InputFiles::read`] of a file that may be binary: its bytes.
    pub(crate) fn read_bytes(&mut self, field: &str, name: &str) -> Result<(PathBuf, Vec<u8>)> {
        self.read_with(field, name, read_binary_file)
    }

    fn read_with<T>(
        &mut self,
        field: &str,
        name: &str,
        read: fn(&Path, &Limits) -> Result<T>,
    ) -> Result<(PathBuf, T)> {
        let joined = self.resolve(field, name)?;
        let canonical = joined
            .canonicalize()
            .map_err(|e| self.unreadable(field, &joined, e))?;
        if !self.options.allow_outside_paths {
            let root = self
                .directory()
                .canonicalize()
                .map_err(|e| Error::io(self.directory(), e))?;
            if !canonical.starts_with(&root) {
                return Err(self.outside(field, name));
            }
        }
        // read the canonical path, so that the file checked is the file read
        let text = read(&canonical, self.limits()).map_err(|e| match e {
            Error::Io { message, .. } => self.unreadable(field, &joined, message),
            other => other,
        })?;
        self.read.push(canonical);
        Ok((joined, text))
    }

    /// `name` joined to the model file's directory, after the checks that need no file
    /// system: no control characters, not empty, and (unless allowed) neither absolute nor
    /// climbing above the directory with `..`.
    fn resolve(&self, field: &str, name: &str) -> Result<PathBuf> {
        let file = self.model_file;
        if name.is_empty() {
            return Err(Error::field(file, field, "the file name is empty"));
        }
        if name.chars().any(char::is_control) {
            return Err(Error::field(
                file,
                field,
                format!(
                    "the file name {} contains control characters",
                    excerpt(name)
                ),
            ));
        }
        if !self.options.allow_outside_paths {
            let mut depth = 0usize;
            for c in Path::new(name).components() {
                match c {
                    Component::Normal(_) => depth += 1,
                    Component::CurDir => {}
                    Component::ParentDir if depth > 0 => depth -= 1,
                    Component::ParentDir | Component::RootDir | Component::Prefix(_) => {
                        return Err(self.outside(field, name))
                    }
                }
            }
        }
        Ok(self.directory().join(name))
    }

    fn outside(&self, field: &str, name: &str) -> Error {
        Error::field(
            self.model_file,
            field,
            format!(
                "the path {} leads outside the model file's directory; paths in a model file must stay in its directory tree (allow it with --allow-outside-paths, or `LoadOptions::allow_outside_paths`)",
                excerpt(name)
            ),
        )
    }

    fn unreadable(&self, field: &str, joined: &Path, e: impl std::fmt::Display) -> Error {
        Error::field(self.model_file, field, format!("{}: {e}", joined.display()))
    }
}
