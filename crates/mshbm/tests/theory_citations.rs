//! docs/theory.md leads to code (issue 44): every equation tag `(Tn)` of docs/theory.md and
//! every equation of the paper it refers to ("paper eq. 12", "eqs. 33–35") is cited in a
//! source file of the library (`crates/mshbm/src`, comments included), or is marked as
//! having no code by `[no code]` on a line of docs/theory.md that names it (its definition).
//!
//! A tag is cited by the word `Tn` (`T147a` is its own tag) or inside a range `(Ta)–(Tb)`;
//! a paper equation by `eq. n` / `eqs. a, b–c` / `eq. 1/17` (case-insensitive `Eq.`).

use std::collections::BTreeSet;
use std::path::Path;

/// The marker of a tag or paper equation that no code implements (a definition only, a
/// derivation, a statement about the paper).
const NO_CODE: &str = "[no code]";

/// Every tag `Tn` / `Tna` written as a word in `text`, and the tags inside ranges
/// `Ta–Tb` / `(Ta)–(Tb)` (en dash or hyphen) of plain numbers.
fn tags(text: &str) -> BTreeSet<String> {
    let chars: Vec<char> = text.chars().collect();
    let mut found = BTreeSet::new();
    // (position after the tag, number) of the last plain tag, for ranges
    let mut last: Option<(usize, u32)> = None;
    let mut i = 0;
    while i < chars.len() {
        let starts_word = i == 0 || !chars[i - 1].is_alphanumeric();
        if chars[i] == 'T' && starts_word && chars.get(i + 1).is_some_and(char::is_ascii_digit) {
            let mut j = i + 1;
            while j < chars.len() && chars[j].is_ascii_digit() {
                j += 1;
            }
            let digits: String = chars[i + 1..j].iter().collect();
            let suffix = chars
                .get(j)
                .filter(|c| c.is_ascii_lowercase())
                .filter(|_| !chars.get(j + 1).is_some_and(|c| c.is_alphanumeric()));
            let end = j + usize::from(suffix.is_some());
            if chars
                .get(end)
                .is_some_and(|c| c.is_alphanumeric() || *c == '_')
            {
                i = end;
                continue;
            }
            let number: u32 = digits.parse().expect("digits");
            match suffix {
                Some(s) => {
                    found.insert(format!("T{number}{s}"));
                    last = None;
                }
                None => {
                    found.insert(format!("T{number}"));
                    if let Some((after, from)) = last {
                        let between: String = chars[after..i].iter().collect();
                        let between = between.trim_matches(|c: char| c == '(' || c == ')');
                        if (between.trim() == "–" || between.trim() == "-") && from < number {
                            found.extend((from..number).map(|n| format!("T{n}")));
                        }
                    }
                    last = Some((end, number));
                }
            }
            i = end;
        } else {
            i += 1;
        }
    }
    found
}

/// The paper's equation numbers that `text` refers to: `eq. n`, `eqs. a, b–c and d`,
/// `eq. 1/17` (the keyword in either case).
fn paper_equations(text: &str) -> BTreeSet<u32> {
    let mut found = BTreeSet::new();
    let lower = text.to_lowercase();
    for (start, _) in lower.match_indices("eq") {
        if start > 0
            && lower[..start]
                .chars()
                .next_back()
                .is_some_and(char::is_alphanumeric)
        {
            continue;
        }
        let rest = &lower[start + 2..];
        let rest = rest.strip_prefix('s').unwrap_or(rest);
        let Some(rest) = rest.strip_prefix('.') else {
            continue;
        };
        // the list: numbers joined by ", ", " and ", "–", "-", "/"
        let mut previous: Option<u32> = None;
        let mut range = false;
        let mut s = rest.trim_start();
        loop {
            let digits: String = s.chars().take_while(char::is_ascii_digit).collect();
            if digits.is_empty() {
                break;
            }
            let n: u32 = digits.parse().expect("digits");
            match (range, previous) {
                (true, Some(from)) if from < n => found.extend(from..=n),
                _ => {
                    found.insert(n);
                }
            }
            previous = Some(n);
            s = &s[digits.len()..];
            // an equation's letter (eq. 21a) belongs to it
            s = s
                .strip_prefix(|c: char| c.is_ascii_lowercase())
                .unwrap_or(s);
            let separators = [
                (", ", false),
                (" and ", false),
                ("–", true),
                ("-", true),
                ("/", false),
            ];
            match separators.iter().find(|(sep, _)| s.starts_with(sep)) {
                Some((sep, is_range)) => {
                    s = s[sep.len()..].trim_start();
                    range = *is_range;
                }
                None => break,
            }
        }
    }
    found
}

fn read(path: &Path) -> String {
    std::fs::read_to_string(path).unwrap_or_else(|e| panic!("read {}: {e}", path.display()))
}

fn library_text() -> String {
    fn collect(dir: &Path, out: &mut String) {
        let mut entries: Vec<_> = std::fs::read_dir(dir)
            .expect("read src directory")
            .map(|e| e.expect("directory entry").path())
            .collect();
        entries.sort();
        for path in entries {
            if path.is_dir() {
                collect(&path, out);
            } else if path.extension().is_some_and(|e| e == "rs") {
                out.push_str(&read(&path));
                out.push('\n');
            }
        }
    }
    let mut text = String::new();
    collect(
        &Path::new(env!("CARGO_MANIFEST_DIR")).join("src"),
        &mut text,
    );
    text
}

