//! Checking outputs before anything is computed: each command declares the files it will
//! write (with the option that named them) and the files it reads, and [`OutputPlan::check`]
//! refuses, in one line naming the option and the path:
//!
//! * a target that exists and is not a regular file (directory, character or block device,
//!   FIFO, socket) — replacing it would destroy it, and writing into it may block forever;
//! * a symbolic link to anything but a regular file; a symbolic link to a regular file is
//!   followed: the file it points to is replaced atomically and the link stays;
//! * a target whose directory does not exist or is not writable;
//! * a plot whose extension is not `.svg` or `.png`;
//! * an output that is one of the inputs (the model file, `--from-solution`, the files the
//!   model reads) or another output (`--output x --plot x`): compared by device and inode
//!   when the file exists (hard links, symlinks, `./x` and `x` alike), by canonical path
//!   otherwise;
//! * with [`OutputPlan::output_new`], a target that exists (`export` without `--force`).
//!
//! [`check_target`] is the check of one file; [`super::atomic`] applies it again to every
//! file it writes, so that a file whose name is only known later (the paper's figures)
//! follows the same policy.

use std::collections::HashMap;
use std::fs::{FileType, Metadata};
use std::path::{Path, PathBuf};

use anyhow::{anyhow, bail, Result};

/// What an output holds, which decides the extensions it may have.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum OutputKind {
    /// CSV data (any name).
    Data,
    /// A plot: `.svg` or `.png`, the format follows the extension.
    Plot,
    /// Text (summary, model and matrix files; any name).
    Text,
}

impl OutputKind {
    /// The allowed extensions (lower case), `None` for any.
    pub fn extensions(self) -> Option<&'static [&'static str]> {
        match self {
            OutputKind::Plot => Some(&["svg", "png"]),
            OutputKind::Data | OutputKind::Text => None,
        }
    }
}

/// What a file type is, for messages.
fn describe(t: &FileType) -> &'static str {
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if t.is_char_device() {
            return "a character device";
        }
        if t.is_block_device() {
            return "a block device";
        }
        if t.is_fifo() {
            return "a FIFO (named pipe)";
        }
        if t.is_socket() {
            return "a socket";
        }
    }
    if t.is_dir() {
        "a directory"
    } else if t.is_symlink() {
        "a symbolic link"
    } else {
        "not a regular file"
    }
}

/// The directory an output is written into ("." for a bare file name).
pub fn directory_of(path: &Path) -> &Path {
    path.parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."))
}

#[cfg(unix)]
fn writable(dir: &Path) -> bool {
    use std::os::unix::ffi::OsStrExt;
    let Ok(c) = std::ffi::CString::new(dir.as_os_str().as_bytes()) else {
        return false;
    };
    // SAFETY: `c` is a valid NUL-terminated path; access only reads it.
    unsafe { libc::access(c.as_ptr(), libc::W_OK | libc::X_OK) == 0 }
}

#[cfg(not(unix))]
fn writable(dir: &Path) -> bool {
    std::fs::metadata(dir).is_ok_and(|m| !m.permissions().readonly())
}

/// Check one output `path` (named by `option` in messages) of `kind`; returns the path to
/// write: `path` itself, or the regular file a symbolic link at `path` points to.
/// `option` may be empty (a file whose name the command chose): messages then start with
/// the path.
pub fn check_target(option: &str, path: &Path, kind: OutputKind) -> Result<PathBuf> {
    let shown = match option {
        "" => path.display().to_string(),
        o => format!("{o} {}", path.display()),
    };
    if path.file_name().is_none() {
        bail!("{shown}: not a file path");
    }
    if let Some(allowed) = kind.extensions() {
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase);
        if !ext.as_deref().is_some_and(|e| allowed.contains(&e)) {
            bail!(
                "{shown}: unknown plot format; the file name must end in {}",
                allowed
                    .iter()
                    .map(|e| format!(".{e}"))
                    .collect::<Vec<_>>()
                    .join(" or ")
            );
        }
    }
    let target = match std::fs::symlink_metadata(path) {
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => path.to_path_buf(),
        Err(e) => bail!("{shown}: cannot inspect: {e}"),
        Ok(m) if m.file_type().is_file() => path.to_path_buf(),
        Ok(m) if m.file_type().is_symlink() => match std::fs::metadata(path) {
            Ok(t) if t.is_file() => std::fs::canonicalize(path)
                .map_err(|e| anyhow!("{shown}: cannot resolve the symbolic link: {e}"))?,
            Ok(t) => bail!(
                "{shown}: is a symbolic link to {}; outputs must be regular files or new paths",
                describe(&t.file_type())
            ),
            Err(_) => bail!(
                "{shown}: is a symbolic link to nothing; outputs must be regular files or new paths"
            ),
        },
        Ok(m) => bail!(
            "{shown}: is {}; outputs must be regular files or new paths",
            describe(&m.file_type())
        ),
    };
    let dir = directory_of(&target);
    match std::fs::metadata(dir) {
        Ok(m) if m.is_dir() => {}
        Ok(_) => bail!("{shown}: {} is not a directory", dir.display()),
        Err(_) => bail!("{shown}: the directory {} does not exist", dir.display()),
    }
    if !writable(dir) {
        bail!("{shown}: the directory {} is not writable", dir.display());
    }
    Ok(target)
}

