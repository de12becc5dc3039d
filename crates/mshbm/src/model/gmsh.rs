//! Reader of Gmsh meshes, MSH 4.1 ASCII (the format `gmsh -3 -format msh41 part.geo`
//! writes, and the default of current Gmsh versions) and binary ([`parse_msh_bytes`],
//! module `binary`), for `kind = "mesh"` model files
//! ([`crate::model::mesh`]; docs/theory.md §21).
//!
//! What is read: `$MeshFormat` (4.1, ASCII), `$PhysicalNames`, `$Entities` (which physical
//! groups each point, curve, surface and volume belongs to), `$Nodes` and `$Elements`;
//! other sections are skipped. The solid cells are the elements of the highest dimension
//! (Tri3, Tri6 or Quad4 in 2D; Tet4, Tet10, Hex8 or Hex20 in 3D; one kind per mesh), in VTK
//! node order (Gmsh's Tet10 lists the edges 23 and 13 the other way round, (T200); its
//! Hex20 orders the edges otherwise, (T211)). The model's
//! nodes are the nodes of the solid cells, numbered from 0 in increasing Gmsh node tag.
//! Each physical group becomes a node set: the nodes of its elements, in increasing model
//! number; its name is the group's name from `$PhysicalNames`, or `physical_<dim>_<tag>`.
//!
//! A hand-written reader, not the `mshio` crate (0.4.2, on nom 5): its header parser
//! unwraps the parsed data size (one too large for its integer type panics) and panics on
//! a data size it does not support, and its errors carry no line numbers. Here no count
//! read from the file sizes an allocation (vectors grow with the entries actually read,
//! and the text is bounded by the input file limit), every error names the line, and
//! nothing panics on any input (tests/fuzz_readers.rs).

use std::collections::{BTreeMap, BTreeSet, HashMap};

use crate::fe::mesh::{CellKind, Cells, NodeSets};

mod binary;

/// A Gmsh mesh as a model uses it.
#[derive(Clone, Debug)]
pub struct GmshMesh {
    /// Dimension of the solid cells (2 or 3); the coordinates have as many components.
    pub dimension: usize,
    /// Coordinates of the model's nodes.
    pub coordinates: Vec<Vec<f64>>,
    /// Gmsh tag of each model node.
    pub node_tags: Vec<u64>,
    /// The solid cells (model node numbers).
    pub cells: Cells,
    /// Physical groups as node sets (model node numbers, increasing).
    pub groups: NodeSets,
}

/// A reading error at a line of the file (1-based; 0: the file as a whole).
#[derive(Clone, Debug, PartialEq)]
pub struct MshError {
    pub line: usize,
    pub message: String,
}

impl std::fmt::Display for MshError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if self.line == 0 {
            f.write_str(&self.message)
        } else {
            write!(f, "line {}: {}", self.line, self.message)
        }
    }
}

type Parse<T> = std::result::Result<T, MshError>;

fn fail<T>(line: usize, message: impl Into<String>) -> Parse<T> {
    Err(MshError {
        line,
        message: message.into(),
    })
}

/// The lines of the text with their numbers, skipping blank lines.
struct Lines<'a> {
    inner: std::iter::Enumerate<std::str::Lines<'a>>,
    last: usize,
}

impl<'a> Lines<'a> {
    fn next(&mut self) -> Option<(usize, &'a str)> {
        for (i, l) in self.inner.by_ref() {
            self.last = i + 1;
            let l = l.trim();
            if !l.is_empty() {
                return Some((i + 1, l));
            }
        }
        None
    }

    /// The next line, which must exist (inside `section`).
    fn expect(&mut self, section: &str) -> Parse<(usize, &'a str)> {
        self.next().map_or_else(
            || fail(self.last, format!("the file ends inside {section}")),
            Ok,
        )
    }

    /// The next line's numbers.
    fn numbers<T: std::str::FromStr>(
        &mut self,
        section: &str,
        what: &str,
    ) -> Parse<(usize, Vec<T>)> {
        let (n, l) = self.expect(section)?;
        Ok((n, numbers(n, l, what)?))
    }

