//! Matrix Market (`.mtx`) reading and writing: `coordinate` and `array` formats, `real`,
//! `integer` and `pattern` fields, `general`, `symmetric` and `skew-symmetric` storage.
//! Indices in the files are 1-based, as the format prescribes.

use std::fmt::Write as _;
use std::path::Path;

use crate::error::{Error, Result};
use crate::sparse::SparseMatrix;

#[derive(Clone, Copy, PartialEq, Eq)]
enum Layout {
    Coordinate,
    Array,
}

#[derive(Clone, Copy, PartialEq, Eq)]
enum Field {
    Real,
    Pattern,
}

#[derive(Clone, Copy, PartialEq, Eq)]
enum Symmetry {
    General,
    Symmetric,
    SkewSymmetric,
}

fn mm_error(file: &Path, line: usize, message: impl Into<String>) -> Error {
    Error::MatrixMarket {
        file: file.to_path_buf(),
        line,
        message: message.into(),
    }
}

/// Read a Matrix Market file into a sparse matrix.
pub fn read_matrix(file: &Path) -> Result<SparseMatrix> {
    let text = std::fs::read_to_string(file).map_err(|e| Error::io(file, e))?;
    parse_matrix(&text, file)
}

/// Parse Matrix Market text; `file` is used in error messages only.
pub fn parse_matrix(text: &str, file: &Path) -> Result<SparseMatrix> {
    let mut lines = text.lines().enumerate().map(|(k, l)| (k + 1, l));
    let (hline, header) = lines
        .next()
        .ok_or_else(|| mm_error(file, 1, "empty file (expected a `%%MatrixMarket` header)"))?;
    let words: Vec<String> = header
        .split_whitespace()
        .map(|w| w.to_ascii_lowercase())
        .collect();
    if words.len() != 5 || words[0] != "%%matrixmarket" || words[1] != "matrix" {
        return Err(mm_error(
            file,
            hline,
            "expected header `%%MatrixMarket matrix <coordinate|array> <real|integer|pattern> <general|symmetric|skew-symmetric>`",
        ));
    }
    let layout = match words[2].as_str() {
        "coordinate" => Layout::Coordinate,
        "array" => Layout::Array,
        other => {
            return Err(mm_error(
                file,
                hline,
                format!("unsupported format `{other}`"),
            ))
        }
    };
    let field = match words[3].as_str() {
        "real" | "integer" | "double" => Field::Real,
        "pattern" if layout == Layout::Coordinate => Field::Pattern,
        other => {
            return Err(mm_error(
                file,
                hline,
                format!("unsupported field `{other}` (complex matrices are not supported)"),
            ))
        }
    };
    let symmetry = match words[4].as_str() {
        "general" => Symmetry::General,
        "symmetric" => Symmetry::Symmetric,
        "skew-symmetric" => Symmetry::SkewSymmetric,
        other => {
            return Err(mm_error(
                file,
                hline,
                format!("unsupported symmetry `{other}`"),
            ))
        }
    };
    let mut data = lines.filter(|(_, l)| {
        let t = l.trim();
        !t.is_empty() && !t.starts_with('%')
    });
    let (sline, size) = data
        .next()
        .ok_or_else(|| mm_error(file, hline, "missing size line"))?;
    let sizes: Vec<usize> = size
        .split_whitespace()
        .map(|w| w.parse::<usize>())
        .collect::<std::result::Result<_, _>>()
        .map_err(|_| {
            mm_error(
                file,
                sline,
                format!("malformed size line `{}`", size.trim()),
            )
        })?;
    let parse_f = |line: usize, w: &str| -> Result<f64> {
        let v: f64 = w
            .parse()
            .map_err(|_| mm_error(file, line, format!("`{w}` is not a number")))?;
        if !v.is_finite() {
            return Err(mm_error(file, line, format!("`{w}` is not finite")));
        }
        Ok(v)
    };
    let mut triplets = Vec::new();
    let (nrows, ncols);
    match layout {
        Layout::Coordinate => {
            if sizes.len() != 3 {
                return Err(mm_error(
                    file,
                    sline,
                    "coordinate size line must be `rows cols entries`",
                ));
            }
            (nrows, ncols) = (sizes[0], sizes[1]);
            let nnz = sizes[2];
            let mut count = 0;
            for (line, l) in data {
                let w: Vec<&str> = l.split_whitespace().collect();
                let expected = if field == Field::Pattern { 2 } else { 3 };
                if w.len() != expected {
                    return Err(mm_error(
                        file,
                        line,
                        format!("expected {expected} values per entry, found {}", w.len()),
                    ));
                }
                let idx = |s: &str| -> Result<usize> {
                    s.parse::<usize>()
                        .map_err(|_| mm_error(file, line, format!("`{s}` is not a 1-based index")))
                };
                let (i, j) = (idx(w[0])?, idx(w[1])?);
                if i == 0 || j == 0 || i > nrows || j > ncols {
                    return Err(mm_error(
                        file,
                        line,
                        format!("index ({i}, {j}) outside the {nrows}×{ncols} matrix"),
                    ));
                }
                let v = if field == Field::Pattern {
                    1.0
                } else {
                    parse_f(line, w[2])?
                };
                push_entry(&mut triplets, i - 1, j - 1, v, symmetry);
                count += 1;
            }
            if count != nnz {
                return Err(mm_error(
                    file,
                    sline,
                    format!("size line announces {nnz} entries, file has {count}"),
                ));
            }
        }
        Layout::Array => {
            if sizes.len() != 2 {
                return Err(mm_error(file, sline, "array size line must be `rows cols`"));
            }
            (nrows, ncols) = (sizes[0], sizes[1]);
            let mut positions = Vec::new();
            for j in 0..ncols {
                let start = if symmetry == Symmetry::General {
                    0
                } else {
                    j + usize::from(symmetry == Symmetry::SkewSymmetric)
                };
                for i in start..nrows {
                    positions.push((i, j));
                }
            }
            let mut k = 0;
            for (line, l) in data {
                for w in l.split_whitespace() {
                    if k >= positions.len() {
                        return Err(mm_error(
                            file,
                            line,
                            format!(
                                "more than the {} values the size line announces",
                                positions.len()
                            ),
                        ));
                    }
                    let (i, j) = positions[k];
                    let v = parse_f(line, w)?;
                    if v != 0.0 {
                        push_entry(&mut triplets, i, j, v, symmetry);
                    }
                    k += 1;
                }
            }
            if k != positions.len() {
                return Err(mm_error(
                    file,
                    sline,
                    format!(
                        "size line announces {} values, file has {k}",
                        positions.len()
                    ),
                ));
            }
        }
    }
    if symmetry != Symmetry::General && nrows != ncols {
        return Err(mm_error(file, sline, "a symmetric matrix must be square"));
    }
    Ok(SparseMatrix::from_triplets(nrows, ncols, &triplets))
}

