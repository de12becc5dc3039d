//! Reader of an Abaqus input file subset (`.inp`) for `kind = "mesh"` model files
//! ([`crate::model::mesh`]): the mesh and its sets, into the same [`GmshMesh`] the Gmsh
//! reader yields, so that everything downstream (assembly, conditions, interfaces,
//! redistribution) is shared.
//!
//! What is read (keywords and parameters case-insensitive, `**` comments, data fields
//! separated by commas, a line ending with a comma continued on the next):
//! * `*NODE [, NSET=n]`: `label, x, y[, z]` (an empty field is 0);
//! * `*ELEMENT, TYPE=t [, ELSET=n]`: `label, node, node, …`, with `t` one of C3D4, C3D10,
//!   C3D8, C3D20 (3D), CPS3/CPE3, CPS6/CPE6, CPS4/CPE4 (2D; plane stress or strain is the
//!   model file's `mesh.plane`, the letter S/E of the type is not read), and, for sets
//!   only, the lower-dimensional types Gmsh writes for its physical surfaces and curves
//!   (the 2D types, CPS8/CPE8, T2D2/T2D3/T3D2/T3D3);
//! * `*NSET, NSET=n [, GENERATE] [, ELSET=e]`: node labels or earlier node sets' names;
//!   `first, last[, step]` with GENERATE; with ELSET=, the nodes of that element set;
//! * `*ELSET, ELSET=n [, GENERATE]`: element labels or earlier element sets' names;
//! * `*SURFACE, NAME=n, TYPE=NODE`: node sets' names or node labels (an optional area
//!   field is ignored).
//!
//! Other keywords (`*HEADING`, `*MATERIAL`, `*STEP`, …) are skipped with their data
//! lines; `*PART`, `*INSTANCE` and `*INCLUDE` are refused (flat files only). As in the
//! Gmsh reader, the solid cells are the elements of the highest dimension (one kind per
//! mesh), the model's nodes are their nodes numbered from 0 in increasing node label, and
//! every set becomes a node set of the model, named as written in the file: a node set as
//! it is, an element set as the nodes of its elements, a node surface as its nodes; a node
//! set shadows an element set of the same name (Gmsh writes both for a physical group with
//! `Mesh.SaveGroupsOfNodes = 1`). Set names are matched case-insensitively inside the file,
//! as Abaqus does; a set defined twice gathers both definitions.
//!
//! Abaqus's node order of every element read is VTK's (docs/theory.md (T200)), so no
//! reordering. A hand-written line reader: the only Rust crate found that reads `.inp`
//! files (oxiphysics-io 0.1.0) is part of a physics engine's I/O, reads from a path and
//! carries no line numbers. No count read from the file sizes an allocation, a GENERATE
//! range may not be longer than the labels defined, every error names the line, and
//! nothing panics on any input (tests/fuzz_readers.rs).

use std::collections::{BTreeMap, BTreeSet, HashMap};

use crate::fe::mesh::{CellKind, Cells};
use crate::model::gmsh::{GmshMesh, MshError};

type Parse<T> = std::result::Result<T, MshError>;

fn fail<T>(line: usize, message: impl Into<String>) -> Parse<T> {
    Err(MshError {
        line,
        message: message.into(),
    })
}

/// The most set memberships stored over all sets (a bound on memory for any input).
const MAX_MEMBERS: usize = 1 << 24;

/// Nodes per element, the solid cell kind (None: sets only) and the dimension.
fn element_type(t: &str) -> Option<(usize, Option<CellKind>, usize)> {
    Some(match t {
        "C3D4" => (4, Some(CellKind::Tet4), 3),
        "C3D10" => (10, Some(CellKind::Tet10), 3),
        "C3D8" => (8, Some(CellKind::Hex8), 3),
        "C3D20" => (20, Some(CellKind::Hex20), 3),
        "CPS3" | "CPE3" => (3, Some(CellKind::Tri3), 2),
        "CPS6" | "CPE6" => (6, Some(CellKind::Tri6), 2),
        "CPS4" | "CPE4" => (4, Some(CellKind::Quad4), 2),
        "CPS8" | "CPE8" => (8, None, 2),
        "T2D2" | "T3D2" => (2, None, 1),
        "T2D3" | "T3D3" => (3, None, 1),
        _ => return None,
    })
}

