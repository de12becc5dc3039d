//! Binary MSH 4.1 (`gmsh -format msh41 -bin`, or `Mesh.Binary = 1`): the sections of the
//! ASCII format with their numbers as raw bytes (Gmsh reference manual, "MSH file format"):
//! `int` is 4 bytes, `size_t` the data size of `$MeshFormat` (8, or 4), `double` 8 bytes,
//! all in the byte order the `int` 1 after the format line shows. `$PhysicalNames` stays
//! text. Read: `$MeshFormat`, `$PhysicalNames`, `$Entities`, `$Nodes`, `$Elements`; any
//! other section is skipped to its `$End…` line. Every count read from the file is only a
//! loop bound: each entry consumes bytes of the (bounded) file, so a huge count ends at the
//! end of the data with an error, and no count sizes an allocation. Errors name the byte
//! offset (the file has no lines in its binary parts).

use std::collections::HashMap;

use super::{element_type, ElementBlock, MshError, Parse};

fn fail<T>(offset: usize, message: impl Into<String>) -> Parse<T> {
    Err(MshError {
        line: 0,
        message: format!("byte {offset}: {}", message.into()),
    })
}

/// A cursor over the bytes.
struct Reader<'a> {
    bytes: &'a [u8],
    at: usize,
    size_t: usize,
    big_endian: bool,
}

impl<'a> Reader<'a> {
    fn take(&mut self, n: usize, what: &str) -> Parse<&'a [u8]> {
        match self.bytes.get(self.at..self.at.saturating_add(n)) {
            Some(b) => {
                self.at += n;
                Ok(b)
            }
            None => fail(self.at, format!("the file ends inside {what}")),
        }
    }

    fn word(&mut self, n: usize, what: &str) -> Parse<u64> {
        let b = self.take(n, what)?;
        let mut v = 0u64;
        if self.big_endian {
            for &x in b {
                v = (v << 8) | x as u64;
            }
        } else {
            for &x in b.iter().rev() {
                v = (v << 8) | x as u64;
            }
        }
        Ok(v)
    }

    fn int(&mut self, what: &str) -> Parse<i64> {
        Ok(self.word(4, what)? as u32 as i32 as i64)
    }

    fn size(&mut self, what: &str) -> Parse<u64> {
        self.word(self.size_t, what)
    }

    fn double(&mut self, what: &str) -> Parse<f64> {
        Ok(f64::from_bits(self.word(8, what)?))
    }

    /// The next text line (without its `\r\n` or `\n`), skipping blank lines.
    fn line(&mut self, what: &str) -> Parse<&'a str> {
        loop {
            let start = self.at;
            let rest = self.bytes.get(start..).unwrap_or(&[]);
            if rest.is_empty() {
                return fail(start, format!("the file ends before {what}"));
            }
            let end = rest.iter().position(|&b| b == b'\n').unwrap_or(rest.len());
            self.at = start + (end + 1).min(rest.len());
            let l = std::str::from_utf8(&rest[..end])
                .map_err(|_| MshError {
                    line: 0,
                    message: format!("byte {start}: expected a text line ({what})"),
                })?
                .trim();
            if !l.is_empty() {
                return Ok(l);
            }
        }
    }

    /// The `$End<section>` line after the binary data of a section.
    fn end(&mut self, section: &str) -> Parse<()> {
        let at = self.at;
        let l = self.line(&format!("$End{section}"))?;
        if l != format!("$End{section}") {
            return fail(at, format!("expected $End{section}"));
        }
        Ok(())
    }
}

/// A count that must be non-negative and not more than the bytes left (each entry takes
/// at least one byte).
fn count(r: &Reader<'_>, v: i64, what: &str) -> Parse<u64> {
    if v < 0 || v as u64 > (r.bytes.len() - r.at) as u64 {
        return fail(r.at, format!("{what}: {v} is more than the file holds"));
    }
    Ok(v as u64)
}

