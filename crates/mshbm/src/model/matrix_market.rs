//! Matrix Market (`.mtx`) reading and writing: `coordinate` and `array` formats, `real`,
//! `integer` and `pattern` fields, `general`, `symmetric` and `skew-symmetric` storage.
//! Indices in the files are 1-based, as the format prescribes.

use std::fmt::Write as _;
use std::path::Path;

use crate::error::{Error, Result};
use crate::limits::{read_text_file, Limits};
use crate::model::excerpt::data_excerpt as excerpt;
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

/// Read a Matrix Market file into a sparse matrix, with the default [`Limits`].
pub fn read_matrix(file: &Path) -> Result<SparseMatrix> {
    read_matrix_with(file, &Limits::default())
}

/// Read a Matrix Market file into a sparse matrix: a bounded read of a regular file
/// ([`read_text_file`]), then [`parse_matrix_with`].
pub fn read_matrix_with(file: &Path, limits: &Limits) -> Result<SparseMatrix> {
    let text = read_text_file(file, limits)?;
    parse_matrix_with(&text, file, limits)
}

/// Parse Matrix Market text with the default [`Limits`]; `file` is used in error messages
/// only.
pub fn parse_matrix(text: &str, file: &Path) -> Result<SparseMatrix> {
    parse_matrix_with(text, file, &Limits::default())
}

/// What the header and the size line of a Matrix Market file declare.
struct Header {
    layout: Layout,
    field: Field,
    symmetry: Symmetry,
    nrows: usize,
    ncols: usize,
    /// Entries announced by a coordinate file.
    entries: Option<usize>,
    /// Line number of the size line.
    size_line: usize,
}

/// Smallest number of bytes one entry line takes in a coordinate file: `"1 1 1\n"` (a
/// pattern entry: `"1 1\n"`). The last line may lack its newline, hence `len + 1` below.
fn min_entry_bytes(field: Field) -> u64 {
    if field == Field::Pattern {
        4
    } else {
        6
    }
}

/// Smallest number of bytes one value takes in an array file: `"1\n"`.
const MIN_ARRAY_VALUE_BYTES: u64 = 2;

/// Read the header line and the size line from `lines` (comments and blank lines before the
/// size line are skipped).
fn parse_header<'t>(
    lines: &mut impl Iterator<Item = (usize, &'t str)>,
    file: &Path,
) -> Result<Header> {
    let (hline, header) = lines
        .next()
        .ok_or_else(|| mm_error(file, 1, "empty file (expected a `%%MatrixMarket` header)"))?;
    // at most six words, compared without copying: the first line of a hostile file may be
    // the whole file (a gibibyte without a line break), and it is never copied
    let words: Vec<&str> = header.split_whitespace().take(6).collect();
    if words.len() != 5
        || !words[0].eq_ignore_ascii_case("%%matrixmarket")
        || !words[1].eq_ignore_ascii_case("matrix")
    {
        return Err(mm_error(
            file,
            hline,
            "expected header `%%MatrixMarket matrix <coordinate|array> <real|integer|pattern> <general|symmetric|skew-symmetric>`",
        ));
    }
    let is = |word: &str, name: &str| word.eq_ignore_ascii_case(name);
    let layout = if is(words[2], "coordinate") {
        Layout::Coordinate
    } else if is(words[2], "array") {
        Layout::Array
    } else {
        return Err(mm_error(
            file,
            hline,
            format!("unsupported format {}", excerpt(words[2])),
        ));
    };
    let field = if ["real", "integer", "double"]
        .iter()
        .any(|n| is(words[3], n))
    {
        Field::Real
    } else if is(words[3], "pattern") && layout == Layout::Coordinate {
        Field::Pattern
    } else {
        return Err(mm_error(
            file,
            hline,
            format!(
                "unsupported field {} (complex matrices are not supported)",
                excerpt(words[3])
            ),
        ));
    };
    let symmetry = if is(words[4], "general") {
        Symmetry::General
    } else if is(words[4], "symmetric") {
        Symmetry::Symmetric
    } else if is(words[4], "skew-symmetric") {
        Symmetry::SkewSymmetric
    } else {
        return Err(mm_error(
            file,
            hline,
            format!("unsupported symmetry {}", excerpt(words[4])),
        ));
    };
    let (sline, size) = lines
        .find(|(_, l)| {
            let t = l.trim();
            !t.is_empty() && !t.starts_with('%')
        })
        .ok_or_else(|| mm_error(file, hline, "missing size line"))?;
    // at most four numbers (three are expected): a size line may be the rest of the file
    let sizes: Vec<usize> = size
        .split_whitespace()
        .take(4)
        .map(|w| w.parse::<usize>())
        .collect::<std::result::Result<_, _>>()
        .map_err(|_| {
            mm_error(
                file,
                sline,
                format!(
                    "malformed size line {} (expected non-negative integers below 2^64)",
                    excerpt(size.trim())
                ),
            )
        })?;
    let entries = match layout {
        Layout::Coordinate => {
            if sizes.len() != 3 {
                return Err(mm_error(
                    file,
                    sline,
                    "coordinate size line must be `rows cols entries`",
                ));
            }
            Some(sizes[2])
        }
        Layout::Array => {
            if sizes.len() != 2 {
                return Err(mm_error(file, sline, "array size line must be `rows cols`"));
            }
            None
        }
    };
    Ok(Header {
        layout,
        field,
        symmetry,
        nrows: sizes[0],
        ncols: sizes[1],
        entries,
        size_line: sline,
    })
}

