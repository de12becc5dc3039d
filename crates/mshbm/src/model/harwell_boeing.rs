//! Reader of Harwell–Boeing and Rutherford–Boeing matrix files (`.rua`, `.rsa`, `.rb`;
//! Duff, Grimes & Lewis, "Users' guide for the Harwell-Boeing sparse matrix collection",
//! 1992; Ansys' `HBMAT` writes them): real or integer, assembled, unsymmetric (`?UA`),
//! symmetric (`?SA`, the lower triangle, mirrored here), skew-symmetric (`?ZA`) or
//! rectangular (`?RA`); pattern files (`P??`) give ones. Not read: complex (`C??`) and
//! elemental (`??E`) matrices, and right-hand sides (skipped).
//!
//! The header is four lines (five with right-hand sides):
//!
//! ```text
//! title (72 characters) key (8)
//! TOTCRD PTRCRD INDCRD VALCRD [RHSCRD]        card counts of the sections
//! MXTYPE NROW NCOL NNZERO [NELTVL]             e.g. RSA 101 101 201 0
//! (PTRFMT) (INDFMT) (VALFMT) [(RHSFMT)]        Fortran formats, e.g. (20I4) (3E25.16)
//! ```
//!
//! then `PTRCRD` lines of column pointers (`NCOL + 1`, 1-based), `INDCRD` lines of row
//! indices (`NNZERO`, 1-based) and `VALCRD` lines of values, column by column. The data are
//! in fixed-width fields (values need not be separated by blanks, e.g.
//! `-1.0E+00-2.0E+00`), so each line is cut by the width of its section's format (or, when
//! that gives fields that are not numbers, split at blanks: SciPy writes `E24` fields
//! under an `E25` format); `D` exponents are read. The counts of the header line 2 are read as blank-separated integers
//! (Rutherford–Boeing files give four). Every count is checked against the text before
//! anything is allocated, and every error names the line and the field.

use std::path::Path;

use crate::error::{Error, Result};
use crate::limits::Limits;
use crate::model::excerpt::data_excerpt as excerpt;
use crate::sparse::SparseMatrix;

fn error(file: &Path, line: usize, message: impl Into<String>) -> Error {
    Error::MatrixMarket {
        file: file.to_path_buf(),
        line,
        message: message.into(),
    }
}

/// The text looks like a Harwell–Boeing file: its third line starts with a matrix type
/// code (`RUA`, `RSA`, `PSA`, …) followed by a blank.
pub fn looks_like_harwell_boeing(text: &str) -> bool {
    text.lines().nth(2).is_some_and(|l| {
        let b = l.as_bytes();
        b.len() > 3
            && b"RPICrpic".contains(&b[0])
            && b"SUHZRsuhzr".contains(&b[1])
            && b"AEae".contains(&b[2])
            && b[3] == b' '
    })
}

/// A data format: `count` fields of `width` characters per line.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct DataFormat {
    count: usize,
    width: usize,
}

