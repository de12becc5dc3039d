//! The mutation fuzzer of the library's readers, shared by the smoke test
//! (`tests/fuzz_readers.rs`, a few thousand inputs in `cargo test`) and the campaign
//! (`examples/fuzz_inputs.rs`, run by `tools/fuzz-inputs`, ≥ 10⁵ inputs per target with a
//! per-input time limit and a per-input peak-memory check).
//!
//! Ten targets, each fed inputs mutated from seeds (byte flips, random insertions,
//! deletions, duplicated lines, splices from another seed, numbers replaced by extreme
//! values) by a deterministic generator: case `c` of seed `s` is always the same input, so
//! a finding is replayed alone.
//!
//! * `model`: a model file (TOML) parsed from text, every sixteenth read from disk;
//! * `matrix`: a Matrix Market file parsed alone, every fourth also read as a model's
//!   stiffness (or, when it is not Matrix Market, its coordinates);
//! * `tables`: the per-node tables a model names — `gap_file` and `mu_file` of an obstacle
//!   interface, the `gap_file` of a pairs interface, `contacts_file`, a node set's `file`;
//! * `overrides`: one to three `--set KEY=VALUE` assignments (keys of the seed, mutated or
//!   not; values extreme, of another type, or mutated) applied to a seed model;
//! * `mesh`: a Gmsh MSH 4.1 file (the meshes of tests/data/gmsh and
//!   `tests/fuzz_corpus/meshes/`) parsed alone, every fourth also read as the mesh of a
//!   `kind = "mesh"` model (clamped, loaded and in contact on its groups) and assembled;
//! * `inp`: an Abaqus input file (tests/data/abaqus and `tests/fuzz_corpus/abaqus/`)
//!   parsed alone, every fourth also read as the mesh of the same model;
//! * `abaqus_matrix`: an Abaqus `*MATRIX OUTPUT` file (`tests/fuzz_corpus/abaqus_matrices/`)
//!   parsed and assembled by its DOF map, every sixteenth also read as the stiffness of a
//!   `kind = "matrices"` model whose contact names a node by label;
//! * `harwell_boeing`: a Harwell–Boeing file (`tests/fuzz_corpus/harwell_boeing/` and
//!   `tests/data/matrix_formats/`) parsed alone, every sixteenth also read as the stiffness
//!   of the bar;
//! * `binary_mesh`: a binary MSH 4.1 file (`tests/fuzz_corpus/meshes_binary/` and the
//!   binary twins in tests/data/gmsh) parsed alone, every sixteenth also read as the mesh
//!   of the `mesh` target's model;
//! * `solution`: a `--from-solution` JSON (a solution of the bar written by `solve --json`,
//!   mutated mostly near the fields a start uses), parsed, checked against the bar
//!   (`PeriodicSolution::unusable_start`), resized to H and solved from, as `mshbm solve
//!   --from-solution` does.

#![allow(dead_code)]

use std::path::{Path, PathBuf};

use mshbm::limits::Limits;
use mshbm::method::settings::MethodSettings;
use mshbm::model::abaqus_matrix::{assemble, parse_abaqus_matrix, DofMap};
use mshbm::model::file::{load_model_with, parse_model_with};
use mshbm::model::harwell_boeing::parse_harwell_boeing;
use mshbm::model::matrix_market::parse_matrix_with;
use mshbm::model::LoadOptions;
use mshbm::solution::{MethodKind, PeriodicSolution};
use mshbm::solve::{solve_periodic, SolveSettings, SolveStart};
use mshbm::Model;

mod mutate;
mod watch;

pub use mutate::{mutate, Rng};
#[allow(unused_imports)] // the campaign measures the peak, the smoke test does not
pub use watch::{peak_rss, reset_peak_rss, Watchdog};

/// The targets, in the order of the campaign.
pub const TARGETS: &[&str] = &[
    "model",
    "matrix",
    "tables",
    "overrides",
    "mesh",
    "inp",
    "solution",
    "abaqus_matrix",
    "harwell_boeing",
    "binary_mesh",
];

fn corpus() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fuzz_corpus")
}

fn examples() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples")
}