fn push_entry(t: &mut Vec<(usize, usize, f64)>, i: usize, j: usize, v: f64, symmetry: Symmetry) {
    t.push((i, j, v));
    if i != j {
        match symmetry {
            Symmetry::General => {}
            Symmetry::Symmetric => t.push((j, i, v)),
            Symmetry::SkewSymmetric => t.push((j, i, -v)),
        }
    }
}

/// Write a matrix in `coordinate real` format: `symmetric` (lower triangle) when the matrix
/// is exactly symmetric, `general` otherwise. Values are written with 17 significant
/// digits so that a round trip is exact.
pub fn write_matrix(file: &Path, a: &SparseMatrix) -> Result<()> {
    std::fs::write(file, format_matrix(a)).map_err(|e| Error::io(file, e))
}

/// The Matrix Market text of `a` (see [`write_matrix`]).
pub fn format_matrix(a: &SparseMatrix) -> String {
    let symmetric = a.nrows() == a.ncols() && a.asymmetry(0.0).is_none();
    let entries: Vec<(usize, usize, f64)> =
        a.iter().filter(|&(i, j, _)| !symmetric || i >= j).collect();
    let mut s = String::new();
    let kind = if symmetric { "symmetric" } else { "general" };
    let _ = writeln!(s, "%%MatrixMarket matrix coordinate real {kind}");
    let _ = writeln!(s, "{} {} {}", a.nrows(), a.ncols(), entries.len());
    for (i, j, v) in entries {
        let _ = writeln!(s, "{} {} {:.17e}", i + 1, j + 1, v);
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn symmetric_coordinate_is_mirrored_and_round_trips() {
        let text = "%%MatrixMarket matrix coordinate real symmetric\n% comment\n3 3 4\n1 1 2\n2 1 -1\n2 2 2\n3 3 1.5\n";
        let a = parse_matrix(text, Path::new("a.mtx")).unwrap();
        assert_eq!(a.get(0, 1), -1.0);
        assert_eq!(a.get(1, 0), -1.0);
        assert_eq!(a.get(2, 2), 1.5);
        let b = parse_matrix(&format_matrix(&a), Path::new("b.mtx")).unwrap();
        assert_eq!(a, b);
    }

    #[test]
    fn array_general_is_column_major() {
        let text = "%%MatrixMarket matrix array real general\n2 2\n1\n2\n3\n4\n";
        let a = parse_matrix(text, Path::new("a.mtx")).unwrap();
        assert_eq!(a.get(1, 0), 2.0);
        assert_eq!(a.get(0, 1), 3.0);
    }

    #[test]
    fn errors_name_the_line() {
        let text = "%%MatrixMarket matrix coordinate real general\n2 2 1\n3 1 1.0\n";
        let err = parse_matrix(text, Path::new("k.mtx"))
            .unwrap_err()
            .to_string();
        assert!(err.contains("k.mtx, line 3"), "{err}");
        let err = parse_matrix("hello\n", Path::new("k.mtx"))
            .unwrap_err()
            .to_string();
        assert!(err.contains("line 1"), "{err}");
        let text = "%%MatrixMarket matrix coordinate real general\n2 2 2\n1 1 1.0\n";
        assert!(parse_matrix(text, Path::new("k.mtx")).is_err());
    }
}
