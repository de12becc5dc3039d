//! Model files (TOML) and `--set key=value` overrides.
//!
//! Five kinds, chosen by the top-level `kind` key (`kind = "solid"`, a meshed
//! linear-elastic rectangle or box with contact interfaces, is described in
//! [`crate::model::solid`]; `kind = "mesh"`, a solid meshed in Gmsh whose physical groups
//! name the sets, in [`crate::model::mesh`]):
//!
//! * `kind = "bar"` — the paper's clamped bar (see [`crate::model::bar`]):
//!   ```toml
//!   kind = "bar"
//!   [bar]
//!   elements = 100        # number of two-node elements
//!   length = 20.0         # total length [mm]
//!   density = 9e-9        # [t/mm^3]
//!   young = 2.1e5         # Young's modulus [MPa]
//!   area = 1.0            # cross-section [mm^2]
//!   clamped_end = "left"  # "left" (x = 0) or "right"; the contact is at the other end
//!   [load]
//!   amplitude = 4000.0    # harmonic force F cos(wt) [N], along +x
//!   position = 10.0       # where it acts [mm] (or `node = 50`)
//!   [contact]
//!   gap = 0.2             # initial gap g0 [mm]; omit the table for no contact
//!   [damping]
//!   alpha = 0.0           # C = alpha M_used + beta K + beta_linear K_LL [1/s], [s], [s]
//!   beta = 0.0
//!   beta_linear = 0.0     # stiffness-proportional on the linear part only (K without the
//!                         # contact-node rows/columns): allowed by the redistributed method
//!   beta_condensed = 0.0  # [s] stiffness-proportional on the linear part with the contact
//!                         # nodes relaxed, K_LL − K_LN K_NN⁻¹ K_NL: does not pin the nodes
//!                         # next to a contact, as beta_linear does (docs/theory.md (T121))
//!   # first_mode_ratio = 0.01   # sets alpha = 2 zeta w1 (instead of alpha)
//!   ```
//! * `kind = "matrices"` — a general model from Matrix Market files, from Abaqus
//!   `*MATRIX OUTPUT` files ([`crate::model::abaqus_matrix`]: `node, DOF, node, DOF,
//!   value` lines, nodes numbered by increasing label) or from Harwell–Boeing files
//!   ([`crate::model::harwell_boeing`]), chosen by `matrices.format` (`"matrix_market"`,
//!   `"abaqus"`, `"harwell_boeing"`) or, without it, by each file's content (paths
//!   relative to the model file and inside its directory tree unless
//!   [`LoadOptions::allow_outside_paths`]; DOFs numbered from 0, DOF = node *
//!   dofs_per_node + component; with Abaqus matrices component = Abaqus DOF − 1 and
//!   `dofs_per_node` defaults to the largest DOF number):
//!   ```toml
//!   kind = "matrices"
//!   [matrices]
//!   mass = "M.mtx"
//!   stiffness = "K.mtx"
//!   # damping = "C.mtx"
//!   # format = "abaqus"         # or "matrix_market", "harwell_boeing"; default: by content
//!   [mesh]
//!   dofs_per_node = 1
//!   coordinates = "nodes.txt"   # one node per line, 1-3 numbers; or inline [[x], [x], ...]
//!   dirichlet = [0]
//!   [[contacts]]                # g = sum_i w_i q_{dofs_i} + gap >= 0
//!   dofs = [100]                # or, with Abaqus matrices, node_dofs = [[label, dof]]
//!   w = [-1.0]
//!   gap = 0.2
//!   # mu = 0.3                  # Coulomb friction along a tangent (redistributed MS-HBM,
//!   # tangent_dofs = [101]      # docs/theory.md §20): y_T = sum_i tangent_w_i q_(dofs_i),
//!   # tangent_w = [1.0]         # orthogonal to w and of the same norm
//!   # tangent2_dofs = [102]     # in space, a second tangent (orthogonal to w and the
//!   # tangent2_w = [1.0]        # first): the friction force in the Coulomb cone (T185)
//!   # contacts_file = "contacts.csv"   # more contacts, one per line: gap, dof, w[, dof, w …]
//!   # [[node_sets]]             # named node sets: nodes = [..], or file = "set.csv" (node
//!   # name = "stop"             # numbers separated by commas, blanks or line breaks), or
//!   #                           # labels = [..] (node labels of Abaqus matrices)
//!   # file = "stop_nodes.csv"
//!   # [[interfaces]]            # contact interfaces of many nodes on node sets, as for
//!   # name = "stop"             # kind = "solid" (crate::model::solid): obstacle or pairs
//!   # kind = "obstacle"
//!   # set = "stop"
//!   # normal = [0.0, 1.0]
//!   # gap = 0.05
//!   [[frictions]]               # Coulomb friction: slip velocity sum_i w_i qdot_{dofs_i},
//!   dofs = [3]                  # force in [-mu F_N, mu F_N] along w
//!   w = [1.0]
//!   mu = 0.3
//!   normal_force = 10.0         # prescribed F_N; or `contact = 0` (F_N = force of contacts[0])
//!   [load]
//!   harmonic = [[50, 4000.0]]   # (dof, amplitude) pairs of F cos(wt); or harmonic_file = "f.mtx"
//!   constant = []               # (dof, value) pairs; or constant_file = "f0.mtx"
//!   # acceleration = [-9810.0]  # uniform acceleration per component, load = M_used (1 ⊗ a)
//!   [damping]
//!   alpha = 0.0
//!   ```
//! * `kind = "dropped_bar"` — a free bar dropped under gravity onto a rigid support (the
//!   paper's Figs. 3–5, see [`crate::model::dropped_bar`]):
//!   ```toml
//!   kind = "dropped_bar"
//!   [bar]
//!   elements = 100
//!   length = 1.0
//!   density = 1.0
//!   young = 1.0
//!   area = 1.0
//!   [drop]
//!   kappa = 3             # integer kappa = v0 c/(g L) >= 3: exactly periodic; or `height = h0`
//!   gravity = 1.0         # g, acting downward
//!   ```
//!
//! Unknown keys are errors. Errors name the file and the field.