    /// The closing `$End…` line of `section`.
    fn end(&mut self, section: &str) -> Parse<()> {
        let (n, l) = self.expect(section)?;
        if l != format!("$End{section}") {
            return fail(n, format!("expected $End{section}, found {}", shown(l)));
        }
        Ok(())
    }
}

/// A line, shortened and without control characters, for messages.
fn shown(l: &str) -> String {
    let s: String = l
        .chars()
        .take(40)
        .map(|c| if c.is_control() { '?' } else { c })
        .collect();
    if l.chars().count() > 40 {
        format!("\"{s}…\"")
    } else {
        format!("\"{s}\"")
    }
}

fn numbers<T: std::str::FromStr>(n: usize, l: &str, what: &str) -> Parse<Vec<T>> {
    l.split_whitespace()
        .map(|t| {
            t.parse::<T>()
                .or_else(|_| fail(n, format!("{what}: {} is not a valid number", shown(t))))
        })
        .collect()
}

/// Nodes per element of the Gmsh element types, and the cell kind of the solid ones.
fn element_type(t: u32) -> Option<(usize, Option<CellKind>, usize)> {
    // (nodes, solid cell kind, dimension)
    Some(match t {
        15 => (1, None, 0),
        1 => (2, None, 1),
        8 => (3, None, 1),
        2 => (3, Some(CellKind::Tri3), 2),
        9 => (6, Some(CellKind::Tri6), 2),
        3 => (4, Some(CellKind::Quad4), 2),
        16 => (8, None, 2),
        10 => (9, None, 2),
        4 => (4, Some(CellKind::Tet4), 3),
        11 => (10, Some(CellKind::Tet10), 3),
        5 => (8, Some(CellKind::Hex8), 3),
        17 => (20, Some(CellKind::Hex20), 3),
        12 => (27, None, 3),
        6 => (6, None, 3),
        7 => (5, None, 3),
        _ => return None,
    })
}

/// One block of elements: its entity and its elements' nodes (Gmsh tags).
struct ElementBlock {
    dim: usize,
    entity: i64,
    kind: Option<CellKind>,
    line: usize,
    nodes: Vec<u64>,
}

/// Parse an MSH 4.1 file, ASCII or binary: the `$MeshFormat` header (text in both)
/// decides.
pub fn parse_msh_bytes(bytes: &[u8]) -> Parse<GmshMesh> {
    if let Some((format_at, size_t)) = binary_header(bytes) {
        return binary::parse_binary(bytes, format_at, size_t);
    }
    match std::str::from_utf8(bytes) {
        Ok(text) => parse_msh(text),
        Err(e) => fail(
            0,
            format!(
                "neither an ASCII MSH file (invalid UTF-8 at byte {}) nor a binary one (a `$MeshFormat` line, then `4.1 1 8`)",
                e.valid_up_to()
            ),
        ),
    }
}

/// When `bytes` start (after blank lines) with `$MeshFormat` and the line `4.1 1 <data
/// size>`: the offset of that line and the data size.
fn binary_header(bytes: &[u8]) -> Option<(usize, usize)> {
    let start = bytes.iter().position(|b| !b.is_ascii_whitespace())?;
    let rest = bytes[start..].strip_prefix(b"$MeshFormat")?;
    let line_at = start + b"$MeshFormat".len() + rest.iter().position(|&b| b == b'\n')? + 1;
    let end = bytes[line_at..].iter().position(|&b| b == b'\n')?;
    let line = std::str::from_utf8(&bytes[line_at..line_at + end]).ok()?;
    let f: Vec<&str> = line.split_whitespace().collect();
    match f[..] {
        ["4.1", "1", size] => Some((line_at, size.parse().ok()?)),
        _ => None,
    }
}