fn files_in(dir: &Path) -> Vec<PathBuf> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.is_file())
        .collect();
    files.sort();
    files
}

fn copy_all(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for f in files_in(from) {
        std::fs::copy(&f, to.join(f.file_name().unwrap())).unwrap();
    }
}

/// A model seed: its text and the scratch directory its referenced files are in.
struct ModelSeed {
    text: Vec<u8>,
    dir: PathBuf,
}

/// A table seed: the model that names it, and the table's file name and text.
struct TableSeed {
    model: PathBuf,
    name: &'static str,
    text: Vec<u8>,
}

/// One input of a target, as bytes (shown when it fails) plus, for `overrides`, the
/// assignments.
pub struct Input {
    pub bytes: Vec<u8>,
    run: Run,
}

enum Run {
    ModelText { dir: PathBuf, from_disk: bool },
    Matrix { as_model: bool },
    Table { model: PathBuf, name: &'static str },
    Overrides { seed: usize, sets: Vec<String> },
    Solution { harmonics: usize },
    Mesh { as_model: bool },
    Inp { as_model: bool },
    AbaqusMatrix { as_model: bool },
    HarwellBoeing { as_model: bool },
    BinaryMesh { as_model: bool },
}

/// The seeds, a scratch directory with the files they reference (removed on drop), and
/// the limits every reader runs with.
pub struct Harness {
    root: PathBuf,
    models: Vec<ModelSeed>,
    matrices: Vec<Vec<u8>>,
    meshes: Vec<Vec<u8>>,
    inps: Vec<Vec<u8>>,
    abaqus_matrices: Vec<Vec<u8>>,
    harwell_boeing: Vec<Vec<u8>>,
    binary_meshes: Vec<Vec<u8>>,
    tables: Vec<TableSeed>,
    solution: Vec<u8>,
    bar: Model,
    pub options: LoadOptions,
}

impl Harness {
    /// Seeds from `tests/fuzz_corpus/` and `examples/`, scratch files under `root`, every
    /// reader within a memory budget of `memory_bytes` (so that an input the budget
    /// allows runs, and one it refuses is refused by its plan).
    pub fn new(root: &Path, memory_bytes: u64) -> Self {
        let options = LoadOptions {
            limits: Limits {
                memory_bytes,
                file_bytes: 1 << 20,
                cancel: Default::default(),
            },
            allow_outside_paths: false,
        };
        // referenced files: the bar's Matrix Market files (101 DOFs), the friction
        // oscillator's, the table seeds' (plate and bar with their tables)
        copy_all(&examples().join("bar_matrices"), &root.join("bar"));
        copy_all(&examples().join("friction_oscillator"), &root.join("chain"));
        copy_all(&examples().join("bar_matrices"), &root.join("data"));
        copy_all(&examples().join("bar_matrices"), &root.join("data_nodes"));
        copy_all(&examples().join("bar_matrices"), &root.join("tables"));
        copy_all(&corpus().join("tables"), &root.join("tables"));

        let mut model_files = files_in(&corpus().join("models"));
        model_files.extend(
            files_in(&examples())
                .into_iter()
                .filter(|p| p.extension().is_some_and(|e| e == "toml")),
        );
        model_files.push(examples().join("bar_matrices/model.toml"));
        model_files.push(examples().join("friction_oscillator/model.toml"));
        model_files.push(examples().join("friction_damper/model.toml"));
        model_files.push(corpus().join("tables/plate.toml"));
        model_files.push(corpus().join("tables/bar.toml"));
        let models = model_files
            .iter()
            .map(|p| {
                let text = std::fs::read(p).unwrap();
                let s = String::from_utf8_lossy(&text);
                let dir = if s.contains("gap_file") || s.contains("contacts_file") {
                    root.join("tables")
                } else if s.contains("coordinates = [") {
                    root.join("chain")
                } else {
                    root.join("bar")
                };
                ModelSeed { text, dir }
            })
            .collect();

        let mut matrices: Vec<Vec<u8>> = files_in(&corpus().join("matrices"))
            .iter()
            .map(|p| std::fs::read(p).unwrap())
            .collect();
        for f in [
            "mass.mtx",
            "stiffness.mtx",
            "harmonic_load.mtx",
            "nodes.txt",
        ] {
            matrices.push(std::fs::read(examples().join("bar_matrices").join(f)).unwrap());
        }

        let mut meshes: Vec<Vec<u8>> = files_in(&corpus().join("meshes"))
            .iter()
            .map(|p| std::fs::read(p).unwrap())
            .collect();
        let gmsh = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/gmsh");
        for f in [
            "box_tet4.msh",
            "plate_tri6.msh",
            "box_tet10.msh",
            "box_hex20.msh",
        ] {
            meshes.push(std::fs::read(gmsh.join(f)).unwrap());
        }
        // the model a mesh is read by: every group name of the seeds, so that a mutated
        // mesh still reaches the assembly and the conditions
        std::fs::create_dir_all(root.join("mesh")).unwrap();
        std::fs::write(root.join("mesh/model.toml"), MESH_MODEL).unwrap();
        let mut inps: Vec<Vec<u8>> = files_in(&corpus().join("abaqus"))
            .iter()
            .map(|p| std::fs::read(p).unwrap())
            .collect();
        let abaqus = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/abaqus");
        for f in [
            "box_tet4.inp",
            "plate_tri6.inp",
            "box_tet10.inp",
            "box_hex20.inp",
        ] {
            inps.push(std::fs::read(abaqus.join(f)).unwrap());
        }
        std::fs::write(
            root.join("mesh/model_inp.toml"),
            MESH_MODEL.replace("mesh.msh", "mesh.inp"),
        )
        .unwrap();

        // the new matrix formats and binary meshes, with the models they are read by
        let seeds_in = |dir: &Path| -> Vec<Vec<u8>> {
            files_in(dir)
                .iter()
                .map(|p| std::fs::read(p).unwrap())
                .collect()
        };
        let abaqus_matrices = seeds_in(&corpus().join("abaqus_matrices"));
        std::fs::create_dir_all(root.join("abaqus_matrix")).unwrap();
        std::fs::copy(
            corpus().join("abaqus_matrices/chain_MASS2.mtx"),
            root.join("abaqus_matrix/mass.mtx"),
        )
        .unwrap();
        std::fs::write(root.join("abaqus_matrix/model.toml"), ABAQUS_MODEL).unwrap();
        let matrix_formats =
            Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/matrix_formats");
        let mut harwell_boeing = seeds_in(&corpus().join("harwell_boeing"));
        harwell_boeing.extend(seeds_in(&matrix_formats));
        copy_all(
            &examples().join("bar_matrices"),
            &root.join("harwell_boeing"),
        );
        copy_all(&matrix_formats, &root.join("harwell_boeing"));
        std::fs::write(
            root.join("harwell_boeing/model.toml"),
            std::fs::read_to_string(examples().join("bar_matrices/model.toml"))
                .unwrap()
                .replace("\"mass.mtx\"", "\"bar_mass.rsa\"")
                .replace("\"stiffness.mtx\"", "\"stiffness.rua\""),
        )
        .unwrap();
        let mut binary_meshes = seeds_in(&corpus().join("meshes_binary"));
        binary_meshes.push(std::fs::read(gmsh.join("plate_tri6_binary.msh")).unwrap());
        std::fs::write(
            root.join("mesh/model_binary.toml"),
            MESH_MODEL.replace("mesh.msh", "mesh_binary.msh"),
        )
        .unwrap();

        let tables_dir = root.join("tables");
        let table = |model: &str, name: &'static str| TableSeed {
            model: tables_dir.join(model),
            name,
            text: std::fs::read(tables_dir.join(name)).unwrap(),
        };
        let tables = vec![
            table("plate.toml", "gaps.csv"),
            table("plate.toml", "mu.csv"),
            table("plate.toml", "crack_gaps.csv"),
            table("bar.toml", "contacts.csv"),
            table("bar.toml", "tip.csv"),
        ];