fn theory() -> String {
    read(&Path::new(env!("CARGO_MANIFEST_DIR")).join("../../docs/theory.md"))
}

/// The tags and paper equations of docs/theory.md that are neither cited in `code` nor
/// marked [`NO_CODE`] on a line that names them.
fn uncited(theory: &str, code: &str) -> (Vec<String>, Vec<u32>) {
    let (code_tags, code_equations) = (tags(code), paper_equations(code));
    let marked: Vec<&str> = theory.lines().filter(|l| l.contains(NO_CODE)).collect();
    let marked_tags: BTreeSet<String> = marked.iter().flat_map(|l| tags(l)).collect();
    let marked_equations: BTreeSet<u32> = marked.iter().flat_map(|l| paper_equations(l)).collect();
    // the tags docs/theory.md defines or cites, written `(Tn)`
    let theory_tags: BTreeSet<String> = tags(theory)
        .into_iter()
        .filter(|t| theory.contains(&format!("({t})")))
        .collect();
    let tags = theory_tags
        .into_iter()
        .filter(|t| !code_tags.contains(t) && !marked_tags.contains(t))
        .collect();
    let equations = paper_equations(theory)
        .into_iter()
        .filter(|e| !code_equations.contains(e) && !marked_equations.contains(e))
        .collect();
    (tags, equations)
}

#[test]
fn the_scanners_read_tags_ranges_and_equation_lists() {
    let t = tags("(T1) cites T12, (T143)–(T147), T20-T22 and T147a; not T3xy, AT5, T7_b");
    let expected = [
        "T1", "T12", "T143", "T144", "T145", "T146", "T147", "T147a", "T20", "T21", "T22",
    ];
    assert_eq!(t, expected.iter().map(|s| s.to_string()).collect());
    let e = paper_equations("paper eqs. 33–35, 9 and 12; Eq. 1/17; eq. 21a; req. 5; eqs.x");
    assert_eq!(e, [1, 9, 12, 17, 21, 33, 34, 35].into_iter().collect());
}

#[test]
fn the_check_finds_an_uncited_tag_and_equation() {
    let theory = "a = b (T1)\nc = d (T2)\ne (T3) [no code]\n(paper eqs. 4–5)\neq. 6 [no code]\n";
    let code = "// (T1), paper eq. 4\n";
    assert_eq!(uncited(theory, code), (vec!["T2".to_string()], vec![5]));
}

#[test]
fn every_tag_and_paper_equation_of_the_theory_is_cited_in_the_library_or_marked() {
    let (tags, equations) = uncited(&theory(), &library_text());
    assert!(
        tags.is_empty() && equations.is_empty(),
        "docs/theory.md: equation tags {tags:?} and paper equations {equations:?} are cited \
         nowhere in crates/mshbm/src; cite them in the code that implements them, or write \
         `{NO_CODE}` on their line in docs/theory.md"
    );
}

/// The numbered sections (`## `) of `theory` that name no source file that exists (a path
/// ending in `.rs` or a folder `…/`, relative to the repository or to the library's `src`;
/// tests do not count: a section names the code that implements it).
fn sections_without_files(theory: &str, exists: impl Fn(&str) -> bool) -> Vec<String> {
    let mut missing = Vec::new();
    let mut title: Option<&str> = None;
    let mut named = false;
    let close = |title: Option<&str>, named: bool, missing: &mut Vec<String>| {
        if let Some(t) = title {
            if !named {
                missing.push(t.to_string());
            }
        }
    };
    for line in theory.lines() {
        if let Some(t) = line.strip_prefix("## ") {
            close(title, named, &mut missing);
            title = Some(t);
            named = false;
            continue;
        }
        if title.is_some() && !named {
            named = line.split('`').skip(1).step_by(2).any(|span| {
                (span.ends_with(".rs") || span.ends_with('/'))
                    && !span.starts_with("tests/")
                    && !span.contains("/tests/")
                    && exists(span)
            });
        }
    }
    close(title, named, &mut missing);
    missing
}

#[test]
fn the_section_check_finds_a_section_without_a_file() {
    let theory =
        "## 1. A\nIn `src/a.rs`.\n## 2. B\nNothing.\n## 3. C\nIn `gone.rs`.\n## 4. D\nIn `dir/`.\n";
    let exists = |p: &str| p == "src/a.rs" || p == "dir/";
    assert_eq!(
        sections_without_files(theory, exists),
        vec!["2. B".to_string(), "3. C".to_string()]
    );
}

#[test]
fn every_section_of_the_theory_names_the_files_that_implement_it() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let exists = |p: &str| {
        let p = p.trim_start_matches("crates/mshbm/src/");
        [
            root.join(p),
            src.join(p),
            src.join("method").join(p),
            src.join("method/redistributed").join(p),
        ]
        .iter()
        .any(|c| c.exists())
    };
    let missing = sections_without_files(&theory(), exists);
    assert!(
        missing.is_empty(),
        "docs/theory.md: the sections {missing:?} name no existing file (a `path.rs` or a \
         library folder `dir/` in backticks) that implements them"
    );
}