/// Parse the text of an MSH 4.1 ASCII file.
pub fn parse_msh(text: &str) -> Parse<GmshMesh> {
    let mut lines = Lines {
        inner: text.lines().enumerate(),
        last: 0,
    };
    let mut format_seen = false;
    let mut names: HashMap<(usize, i64), String> = HashMap::new();
    // (dim, entity tag) → physical tags
    let mut entities: HashMap<(usize, i64), Vec<i64>> = HashMap::new();
    let mut nodes: HashMap<u64, [f64; 3]> = HashMap::new();
    let mut blocks: Vec<ElementBlock> = Vec::new();
    let (mut nodes_seen, mut elements_seen) = (false, false);
    while let Some((n, l)) = lines.next() {
        match l {
            "$MeshFormat" => {
                let (m, l) = lines.expect("MeshFormat")?;
                let f: Vec<&str> = l.split_whitespace().collect();
                if f.first() != Some(&"4.1") {
                    return fail(
                        m,
                        format!(
                            "MSH version {} is not read; save the mesh as MSH 4.1 (Gmsh: -format msh41)",
                            f.first().map_or("(none)".into(), |v| shown(v))
                        ),
                    );
                }
                if f.get(1) != Some(&"0") {
                    return fail(
                        m,
                        "a binary MSH file given as text: read its bytes (`parse_msh_bytes`)",
                    );
                }
                lines.end("MeshFormat")?;
                format_seen = true;
            }
            _ if !format_seen => {
                return fail(n, format!("expected $MeshFormat, found {}", shown(l)));
            }
            "$PhysicalNames" => {
                let (m, count) = lines.numbers::<usize>("PhysicalNames", "the number of names")?;
                let [count] = count[..] else {
                    return fail(m, "expected the number of physical names");
                };
                for _ in 0..count {
                    let (m, l) = lines.expect("PhysicalNames")?;
                    let mut parts = l.splitn(3, char::is_whitespace);
                    let (Some(d), Some(t), Some(name)) = (parts.next(), parts.next(), parts.next())
                    else {
                        return fail(m, "expected `dimension tag \"name\"`");
                    };
                    let d: usize = d
                        .parse()
                        .ok()
                        .filter(|&d| d <= 3)
                        .map_or_else(|| fail(m, "the dimension must be 0 to 3"), Ok)?;
                    let t: i64 = t
                        .parse()
                        .or_else(|_| fail(m, format!("tag {} is not an integer", shown(t))))?;
                    let name = name.trim();
                    let Some(name) = name
                        .strip_prefix('"')
                        .and_then(|s| s.strip_suffix('"'))
                        .filter(|s| !s.is_empty() && !s.contains('"'))
                    else {
                        return fail(m, format!("the name {} must be quoted", shown(name)));
                    };
                    if names.insert((d, t), name.to_string()).is_some() {
                        return fail(m, format!("physical group ({d}, {t}) named twice"));
                    }
                }
                lines.end("PhysicalNames")?;
            }
            "$Entities" => {
                let (m, counts) = lines.numbers::<usize>("Entities", "the numbers of entities")?;
                let [points, curves, surfaces, volumes] = counts[..] else {
                    return fail(
                        m,
                        "expected the numbers of points, curves, surfaces and volumes",
                    );
                };
                for (dim, count) in [points, curves, surfaces, volumes].into_iter().enumerate() {
                    for _ in 0..count {
                        let (m, v) = lines.numbers::<f64>("Entities", "an entity")?;
                        // tag, coordinates (3 for a point, a box of 6 otherwise), physical tags
                        let at = if dim == 0 { 4 } else { 7 };
                        let count = v.get(at).copied().unwrap_or(-1.0);
                        let integer = |x: f64| x.fract() == 0.0 && x.abs() < 1e15;
                        if !(integer(v[0]) && count >= 0.0 && integer(count))
                            || v.len() < at + 1 + count as usize
                        {
                            return fail(m, "expected an entity: tag, coordinates, physical tags");
                        }
                        let tags = &v[at + 1..at + 1 + count as usize];
                        if !tags.iter().all(|&t| integer(t)) {
                            return fail(m, "physical tags must be integers");
                        }
                        entities
                            .insert((dim, v[0] as i64), tags.iter().map(|&t| t as i64).collect());
                    }
                }
                lines.end("Entities")?;
            }
            "$Nodes" => {
                if nodes_seen {
                    return fail(n, "a second $Nodes section");
                }
                nodes_seen = true;
                let (m, head) = lines.numbers::<u64>("Nodes", "the nodes' header")?;
                let [blocks_count, ..] = head[..] else {
                    return fail(
                        m,
                        "expected `numEntityBlocks numNodes minNodeTag maxNodeTag`",
                    );
                };
                if head.len() != 4 {
                    return fail(
                        m,
                        "expected `numEntityBlocks numNodes minNodeTag maxNodeTag`",
                    );
                }
                for _ in 0..blocks_count {
                    let (m, b) = lines.numbers::<i64>("Nodes", "a node block's header")?;
                    let [_, _, parametric, count] = b[..] else {
                        return fail(
                            m,
                            "expected `entityDim entityTag parametric numNodesInBlock`",
                        );
                    };
                    if parametric != 0 {
                        return fail(m, "parametric node coordinates are not read; save without them (Gmsh: Mesh.SaveParametric = 0)");
                    }
                    if count < 0 {
                        return fail(m, "negative number of nodes");
                    }
                    let mut tags = Vec::new();
                    for _ in 0..count {
                        let (m, t) = lines.numbers::<u64>("Nodes", "a node tag")?;
                        let [t] = t[..] else {
                            return fail(m, "expected one node tag");
                        };
                        tags.push((m, t));
                    }
                    for (tag_line, t) in tags {
                        let (m, x) = lines.numbers::<f64>("Nodes", "a node's coordinates")?;
                        let [x, y, z] = x[..] else {
                            return fail(m, "expected three coordinates");
                        };
                        if !(x.is_finite() && y.is_finite() && z.is_finite()) {
                            return fail(m, "coordinates must be finite");
                        }
                        if nodes.insert(t, [x, y, z]).is_some() {
                            return fail(tag_line, format!("node {t} defined twice"));
                        }
                    }
                }
                lines.end("Nodes")?;
            }
            "$Elements" => {
                if elements_seen {
                    return fail(n, "a second $Elements section");
                }
                elements_seen = true;
                let (m, head) = lines.numbers::<u64>("Elements", "the elements' header")?;
                let [blocks_count, _, _, _] = head[..] else {
                    return fail(
                        m,
                        "expected `numEntityBlocks numElements minElementTag maxElementTag`",
                    );
                };
                for _ in 0..blocks_count {
                    let (m, b) = lines.numbers::<i64>("Elements", "an element block's header")?;
                    let [dim, entity, t, count] = b[..] else {
                        return fail(
                            m,
                            "expected `entityDim entityTag elementType numElementsInBlock`",
                        );
                    };
                    let Some((per, kind, tdim)) = u32::try_from(t).ok().and_then(element_type)
                    else {
                        return fail(m, format!("element type {t} is not read (points, lines, triangles, quadrilaterals, tetrahedra, hexahedra)"));
                    };
                    if dim != tdim as i64 || count < 0 {
                        return fail(
                            m,
                            format!(
                                "element type {t} is of dimension {tdim}, the block says {dim}"
                            ),
                        );
                    }
                    let mut block = ElementBlock {
                        dim: tdim,
                        entity,
                        kind,
                        line: m,
                        nodes: Vec::new(),
                    };
                    for _ in 0..count {
                        let (e, v) = lines.numbers::<u64>("Elements", "an element")?;
                        if v.len() != per + 1 {
                            return fail(
                                e,
                                format!(
                                    "expected an element tag and {per} node tags, found {} numbers",
                                    v.len()
                                ),
                            );
                        }
                        block.nodes.extend_from_slice(&v[1..]);
                    }
                    blocks.push(block);
                }
                lines.end("Elements")?;
            }
            l if l.starts_with('$') && !l.starts_with("$End") => {
                // another section: skip to its end
                let end = format!("$End{}", &l[1..]);
                loop {
                    let (_, k) = lines.expect(&l[1..])?;
                    if k == end {
                        break;
                    }
                }
            }
            _ => {
                return fail(
                    n,
                    format!(
                        "expected a section ($Nodes, $Elements, …), found {}",
                        shown(l)
                    ),
                )
            }
        }
    }
    if !format_seen {
        return fail(0, "not a Gmsh mesh: no $MeshFormat section");
    }
    assemble_mesh(&names, &entities, &nodes, &blocks)
}

