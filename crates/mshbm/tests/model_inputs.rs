//! Model inputs are bounded, confined and escaped (issue 15): every referenced file is read
//! only when it is a regular file inside the model file's directory tree, declared sizes
//! are checked before allocating, error messages quote input text only as a short escaped
//! excerpt, and degenerate contacts are refused at load time.

use std::path::{Path, PathBuf};
use std::time::Instant;

use mshbm::limits::Limits;
use mshbm::model::file::{load_model, load_model_with};
use mshbm::model::matrix_market::parse_matrix_with;
use mshbm::model::LoadOptions;

fn examples() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples")
}

/// A copy of `examples/bar_matrices` in a fresh directory `<tmp>/<name>/model`, with the
/// model file's text editable.
struct BarMatrices {
    root: PathBuf,
}

impl BarMatrices {
    fn new(name: &str) -> Self {
        let root = std::env::temp_dir().join(format!("mshbm-inputs-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&root);
        std::fs::create_dir_all(root.join("model")).unwrap();
        for e in std::fs::read_dir(examples().join("bar_matrices")).unwrap() {
            let p = e.unwrap().path();
            std::fs::copy(&p, root.join("model").join(p.file_name().unwrap())).unwrap();
        }
        BarMatrices { root }
    }
    fn dir(&self) -> PathBuf {
        self.root.join("model")
    }
    fn model(&self) -> PathBuf {
        self.dir().join("model.toml")
    }
    fn edit(&self, from: &str, to: &str) {
        let s = std::fs::read_to_string(self.model()).unwrap();
        assert!(s.contains(from), "fixture lacks {from}");
        std::fs::write(self.model(), s.replacen(from, to, 1)).unwrap();
    }
    fn append(&self, text: &str) {
        let s = std::fs::read_to_string(self.model()).unwrap();
        std::fs::write(self.model(), s + text).unwrap();
    }
    fn error(&self) -> String {
        load_model(&self.model(), &[]).unwrap_err().to_string()
    }
}

impl Drop for BarMatrices {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.root);
    }
}

fn allow_outside() -> LoadOptions {
    LoadOptions {
        allow_outside_paths: true,
        ..LoadOptions::default()
    }
}

#[test]
fn every_file_read_is_recorded_by_canonical_path() {
    let m = BarMatrices::new("recorded");
    let model = load_model(&m.model(), &[]).unwrap();
    let dir = m.dir().canonicalize().unwrap();
    let want: Vec<PathBuf> = [
        "model.toml",
        "stiffness.mtx",
        "mass.mtx",
        "nodes.txt",
        "harmonic_load.mtx",
        "constant_load.mtx",
    ]
    .iter()
    .map(|f| dir.join(f))
    .collect();
    assert_eq!(model.input_files, want);
    // a subdirectory is inside the tree
    std::fs::create_dir(m.dir().join("sub")).unwrap();
    std::fs::rename(m.dir().join("nodes.txt"), m.dir().join("sub/nodes.txt")).unwrap();
    m.edit("\"nodes.txt\"", "\"sub/../sub/./nodes.txt\"");
    let model = load_model(&m.model(), &[]).unwrap();
    assert!(model.input_files.contains(&dir.join("sub/nodes.txt")));
}