/// Who a file is: its device and inode when it exists, and its canonical path (the
/// directory canonicalized, the name appended) to compare files that do not exist yet.
#[derive(Debug)]
struct Identity {
    inode: Option<(u64, u64)>,
    path: PathBuf,
}

impl Identity {
    fn of(path: &Path) -> Identity {
        let inode = std::fs::metadata(path).ok().and_then(|m| inode(&m));
        let canonical = std::fs::canonicalize(path).unwrap_or_else(|_| {
            let dir = std::fs::canonicalize(directory_of(path))
                .unwrap_or_else(|_| directory_of(path).to_path_buf());
            match path.file_name() {
                Some(name) => dir.join(name),
                None => dir,
            }
        });
        Identity {
            inode,
            path: canonical,
        }
    }

    fn same(&self, other: &Identity) -> bool {
        match (self.inode, other.inode) {
            (Some(a), Some(b)) => a == b,
            _ => self.path == other.path,
        }
    }
}

#[cfg(unix)]
fn inode(m: &Metadata) -> Option<(u64, u64)> {
    use std::os::unix::fs::MetadataExt;
    Some((m.dev(), m.ino()))
}

#[cfg(not(unix))]
fn inode(_m: &Metadata) -> Option<(u64, u64)> {
    None
}

struct Planned {
    option: String,
    path: PathBuf,
    kind: OutputKind,
    /// Refuse a target that exists.
    must_be_new: bool,
}

/// The inputs and outputs of one command, checked together before computing.
#[derive(Default)]
pub struct OutputPlan {
    inputs: Vec<(String, PathBuf)>,
    outputs: Vec<Planned>,
}

impl OutputPlan {
    pub fn new() -> Self {
        Self::default()
    }

    /// A file the command reads (`what`: e.g. "the model file", "--from-solution").
    pub fn input(&mut self, what: &str, path: &Path) -> &mut Self {
        self.inputs.push((what.to_string(), path.to_path_buf()));
        self
    }

    /// Files the command reads (e.g. the files a model file refers to).
    pub fn inputs(&mut self, what: &str, paths: &[PathBuf]) -> &mut Self {
        for p in paths {
            self.input(what, p);
        }
        self
    }

    /// An output named by `option` (nothing when `path` is `None`); an existing regular
    /// file is replaced.
    pub fn output(&mut self, option: &str, path: Option<&Path>, kind: OutputKind) -> &mut Self {
        if let Some(p) = path {
            self.outputs.push(Planned {
                option: option.to_string(),
                path: p.to_path_buf(),
                kind,
                must_be_new: false,
            });
        }
        self
    }

    /// An output that must not exist yet (unless the command was told to overwrite).
    pub fn output_new(&mut self, option: &str, path: &Path, kind: OutputKind) -> &mut Self {
        self.outputs.push(Planned {
            option: option.to_string(),
            path: path.to_path_buf(),
            kind,
            must_be_new: true,
        });
        self
    }

    /// Check every output (see the module docs); the first problem is the error.
    pub fn check(&self) -> Result<()> {
        let inputs: Vec<(&str, &Path, Identity)> = self
            .inputs
            .iter()
            .map(|(w, p)| (w.as_str(), p.as_path(), Identity::of(p)))
            .collect();
        // outputs met so far, indexed so that a collection of many files (`--vtk-samples`)
        // is checked in linear time: `Identity::same` compares inodes when both files
        // exist, paths otherwise
        let mut outputs: Vec<&Planned> = Vec::new();
        let mut by_inode: HashMap<(u64, u64), usize> = HashMap::new();
        let mut by_path: HashMap<PathBuf, usize> = HashMap::new();
        let mut by_path_without_inode: HashMap<PathBuf, usize> = HashMap::new();
        for o in &self.outputs {
            let shown = o.path.display();
            if o.must_be_new && std::fs::symlink_metadata(&o.path).is_ok() {
                bail!("{} {shown}: exists; give --force to overwrite it", o.option);
            }
            let target = check_target(&o.option, &o.path, o.kind)?;
            let id = Identity::of(&target);
            if let Some((what, path, _)) = inputs.iter().find(|(_, _, i)| i.same(&id)) {
                bail!(
                    "{} {shown}: is {what} {}; an output never overwrites an input",
                    o.option,
                    path.display()
                );
            }
            let earlier = match id.inode {
                Some(inode) => by_inode
                    .get(&inode)
                    .or_else(|| by_path_without_inode.get(&id.path)),
                None => by_path.get(&id.path),
            };
            if let Some(&k) = earlier {
                let other = outputs[k];
                bail!(
                    "{} {shown}: is also the output of {} {}; give each output its own file",
                    o.option,
                    other.option,
                    other.path.display()
                );
            }
            let k = outputs.len();
            match id.inode {
                Some(inode) => {
                    by_inode.insert(inode, k);
                }
                None => {
                    by_path_without_inode.insert(id.path.clone(), k);
                }
            }
            by_path.insert(id.path, k);
            outputs.push(o);
        }
        Ok(())
    }
}