/// The solid cells, the model's nodes and the physical groups of what was read.
fn assemble_mesh(
    names: &HashMap<(usize, i64), String>,
    entities: &HashMap<(usize, i64), Vec<i64>>,
    nodes: &HashMap<u64, [f64; 3]>,
    blocks: &[ElementBlock],
) -> Parse<GmshMesh> {
    let Some(dimension) = blocks.iter().map(|b| b.dim).max().filter(|&d| d >= 2) else {
        return fail(0, "the mesh has no triangles, quadrilaterals, tetrahedra or hexahedra (no $Elements of dimension 2 or 3)");
    };
    let solid: Vec<&ElementBlock> = blocks
        .iter()
        .filter(|b| b.dim == dimension && !b.nodes.is_empty())
        .collect();
    let mut kind = None;
    for b in &solid {
        let Some(k) = b.kind else {
            return fail(b.line, "these cells (27-node hexahedra, 8- or 9-node quadrilaterals, prisms, pyramids) are not supported: mesh with Tri3/Tri6/Quad4 or Tet4/Tet10/Hex8/Hex20 (Gmsh: Mesh.SecondOrderIncomplete = 1 for Hex20)");
        };
        if kind.is_some_and(|kind| kind != k) {
            return fail(
                b.line,
                format!(
                    "{k:?} cells in a mesh of {:?} cells: one kind of cell per mesh",
                    kind.unwrap_or(k)
                ),
            );
        }
        kind = Some(k);
    }
    let Some(kind) = kind else {
        return fail(0, "the mesh has no cells");
    };
    // model nodes: the nodes of the solid cells, by increasing tag
    let used: BTreeSet<u64> = solid.iter().flat_map(|b| b.nodes.iter().copied()).collect();
    let mut number: HashMap<u64, usize> = HashMap::with_capacity(used.len());
    let mut coordinates = Vec::with_capacity(used.len());
    for (p, &t) in used.iter().enumerate() {
        let Some(x) = nodes.get(&t) else {
            let line = solid
                .iter()
                .find(|b| b.nodes.contains(&t))
                .map_or(0, |b| b.line);
            return fail(
                line,
                format!("node {t} of a cell of this block is not in $Nodes"),
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
    let swap = |a: usize| -> usize {
        // Gmsh's Tet10 edges 8 = 23, 9 = 13; VTK's 8 = 13, 9 = 23
        match (kind, a) {
            (CellKind::Tet10, 8) => 9,
            (CellKind::Tet10, 9) => 8,
            // Gmsh's Hex20 edges 01 03 04 12 15 23 26 37 45 47 56 67 (8–19) in VTK's order
            // 01 12 23 30 45 56 67 74 04 15 26 37 (T211)
            (CellKind::Hex20, 8..=19) => [8, 11, 13, 9, 16, 18, 19, 17, 10, 12, 14, 15][a - 8],
            _ => a,
        }
    };
    let per = kind.nodes_per_cell();
    let mut connectivity = Vec::with_capacity(used.len().min(1 << 24));
    for b in &solid {
        for cell in b.nodes.chunks(per) {
            connectivity.extend((0..per).map(|a| number[&cell[swap(a)]]));
        }
    }
    // physical groups
    let mut sets: BTreeMap<String, BTreeSet<usize>> = BTreeMap::new();
    for b in blocks {
        let Some(tags) = entities.get(&(b.dim, b.entity)) else {
            continue;
        };
        for &t in tags {
            let name = names
                .get(&(b.dim, t))
                .cloned()
                .unwrap_or_else(|| format!("physical_{}_{t}", b.dim));
            let set = sets.entry(name.clone()).or_default();
            for tag in &b.nodes {
                let Some(&p) = number.get(tag) else {
                    return fail(b.line, format!("node {tag} of physical group {name:?} is not a node of the solid cells"));
                };
                set.insert(p);
            }
        }
    }
    let groups = sets
        .into_iter()
        .map(|(k, v)| (k, v.into_iter().collect()))
        .collect();
    Ok(GmshMesh {
        dimension,
        coordinates,
        node_tags: used.into_iter().collect(),
        cells: Cells { kind, connectivity },
        groups,
    })
}