        // the start solution: the bar at 30 kHz, H = 3, as `solve --json` writes it
        let bar =
            mshbm::model::file::load_model(&examples().join("clamped_bar.toml"), &[]).unwrap();
        let solved = solve_periodic(
            &bar,
            &MethodSettings::redistributed(3),
            30000.0,
            &SolveSettings {
                stability: false,
                ..SolveSettings::default()
            },
        )
        .unwrap();
        let solution = serde_json::to_vec_pretty(&solved.solution).unwrap();

        Harness {
            root: root.to_path_buf(),
            models,
            matrices,
            meshes,
            inps,
            abaqus_matrices,
            harwell_boeing,
            binary_meshes,
            tables,
            solution,
            bar,
            options,
        }
    }

    /// Every table seed loads as it is (the fuzzer mutates valid inputs).
    pub fn check_seeds(&self) {
        for t in &self.tables {
            std::fs::write(t.model.with_file_name(t.name), &t.text).unwrap();
        }
        for t in &self.tables {
            if let Err(e) = load_model_with(&t.model, &[], &self.options) {
                panic!("table seed {}: {e}", t.model.display());
            }
        }
    }

    /// The models of the `abaqus_matrix`, `harwell_boeing` and `binary_mesh` targets load
    /// with a seed as it is (so that a mutated seed reaches the model's checks).
    pub fn check_format_seeds(&self) {
        let gmsh = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/gmsh");
        for (folder, name, seed, model) in [
            (
                "abaqus_matrix",
                "stiffness.mtx",
                corpus().join("abaqus_matrices/chain_STIF2.mtx"),
                "model.toml",
            ),
            (
                "harwell_boeing",
                "stiffness.rua",
                self.root.join("harwell_boeing/bar_stiffness.rua"),
                "model.toml",
            ),
            (
                "mesh",
                "mesh_binary.msh",
                gmsh.join("box_tet10_binary.msh"),
                "model_binary.toml",
            ),
        ] {
            let dir = self.root.join(folder);
            std::fs::copy(&seed, dir.join(name)).unwrap();
            if let Err(e) = load_model_with(&dir.join(model), &[], &self.options) {
                panic!("{folder} seed {}: {e}", seed.display());
            }
        }
    }