/// A keyword line: the keyword and its parameters (keys upper-case), with its line.
struct Keyword {
    line: usize,
    name: String,
    params: Vec<(String, String)>,
}

impl Keyword {
    fn get(&self, key: &str) -> Option<&str> {
        self.params
            .iter()
            .find(|(k, _)| k == key)
            .map(|(_, v)| v.as_str())
    }

    fn has(&self, key: &str) -> bool {
        self.params.iter().any(|(k, _)| k == key)
    }

    /// A set's name given by parameter `key`, which must be present.
    fn name(&self, key: &str) -> Parse<String> {
        match self.get(key) {
            Some(v) if !v.is_empty() => Ok(v.to_string()),
            _ => fail(self.line, format!("*{} needs {key}=name", self.name)),
        }
    }
}

/// One logical record: a keyword or a data line (continued lines joined).
enum Record {
    Keyword(Keyword),
    Data(usize, Vec<String>),
}

/// The records of the text, comments and blank lines skipped.
fn records(text: &str) -> Vec<Record> {
    let mut out = Vec::new();
    let mut pending: Option<(usize, String)> = None;
    for (i, raw) in text.lines().enumerate() {
        let l = raw.trim();
        if l.is_empty() || l.starts_with("**") {
            continue;
        }
        let (n, mut joined) = match pending.take() {
            Some((n, mut s)) if !l.starts_with('*') => {
                s.push_str(l);
                (n, s)
            }
            Some((n, s)) => {
                out.push(record(n, &s));
                (i + 1, l.to_string())
            }
            None => (i + 1, l.to_string()),
        };
        if joined.ends_with(',') {
            pending = Some((n, std::mem::take(&mut joined)));
        } else {
            out.push(record(n, &joined));
        }
    }
    if let Some((n, s)) = pending {
        out.push(record(n, &s));
    }
    out
}

fn record(n: usize, l: &str) -> Record {
    let mut fields = l
        .split(',')
        .map(|f| f.trim().to_string())
        .collect::<Vec<_>>();
    // a trailing comma leaves an empty last field
    if fields.len() > 1 && fields.last().is_some_and(|f| f.is_empty()) {
        fields.pop();
    }
    if let Some(k) = l.strip_prefix('*') {
        let mut parts = k.split(',');
        let name = parts.next().unwrap_or("").trim().to_uppercase();
        let params = parts
            .filter(|p| !p.trim().is_empty())
            .map(|p| {
                let (k, v) = p.split_once('=').unwrap_or((p, ""));
                let v = v.trim();
                let v = v
                    .strip_prefix('"')
                    .and_then(|v| v.strip_suffix('"'))
                    .unwrap_or(v);
                (k.trim().to_uppercase(), v.to_string())
            })
            .collect();
        Record::Keyword(Keyword {
            line: n,
            name,
            params,
        })
    } else {
        Record::Data(n, fields)
    }
}

/// A line's field, shortened and without control characters, for messages.
fn shown(l: &str) -> String {
    let s: String = l
        .chars()
        .take(40)
        .map(|c| if c.is_control() { '?' } else { c })
        .collect();
    format!("\"{s}\"")
}

fn label(n: usize, f: &str, what: &str) -> Parse<u64> {
    f.parse::<u64>().or_else(|_| {
        fail(
            n,
            format!("{what} {} is not a label (a positive integer)", shown(f)),
        )
    })
}

/// A named set as read: its name as first written and its labels.
#[derive(Default)]
struct Set {
    name: String,
    labels: BTreeSet<u64>,
}

/// Sets by upper-case name.
type Sets = HashMap<String, Set>;

fn add_to(sets: &mut Sets, name: &str) -> String {
    let key = name.to_uppercase();
    sets.entry(key.clone()).or_insert_with(|| Set {
        name: name.to_string(),
        labels: BTreeSet::new(),
    });
    key
}

