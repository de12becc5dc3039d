//! Reader of the matrices Abaqus/Standard writes with `*MATRIX GENERATE` and
//! `*MATRIX OUTPUT, FORMAT=MATRIX INPUT` (the default; files `job_STIF2.mtx`,
//! `job_MASS2.mtx`, `job_DMPV2.mtx`, …): one entry per line,
//!
//! ```text
//! row node, row DOF, column node, column DOF, value
//! 1,1, 1,1, 1.00000000000000e+05
//! ```
//!
//! with node labels (positive integers, as in the `.inp` file) and DOF numbers 1 to 6
//! (1–3 displacements, 4–6 rotations). This is also the data-line syntax of `*MATRIX INPUT`
//! (Abaqus Keywords Reference). A symmetric matrix is written as one triangle; an entry
//! whose transposed entry is absent is mirrored, so that a lower, an upper or a full square
//! storage all give the same matrix (a full square's two halves are compared later, by the
//! model's symmetry check). Lines starting with `*` (keyword and `**` comment lines) and
//! blank lines are skipped.
//!
//! The matrix index of `(node label, DOF)` is given by a [`DofMap`]: the nodes are the
//! labels of all the model's matrices in increasing order, numbered from 0, and
//! `index = node * dofs_per_node + DOF − 1`, the numbering of every other model
//! (`DOF = node * dofs_per_node + component`). Every `(node, DOF ≤ dofs_per_node)` must
//! appear in some matrix. Negative labels (Abaqus' internal nodes, e.g. Lagrange
//! multipliers) are refused: they have no coordinates.
//!
//! Not read: `FORMAT=LABELS` and `FORMAT=COORDINATE` (the latter's global row and column
//! numbers are plain Matrix Market-like triplets without the node map).

use std::collections::{BTreeSet, HashMap};
use std::path::Path;

use crate::error::{Error, Result};
use crate::limits::Limits;
use crate::model::excerpt::data_excerpt as excerpt;
use crate::sparse::SparseMatrix;

/// The largest DOF number Abaqus writes (3 displacements, 3 rotations).
pub const MAX_ABAQUS_DOF: usize = 6;

/// Smallest number of bytes one entry line takes: `"1,1,1,1,1\n"`.
const MIN_ENTRY_BYTES: usize = 10;

/// An error at `line` of `file` (0: the file as a whole).
fn error(file: &Path, line: usize, message: impl Into<String>) -> Error {
    if line == 0 {
        return Error::Io {
            file: file.to_path_buf(),
            message: message.into(),
        };
    }
    Error::MatrixMarket {
        file: file.to_path_buf(),
        line,
        message: message.into(),
    }
}

/// One entry: row node label, row DOF, column node label, column DOF, value, line.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LabelledEntry {
    pub row: (u64, usize),
    pub col: (u64, usize),
    pub value: f64,
    pub line: usize,
}

/// A matrix as Abaqus writes it: its entries by node label and DOF.
#[derive(Clone, Debug, PartialEq)]
pub struct LabelledMatrix {
    pub entries: Vec<LabelledEntry>,
}

/// The text looks like an Abaqus matrix: its first line that is neither blank nor a
/// keyword/comment line has five comma-separated fields.
pub fn looks_like_abaqus_matrix(text: &str) -> bool {
    text.lines()
        .map(str::trim)
        .find(|l| !l.is_empty() && !l.starts_with('*'))
        .is_some_and(|l| l.split(',').take(6).count() == 5)
}