#[test]
fn paths_leaving_the_model_directory_are_refused_unless_allowed() {
    let m = BarMatrices::new("outside");
    // `..` and an absolute path, refused before the file system is asked
    std::fs::copy(m.dir().join("mass.mtx"), m.root.join("mass.mtx")).unwrap();
    m.edit("\"mass.mtx\"", "\"../mass.mtx\"");
    let err = m.error();
    assert!(
        err.contains("model.toml")
            && err.contains("matrices.mass")
            && err.contains("\"../mass.mtx\"")
            && err.contains("--allow-outside-paths")
            && !err.contains('\n'),
        "{err}"
    );
    let model = load_model_with(&m.model(), &[], &allow_outside()).unwrap();
    assert!(model
        .input_files
        .contains(&m.root.join("mass.mtx").canonicalize().unwrap()));
    m.edit("\"../mass.mtx\"", "\"mass.mtx\"");

    // /etc/passwd: refused without reading; allowed, the message quotes at most 16
    // characters of it, escaped
    m.edit("\"nodes.txt\"", "\"/etc/passwd\"");
    let err = m.error();
    assert!(
        err.contains("mesh.coordinates") && err.contains("leads outside"),
        "{err}"
    );
    #[cfg(unix)]
    if let Ok(passwd) = std::fs::read_to_string("/etc/passwd") {
        let first = passwd.lines().next().unwrap_or_default();
        let err = load_model_with(&m.model(), &[], &allow_outside())
            .unwrap_err()
            .to_string();
        if first.len() > 16 {
            assert!(!err.contains(first), "{err}");
        }
        let quoted = err.split('"').nth(1).unwrap_or_default();
        assert!(quoted.chars().count() <= 16, "{err}");
    }
    m.edit("\"/etc/passwd\"", "\"nodes.txt\"");

    // a symbolic link pointing out of the tree
    #[cfg(unix)]
    {
        std::fs::copy(m.dir().join("nodes.txt"), m.root.join("nodes.txt")).unwrap();
        std::os::unix::fs::symlink(m.root.join("nodes.txt"), m.dir().join("link.txt")).unwrap();
        m.edit("\"nodes.txt\"", "\"link.txt\"");
        let err = m.error();
        assert!(
            err.contains("mesh.coordinates") && err.contains("leads outside"),
            "{err}"
        );
        load_model_with(&m.model(), &[], &allow_outside()).unwrap();
    }
}

#[cfg(unix)]
#[test]
fn devices_and_fifos_are_refused_at_once() {
    let m = BarMatrices::new("devices");
    m.edit("\"stiffness.mtx\"", "\"/dev/zero\"");
    let start = Instant::now();
    let err = load_model_with(&m.model(), &[], &allow_outside())
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("matrices.stiffness")
            && err.contains("/dev/zero")
            && err.contains("not a regular file"),
        "{err}"
    );
    m.edit("\"/dev/zero\"", "\"/dev/urandom\"");
    let err = load_model_with(&m.model(), &[], &allow_outside())
        .unwrap_err()
        .to_string();
    assert!(err.contains("not a regular file"), "{err}");
    m.edit("\"/dev/urandom\"", "\"stiffness.mtx\"");
    // a FIFO without a writer: opening it for reading would block
    let status = std::process::Command::new("mkfifo")
        .arg(m.dir().join("fifo"))
        .status()
        .unwrap();
    assert!(status.success());
    m.edit("\"nodes.txt\"", "\"fifo\"");
    let err = m.error();
    assert!(
        err.contains("mesh.coordinates") && err.contains("a FIFO"),
        "{err}"
    );
    // the model file itself
    let err = load_model(&m.dir().join("fifo"), &[])
        .unwrap_err()
        .to_string();
    assert!(err.contains("a FIFO"), "{err}");
    assert!(start.elapsed().as_secs_f64() < 1.0, "{:?}", start.elapsed());
}