/// The `(rows, columns)` a Matrix Market text declares, read from its header and size line
/// only (nothing is allocated), so that a caller can check them before parsing.
pub fn declared_dimensions(text: &str, file: &Path) -> Result<(usize, usize)> {
    let mut lines = text.lines().enumerate().map(|(k, l)| (k + 1, l));
    let h = parse_header(&mut lines, file)?;
    Ok((h.nrows, h.ncols))
}

/// Parse Matrix Market text; `file` is used in error messages only. The declared sizes are
/// checked before anything is allocated: the announced entries (coordinate) or values
/// (array) must fit in the text (at least 6, resp. 2, bytes each), and the matrix's
/// assembly ([`SparseMatrix::assembly_bytes`]) must fit `limits.memory_bytes`.
pub fn parse_matrix_with(text: &str, file: &Path, limits: &Limits) -> Result<SparseMatrix> {
    let mut lines = text.lines().enumerate().map(|(k, l)| (k + 1, l));
    let h = parse_header(&mut lines, file)?;
    let (nrows, ncols, sline, symmetry, field) =
        (h.nrows, h.ncols, h.size_line, h.symmetry, h.field);
    if symmetry != Symmetry::General && nrows != ncols {
        return Err(mm_error(file, sline, "a symmetric matrix must be square"));
    }
    let text_bytes = text.len() as u64 + 1;
    let too_many = |what: &str, count: usize, min_bytes: u64| {
        mm_error(
            file,
            sline,
            format!(
                "the size line announces {count} {what}, more than the file's {} bytes can hold ({min_bytes} bytes or more each)",
                text.len()
            ),
        )
    };
    // values stored in the file, and the triplets they give (mirrored off the diagonal)
    let (announced, what, min_bytes) = match h.layout {
        Layout::Coordinate => (h.entries, "entries", min_entry_bytes(field)),
        Layout::Array => {
            let n = nrows as u64;
            let values = match symmetry {
                Symmetry::General => n.checked_mul(ncols as u64),
                Symmetry::Symmetric => n.checked_mul(n.saturating_add(1)).map(|v| v / 2),
                Symmetry::SkewSymmetric => n.checked_mul(n.saturating_sub(1)).map(|v| v / 2),
            };
            (
                values.and_then(|v| usize::try_from(v).ok()),
                "values",
                MIN_ARRAY_VALUE_BYTES,
            )
        }
    };
    let announced = match announced {
        Some(a)
            if (a as u64)
                .checked_mul(min_bytes)
                .is_some_and(|b| b <= text_bytes) =>
        {
            a
        }
        Some(a) => return Err(too_many(what, a, min_bytes)),
        None => {
            return Err(mm_error(
                file,
                sline,
                format!("the size line announces {nrows}×{ncols} values, more than 2^64"),
            ))
        }
    };
    let triplets_bound = if symmetry == Symmetry::General {
        Some(announced)
    } else {
        announced.checked_mul(2)
    };
    limits.check_memory(
        &format!(
            "{}, line {sline}: the {nrows}×{ncols} matrix with {announced} {what}",
            file.display()
        ),
        triplets_bound.and_then(|t| SparseMatrix::assembly_bytes(ncols, t)),
    )?;
    let mut triplets: Vec<(usize, usize, f64)> = Vec::new();
    triplets
        .try_reserve_exact(triplets_bound.unwrap_or(usize::MAX))
        .map_err(|_| mm_error(file, sline, "cannot allocate memory for the matrix"))?;
    let parse_f = |line: usize, w: &str| -> Result<f64> {
        let v: f64 = w
            .parse()
            .map_err(|_| mm_error(file, line, format!("{} is not a number", excerpt(w))))?;
        if !v.is_finite() {
            return Err(mm_error(
                file,
                line,
                format!("{} is not finite", excerpt(w)),
            ));
        }
        Ok(v)
    };
    let data = lines.filter(|(_, l)| {
        let t = l.trim();
        !t.is_empty() && !t.starts_with('%')
    });
    let mut count = 0;
    match h.layout {
        Layout::Coordinate => {
            let expected = if field == Field::Pattern { 2 } else { 3 };
            for (line, l) in data {
                if count == announced {
                    return Err(mm_error(
                        file,
                        line,
                        format!("more than the {announced} entries the size line announces"),
                    ));
                }
                let w: Vec<&str> = l.split_whitespace().take(expected + 1).collect();
                if w.len() != expected {
                    return Err(mm_error(
                        file,
                        line,
                        format!(
                            "expected {expected} values per entry, found {}",
                            if w.len() > expected {
                                "more".to_string()
                            } else {
                                w.len().to_string()
                            }
                        ),
                    ));
                }
                let idx = |s: &str| -> Result<usize> {
                    s.parse::<usize>().map_err(|_| {
                        mm_error(file, line, format!("{} is not a 1-based index", excerpt(s)))
                    })
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
            if count != announced {
                return Err(mm_error(
                    file,
                    sline,
                    format!("size line announces {announced} entries, file has {count}"),
                ));
            }
        }
        Layout::Array => {
            // column-major; a symmetric (skew-symmetric) file stores the lower triangle
            // with (without) the diagonal
            let first_row = |j: usize| match symmetry {
                Symmetry::General => 0,
                Symmetry::Symmetric => j,
                Symmetry::SkewSymmetric => j + 1,
            };
            let (mut i, mut j) = (first_row(0), 0);
            for (line, l) in data {
                for w in l.split_whitespace() {
                    if count >= announced {
                        return Err(mm_error(
                            file,
                            line,
                            format!("more than the {announced} values the size line announces"),
                        ));
                    }
                    while i >= nrows {
                        j += 1;
                        i = first_row(j);
                    }
                    let v = parse_f(line, w)?;
                    if v != 0.0 {
                        push_entry(&mut triplets, i, j, v, symmetry);
                    }
                    i += 1;
                    count += 1;
                }
            }
            if count != announced {
                return Err(mm_error(
                    file,
                    sline,
                    format!("size line announces {announced} values, file has {count}"),
                ));
            }
        }
    }
    SparseMatrix::try_from_triplets(nrows, ncols, &triplets)
        .map_err(|e| mm_error(file, sline, e.to_string()))
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