/// What the data lines under the current keyword are.
enum Mode {
    Skip,
    Nodes(Option<String>),
    Elements {
        per: usize,
        kind: Option<CellKind>,
        dim: usize,
        elset: Option<String>,
    },
    NodeSet {
        key: String,
        generate: bool,
    },
    ElementSet {
        key: String,
        generate: bool,
    },
    Surface {
        key: String,
    },
}

struct Element {
    line: usize,
    dim: usize,
    kind: Option<CellKind>,
    nodes: Vec<u64>,
}

/// Parse the text of an Abaqus input file (module docs for the subset read).
pub fn parse_inp(text: &str) -> Parse<GmshMesh> {
    let mut nodes: HashMap<u64, [f64; 3]> = HashMap::new();
    let mut elements: BTreeMap<u64, Element> = BTreeMap::new();
    let mut order: Vec<u64> = Vec::new();
    let mut nsets: Sets = HashMap::new();
    let mut elsets: Sets = HashMap::new();
    let mut members = 0usize;
    let mut mode = Mode::Skip;
    for r in records(text) {
        let (n, fields) = match r {
            Record::Keyword(k) => {
                mode = keyword(&k, &mut nsets, &mut elsets)?;
                if let Mode::NodeSet { key, .. } = &mode {
                    if let Some(e) = k.get("ELSET") {
                        let Some(set) = elsets.get(&e.to_uppercase()) else {
                            return fail(
                                k.line,
                                format!(
                                    "element set {} is not defined (above this line)",
                                    shown(e)
                                ),
                            );
                        };
                        let labels: Vec<u64> = set
                            .labels
                            .iter()
                            .flat_map(|l| elements[l].nodes.iter().copied())
                            .collect();
                        members += labels.len();
                        if let Some(s) = nsets.get_mut(key) {
                            s.labels.extend(labels);
                        }
                        mode = Mode::Skip;
                    }
                }
                continue;
            }
            Record::Data(n, f) => (n, f),
        };
        match &mode {
            Mode::Skip => {}
            Mode::Nodes(nset) => {
                let t = label(n, &fields[0], "node")?;
                if !(3..=4).contains(&fields.len()) {
                    return fail(n, "expected `label, x, y[, z]`");
                }
                let mut x = [0.0; 3];
                for (a, f) in fields[1..].iter().enumerate() {
                    x[a] = if f.is_empty() {
                        0.0
                    } else {
                        f.parse::<f64>()
                            .ok()
                            .filter(|v| v.is_finite())
                            .map_or_else(
                                || {
                                    fail(
                                        n,
                                        format!("coordinate {} is not a finite number", shown(f)),
                                    )
                                },
                                Ok,
                            )?
                    };
                }
                if nodes.insert(t, x).is_some() {
                    return fail(n, format!("node {t} defined twice"));
                }
                if let Some(key) = nset {
                    members += 1;
                    if let Some(s) = nsets.get_mut(key) {
                        s.labels.insert(t);
                    }
                }
            }
            Mode::Elements {
                per,
                kind,
                dim,
                elset,
            } => {
                if fields.len() != per + 1 {
                    return fail(
                        n,
                        format!(
                            "expected an element label and {per} node labels, found {} fields",
                            fields.len()
                        ),
                    );
                }
                let e = label(n, &fields[0], "element")?;
                let nodes = fields[1..]
                    .iter()
                    .map(|f| label(n, f, "node"))
                    .collect::<Parse<Vec<u64>>>()?;
                if elements
                    .insert(
                        e,
                        Element {
                            line: n,
                            dim: *dim,
                            kind: *kind,
                            nodes,
                        },
                    )
                    .is_some()
                {
                    return fail(n, format!("element {e} defined twice"));
                }
                order.push(e);
                if let Some(key) = elset {
                    members += 1;
                    if let Some(s) = elsets.get_mut(key) {
                        s.labels.insert(e);
                    }
                }
            }
            Mode::NodeSet { key, generate } | Mode::ElementSet { key, generate } => {
                let node = matches!(mode, Mode::NodeSet { .. });
                let what = if node { "node" } else { "element" };
                let defined = if node { nodes.len() } else { elements.len() };
                let exists = |l: u64| {
                    if node {
                        nodes.contains_key(&l)
                    } else {
                        elements.contains_key(&l)
                    }
                };
                let mut labels = Vec::new();
                if *generate {
                    let v = fields
                        .iter()
                        .map(|f| label(n, f, what))
                        .collect::<Parse<Vec<u64>>>()?;
                    let (a, b, s) = match v[..] {
                        [a, b] => (a, b, 1),
                        [a, b, s] => (a, b, s),
                        _ => return fail(n, "expected `first, last[, step]` (GENERATE)"),
                    };
                    if s == 0 || b < a || (b - a) / s >= defined as u64 {
                        return fail(n, format!("GENERATE {a} to {b} by {s}: not a range of the {defined} {what}s defined"));
                    }
                    labels.extend((a..=b).step_by(s as usize));
                } else {
                    let sets = if node { &nsets } else { &elsets };
                    for f in &fields {
                        if f.starts_with(|c: char| c.is_ascii_digit()) {
                            labels.push(label(n, f, what)?);
                        } else {
                            let Some(set) = sets.get(&f.to_uppercase()) else {
                                return fail(
                                    n,
                                    format!(
                                        "{what} set {} is not defined (above this line)",
                                        shown(f)
                                    ),
                                );
                            };
                            labels.extend(set.labels.iter().copied());
                        }
                    }
                }
                if let Some(l) = labels.iter().find(|&&l| !exists(l)) {
                    return fail(n, format!("{what} {l} is not defined (above this line)"));
                }
                members += labels.len();
                let sets = if node { &mut nsets } else { &mut elsets };
                if let Some(s) = sets.get_mut(key) {
                    s.labels.extend(labels);
                }
            }
            Mode::Surface { key } => {
                let f = &fields[0];
                let labels: Vec<u64> = if f.starts_with(|c: char| c.is_ascii_digit()) {
                    let l = label(n, f, "node")?;
                    if !nodes.contains_key(&l) {
                        return fail(n, format!("node {l} is not defined (above this line)"));
                    }
                    vec![l]
                } else {
                    let Some(set) = nsets.get(&f.to_uppercase()) else {
                        return fail(
                            n,
                            format!(
                                "node set {} of the surface is not defined (above this line)",
                                shown(f)
                            ),
                        );
                    };
                    set.labels.iter().copied().collect()
                };
                members += labels.len();
                if let Some(s) = nsets.get_mut(key) {
                    s.labels.extend(labels);
                }
            }
        }
        if members > MAX_MEMBERS {
            return fail(
                n,
                format!("the sets hold more than {MAX_MEMBERS} labels in all"),
            );
        }
    }
    assemble(&nodes, &elements, &order, nsets, elsets)
}