/// The 70-byte file declaring 10^9 × 10^9, and sizes near 2^32 and `usize::MAX`: refused
/// from the size line, in milliseconds, naming the file and the field.
#[test]
fn huge_declared_matrix_sizes_are_refused_before_allocating() {
    let m = BarMatrices::new("huge");
    for size in [
        "1000000000 1000000000 1",
        "4294967296 4294967296 1",
        "4294967295 4294967295 1",
        "18446744073709551615 18446744073709551615 1",
        "101 101 1000000000",
        "101 101 18446744073709551615",
    ] {
        let text = format!("%%MatrixMarket matrix coordinate real symmetric\n{size}\n1 1 1.0\n");
        std::fs::write(m.dir().join("stiffness.mtx"), &text).unwrap();
        let start = Instant::now();
        let err = m.error();
        assert!(
            start.elapsed().as_millis() < 100,
            "{size}: {:?}",
            start.elapsed()
        );
        assert!(
            err.contains("stiffness.mtx") && !err.contains('\n'),
            "{size}: {err}"
        );
        assert!(
            err.contains("matrices.stiffness") || err.contains("line 2"),
            "{size}: {err}"
        );
    }
    // the Matrix Market reader alone, with a small budget
    let limits = Limits {
        memory_bytes: 1 << 20,
        file_bytes: 1 << 20,
        cancel: Default::default(),
    };
    for text in [
        "%%MatrixMarket matrix coordinate real general\n1000000000 1000000000 0\n",
        "%%MatrixMarket matrix array real general\n4294967296 4294967296\n1\n",
        "%%MatrixMarket matrix array real symmetric\n18446744073709551615 18446744073709551615\n",
        "%%MatrixMarket matrix coordinate real general\n1 18446744073709551615 0\n",
    ] {
        let err = parse_matrix_with(text, Path::new("big.mtx"), &limits).unwrap_err();
        assert!(err.to_string().contains("big.mtx, line 2"), "{err}");
    }
    // just under the text bound: 2 entries of 6 bytes each are accepted
    let ok = "%%MatrixMarket matrix coordinate real general\n2 2 2\n1 1 1\n2 2 2";
    assert_eq!(
        parse_matrix_with(ok, Path::new("a.mtx"), &limits)
            .unwrap()
            .nnz(),
        2
    );
}

/// File contents reach a message only as a short excerpt with control characters escaped.
#[test]
fn messages_quote_input_text_escaped() {
    let m = BarMatrices::new("escaped");
    let evil = "1\u{1b}[31mRED\u{1b}]0;title\u{7}";
    let mass = std::fs::read_to_string(m.dir().join("mass.mtx")).unwrap();
    std::fs::write(
        m.dir().join("mass.mtx"),
        mass.replacen("5.99999999999999996e-10", evil, 1),
    )
    .unwrap();
    let err = m.error();
    assert!(!err.chars().any(char::is_control), "{err:?}");
    assert!(
        err.contains("\\u{1b}[31mRED") && err.contains("mass.mtx, line 3"),
        "{err}"
    );
    std::fs::write(m.dir().join("mass.mtx"), mass).unwrap();

    std::fs::write(
        m.dir().join("nodes.txt"),
        format!("0.0\n{}\n", "\u{1b}[2J".repeat(50)),
    )
    .unwrap();
    let err = m.error();
    assert!(!err.chars().any(char::is_control), "{err:?}");
    assert!(err.contains("nodes.txt, line 2"), "{err}");

    // TOML syntax errors: the parser's message and the position, not the source line
    std::fs::write(
        m.model(),
        "kind = \"matrices\"\nname = \"\u{1b}[31msecret line that must not be echoed\n",
    )
    .unwrap();
    let err = m.error();
    assert!(
        err.contains("malformed TOML") && err.contains("line 2") && !err.contains("secret line"),
        "{err}"
    );
    assert!(!err.chars().any(char::is_control), "{err:?}");
    // a key or a kind with an escape sequence
    std::fs::write(m.model(), "kind = \"bar\\u001b[31m\"\n").unwrap();
    let err = m.error();
    assert!(
        err.contains("field `kind`") && !err.chars().any(char::is_control),
        "{err:?}"
    );
    std::fs::write(m.model(), "kind = \"bar\"\n\"\\u001b[2J\" = 1\n").unwrap();
    let err = m.error();
    assert!(
        err.contains("\\u{1b}[2J") && !err.chars().any(char::is_control),
        "{err:?}"
    );
}