    /// The input of case `rng` for `target`.
    pub fn input(&self, target: &str, rng: &mut Rng) -> Input {
        match target {
            "model" => {
                let seed = &self.models[rng.below(self.models.len())];
                let other = &self.models[rng.below(self.models.len())].text;
                let from_disk = rng.below(16) == 0;
                Input {
                    bytes: mutate(&seed.text, other, rng),
                    run: Run::ModelText {
                        dir: seed.dir.clone(),
                        from_disk,
                    },
                }
            }
            "matrix" => {
                let seed = &self.matrices[rng.below(self.matrices.len())];
                let other = &self.matrices[rng.below(self.matrices.len())];
                let as_model = rng.below(4) == 0;
                Input {
                    bytes: mutate(seed, other, rng),
                    run: Run::Matrix { as_model },
                }
            }
            "tables" => {
                let t = &self.tables[rng.below(self.tables.len())];
                let other = &self.tables[rng.below(self.tables.len())].text;
                Input {
                    bytes: mutate(&t.text, other, rng),
                    run: Run::Table {
                        model: t.model.clone(),
                        name: t.name,
                    },
                }
            }
            "overrides" => {
                let seed = rng.below(self.models.len());
                let text = String::from_utf8_lossy(&self.models[seed].text).into_owned();
                let keys = leaf_keys(&text);
                let sets: Vec<String> = (0..1 + rng.below(3))
                    .map(|_| assignment(&keys, rng))
                    .collect();
                Input {
                    bytes: sets.join("\n").into_bytes(),
                    run: Run::Overrides { seed, sets },
                }
            }
            "solution" => {
                let bytes = if rng.below(4) == 0 {
                    mutate(&self.solution, &self.solution, rng)
                } else {
                    // mostly near the fields a start uses
                    let text = &self.solution;
                    let keys = [
                        "\"unknowns\"",
                        "\"harmonics\"",
                        "\"method\"",
                        "\"contact_dofs\"",
                        "\"frequency_hz\"",
                    ];
                    let key = keys[rng.below(keys.len())].as_bytes();
                    let at = text.windows(key.len()).position(|w| w == key).unwrap_or(0);
                    let end = (at + 40 + rng.below(400)).min(text.len());
                    let mut out = text[..at].to_vec();
                    out.extend(mutate(&text[at..end], &self.solution, rng));
                    out.extend_from_slice(&text[end..]);
                    out
                };
                Input {
                    bytes,
                    run: Run::Solution {
                        harmonics: 1 + rng.below(5),
                    },
                }
            }
            "mesh" => {
                let seed = &self.meshes[rng.below(self.meshes.len())];
                let other = &self.meshes[rng.below(self.meshes.len())];
                Input {
                    bytes: mutate(seed, other, rng),
                    run: Run::Mesh {
                        as_model: rng.below(4) == 0,
                    },
                }
            }
            "inp" => {
                let seed = &self.inps[rng.below(self.inps.len())];
                let other = &self.inps[rng.below(self.inps.len())];
                Input {
                    bytes: mutate(seed, other, rng),
                    run: Run::Inp {
                        as_model: rng.below(4) == 0,
                    },
                }
            }
            "abaqus_matrix" | "harwell_boeing" | "binary_mesh" => {
                let seeds = match target {
                    "abaqus_matrix" => &self.abaqus_matrices,
                    "harwell_boeing" => &self.harwell_boeing,
                    _ => &self.binary_meshes,
                };
                let seed = &seeds[rng.below(seeds.len())];
                let other = &seeds[rng.below(seeds.len())];
                // a model load costs milliseconds, a parse microseconds
                let as_model = rng.below(16) == 0;
                Input {
                    bytes: mutate(seed, other, rng),
                    run: match target {
                        "abaqus_matrix" => Run::AbaqusMatrix { as_model },
                        "harwell_boeing" => Run::HarwellBoeing { as_model },
                        _ => Run::BinaryMesh { as_model },
                    },
                }
            }
            other => panic!("unknown target {other:?} (one of {TARGETS:?})"),
        }
    }