/// The mode of the data lines under keyword `k` (sets it names created).
fn keyword(k: &Keyword, nsets: &mut Sets, elsets: &mut Sets) -> Parse<Mode> {
    let generate = k.has("GENERATE");
    Ok(match k.name.as_str() {
        "NODE" => Mode::Nodes(k.get("NSET").map(|s| add_to(nsets, s))),
        "ELEMENT" => {
            let Some(t) = k.get("TYPE") else {
                return fail(k.line, "*ELEMENT needs TYPE=");
            };
            let Some((per, kind, dim)) = element_type(&t.to_uppercase()) else {
                return fail(k.line, format!("element type {} is not read (C3D4, C3D10, C3D8, C3D20, CPS3/CPE3, CPS6/CPE6, CPS4/CPE4)", shown(t)));
            };
            Mode::Elements {
                per,
                kind,
                dim,
                elset: k.get("ELSET").map(|s| add_to(elsets, s)),
            }
        }
        "NSET" => Mode::NodeSet {
            key: add_to(nsets, &k.name("NSET")?),
            generate,
        },
        "ELSET" => Mode::ElementSet {
            key: add_to(elsets, &k.name("ELSET")?),
            generate,
        },
        "SURFACE" => {
            let t = k.get("TYPE").unwrap_or("ELEMENT").to_uppercase();
            if t != "NODE" {
                return fail(k.line, format!("*SURFACE of TYPE={t} is not read: define the surface by nodes (TYPE=NODE) or name a node set"));
            }
            Mode::Surface {
                key: add_to(nsets, &k.name("NAME")?),
            }
        }
        "PART" | "INSTANCE" | "ASSEMBLY" | "INCLUDE" => {
            return fail(k.line, format!("*{} is not read: write a flat input file (Abaqus/CAE: Model > Edit Attributes > Do not use parts and assemblies in input files)", k.name));
        }
        _ => Mode::Skip,
    })
}