use std::path::Path;

use serde::Deserialize;

use crate::error::{Error, Result};
use crate::limits::{read_model_file, Limits};
use crate::model::bar::{BarParameters, ClampedEnd, ForceLocation};
use crate::model::damping_section::DampingSection;
use crate::model::dropped_bar::DroppedBarParameters;
use crate::model::excerpt::{excerpt, sanitize_message};
use crate::model::input_files::InputFiles;
pub use crate::model::input_files::LoadOptions;
use crate::model::overrides::apply_override;
use crate::model::Model;

mod matrices;
mod matrix_formats;

use matrices::{matrices_model, MatricesFile};

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct BarFile {
    #[allow(dead_code)]
    kind: String,
    name: Option<String>,
    bar: BarSection,
    load: BarLoad,
    contact: Option<BarContact>,
    #[serde(default)]
    damping: DampingSection,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct BarSection {
    elements: usize,
    length: f64,
    density: f64,
    young: f64,
    area: f64,
    #[serde(default = "default_clamped_end")]
    clamped_end: ClampedEnd,
}

fn default_clamped_end() -> ClampedEnd {
    ClampedEnd::Left
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct BarLoad {
    amplitude: f64,
    node: Option<usize>,
    position: Option<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct BarContact {
    gap: f64,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct DroppedBarFile {
    #[allow(dead_code)]
    kind: String,
    name: Option<String>,
    bar: DroppedBarSection,
    drop: DropSection,
    #[serde(default)]
    damping: DampingSection,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct DroppedBarSection {
    elements: usize,
    length: f64,
    density: f64,
    young: f64,
    area: f64,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct DropSection {
    height: Option<f64>,
    kappa: Option<f64>,
    gravity: f64,
}

/// Read a model file with the default [`LoadOptions`], apply `overrides` (`key=value`,
/// dotted paths) and build the model.
pub fn load_model(path: &Path, overrides: &[String]) -> Result<Model> {
    load_model_with(path, overrides, &LoadOptions::default())
}

/// Read a model file, apply `overrides` (`key=value`, dotted paths) and build the model.
/// Every file is read bounded (regular files only, `options.limits.file_bytes`, UTF-8);
/// paths in the file resolve relative to its directory and must stay in its directory
/// tree unless `options.allow_outside_paths`; sizes are checked against
/// `options.limits.memory_bytes` before anything is allocated. The files read are
/// recorded in [`Model::input_files`].
pub fn load_model_with(path: &Path, overrides: &[String], options: &LoadOptions) -> Result<Model> {
    let text = read_model_file(path, &options.limits)?;
    let mut model = parse_model_with(&text, path, overrides, options)?;
    let canonical = path.canonicalize().map_err(|e| Error::io(path, e))?;
    model.input_files.insert(0, canonical);
    Ok(model)
}

/// Parse model-file text with the default [`LoadOptions`] (`path` locates relative
/// matrix files and names errors).
pub fn parse_model(text: &str, path: &Path, overrides: &[String]) -> Result<Model> {
    parse_model_with(text, path, overrides, &LoadOptions::default())
}

/// Parse model-file text (`path` locates relative matrix files and names errors); the
/// files it refers to are read as [`load_model_with`] reads them.
pub fn parse_model_with(
    text: &str,
    path: &Path,
    overrides: &[String],
    options: &LoadOptions,
) -> Result<Model> {
    let mut value = parse_toml(text, path)?;
    for o in overrides {
        apply_override(&mut value, o)?;
    }
    let kind = model_kind(&value, path)?;
    match kind.as_str() {
        "bar" => {
            let f: BarFile = deserialize(value, path)?;
            bar_model(f, path, &options.limits)
        }
        "matrices" => {
            let f: MatricesFile = deserialize(value, path)?;
            matrices_model(f, path, &mut InputFiles::new(path, options))
        }
        "solid" => {
            let f: super::solid::SolidFile = deserialize(value, path)?;
            super::solid::solid_model(f, path, &mut InputFiles::new(path, options))
        }
        "mesh" => {
            let f: super::mesh::MeshFile = deserialize(value, path)?;
            super::mesh::mesh_model(f, path, &mut InputFiles::new(path, options))
        }
        "dropped_bar" => {
            let f: DroppedBarFile = deserialize(value, path)?;
            let (params, name) = dropped_bar_parameters(f, path)?;
            let mut model = params.build_with(path, &options.limits)?;
            if let Some(name) = name {
                model.name = name;
            }
            Ok(model)
        }
        other => Err(Error::field(
            path,
            "kind",
            format!("unknown kind {} (expected {KINDS})", excerpt(other)),
        )),
    }
}

/// Parse TOML text. The message is built from the parser's message and the line and
/// column of the error, never from the source line the `toml` crate would quote.
fn parse_toml(text: &str, path: &Path) -> Result<toml::Value> {
    toml::from_str(text).map_err(|e: toml::de::Error| {
        let at = e
            .span()
            .map(|span| {
                let mut start = span.start.min(text.len());
                while !text.is_char_boundary(start) {
                    start -= 1;
                }
                let before = &text[..start];
                let line = before.matches('\n').count() + 1;
                let column = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
                format!("line {line}, column {column}: ")
            })
            .unwrap_or_default();
        Error::Toml {
            file: path.to_path_buf(),
            message: format!(
                "{at}{}",
                sanitize_message(&e.message().trim().replace('\n', "; "))
            ),
        }
    })
}

const KINDS: &str = "\"bar\", \"matrices\", \"solid\", \"mesh\" or \"dropped_bar\"";

fn model_kind(value: &toml::Value, path: &Path) -> Result<String> {
    Ok(value
        .get("kind")
        .ok_or_else(|| Error::field(path, "kind", format!("missing (expected {KINDS})")))?
        .as_str()
        .ok_or_else(|| Error::field(path, "kind", format!("must be a string ({KINDS})")))?
        .to_string())
}

/// The parameters of a `kind = "dropped_bar"` model file (with `overrides` applied), or
/// `None` for any other kind — so that callers can compare with the closed-form solution.
/// The file is read with the default [`LoadOptions`].
pub fn load_dropped_bar(path: &Path, overrides: &[String]) -> Result<Option<DroppedBarParameters>> {
    load_dropped_bar_with(path, overrides, &LoadOptions::default())
}

/// [`load_dropped_bar`] with explicit [`LoadOptions`] (a dropped bar refers to no other
/// file; the options bound the read of the model file).
pub fn load_dropped_bar_with(
    path: &Path,
    overrides: &[String],
    options: &LoadOptions,
) -> Result<Option<DroppedBarParameters>> {
    let text = read_model_file(path, &options.limits)?;
    let mut value = parse_toml(&text, path)?;
    for o in overrides {
        apply_override(&mut value, o)?;
    }
    if model_kind(&value, path)? != "dropped_bar" {
        return Ok(None);
    }
    let f: DroppedBarFile = deserialize(value, path)?;
    Ok(Some(dropped_bar_parameters(f, path)?.0))
}

fn dropped_bar_parameters(
    f: DroppedBarFile,
    path: &Path,
) -> Result<(DroppedBarParameters, Option<String>)> {
    let mut params = DroppedBarParameters {
        elements: f.bar.elements,
        length: f.bar.length,
        density: f.bar.density,
        young: f.bar.young,
        area: f.bar.area,
        height: 0.0,
        gravity: f.drop.gravity,
        damping: f.damping.into(),
    };
    params.height = match (f.drop.height, f.drop.kappa) {
        (Some(h), None) => h,
        (None, Some(k)) => {
            if !(k.is_finite() && k > 0.0) {
                return Err(Error::field(
                    path,
                    "drop.kappa",
                    format!("must be positive, got {k}"),
                ));
            }
            params.height_for_kappa(k)
        }
        _ => {
            return Err(Error::field(
                path,
                "drop",
                "give exactly one of `height` and `kappa`",
            ))
        }
    };
    Ok((params, f.name))
}

fn deserialize<T: serde::de::DeserializeOwned>(value: toml::Value, path: &Path) -> Result<T> {
    serde_path_to_error::deserialize(value).map_err(|e| {
        let field = e.path().to_string();
        let field = if field == "." {
            "(top level)".to_string()
        } else {
            field
        };
        // the TOML deserializer appends "\nin `table`"; the path already says where
        let message = e.into_inner().to_string();
        let message = sanitize_message(message.lines().next().unwrap_or_default().trim());
        Error::field(path, sanitize_message(&field), message)
    })
}

fn bar_model(f: BarFile, path: &Path, limits: &Limits) -> Result<Model> {
    let force_location = match (f.load.node, f.load.position) {
        (Some(n), None) => ForceLocation::Node(n),
        (None, Some(x)) => ForceLocation::Position(x),
        _ => {
            return Err(Error::field(
                path,
                "load",
                "give exactly one of `node` and `position`",
            ))
        }
    };
    let params = BarParameters {
        elements: f.bar.elements,
        length: f.bar.length,
        density: f.bar.density,
        young: f.bar.young,
        area: f.bar.area,
        clamped_end: f.bar.clamped_end,
        force_amplitude: f.load.amplitude,
        force_location,
        gap: f.contact.map(|c| c.gap),
        damping: f.damping.into(),
    };
    let mut model = params.build_with(path, limits)?;
    if let Some(name) = f.name {
        model.name = name;
    }
    Ok(model)
}