    /// Feed `input` to its reader: `true` when it was accepted (and, for a solution,
    /// solved from), `false` when refused with an error. A panic propagates.
    pub fn run(&self, input: &Input) -> bool {
        let text = || String::from_utf8_lossy(&input.bytes).into_owned();
        match &input.run {
            Run::ModelText { dir, from_disk } => {
                let path = dir.join("fuzzed.toml");
                if *from_disk {
                    std::fs::write(&path, &input.bytes).unwrap();
                    load_model_with(&path, &[], &self.options).is_ok()
                } else {
                    parse_model_with(&text(), &path, &[], &self.options).is_ok()
                }
            }
            Run::Matrix { as_model } => {
                let text = text();
                let ok =
                    parse_matrix_with(&text, Path::new("fuzzed.mtx"), &self.options.limits).is_ok();
                if *as_model {
                    let (folder, name) = if text.starts_with("%%") {
                        ("data", "stiffness.mtx")
                    } else {
                        ("data_nodes", "nodes.txt")
                    };
                    std::fs::write(self.root.join(folder).join(name), &input.bytes).unwrap();
                    let model = self.root.join(folder).join("model.toml");
                    let _ = load_model_with(&model, &[], &self.options);
                }
                ok
            }
            Run::Table { model, name } => {
                std::fs::write(model.with_file_name(name), &input.bytes).unwrap();
                let ok = load_model_with(model, &[], &self.options).is_ok();
                // the seed back, so that the next input mutates one table at a time
                let seed = self.tables.iter().find(|t| t.name == *name).unwrap();
                std::fs::write(model.with_file_name(name), &seed.text).unwrap();
                ok
            }
            Run::Overrides { seed, sets } => {
                let s = &self.models[*seed];
                let text = String::from_utf8_lossy(&s.text);
                parse_model_with(&text, &s.dir.join("fuzzed.toml"), sets, &self.options).is_ok()
            }
            Run::Solution { harmonics } => self.start_from(&text(), *harmonics),
            Run::Mesh { as_model } => {
                let ok = mshbm::model::gmsh::parse_msh(&text()).is_ok();
                if *as_model {
                    std::fs::write(self.root.join("mesh/mesh.msh"), &input.bytes).unwrap();
                    let model = self.root.join("mesh/model.toml");
                    let _ = load_model_with(&model, &[], &self.options);
                }
                ok
            }
            Run::AbaqusMatrix { as_model } => {
                let text = text();
                let file = Path::new("fuzzed.mtx");
                let ok = parse_abaqus_matrix(&text, file, &self.options.limits)
                    .and_then(|m| {
                        let map = DofMap::new(&[(file, &m)], None)?;
                        assemble(&m, &map, file)
                    })
                    .is_ok();
                if *as_model {
                    self.load_with("abaqus_matrix", "stiffness.mtx", &input.bytes, "model.toml");
                }
                ok
            }
            Run::HarwellBoeing { as_model } => {
                let ok =
                    parse_harwell_boeing(&text(), Path::new("fuzzed.rua"), &self.options.limits)
                        .is_ok();
                if *as_model {
                    self.load_with(
                        "harwell_boeing",
                        "stiffness.rua",
                        &input.bytes,
                        "model.toml",
                    );
                }
                ok
            }
            Run::BinaryMesh { as_model } => {
                let ok = mshbm::model::gmsh::parse_msh_bytes(&input.bytes).is_ok();
                if *as_model {
                    self.load_with("mesh", "mesh_binary.msh", &input.bytes, "model_binary.toml");
                }
                ok
            }
            Run::Inp { as_model } => {
                let ok = mshbm::model::abaqus::parse_inp(&text()).is_ok();
                if *as_model {
                    std::fs::write(self.root.join("mesh/mesh.inp"), &input.bytes).unwrap();
                    let model = self.root.join("mesh/model_inp.toml");
                    let _ = load_model_with(&model, &[], &self.options);
                }
                ok
            }
        }
    }