/// Parse the text of an Abaqus matrix file; `file` is for messages. The entries the text
/// can hold are checked against `limits.memory_bytes` before anything is allocated.
pub fn parse_abaqus_matrix(text: &str, file: &Path, limits: &Limits) -> Result<LabelledMatrix> {
    let bound = text.len() / MIN_ENTRY_BYTES + 1;
    // the entries, their mirror images and the map that finds transposed entries
    limits.check_items(
        &format!(
            "{}: an Abaqus matrix of up to {bound} entries",
            file.display()
        ),
        bound as u64,
        (std::mem::size_of::<LabelledEntry>() + 2 * 48 + 64) as u64,
    )?;
    let mut entries = Vec::new();
    const FIELDS: [&str; 5] = ["row node", "row DOF", "column node", "column DOF", "value"];
    for (k, l) in text.lines().enumerate() {
        let line = k + 1;
        let l = l.trim();
        if l.is_empty() || l.starts_with('*') {
            continue;
        }
        let w: Vec<&str> = l.split(',').map(str::trim).take(6).collect();
        if w.len() != 5 {
            return Err(error(
                file,
                line,
                format!(
                    "expected `row node, row DOF, column node, column DOF, value`, found {} fields",
                    if w.len() > 5 {
                        "more than 5".to_string()
                    } else {
                        w.len().to_string()
                    }
                ),
            ));
        }
        let node = |f: usize| -> Result<u64> {
            match w[f].parse::<u64>() {
                Ok(n) if n > 0 => Ok(n),
                _ if w[f].parse::<i64>().is_ok_and(|n| n < 0) => Err(error(
                    file,
                    line,
                    format!(
                        "field {} ({}): node {} is an Abaqus internal node (e.g. a Lagrange multiplier), which has no coordinates; generate the matrices without them",
                        f + 1,
                        FIELDS[f],
                        w[f]
                    ),
                )),
                _ => Err(error(
                    file,
                    line,
                    format!(
                        "field {} ({}): {} is not a positive node label",
                        f + 1,
                        FIELDS[f],
                        excerpt(w[f])
                    ),
                )),
            }
        };
        let dof = |f: usize| -> Result<usize> {
            match w[f].parse::<usize>() {
                Ok(d) if (1..=MAX_ABAQUS_DOF).contains(&d) => Ok(d),
                _ => Err(error(
                    file,
                    line,
                    format!(
                        "field {} ({}): {} is not a DOF number 1 to {MAX_ABAQUS_DOF}",
                        f + 1,
                        FIELDS[f],
                        excerpt(w[f])
                    ),
                )),
            }
        };
        let value: f64 = w[4].parse().map_err(|_| {
            error(
                file,
                line,
                format!("field 5 (value): {} is not a number", excerpt(w[4])),
            )
        })?;
        if !value.is_finite() {
            return Err(error(
                file,
                line,
                format!("field 5 (value): {} is not finite", excerpt(w[4])),
            ));
        }
        entries.push(LabelledEntry {
            row: (node(0)?, dof(1)?),
            col: (node(2)?, dof(3)?),
            value,
            line,
        });
    }
    if entries.is_empty() {
        return Err(error(
            file,
            1,
            "no entries (expected lines `row node, row DOF, column node, column DOF, value`)",
        ));
    }
    Ok(LabelledMatrix { entries })
}

/// The matrix index of each `(node label, DOF)` of a model read from Abaqus matrices.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct DofMap {
    /// Node labels in increasing order; model node `p` is `labels[p]`.
    pub labels: Vec<u64>,
    /// DOFs per node: DOF numbers `1..=dofs_per_node`.
    pub dofs_per_node: usize,
}

impl DofMap {
    /// The map of `matrices` (their labels in increasing order), with `dofs_per_node` when
    /// given, else the largest DOF number they hold. Every `(node, DOF)` of the map must
    /// appear in some matrix, and no DOF may exceed `dofs_per_node`.
    pub fn new(
        matrices: &[(&Path, &LabelledMatrix)],
        dofs_per_node: Option<usize>,
    ) -> Result<Self> {
        let mut present: BTreeSet<(u64, usize)> = BTreeSet::new();
        for (_, m) in matrices {
            for e in &m.entries {
                present.insert(e.row);
                present.insert(e.col);
            }
        }
        let largest = present.iter().map(|&(_, d)| d).max().unwrap_or(1);
        let dofs_per_node = dofs_per_node.unwrap_or(largest);
        for (file, m) in matrices {
            if let Some(e) = m
                .entries
                .iter()
                .find(|e| e.row.1 > dofs_per_node || e.col.1 > dofs_per_node)
            {
                return Err(error(
                    file,
                    e.line,
                    format!(
                        "DOF {} above `mesh.dofs_per_node` = {dofs_per_node}",
                        e.row.1.max(e.col.1)
                    ),
                ));
            }
        }
        let labels: Vec<u64> = present
            .iter()
            .map(|&(n, _)| n)
            .collect::<BTreeSet<u64>>()
            .into_iter()
            .collect();
        for &n in &labels {
            for d in 1..=dofs_per_node {
                if !present.contains(&(n, d)) {
                    let files: Vec<String> = matrices
                        .iter()
                        .map(|(f, _)| f.display().to_string())
                        .collect();
                    return Err(error(
                        matrices[0].0,
                        0,
                        format!(
                            "node {n}, DOF {d} appears in none of {} (every node needs DOFs 1 to {dofs_per_node}; set `mesh.dofs_per_node` to the DOFs per node of the model)",
                            files.join(", ")
                        ),
                    ));
                }
            }
        }
        Ok(DofMap {
            labels,
            dofs_per_node,
        })
    }

    /// Model node number of a label.
    pub fn node(&self, label: u64) -> Option<usize> {
        self.labels.binary_search(&label).ok()
    }

    /// Matrix index of `(label, dof)` (DOF 1-based).
    pub fn index(&self, label: u64, dof: usize) -> Option<usize> {
        if dof == 0 || dof > self.dofs_per_node {
            return None;
        }
        Some(self.node(label)? * self.dofs_per_node + dof - 1)
    }