/// The solid cells, the model's nodes and the sets as node sets.
fn assemble(
    nodes: &HashMap<u64, [f64; 3]>,
    elements: &BTreeMap<u64, Element>,
    order: &[u64],
    nsets: Sets,
    elsets: Sets,
) -> Parse<GmshMesh> {
    let Some(dimension) = elements.values().map(|e| e.dim).max().filter(|&d| d >= 2) else {
        return fail(0, "the file has no 2D or 3D elements (*ELEMENT, TYPE=C3D4, C3D10, C3D8, C3D20, CPS3, CPS6, CPS4, …)");
    };
    let solid: Vec<&Element> = order
        .iter()
        .map(|l| &elements[l])
        .filter(|e| e.dim == dimension)
        .collect();
    let mut kind = None;
    for e in &solid {
        let Some(k) = e.kind else {
            return fail(
                e.line,
                "8-node quadrilaterals are not supported: mesh with CPS3/CPS6/CPS4 in 2D",
            );
        };
        if kind.is_some_and(|kind| kind != k) {
            return fail(
                e.line,
                format!(
                    "{k:?} cells in a mesh of {:?} cells: one kind of cell per mesh",
                    kind.unwrap_or(k)
                ),
            );
        }
        kind = Some(k);
    }
    let Some(kind) = kind else {
        return fail(0, "the file has no cells");
    };
    let used: BTreeSet<u64> = solid.iter().flat_map(|e| e.nodes.iter().copied()).collect();
    let mut number: HashMap<u64, usize> = HashMap::with_capacity(used.len());
    let mut coordinates = Vec::with_capacity(used.len());
    for (p, &t) in used.iter().enumerate() {
        let Some(x) = nodes.get(&t) else {
            let line = solid
                .iter()
                .find(|e| e.nodes.contains(&t))
                .map_or(0, |e| e.line);
            return fail(
                line,
                format!("node {t} of this element is not defined (*NODE)"),
            );
        };
        if dimension == 2 && x[2] != 0.0 {
            return fail(
                0,
                format!(
                    "node {t} has z = {}: a 2D mesh must lie in the plane z = 0",
                    x[2]
                ),
            );
        }
        coordinates.push(x[..dimension].to_vec());
        number.insert(t, p);
    }
    let connectivity = solid
        .iter()
        .flat_map(|e| e.nodes.iter().map(|t| number[t]))
        .collect();
    let mut groups: BTreeMap<String, Vec<usize>> = BTreeMap::new();
    let mut to_model = |name: &str, labels: &mut dyn Iterator<Item = u64>| -> Parse<()> {
        let mut set = BTreeSet::new();
        for t in labels {
            let Some(&p) = number.get(&t) else {
                return fail(
                    0,
                    format!("node {t} of set {name:?} is not a node of the solid cells"),
                );
            };
            set.insert(p);
        }
        groups.insert(name.to_string(), set.into_iter().collect());
        Ok(())
    };
    let mut shadowed = BTreeSet::new();
    for s in nsets.values() {
        shadowed.insert(s.name.to_uppercase());
        to_model(&s.name, &mut s.labels.iter().copied())?;
    }
    for s in elsets
        .values()
        .filter(|s| !shadowed.contains(&s.name.to_uppercase()))
    {
        let mut labels = s
            .labels
            .iter()
            .flat_map(|l| elements[l].nodes.iter().copied());
        to_model(&s.name, &mut labels)?;
    }
    Ok(GmshMesh {
        dimension,
        coordinates,
        node_tags: used.into_iter().collect(),
        cells: Cells { kind, connectivity },
        groups,
    })
}
