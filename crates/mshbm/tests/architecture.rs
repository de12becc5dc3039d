//! The layer rule of the library (docs/architecture.md): a module of `crates/mshbm/src` may
//! use only modules of its own layer or of lower ones, and the library never prints.
//!
//! This test reads every source file, collects the `crate::ROOM` paths it uses (in `use`
//! lines, grouped `use crate::{…}` imports and paths in code; comments are ignored), and
//! fails naming the file and the import when `ROOM` is in a higher layer than the file's
//! own room. The layer table below is the rule's one statement in code.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// The rooms of the library, lowest layer first. A room may import rooms of its own layer
/// and of the layers before it.
const LAYERS: &[&[&str]] = &[
    &[
        "error", "limits", "sparse", "dense", "roots", "analytic", "krylov", "ode",
    ],
    &["harmonic", "fe", "contact", "modes"],
    &["model"],
    &["linear", "stability", "integrate", "solution"],
    &["problem"],
    &["newton"],
    &["method"],
    &["continuation"],
    &["frd", "solve", "simulation", "request"],
];

/// Imports that break the rule and are known, with the reason; each must be removed when
/// its reason goes away (the test fails when a listed import no longer exists).
const KNOWN_EXCEPTIONS: &[(&str, &str, &str)] = &[];

fn layer_of(room: &str) -> Option<usize> {
    LAYERS.iter().position(|layer| layer.contains(&room))
}