    /// Number of matrix rows.
    pub fn dofs(&self) -> usize {
        self.labels.len() * self.dofs_per_node
    }
}

/// The sparse matrix of `m` under `map` (built from `m` among others): the entries in
/// place, each mirrored unless its transposed entry is given too. An entry given twice is
/// an error naming both lines.
pub fn assemble(m: &LabelledMatrix, map: &DofMap, file: &Path) -> Result<SparseMatrix> {
    let mut at: HashMap<(usize, usize), usize> = HashMap::with_capacity(m.entries.len());
    let mut indexed = Vec::with_capacity(m.entries.len());
    for e in &m.entries {
        let missing = || error(file, e.line, "node or DOF outside the DOF map");
        let i = map.index(e.row.0, e.row.1).ok_or_else(missing)?;
        let j = map.index(e.col.0, e.col.1).ok_or_else(missing)?;
        if let Some(first) = at.insert((i, j), e.line) {
            return Err(error(
                file,
                e.line,
                format!(
                    "entry (node {}, DOF {}; node {}, DOF {}) given twice (first on line {first})",
                    e.row.0, e.row.1, e.col.0, e.col.1
                ),
            ));
        }
        indexed.push((i, j, e.value));
    }
    let mut triplets = Vec::with_capacity(2 * indexed.len());
    for &(i, j, v) in &indexed {
        triplets.push((i, j, v));
        if i != j && !at.contains_key(&(j, i)) {
            triplets.push((j, i, v));
        }
    }
    let n = map.dofs();
    SparseMatrix::try_from_triplets(n, n, &triplets).map_err(|e| error(file, 0, e.to_string()))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<LabelledMatrix> {
        parse_abaqus_matrix(text, Path::new("k.mtx"), &Limits::default())
    }

    #[test]
    fn lower_upper_and_square_storage_give_one_matrix() {
        let lower = "** comment\n1,1, 1,1, 2.0\n1,2, 1,1, -1.0\n1,2, 1,2, 3.0\n5,1, 1,2, 0.5\n5,1, 5,1, 4.0\n5,2, 5,2, 1.0\n";
        let upper = "1,1, 1,1, 2.0\n1,1, 1,2, -1.0\n1,2, 1,2, 3.0\n1,2, 5,1, 0.5\n5,1, 5,1, 4.0\n5,2, 5,2, 1.0\n";
        let square = format!("{lower}1,1, 1,2, -1.0\n1,2, 5,1, 0.5\n");
        let mats: Vec<SparseMatrix> = [lower, upper, square.as_str()]
            .iter()
            .map(|t| {
                let m = parse(t).unwrap();
                let map = DofMap::new(&[(Path::new("k.mtx"), &m)], None).unwrap();
                assert_eq!(map.labels, [1, 5]);
                assert_eq!(map.dofs_per_node, 2);
                assemble(&m, &map, Path::new("k.mtx")).unwrap()
            })
            .collect();
        assert_eq!(mats[0], mats[1]);
        assert_eq!(mats[0], mats[2]);
        // node 5 is model node 1: DOF 1 of node 5 is index 2
        assert_eq!(mats[0].get(2, 1), 0.5);
        assert_eq!(mats[0].get(1, 2), 0.5);
        assert_eq!(mats[0].get(0, 1), -1.0);
        assert_eq!(mats[0].get(3, 3), 1.0);
    }

    #[test]
    fn errors_name_the_line_and_the_field() {
        let e = parse("1,1,1,1,1.0\n1,7,1,1,2.0\n").unwrap_err().to_string();
        assert!(
            e.contains("k.mtx, line 2") && e.contains("field 2 (row DOF)"),
            "{e}"
        );
        let e = parse("1,1,1,1,x\n").unwrap_err().to_string();
        assert!(e.contains("line 1") && e.contains("field 5 (value)"), "{e}");
        let e = parse("-3,1,1,1,1\n").unwrap_err().to_string();
        assert!(e.contains("internal node"), "{e}");
        let e = parse("1,1,1,1\n").unwrap_err().to_string();
        assert!(e.contains("found 4 fields"), "{e}");
        let m = parse("1,1,1,1,1\n1,1,1,1,2\n").unwrap();
        let map = DofMap::new(&[(Path::new("k.mtx"), &m)], None).unwrap();
        let e = assemble(&m, &map, Path::new("k.mtx"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("line 2") && e.contains("twice"), "{e}");
        let m = parse("1,1,1,1,1\n2,2,2,2,1\n").unwrap();
        let e = DofMap::new(&[(Path::new("k.mtx"), &m)], None)
            .unwrap_err()
            .to_string();
        assert!(e.contains("node 1, DOF 2"), "{e}");
    }
}