#[test]
fn degenerate_contacts_are_refused_at_load_time() {
    let m = BarMatrices::new("contacts");
    // weights of a repeated DOF that cancel
    m.edit("dofs = [100]\nw = [-1.0]", "dofs = [3, 3]\nw = [-1.0, 1.0]");
    let err = m.error();
    assert!(
        err.contains("contacts[0].w") && err.contains("vanishes"),
        "{err}"
    );
    m.edit(
        "dofs = [3, 3]\nw = [-1.0, 1.0]",
        "dofs = [3, 3, 100]\nw = [-1.0, 1.0, -1.0]",
    );
    load_model(&m.model(), &[]).unwrap();
    m.edit(
        "dofs = [3, 3, 100]\nw = [-1.0, 1.0, -1.0]",
        "dofs = [100]\nw = [-1.0]",
    );

    // the same contact twice (scaled): parallel gap gradients on the same DOF
    m.append("\n[[contacts]]\ndofs = [100]\nw = [-2.0]\ngap = 0.3\n");
    let err = m.error();
    assert!(
        err.contains("contacts[1]") && err.contains("contacts[0]"),
        "{err}"
    );
    assert!(err.contains("singular"), "{err}");

    // a stop on each side (opposite gradients) with clearance is a valid model ...
    m.edit("w = [-2.0]\ngap = 0.3", "w = [2.0]\ngap = 0.3");
    let model = load_model(&m.model(), &[]).unwrap();
    assert_eq!(model.contacts.len(), 2);
    // ... without clearance it is not: g0 + g1 / 2 = 0.2 - 0.4 / 2 = 0
    m.edit("w = [2.0]\ngap = 0.3", "w = [2.0]\ngap = -0.4");
    let err = m.error();
    assert!(
        err.contains("contacts[1]") && err.contains("clearance"),
        "{err}"
    );
    m.edit("w = [2.0]\ngap = -0.4", "w = [2.0]\ngap = 0.3");

    // contacts sharing one DOF among different DOF sets stay allowed
    m.append("\n[[contacts]]\ndofs = [100, 99]\nw = [-1.0, 1.0]\ngap = 0.1\n");
    load_model(&m.model(), &[]).unwrap();
    // but the same DOF set in another order with a parallel gradient is a duplicate
    m.append("\n[[contacts]]\ndofs = [99, 100]\nw = [0.5, -0.5]\ngap = 0.1\n");
    let err = m.error();
    assert!(
        err.contains("contacts[3]") && err.contains("contacts[2]"),
        "{err}"
    );
}

#[test]
fn duplicate_friction_elements_are_refused() {
    let model = examples().join("friction_oscillator/model.toml");
    load_model(&model, &[]).unwrap();
    let text = std::fs::read_to_string(&model).unwrap();
    let dir = std::env::temp_dir().join(format!("mshbm-inputs-{}-friction", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for f in ["mass.mtx", "stiffness.mtx"] {
        std::fs::copy(examples().join("friction_oscillator").join(f), dir.join(f)).unwrap();
    }
    let path = dir.join("model.toml");
    let with = |extra: &str| {
        std::fs::write(&path, format!("{text}\n{extra}")).unwrap();
        load_model(&path, &[])
    };
    // a slip direction that cancels
    let err = with("[[frictions]]\ndofs = [1, 1]\nw = [0.5, -0.5]\nmu = 0.1\nnormal_force = 1.0\n")
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("frictions[1].w") && err.contains("vanishes"),
        "{err}"
    );
    // the same line in the opposite sense: a duplicate (the friction law is odd)
    let err = with("[[frictions]]\ndofs = [2]\nw = [-1.0]\nmu = 0.1\nnormal_force = 1.0\n")
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("frictions[1]") && err.contains("frictions[0]"),
        "{err}"
    );
    // another DOF set sharing DOF 2: allowed
    with("[[frictions]]\ndofs = [2, 1]\nw = [1.0, -1.0]\nmu = 0.1\nnormal_force = 1.0\n").unwrap();
    std::fs::remove_dir_all(&dir).unwrap();
}