/// Parse a Fortran format such as `(20I4)`, `(3E25.16)`, `(1P,4E20.12)`, `(1P5D16.8)`,
/// `(5F15.7)`; `field` names it in errors.
fn data_format(text: &str, file: &Path, line: usize, field: &str) -> Result<DataFormat> {
    let bad = || {
        error(
            file,
            line,
            format!(
                "{field}: {} is not a Fortran data format such as (20I4) or (3E25.16)",
                excerpt(text)
            ),
        )
    };
    let t = text.trim().to_ascii_uppercase();
    let t = t
        .strip_prefix('(')
        .and_then(|t| t.strip_suffix(')'))
        .ok_or_else(bad)?;
    // a scale factor `1P` (optionally followed by a comma) changes nothing in reading
    let t = t.trim();
    let t = match t.find('P') {
        Some(p) if t[..p].chars().all(|c| c.is_ascii_digit() || c == '-') => {
            t[p + 1..].trim_start_matches(',').trim()
        }
        _ => t,
    };
    let letter = t.find(|c: char| c.is_ascii_alphabetic()).ok_or_else(bad)?;
    if !matches!(&t[letter..=letter], "I" | "E" | "D" | "F" | "G") {
        return Err(bad());
    }
    let count = if letter == 0 {
        1
    } else {
        t[..letter].parse::<usize>().map_err(|_| bad())?
    };
    let rest = &t[letter + 1..];
    let width_end = rest
        .find(|c: char| !c.is_ascii_digit())
        .unwrap_or(rest.len());
    let width = rest[..width_end].parse::<usize>().map_err(|_| bad())?;
    let tail = &rest[width_end..];
    let precision_ok = tail.is_empty()
        || tail
            .strip_prefix('.')
            .is_some_and(|d| !d.is_empty() && d.chars().all(|c| c.is_ascii_alphanumeric()));
    if count == 0 || width == 0 || width > 100 || count > 1000 || !precision_ok {
        return Err(bad());
    }
    Ok(DataFormat { count, width })
}

/// Whether a field is a number of its section: an integer, or (`real`) a real number with
/// an `E` or `D` exponent.
fn is_number(f: &str, real: bool) -> bool {
    if real {
        f.replace(['D', 'd'], "E").parse::<f64>().is_ok()
    } else {
        f.parse::<u64>().is_ok()
    }
}

/// The fields of one line: cut into at most `format.count` fields of `format.width`
/// characters, blank fields skipped (a short last line) — unless a cut field is not a
/// number (holds a blank, or does not parse), then the blank-separated words: some writers
/// (SciPy 1.17's `hb_write`) write fields one character narrower than their format says,
/// separated by blanks.
fn line_fields(l: &str, format: DataFormat, real: bool) -> Vec<&str> {
    let mut cut = Vec::with_capacity(format.count);
    let mut rest = l;
    while !rest.is_empty() {
        let at = rest
            .char_indices()
            .nth(format.width)
            .map_or(rest.len(), |(i, _)| i);
        let (f, r) = rest.split_at(at);
        rest = r;
        let f = f.trim();
        if !f.is_empty() {
            cut.push(f);
        }
        if cut.len() > format.count {
            break;
        }
    }
    if cut.iter().all(|f| is_number(f, real)) {
        cut
    } else {
        l.split_whitespace().take(format.count + 1).collect()
    }
}

/// The fields of `count` values from the lines `lines` (numbered from `first_line`), each
/// line cut by [`line_fields`].
fn fields<'t>(
    lines: &[&'t str],
    first_line: usize,
    format: DataFormat,
    count: usize,
    file: &Path,
    what: &str,
    real: bool,
) -> Result<Vec<(usize, &'t str)>> {
    let mut out = Vec::with_capacity(count);
    for (k, l) in lines.iter().enumerate() {
        let line = first_line + k;
        let on_line = line_fields(l, format, real);
        if on_line.len() > format.count {
            return Err(error(
                file,
                line,
                format!(
                    "more than {} {what} on one line (the format gives {} fields of {} characters)",
                    format.count, format.count, format.width
                ),
            ));
        }
        for f in on_line {
            if out.len() == count {
                return Err(error(
                    file,
                    line,
                    format!("more {what} than the {count} the header announces"),
                ));
            }
            out.push((line, f));
        }
    }
    if out.len() != count {
        return Err(error(
            file,
            first_line + lines.len().saturating_sub(1),
            format!(
                "the header announces {count} {what}, the section has {}",
                out.len()
            ),
        ));
    }
    Ok(out)
}