    /// Write `bytes` as `name` in the scratch folder `folder` and load the model file
    /// `model` there (its outcome does not matter: only that it returns).
    fn load_with(&self, folder: &str, name: &str, bytes: &[u8], model: &str) {
        std::fs::write(self.root.join(folder).join(name), bytes).unwrap();
        let _ = load_model_with(&self.root.join(folder).join(model), &[], &self.options);
    }

    /// `mshbm solve examples/clamped_bar.toml --harmonics H --from-solution FILE` in
    /// process: the solution parsed, checked against the bar, resized to H and solved from
    /// (with the Floquet multipliers, as the CLI's default).
    fn start_from(&self, json: &str, harmonics: usize) -> bool {
        let Ok(s) = serde_json::from_str::<PeriodicSolution>(json) else {
            return false;
        };
        if s.unusable_start(&self.bar, MethodKind::Redistributed)
            .is_some()
        {
            return false;
        }
        let Some(x) = s.unknowns.as_ref() else {
            return false;
        };
        let Some(x) = mshbm::harmonic::with_harmonics(x, s.harmonics, harmonics) else {
            return false;
        };
        // the CLI's own check of the frequency
        let f = s.frequency_hz;
        if !(f.is_finite() && f > 0.0) {
            return false;
        }
        let settings = SolveSettings {
            limits: self.options.limits,
            start: SolveStart::Unknowns(x),
            ..SolveSettings::default()
        };
        solve_periodic(
            &self.bar,
            &MethodSettings::redistributed(harmonics),
            f,
            &settings,
        )
        .is_ok_and(|s| s.outcome.converged)
    }
}

/// The model file the `mesh` target reads its meshes with (3D; a 2D mesh is refused by
/// the 3-component load, after it is read and assembled).
const MESH_MODEL: &str = r#"
kind = "mesh"
[mesh]
file = "mesh.msh"
young = 2.1e5
poisson = 0.3
density = 7.85e-9
clamped = ["root"]
[[loads]]
set = "top"
harmonic = [0.0, 0.0, -10.0]
[[interfaces]]
name = "end"
kind = "obstacle"
set = "tip"
normal = [-1.0, 0.0, 0.0]
gap = 0.001
"#;