/// Parse a binary MSH 4.1 file whose `$MeshFormat` line is at `format_at` (the offset of
/// the line after `$MeshFormat`); `size_t` is its data size.
pub(super) fn parse_binary(
    bytes: &[u8],
    format_at: usize,
    size_t: usize,
) -> Parse<super::GmshMesh> {
    if size_t != 4 && size_t != 8 {
        return fail(format_at, format!("data size {size_t}: expected 8 (or 4)"));
    }
    let mut r = Reader {
        bytes,
        at: format_at,
        size_t,
        big_endian: false,
    };
    r.line("the format line")?;
    let one = r.take(4, "the byte-order check")?;
    r.big_endian = match one {
        [1, 0, 0, 0] => false,
        [0, 0, 0, 1] => true,
        _ => return fail(r.at - 4, "the byte-order check is not the integer 1"),
    };
    r.end("MeshFormat")?;
    let mut names: HashMap<(usize, i64), String> = HashMap::new();
    let mut entities: HashMap<(usize, i64), Vec<i64>> = HashMap::new();
    let mut nodes: HashMap<u64, [f64; 3]> = HashMap::new();
    let mut blocks: Vec<ElementBlock> = Vec::new();
    let (mut nodes_seen, mut elements_seen) = (false, false);
    while r.at < bytes.len() {
        let at = r.at;
        let section = match r.line("a section") {
            Ok(l) => l,
            // trailing blank lines
            Err(_) if bytes[at..].iter().all(u8::is_ascii_whitespace) => break,
            Err(e) => return Err(e),
        };
        match section {
            "$PhysicalNames" => {
                let l = r.line("the number of physical names")?;
                let n: usize = l
                    .parse()
                    .or_else(|_| fail(at, "expected the number of physical names"))?;
                for _ in 0..n {
                    let at = r.at;
                    let l = r.line("a physical name")?;
                    let mut parts = l.splitn(3, char::is_whitespace);
                    let (Some(d), Some(t), Some(name)) = (parts.next(), parts.next(), parts.next())
                    else {
                        return fail(at, "expected `dimension tag \"name\"`");
                    };
                    let (Ok(d), Ok(t)) = (d.parse::<usize>(), t.parse::<i64>()) else {
                        return fail(at, "expected `dimension tag \"name\"`");
                    };
                    let Some(name) = name
                        .trim()
                        .strip_prefix('"')
                        .and_then(|s| s.strip_suffix('"'))
                        .filter(|s| !s.is_empty() && !s.contains('"') && d <= 3)
                    else {
                        return fail(at, "expected a dimension 0 to 3 and a quoted name");
                    };
                    if names.insert((d, t), name.to_string()).is_some() {
                        return fail(at, format!("physical group ({d}, {t}) named twice"));
                    }
                }
                r.end("PhysicalNames")?;
            }
            "$Entities" => {
                let mut counts = [0u64; 4];
                for c in &mut counts {
                    let v = r.size("the numbers of entities")?;
                    *c = count(&r, v.min(i64::MAX as u64) as i64, "a number of entities")?;
                }
                for (dim, &n) in counts.iter().enumerate() {
                    for _ in 0..n {
                        let tag = r.int("an entity tag")?;
                        let boxes = if dim == 0 { 3 } else { 6 };
                        for _ in 0..boxes {
                            r.double("an entity's coordinates")?;
                        }
                        let np = r.size("the number of physical tags")?;
                        let np = count(&r, np.min(i64::MAX as u64) as i64, "physical tags")?;
                        let mut tags = Vec::new();
                        for _ in 0..np {
                            tags.push(r.int("a physical tag")?);
                        }
                        if dim > 0 {
                            let nb = r.size("the number of bounding entities")?;
                            let nb =
                                count(&r, nb.min(i64::MAX as u64) as i64, "bounding entities")?;
                            for _ in 0..nb {
                                r.int("a bounding entity")?;
                            }
                        }
                        entities.insert((dim, tag), tags);
                    }
                }
                r.end("Entities")?;
            }
            "$Nodes" => {
                if nodes_seen {
                    return fail(at, "a second $Nodes section");
                }
                nodes_seen = true;
                let nb = r.size("the number of node blocks")?;
                for _ in 0..3 {
                    r.size("the nodes' header")?;
                }
                let nb = count(&r, nb.min(i64::MAX as u64) as i64, "node blocks")?;
                for _ in 0..nb {
                    let block_at = r.at;
                    r.int("a node block's dimension")?;
                    r.int("a node block's entity")?;
                    let parametric = r.int("a node block's parametric flag")?;
                    if parametric != 0 {
                        return fail(block_at, "parametric node coordinates are not read; save without them (Gmsh: Mesh.SaveParametric = 0)");
                    }
                    let n = r.size("a node block's size")?;
                    let n = count(&r, n.min(i64::MAX as u64) as i64, "nodes in a block")?;
                    let tags_at = r.at;
                    // tags first, then coordinates: both must fit before either is kept
                    let need = n.checked_mul(size_t as u64 + 24);
                    if need.is_none_or(|b| b > (bytes.len() - r.at) as u64) {
                        return fail(tags_at, format!("{n} nodes are more than the file holds"));
                    }
                    let mut tags = Vec::with_capacity(n as usize);
                    for _ in 0..n {
                        tags.push(r.size("a node tag")?);
                    }
                    for t in tags {
                        let at = r.at;
                        let x = [
                            r.double("a node's coordinates")?,
                            r.double("a node's coordinates")?,
                            r.double("a node's coordinates")?,
                        ];
                        if !x.iter().all(|v| v.is_finite()) {
                            return fail(at, format!("node {t}: coordinates must be finite"));
                        }
                        if nodes.insert(t, x).is_some() {
                            return fail(at, format!("node {t} defined twice"));
                        }
                    }
                }
                r.end("Nodes")?;
            }
            "$Elements" => {
                if elements_seen {
                    return fail(at, "a second $Elements section");
                }
                elements_seen = true;
                let nb = r.size("the number of element blocks")?;
                for _ in 0..3 {
                    r.size("the elements' header")?;
                }
                let nb = count(&r, nb.min(i64::MAX as u64) as i64, "element blocks")?;
                for _ in 0..nb {
                    let block_at = r.at;
                    let dim = r.int("an element block's dimension")?;
                    let entity = r.int("an element block's entity")?;
                    let t = r.int("an element type")?;
                    let n = r.size("an element block's size")?;
                    let Some((per, kind, tdim)) = u32::try_from(t).ok().and_then(element_type)
                    else {
                        return fail(block_at, format!("element type {t} is not read (points, lines, triangles, quadrilaterals, tetrahedra, hexahedra)"));
                    };
                    if dim != tdim as i64 {
                        return fail(
                            block_at,
                            format!(
                                "element type {t} is of dimension {tdim}, the block says {dim}"
                            ),
                        );
                    }
                    let n = count(&r, n.min(i64::MAX as u64) as i64, "elements in a block")?;
                    let need = n.checked_mul((per as u64 + 1) * size_t as u64);
                    if need.is_none_or(|b| b > (bytes.len() - r.at) as u64) {
                        return fail(r.at, format!("{n} elements are more than the file holds"));
                    }
                    let mut block = ElementBlock {
                        dim: tdim,
                        entity,
                        kind,
                        line: 0,
                        nodes: Vec::with_capacity(n as usize * per),
                    };
                    for _ in 0..n {
                        r.size("an element tag")?;
                        for _ in 0..per {
                            block.nodes.push(r.size("an element's node")?);
                        }
                    }
                    blocks.push(block);
                }
                r.end("Elements")?;
            }
            "$MeshFormat" => return fail(at, "a second $MeshFormat section"),
            l if l.starts_with('$') && !l.starts_with("$End") => {
                // another section: skip to its end line
                let end = format!("\n$End{}", &l[1..]);
                let Some(k) = bytes[r.at.saturating_sub(1)..]
                    .windows(end.len())
                    .position(|w| w == end.as_bytes())
                else {
                    return fail(at, format!("the file ends inside {l}"));
                };
                r.at = r.at.saturating_sub(1) + k + 1;
                r.line("the end of a section")?;
            }
            _ => return fail(at, "expected a section ($Nodes, $Elements, …)"),
        }
    }
    super::assemble_mesh(&names, &entities, &nodes, &blocks)
}