/// Parse a Harwell–Boeing file; `file` is for messages.
pub fn parse_harwell_boeing(text: &str, file: &Path, limits: &Limits) -> Result<SparseMatrix> {
    let lines: Vec<&str> = text.lines().collect();
    let header = |k: usize, what: &str| -> Result<&str> {
        lines.get(k).copied().ok_or_else(|| {
            error(
                file,
                k + 1,
                format!("the file ends in its header (line {} holds {what})", k + 1),
            )
        })
    };
    let integers = |k: usize, l: &str, what: &str, fields: &[&str]| -> Result<Vec<usize>> {
        l.split_whitespace()
            .take(fields.len() + 1)
            .enumerate()
            .map(|(f, w)| {
                w.parse::<usize>().map_err(|_| {
                    error(
                        file,
                        k + 1,
                        format!(
                            "{what}: {} {} is not a non-negative integer",
                            fields.get(f).copied().unwrap_or("field"),
                            excerpt(w)
                        ),
                    )
                })
            })
            .collect()
    };
    const CARDS: [&str; 5] = ["TOTCRD", "PTRCRD", "INDCRD", "VALCRD", "RHSCRD"];
    let cards = integers(1, header(1, "the card counts")?, "line 2", &CARDS)?;
    if !(4..=5).contains(&cards.len()) {
        return Err(error(
            file,
            2,
            "expected the card counts `TOTCRD PTRCRD INDCRD VALCRD [RHSCRD]`",
        ));
    }
    let (ptrcrd, indcrd, valcrd) = (cards[1], cards[2], cards[3]);
    let rhscrd = cards.get(4).copied().unwrap_or(0);
    let l3 = header(2, "the matrix type and sizes")?;
    let mxtype: String = l3.chars().take(3).collect::<String>().to_ascii_uppercase();
    let b = mxtype.as_bytes();
    if b.len() != 3 || !b"RPI".contains(&b[0]) || !b"SUHZR".contains(&b[1]) || b[2] != b'A' {
        let why = match b.first() {
            Some(b'C') => "complex matrices are not read",
            _ if b.get(2) == Some(&b'E') => "elemental (unassembled) matrices are not read",
            _ => "expected a type such as RUA, RSA or RZA",
        };
        return Err(error(
            file,
            3,
            format!("MXTYPE {}: {why}", excerpt(&mxtype)),
        ));
    }
    let pattern = b[0] == b'P';
    let sizes = integers(
        2,
        l3.get(3..).unwrap_or(""),
        "line 3",
        &["NROW", "NCOL", "NNZERO", "NELTVL"],
    )?;
    let [nrow, ncol, nnz, ..] = sizes[..] else {
        return Err(error(
            file,
            3,
            "expected `MXTYPE NROW NCOL NNZERO [NELTVL]`",
        ));
    };
    if b[1] != b'R' && b[1] != b'U' && nrow != ncol {
        return Err(error(
            file,
            3,
            format!("a {mxtype} matrix must be square, NROW = {nrow}, NCOL = {ncol}"),
        ));
    }
    let l4 = header(3, "the formats")?;
    // the parenthesized formats, in order
    let formats: Vec<&str> = l4
        .split_inclusive(')')
        .map(|s| s.trim())
        .filter(|s| s.contains('('))
        .map(|s| &s[s.find('(').unwrap_or(0)..])
        .collect();
    let needed = if pattern { 2 } else { 3 };
    if formats.len() < needed {
        return Err(error(
            file,
            4,
            format!(
                "expected {needed} Fortran formats (PTRFMT, INDFMT{}), found {}",
                if pattern { "" } else { ", VALFMT" },
                formats.len()
            ),
        ));
    }
    let ptr_format = data_format(formats[0], file, 4, "PTRFMT")?;
    let ind_format = data_format(formats[1], file, 4, "INDFMT")?;
    let val_format = if pattern {
        None
    } else {
        Some(data_format(formats[2], file, 4, "VALFMT")?)
    };
    let data_start = if rhscrd > 0 { 5 } else { 4 };
    // the sections' lines, checked against the file before any count sizes an allocation
    let available = lines.len().saturating_sub(data_start);
    let declared = ptrcrd
        .checked_add(indcrd)
        .and_then(|c| c.checked_add(if pattern { 0 } else { valcrd }));
    if declared.is_none_or(|d| d > available) {
        return Err(error(
            file,
            2,
            format!(
                "PTRCRD + INDCRD{} = {} lines, more than the {available} lines after the header",
                if pattern { "" } else { " + VALCRD" },
                declared.map_or("more than 2^64".into(), |d| d.to_string())
            ),
        ));
    }
    let fits = |count: usize, cards: usize, f: DataFormat| {
        cards
            .checked_mul(f.count)
            .is_some_and(|capacity| count <= capacity)
    };
    let np = ncol.saturating_add(1);
    if !fits(np, ptrcrd, ptr_format)
        || !fits(nnz, indcrd, ind_format)
        || val_format.is_some_and(|f| !fits(nnz, valcrd, f))
    {
        return Err(error(
            file,
            3,
            format!(
                "NCOL = {ncol} and NNZERO = {nnz} do not fit in the {ptrcrd}, {indcrd} and {valcrd} lines of the sections"
            ),
        ));
    }
    // every pointer, index and value takes a non-blank character of the text
    if np.max(nnz) > text.len() {
        return Err(error(
            file,
            3,
            format!(
                "NCOL = {ncol} and NNZERO = {nnz} are more values than the file's {} bytes can hold",
                text.len()
            ),
        ));
    }
    let symmetric = matches!(b[1], b'S' | b'H' | b'Z');
    limits.check_memory(
        &format!(
            "{}, line 3: the {nrow}×{ncol} matrix with {nnz} entries",
            file.display()
        ),
        SparseMatrix::assembly_bytes(ncol, if symmetric { 2 * nnz } else { nnz }),
    )?;
    let ptr_lines = &lines[data_start..data_start + ptrcrd];
    let ind_lines = &lines[data_start + ptrcrd..data_start + ptrcrd + indcrd];
    let val_first = data_start + ptrcrd + indcrd;
    let index = |(line, f): (usize, &str), what: &str| -> Result<usize> {
        f.parse::<usize>().ok().filter(|&i| i >= 1).ok_or_else(|| {
            error(
                file,
                line,
                format!("{what} {} is not a positive integer", excerpt(f)),
            )
        })
    };
    let ptr_fields = fields(
        ptr_lines,
        data_start + 1,
        ptr_format,
        np,
        file,
        "column pointers",
        false,
    )?;
    let mut ptr = Vec::with_capacity(np);
    for (k, &pf) in ptr_fields.iter().enumerate() {
        let p = index(pf, "column pointer")?;
        let expected_first = k == 0 && p != 1;
        let decreasing = ptr.last().is_some_and(|&q| p < q);
        let last_wrong = k == ncol && p != nnz + 1;
        if expected_first || decreasing || last_wrong {
            return Err(error(
                file,
                pf.0,
                format!(
                    "column pointer {} of column {}: pointers start at 1, never decrease and end at NNZERO + 1 = {}",
                    p,
                    k + 1,
                    nnz + 1
                ),
            ));
        }
        ptr.push(p);
    }
    let ind_fields = fields(
        ind_lines,
        data_start + ptrcrd + 1,
        ind_format,
        nnz,
        file,
        "row indices",
        false,
    )?;
    let values: Vec<f64> = match val_format {
        None => vec![1.0; nnz],
        Some(f) => {
            let val_lines = &lines[val_first..val_first + valcrd];
            fields(val_lines, val_first + 1, f, nnz, file, "values", true)?
                .into_iter()
                .map(|(line, s)| {
                    let v: f64 = s.replace(['D', 'd'], "E").parse().map_err(|_| {
                        error(file, line, format!("value {} is not a number", excerpt(s)))
                    })?;
                    if v.is_finite() {
                        Ok(v)
                    } else {
                        Err(error(
                            file,
                            line,
                            format!("value {} is not finite", excerpt(s)),
                        ))
                    }
                })
                .collect::<Result<_>>()?
        }
    };
    let mut triplets = Vec::with_capacity(if symmetric { 2 * nnz } else { nnz });
    for j in 0..ncol {
        for k in ptr[j] - 1..ptr[j + 1] - 1 {
            let i = index(ind_fields[k], "row index")?;
            if i > nrow {
                return Err(error(
                    file,
                    ind_fields[k].0,
                    format!("row index {i} outside the {nrow} rows"),
                ));
            }
            let (i, v) = (i - 1, values[k]);
            if symmetric && i < j {
                return Err(error(
                    file,
                    ind_fields[k].0,
                    format!(
                        "row {} of column {}: a {mxtype} file stores the lower triangle only",
                        i + 1,
                        j + 1
                    ),
                ));
            }
            triplets.push((i, j, v));
            if symmetric && i != j {
                triplets.push((j, i, if b[1] == b'Z' { -v } else { v }));
            }
        }
    }
    SparseMatrix::try_from_triplets(nrow, ncol, &triplets)
        .map_err(|e| error(file, 3, e.to_string()))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<SparseMatrix> {
        parse_harwell_boeing(text, Path::new("a.rsa"), &Limits::default())
    }

    #[test]
    fn fortran_formats() {
        let f = |s: &str| data_format(s, Path::new("a"), 4, "PTRFMT");
        for (text, count, width) in [
            ("(20I4)", 20, 4),
            ("(3E25.16)", 3, 25),
            ("(1P,4E20.12)", 4, 20),
            ("(1P5D16.8)", 5, 16),
            ("(E26.18E3)", 1, 26),
        ] {
            assert_eq!(f(text).unwrap(), DataFormat { count, width }, "{text}");
        }
        for bad in ["20I4", "(0I4)", "(20X4)", "(I)", "()"] {
            assert!(f(bad).is_err(), "{bad}");
        }
    }

    /// A 3 × 3 symmetric matrix, lower triangle, values touching (no blanks between
    /// them) and with D exponents.
    const RSA: &str = "\
symmetric test                                                          key
             5             1             1             2
RSA                        3             3             5             0
(4I3)           (5I3)           (3D10.3)
  1  3  5  6
  1  2  2  3  3
 2.000D+00-1.000D+00 3.000D+00
-5.000D-01 4.000D+00
";

    #[test]
    fn symmetric_lower_triangle_is_mirrored() {
        let a = parse(RSA).unwrap();
        let expected = [[2.0, -1.0, 0.0], [-1.0, 3.0, -0.5], [0.0, -0.5, 4.0]];
        for (i, row) in expected.iter().enumerate() {
            for (j, &v) in row.iter().enumerate() {
                assert_eq!(a.get(i, j), v, "({i}, {j})");
            }
        }
    }

    #[test]
    fn errors_name_the_line_and_the_field() {
        let e = parse(&RSA.replace("RSA", "CSA")).unwrap_err().to_string();
        assert!(e.contains("a.rsa, line 3") && e.contains("complex"), "{e}");
        let e = parse(&RSA.replace("  1  2  2  3  3", "  1  2  2  9  3"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("line 6") && e.contains("row index 9"), "{e}");
        let e = parse(&RSA.replace("-5.000D-01", "-5.000X-01"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("line 8") && e.contains("value"), "{e}");
        let e = parse(&RSA.replace("  1  3  5  6", "  1  5  3  6"))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("line 5") && e.contains("column pointer 3 of column 3"),
            "{e}"
        );
        let e = parse(&RSA.replace("(5I3)", "(5J3)"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("line 4") && e.contains("INDFMT"), "{e}");
        let e = parse(&RSA.replace(
            "5             1             1             2",
            "5             1             1             99",
        ))
        .unwrap_err()
        .to_string();
        assert!(e.contains("line 2") && e.contains("more than the"), "{e}");
        let e = parse(&RSA.replace("  1  2  2  3  3", "  1  2  1  3  3"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("lower triangle"), "{e}");
        assert!(parse("only\ntwo lines").is_err());
    }
}