/// The model file the `abaqus_matrix` target reads a stiffness with: the chain of
/// `tests/fuzz_corpus/abaqus_matrices/` (labels 11 to 14, two DOFs), its last node
/// against a stop by label.
const ABAQUS_MODEL: &str = r#"
kind = "matrices"
[matrices]
stiffness = "stiffness.mtx"
mass = "mass.mtx"
[mesh]
coordinates = [[0.0], [1.0], [2.0], [3.0]]
dirichlet = [0, 1]
[[contacts]]
node_dofs = [[14, 1]]
w = [-1.0]
gap = 0.1
[[node_sets]]
name = "tip"
labels = [14]
[load]
harmonic = [[6, 1.0]]
"#;

/// The dotted paths of the leaves of a TOML document (array elements by index) and of its
/// tables and arrays, each with its value as TOML text; empty when it does not parse.
fn leaf_keys(text: &str) -> Vec<(String, String)> {
    fn walk(v: &toml::Value, path: &str, out: &mut Vec<(String, String)>) {
        match v {
            toml::Value::Table(t) => {
                if !path.is_empty() {
                    out.push((path.to_string(), "{}".into()));
                }
                for (k, v) in t {
                    let p = if path.is_empty() {
                        k.clone()
                    } else {
                        format!("{path}.{k}")
                    };
                    walk(v, &p, out);
                }
            }
            toml::Value::Array(a) => {
                out.push((path.to_string(), v.to_string()));
                for (i, v) in a.iter().enumerate().take(4) {
                    walk(v, &format!("{path}.{i}"), out);
                }
            }
            _ => out.push((path.to_string(), v.to_string())),
        }
    }
    let mut out = Vec::new();
    if let Ok(v) = text.parse::<toml::Value>() {
        walk(&v, "", &mut out);
    }
    out
}

/// Values an assignment may set: extreme numbers, other types, arrays, strings.
const VALUES: &[&str] = &[
    "0",
    "-0",
    "-1",
    "1e308",
    "-1e308",
    "1e-320",
    "1e-300",
    "1e300",
    "nan",
    "inf",
    "-inf",
    "18446744073709551615",
    "9223372036854775807",
    "-9223372036854775808",
    "4294967296",
    "1000000",
    "true",
    "\"x\"",
    "\"\u{1b}[2J\"",
    "\"../../etc/passwd\"",
    "[]",
    "[1e308, -1e308]",
    "[0, 0, 0]",
    "[[0.0, 1.0], [1.0, 0.0]]",
    "{}",
    "{ a = 1 }",
    "",
    "=",
    "[",
    "\"",
    "x.y=1",
];

/// One `--set` assignment: a key of the seed (or a mutation of one, or a new one) and a
/// value: extreme, of another type, or the seed's own value mutated (so that many
/// assignments are accepted and reach the model's checks).
fn assignment(keys: &[(String, String)], rng: &mut Rng) -> String {
    let (key, own) = if keys.is_empty() || rng.below(8) == 0 {
        let key = [
            "",
            ".",
            "a..b",
            "bar.",
            ".bar",
            "name",
            "kind",
            "x.0.y",
            "bar.elements.0",
        ][rng.below(9)]
        .to_string();
        (key, "1".to_string())
    } else {
        let (k, v) = keys[rng.below(keys.len())].clone();
        let k = match rng.below(6) {
            0 => format!(
                "{k}.{}",
                ["0", "x", "99999999999999999999", "-1"][rng.below(4)]
            ),
            1 => String::from_utf8_lossy(&mutate(k.as_bytes(), b"0.", rng)).into_owned(),
            _ => k,
        };
        (k, v)
    };
    let value = match rng.below(6) {
        0 => String::from_utf8_lossy(&mutate(b"1.5e3", b"[1, 2]", rng)).into_owned(),
        1 => own,
        2 => String::from_utf8_lossy(&mutate(own.as_bytes(), b"-1e308", rng)).into_owned(),
        _ => VALUES[rng.below(VALUES.len())].to_string(),
    };
    format!("{key}={value}")
}

/// An input for a failure message: escaped, at most 2000 characters.
pub fn show(input: &[u8]) -> String {
    let text = String::from_utf8_lossy(input);
    let shown: String = text.chars().take(2000).collect();
    format!("{shown:?}")
}