fn source_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).expect("read src directory") {
        let path = entry.expect("directory entry").path();
        if path.is_dir() {
            source_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

/// The room of a file: its first path component below `src`, without `.rs`.
fn room_of(relative: &str) -> &str {
    let first = relative.split('/').next().unwrap_or(relative);
    first.strip_suffix(".rs").unwrap_or(first)
}

/// The source with `//` comments (including doc comments) and string literals blanked, so
/// that doc links and messages do not count as imports or prints.
fn strip_comments_and_strings(source: &str) -> String {
    let chars: Vec<char> = source.chars().collect();
    let mut out = String::with_capacity(source.len());
    let mut i = 0;
    while i < chars.len() {
        let c = chars[i];
        if c == '/' && chars.get(i + 1) == Some(&'/') {
            while i < chars.len() && chars[i] != '\n' {
                i += 1;
            }
        } else if c == '/' && chars.get(i + 1) == Some(&'*') {
            i += 2;
            while i + 1 < chars.len() && !(chars[i] == '*' && chars[i + 1] == '/') {
                i += 1;
            }
            i += 2;
        } else if c == '"' {
            // a string literal (raw strings in this crate hold no `crate::` or `println!`)
            out.push('"');
            i += 1;
            while i < chars.len() && chars[i] != '"' {
                if chars[i] == '\\' {
                    i += 1;
                }
                i += 1;
            }
            out.push('"');
            i += 1;
        } else if c == '\'' && chars.get(i + 2) == Some(&'\'') {
            // a character literal such as '"' (not a lifetime)
            out.push_str("' '");
            i += 3;
        } else if c == '\'' && chars.get(i + 1) == Some(&'\\') {
            // an escaped character literal such as '\n' or '\''
            out.push_str("' '");
            i += 2;
            while i < chars.len() && chars[i] != '\'' {
                i += 1;
            }
            i += 1;
        } else {
            out.push(c);
            i += 1;
        }
    }
    out
}

fn is_ident_char(c: char) -> bool {
    c.is_alphanumeric() || c == '_'
}

fn leading_ident(s: &str) -> &str {
    let s = s.trim_start();
    let end = s.find(|c: char| !is_ident_char(c)).unwrap_or(s.len());
    &s[..end]
}

/// The rooms named by `crate::ROOM` paths in `code`, with the path as written (for the
/// message). `crate::{a::x, b}` names `a` and `b`.
fn crate_paths(code: &str) -> Vec<(String, String)> {
    module_paths(code)
        .into_iter()
        .filter(|path| path[0] == "crate" && path.len() > 1)
        .map(|path| (path[1].clone(), path.join("::")))
        .collect()
}

fn library_sources() -> BTreeMap<String, String> {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    source_files(&src, &mut files);
    files
        .into_iter()
        .map(|path| {
            let relative = path
                .strip_prefix(&src)
                .expect("file under src")
                .to_string_lossy()
                .replace('\\', "/");
            let source = std::fs::read_to_string(&path).expect("read source file");
            (relative, strip_comments_and_strings(&source))
        })
        .collect()
}

/// Every `(file, room imported, path)` that breaks the layer rule.
fn upward_imports(sources: &BTreeMap<String, String>) -> Vec<(String, String, String)> {
    let mut violations = Vec::new();
    for (file, code) in sources {
        if file == "lib.rs" {
            continue;
        }
        let room = room_of(file);
        let Some(own) = layer_of(room) else {
            violations.push((
                file.clone(),
                room.to_string(),
                "(room not in the layer table)".into(),
            ));
            continue;
        };
        for (imported, path) in crate_paths(code) {
            match layer_of(&imported) {
                Some(layer) if layer <= own => {}
                Some(_) => violations.push((file.clone(), imported, path)),
                // `crate::Error`, `crate::Result`, … re-exported at the root from `error`
                // and `model`
                None => match imported.as_str() {
                    "Error" | "Result" => {}
                    "Model" | "System" | "MassKind" if own >= layer_of("model").unwrap() => {}
                    _ => violations.push((file.clone(), imported, path)),
                },
            }
        }
    }
    violations
}

#[test]
fn every_room_is_in_the_layer_table() {
    let sources = library_sources();
    assert!(
        sources.len() > 20,
        "found only {} source files",
        sources.len()
    );
    let lib = &sources["lib.rs"];
    for room in crate_paths(lib).iter().map(|(room, _)| room.clone()).chain(
        lib.lines()
            .filter_map(|l| {
                l.trim()
                    .strip_prefix("pub mod ")
                    .or(l.trim().strip_prefix("mod "))
            })
            .map(|l| l.trim_end_matches(';').trim().to_string()),
    ) {
        if room == "error" || room == "model" {
            continue;
        }
        assert!(
            layer_of(&room).is_some(),
            "lib.rs declares `{room}`, which the layer table lacks"
        );
    }
}

#[test]
fn no_module_imports_a_higher_layer() {
    let sources = library_sources();
    let mut violations = upward_imports(&sources);
    for (file, room, reason) in KNOWN_EXCEPTIONS {
        let before = violations.len();
        violations.retain(|(f, r, _)| !(f == file && r == room));
        assert!(
            violations.len() < before,
            "the known exception {file} → {room} ({reason}) no longer exists: remove it from \
             KNOWN_EXCEPTIONS"
        );
    }
    let message: Vec<String> = violations
        .iter()
        .map(|(file, room, path)| {
            let from = room_of(file);
            format!(
                "src/{file} (room `{from}`, layer {:?}) imports `{path}` (room `{room}`, layer {:?})",
                layer_of(from),
                layer_of(room)
            )
        })
        .collect();
    assert!(
        message.is_empty(),
        "upward imports:\n{}",
        message.join("\n")
    );
}

#[test]
fn the_library_never_prints() {
    let mut prints = Vec::new();
    for (file, code) in library_sources() {
        for (number, line) in code.lines().enumerate() {
            for mac in ["println!", "eprintln!", "print!", "eprint!", "dbg!"] {
                let hit = line
                    .match_indices(mac)
                    .any(|(i, _)| !line[..i].chars().next_back().is_some_and(is_ident_char));
                if hit {
                    prints.push(format!("src/{file}:{}: {}", number + 1, line.trim()));
                }
            }
        }
    }
    assert!(
        prints.is_empty(),
        "the library prints:\n{}",
        prints.join("\n")
    );
}

#[test]
fn the_scanner_finds_imports_and_prints() {
    let code = strip_comments_and_strings(
        "use crate::{error::Error, method::x};\n// crate::continuation\nlet s = \"crate::model println!\";\nlet c = '\"'; crate::harmonic::basis(1, 0.0);\n",
    );
    let rooms: Vec<String> = crate_paths(&code).into_iter().map(|(r, _)| r).collect();
    assert_eq!(rooms, ["error", "method", "harmonic"]);
    assert!(!code.contains("println!"));
    let mut sources = BTreeMap::new();
    sources.insert(
        "dense.rs".to_string(),
        "use crate::model::Model;".to_string(),
    );
    sources.insert(
        "model/a.rs".to_string(),
        "fn f() { crate::dense::x(); }".to_string(),
    );
    let violations = upward_imports(&sources);
    assert_eq!(violations.len(), 1);
    assert_eq!(violations[0].0, "dense.rs");
    assert_eq!(violations[0].1, "model");
}

// --- import circles between modules ------------------------------------------------------

/// Circles between modules that are known, with the reason they stay; each must be removed
/// when its reason goes away (the test fails when a listed circle no longer exists).
const KNOWN_CYCLES: &[(&[&str], &str)] = &[];

/// The module path of a file below `src`: `method/memory.rs` → `method::memory`,
/// `method/redistributed/mod.rs` → `method::redistributed`, `lib.rs` → the root.
fn module_of(file: &str) -> Vec<String> {
    let stem = file.strip_suffix(".rs").unwrap_or(file);
    let mut parts: Vec<String> = stem.split('/').map(str::to_string).collect();
    if matches!(parts.last().map(String::as_str), Some("mod" | "lib")) {
        parts.pop();
    }
    parts
}

/// Every path in `code` that starts with `crate::`, `super::` or `self::`, expanded over
/// groups (`super::{a::x, b}` gives `super::a::x` and `super::b`), as segments.
fn module_paths(code: &str) -> Vec<Vec<String>> {
    /// The paths of the tree at `s` (after a `::`), appended to `prefix`.
    fn expand(s: &str, prefix: &[String], out: &mut Vec<Vec<String>>) {
        let s = s.trim_start();
        if let Some(group) = s.strip_prefix('{') {
            let mut depth = 1;
            let mut start = 0;
            for (i, c) in group.char_indices() {
                match c {
                    '{' => depth += 1,
                    '}' => {
                        depth -= 1;
                        if depth == 0 {
                            expand(&group[start..i], prefix, out);
                            return;
                        }
                    }
                    ',' if depth == 1 => {
                        expand(&group[start..i], prefix, out);
                        start = i + 1;
                    }
                    _ => {}
                }
            }
            return;
        }
        let ident = leading_ident(s);
        if ident.is_empty() {
            out.push(prefix.to_vec());
            return;
        }
        let mut path = prefix.to_vec();
        path.push(ident.to_string());
        let rest = &s[ident.len()..];
        match rest.trim_start().strip_prefix("::") {
            Some(after) => expand(after, &path, out),
            None => out.push(path),
        }
    }
    let mut out = Vec::new();
    for start in ["crate::", "super::", "self::"] {
        let mut from = 0;
        while let Some(pos) = code[from..].find(start) {
            let at = from + pos;
            from = at + start.len();
            let before = code[..at].trim_end();
            if code[..at].chars().next_back().is_some_and(is_ident_char) || before.ends_with("::") {
                continue; // `mycrate::`, or `super::super::` counted from its first
            }
            let head = start.trim_end_matches("::").to_string();
            expand(&code[from..], &[head], &mut out);
        }
    }
    out
}

/// The module a path from `module` names (the longest prefix that is a module), by file.
fn resolve(
    module: &[String],
    path: &[String],
    modules: &BTreeMap<Vec<String>, String>,
) -> Option<String> {
    let mut base: Vec<String> = match path[0].as_str() {
        "crate" => Vec::new(),
        _ => module.to_vec(),
    };
    let mut rest = &path[1..];
    if path[0] == "super" {
        base.pop();
    }
    while rest.first().is_some_and(|s| s == "super") {
        base.pop();
        rest = &rest[1..];
    }
    let mut candidate = base;
    let mut best = modules.get(&candidate).cloned();
    for segment in rest {
        candidate.push(segment.clone());
        match modules.get(&candidate) {
            Some(f) => best = Some(f.clone()),
            None => break,
        }
    }
    best
}

/// The import graph between files: an edge for each path of a file that names another
/// module, except between a module and its ancestors (a `mod.rs` declares and re-exports
/// its children, which use its items).
fn import_graph(sources: &BTreeMap<String, String>) -> BTreeMap<String, Vec<String>> {
    let modules: BTreeMap<Vec<String>, String> =
        sources.keys().map(|f| (module_of(f), f.clone())).collect();
    let mut graph: BTreeMap<String, Vec<String>> = BTreeMap::new();
    for (file, code) in sources {
        let module = module_of(file);
        let edges = graph.entry(file.clone()).or_default();
        for path in module_paths(code) {
            let Some(target) = resolve(&module, &path, &modules) else {
                continue;
            };
            let target_module = module_of(&target);
            if target_module.starts_with(&module) || module.starts_with(&target_module) {
                continue;
            }
            if !edges.contains(&target) {
                edges.push(target);
            }
        }
        edges.sort();
    }
    graph
}

/// The circles of `graph`: its strongly connected components of more than one file, each
/// sorted.
fn circles(graph: &BTreeMap<String, Vec<String>>) -> Vec<Vec<String>> {
    let reach = |from: &str| {
        let mut seen = std::collections::BTreeSet::new();
        let mut stack = vec![from.to_string()];
        while let Some(f) = stack.pop() {
            for t in graph.get(&f).into_iter().flatten() {
                if seen.insert(t.clone()) {
                    stack.push(t.clone());
                }
            }
        }
        seen
    };
    let reached: BTreeMap<&String, _> = graph.keys().map(|f| (f, reach(f))).collect();
    let mut found: Vec<Vec<String>> = Vec::new();
    for f in graph.keys() {
        let mut component: Vec<String> = reached[f]
            .iter()
            .filter(|g| *g != f && reached.get(g).is_some_and(|r| r.contains(f)))
            .cloned()
            .collect();
        if component.is_empty() {
            continue;
        }
        component.push(f.clone());
        component.sort();
        if !found.contains(&component) {
            found.push(component);
        }
    }
    found
}

#[test]
fn the_cycle_check_finds_a_circle() {
    let sources: BTreeMap<String, String> = [
        ("a/x.rs", "use super::y::f; use crate::b::g;"),
        ("a/y.rs", "use crate::a::{x::h, mod_item};"),
        ("a/mod.rs", "pub mod x; pub mod y; pub use self::x::h;"),
        ("b.rs", "use crate::a::mod_item;"),
    ]
    .into_iter()
    .map(|(f, c)| (f.to_string(), c.to_string()))
    .collect();
    let graph = import_graph(&sources);
    assert_eq!(
        graph["a/x.rs"],
        vec!["a/y.rs".to_string(), "b.rs".to_string()]
    );
    assert_eq!(
        circles(&graph),
        vec![vec!["a/x.rs".to_string(), "a/y.rs".to_string()]]
    );
}

#[test]
fn no_import_circle_between_modules() {
    let found = circles(&import_graph(&library_sources()));
    let mut unknown = found.clone();
    for (files, reason) in KNOWN_CYCLES {
        let known: Vec<String> = files.iter().map(|f| f.to_string()).collect();
        let before = unknown.len();
        unknown.retain(|c| *c != known);
        assert!(
            unknown.len() < before,
            "the known circle {files:?} ({reason}) no longer exists: remove it from KNOWN_CYCLES \
             (circles now: {found:?})"
        );
    }
    assert!(
        unknown.is_empty(),
        "modules that import each other (directly or through others), in src/: {unknown:?}"
    );
}

/// The most lines a library file may have without saying why (docs/architecture.md: files
/// are split by idea).
const MAX_FILE_LINES: usize = 600;

/// A file longer than [`MAX_FILE_LINES`] says why on a line `// size: <reason>` among its
/// first [`SIZE_REASON_WITHIN`] lines.
const SIZE_REASON_MARKER: &str = "// size:";
const SIZE_REASON_WITHIN: usize = 5;

/// Long files whose reason cannot be written into them now, with the reason; each must be
/// removed when it is split or carries its own reason line (the test fails then).
const KNOWN_LONG_FILES: &[(&str, &str)] = &[];

/// The reason line of a long file (`// size: <reason>` with a non-empty reason in the
/// first lines), if any.
fn size_reason(source: &str) -> Option<&str> {
    source
        .lines()
        .take(SIZE_REASON_WITHIN)
        .find_map(|line| line.trim().strip_prefix(SIZE_REASON_MARKER))
        .map(str::trim)
        .filter(|reason| !reason.is_empty())
}

/// Every library file over [`MAX_FILE_LINES`] lines without a reason line, with its length.
fn long_files_without_reason(sources: &BTreeMap<String, String>) -> Vec<(String, usize)> {
    sources
        .iter()
        .map(|(file, source)| (file, source.lines().count(), source))
        .filter(|(_, lines, source)| *lines > MAX_FILE_LINES && size_reason(source).is_none())
        .map(|(file, lines, _)| (file.clone(), lines))
        .collect()
}

/// The sources as written (comments kept: the reason is a comment).
fn raw_library_sources() -> BTreeMap<String, String> {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    source_files(&src, &mut files);
    files
        .into_iter()
        .map(|path| {
            let relative = path
                .strip_prefix(&src)
                .expect("file under src")
                .to_string_lossy()
                .replace('\\', "/");
            (
                relative,
                std::fs::read_to_string(&path).expect("read source file"),
            )
        })
        .collect()
}

#[test]
fn the_size_check_finds_a_long_file_without_reason() {
    let long = "fn f() {}\n".repeat(MAX_FILE_LINES + 1);
    let sources: BTreeMap<String, String> = [
        ("long.rs".to_string(), long.clone()),
        ("short.rs".to_string(), "fn f() {}\n".repeat(MAX_FILE_LINES)),
        (
            "reasoned.rs".to_string(),
            format!("//! A module.\n// size: one table of coefficients\n{long}"),
        ),
        (
            "empty_reason.rs".to_string(),
            format!("// size:   \n{long}"),
        ),
        (
            "late_reason.rs".to_string(),
            format!(
                "{}// size: too late\n{long}",
                "//!\n".repeat(SIZE_REASON_WITHIN)
            ),
        ),
    ]
    .into_iter()
    .collect();
    let found: Vec<String> = long_files_without_reason(&sources)
        .into_iter()
        .map(|(file, _)| file)
        .collect();
    assert_eq!(found, ["empty_reason.rs", "late_reason.rs", "long.rs"]);
}

#[test]
fn no_long_library_file_without_a_reason() {
    let mut found = long_files_without_reason(&raw_library_sources());
    for (file, reason) in KNOWN_LONG_FILES {
        let before = found.len();
        found.retain(|(f, _)| f != file);
        assert!(
            found.len() < before,
            "{file} ({reason}) is no longer over {MAX_FILE_LINES} lines without a reason: \
             remove it from KNOWN_LONG_FILES"
        );
    }
    assert!(
        found.is_empty(),
        "library files over {MAX_FILE_LINES} lines without a `{SIZE_REASON_MARKER} <reason>` \
         line among their first {SIZE_REASON_WITHIN} (split them by idea, or say why not): \
         {found:?}"
    );
}
