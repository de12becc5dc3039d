//! `kind = "matrices"`: a general model from Matrix Market files, coordinates, contacts,
//! node sets, interfaces, friction elements and loads (the sections and their reading).

use std::path::{Path, PathBuf};

use serde::Deserialize;

use super::super::damping_section::DampingSection;
use crate::error::{Error, Result};
use crate::model::abaqus_matrix::DofMap;
use crate::model::excerpt::data_excerpt;
use crate::model::input_files::InputFiles;
use crate::model::matrix_market::{declared_dimensions, parse_matrix_with};
use crate::model::{Contact, Friction, FrictionNormal, Model, MODEL_BYTES_PER_DOF};

use super::matrix_formats::{read_model_matrices, MatricesSection, ModelMatrices};

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct MatricesFile {
    #[allow(dead_code)]
    kind: String,
    name: Option<String>,
    matrices: MatricesSection,
    mesh: MeshSection,
    #[serde(default)]
    contacts: Vec<ContactSection>,
    /// Contacts from a CSV file, after `contacts` (module docs).
    contacts_file: Option<String>,
    #[serde(default)]
    node_sets: Vec<NodeSetSection>,
    #[serde(default)]
    interfaces: Vec<crate::model::interface::InterfaceSection>,
    #[serde(default)]
    frictions: Vec<FrictionSection>,
    #[serde(default)]
    load: LoadSection,
    #[serde(default)]
    damping: DampingSection,
}

#[derive(Deserialize)]
#[serde(untagged)]
enum Coordinates {
    File(String),
    Inline(Vec<Vec<f64>>),
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct MeshSection {
    /// DOFs per node: 1 when absent, or with Abaqus matrices the largest DOF number.
    dofs_per_node: Option<usize>,
    coordinates: Coordinates,
    #[serde(default)]
    dirichlet: Vec<usize>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ContactSection {
    /// Matrix indices; or `node_dofs`, pairs `[node label, DOF]` of Abaqus matrices.
    #[serde(default)]
    dofs: Vec<usize>,
    node_dofs: Option<Vec<(u64, usize)>>,
    w: Vec<f64>,
    gap: f64,
    /// Coulomb friction along the tangent `tangent_dofs`/`tangent_w` (docs/theory.md §20).
    mu: Option<f64>,
    tangent_dofs: Option<Vec<usize>>,
    tangent_node_dofs: Option<Vec<(u64, usize)>>,
    tangent_w: Option<Vec<f64>>,
    /// The second tangent of a contact in space: the friction force in the Coulomb cone
    /// (docs/theory.md (T185)).
    tangent2_dofs: Option<Vec<usize>>,
    tangent2_w: Option<Vec<f64>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct NodeSetSection {
    name: String,
    nodes: Option<Vec<usize>>,
    /// Node labels of Abaqus matrices.
    labels: Option<Vec<u64>>,
    file: Option<String>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FrictionSection {
    dofs: Vec<usize>,
    w: Vec<f64>,
    mu: f64,
    normal_force: Option<f64>,
    contact: Option<usize>,
}

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct LoadSection {
    #[serde(default)]
    harmonic: Vec<(usize, f64)>,
    harmonic_file: Option<String>,
    #[serde(default)]
    constant: Vec<(usize, f64)>,
    constant_file: Option<String>,
    acceleration: Option<Vec<f64>>,
}
fn read_vector(
    inputs: &mut InputFiles,
    path: &Path,
    field: &str,
    file: &str,
    n: usize,
) -> Result<Vec<f64>> {
    let (full, text) = inputs.read(field, file)?;
    let wrong_size = |rows: usize, cols: usize| {
        Error::field(
            path,
            field,
            format!(
                "{} is {rows}×{cols}, expected a {n}×1 vector",
                full.display()
            ),
        )
    };
    let (rows, cols) = declared_dimensions(&text, &full)?;
    if cols != 1 || rows != n {
        return Err(wrong_size(rows, cols));
    }
    let a = parse_matrix_with(&text, &full, inputs.limits())?;
    let mut v = vec![0.0; n];
    for (i, _, x) in a.iter() {
        v[i] += x;
    }
    Ok(v)
}

fn pairs_to_vector(path: &Path, field: &str, pairs: &[(usize, f64)], n: usize) -> Result<Vec<f64>> {
    let mut v = vec![0.0; n];
    for &(d, x) in pairs {
        if d >= n {
            return Err(Error::field(
                path,
                field,
                format!(
                    "DOF {d} out of range (the model has DOFs 0..{})",
                    n.saturating_sub(1)
                ),
            ));
        }
        v[d] += x;
    }
    Ok(v)
}

/// Node coordinates from a text file: one node per line, 1 to 3 numbers separated by
/// blanks or commas; blank lines and lines starting with `#` or `%` are skipped.
fn read_coordinates(inputs: &mut InputFiles, path: &Path, file: &str) -> Result<Vec<Vec<f64>>> {
    let field = "mesh.coordinates";
    let (full, text) = inputs.read(field, file)?;
    let node_lines = || {
        text.lines().enumerate().filter(|(_, l)| {
            let t = l.trim();
            !(t.is_empty() || t.starts_with('#') || t.starts_with('%'))
        })
    };
    let nodes = node_lines().count();
    inputs.limits().check_items(
        &format!(
            "{}: field `{field}`: {} with {nodes} nodes; a model of that many DOFs",
            path.display(),
            full.display()
        ),
        nodes as u64,
        MODEL_BYTES_PER_DOF,
    )?;
    let mut out = Vec::with_capacity(nodes);
    for (k, line) in node_lines() {
        let mut row = Vec::with_capacity(3);
        for w in line
            .split(|c: char| c == ',' || c.is_whitespace())
            .filter(|w| !w.is_empty())
        {
            let bad = |what: &str| Error::MatrixMarket {
                file: full.clone(),
                line: k + 1,
                message: format!("expected 1 to 3 numbers, {what}"),
            };
            if row.len() == 3 {
                return Err(bad("found more"));
            }
            let x: f64 = w
                .parse()
                .map_err(|_| bad(&format!("found {}", data_excerpt(w))))?;
            row.push(x);
        }
        out.push(row);
    }
    Ok(out)
}

pub(super) fn matrices_model(
    f: MatricesFile,
    path: &Path,
    inputs: &mut InputFiles,
) -> Result<Model> {
    let ModelMatrices {
        stiffness,
        mass,
        damping: damping_matrix,
        dof_map,
    } = read_model_matrices(inputs, path, &f.matrices, f.mesh.dofs_per_node)?;
    let dofs_per_node = dof_map
        .as_ref()
        .map_or(f.mesh.dofs_per_node.unwrap_or(1), |m| m.dofs_per_node);
    let n = stiffness.nrows();
    let coordinates = match &f.mesh.coordinates {
        Coordinates::File(file) => read_coordinates(inputs, path, file)?,
        Coordinates::Inline(c) => c.clone(),
    };
    let mut load_vector =
        |field: &str, pairs: &[(usize, f64)], file: &Option<String>| -> Result<Vec<f64>> {
            match (pairs.is_empty(), file) {
                (_, None) => pairs_to_vector(path, field, pairs, n),
                (true, Some(file)) => read_vector(inputs, path, &format!("{field}_file"), file, n),
                (false, Some(_)) => Err(Error::field(
                    path,
                    field,
                    format!("give either `{field}` or `{field}_file`, not both"),
                )),
            }
        };
    let harmonic_load = load_vector("load.harmonic", &f.load.harmonic, &f.load.harmonic_file)?;
    let constant_load = load_vector("load.constant", &f.load.constant, &f.load.constant_file)?;
    let mut frictions = Vec::with_capacity(f.frictions.len());
    for (k, fr) in f.frictions.into_iter().enumerate() {
        let normal = match (fr.normal_force, fr.contact) {
            (Some(p), None) => FrictionNormal::Force(p),
            (None, Some(c)) => FrictionNormal::Contact(c),
            _ => {
                return Err(Error::field(
                    path,
                    format!("frictions[{k}]"),
                    "give exactly one of `normal_force` (prescribed normal force) and `contact` (index of the unilateral contact whose force is the normal force)",
                ))
            }
        };
        frictions.push(Friction {
            dofs: fr.dofs,
            w: fr.w,
            mu: fr.mu,
            normal,
        });
    }
    let mut contacts = Vec::with_capacity(f.contacts.len());
    for (k, c) in f.contacts.into_iter().enumerate() {
        if c.mu.is_none() && (c.tangent2_dofs.is_some() || c.tangent2_w.is_some()) {
            return Err(Error::field(
                path,
                format!("contacts[{k}].tangent2_dofs"),
                "a second tangent needs friction: `mu`, `tangent_dofs` and `tangent_w`",
            ));
        }
        let field = format!("contacts[{k}]");
        let dofs = by_label(path, &field, "dofs", c.dofs, c.node_dofs, &dof_map)?;
        let tangent_dofs = match (c.tangent_dofs, c.tangent_node_dofs) {
            (None, None) => None,
            (d, l) => Some(by_label(
                path,
                &field,
                "tangent_dofs",
                d.unwrap_or_default(),
                l,
                &dof_map,
            )?),
        };
        let friction = match (c.mu, tangent_dofs, c.tangent_w) {
            (None, None, None) => None,
            (Some(mu), Some(dofs), Some(w)) => Some(crate::model::ContactFriction {
                dofs,
                w,
                mu,
                second: match (c.tangent2_dofs, c.tangent2_w) {
                    (None, None) => None,
                    (Some(dofs), Some(w)) => Some(crate::model::ContactTangent { dofs, w }),
                    (dofs, _) => {
                        let missing = if dofs.is_none() {
                            "tangent2_dofs"
                        } else {
                            "tangent2_w"
                        };
                        return Err(Error::field(
                            path,
                            format!("contacts[{k}].{missing}"),
                            "a second tangent needs both `tangent2_dofs` and `tangent2_w`",
                        ));
                    }
                },
            }),
            (mu, dofs, w) => {
                let missing: Vec<&str> = [
                    (mu.is_none(), "mu"),
                    (dofs.is_none(), "tangent_dofs"),
                    (w.is_none(), "tangent_w"),
                ]
                .iter()
                .filter(|(absent, _)| *absent)
                .map(|(_, name)| *name)
                .collect();
                return Err(Error::field(
                    path,
                    format!("contacts[{k}].{}", missing[0]),
                    format!(
                        "a contact with friction needs `mu`, `tangent_dofs` and `tangent_w` (the tangential displacement y_T = sum_i tangent_w_i q_(tangent_dofs_i)); missing: {}",
                        missing.join(", ")
                    ),
                ));
            }
        };
        contacts.push(Contact {
            dofs,
            w: c.w,
            gap: c.gap,
            friction,
        });
    }
    if let Some(file) = &f.contacts_file {
        contacts.extend(read_contacts(inputs, path, file)?);
    }
    let mut node_sets = crate::fe::mesh::NodeSets::new();
    for (k, sec) in f.node_sets.iter().enumerate() {
        let field = format!("node_sets[{k}]");
        let nodes = match (&sec.nodes, &sec.labels, &sec.file) {
            (Some(list), None, None) => list.clone(),
            (None, Some(labels), None) => nodes_of_labels(path, &field, labels, &dof_map)?,
            (None, None, Some(file)) => {
                read_node_list(inputs, path, &format!("{field}.file"), file)?
            }
            _ => {
                return Err(Error::field(
                    path,
                    field,
                    "give exactly one of `nodes`, `labels` and `file`",
                ))
            }
        };
        if let Some(&bad) = nodes.iter().find(|&&p| p >= coordinates.len()) {
            return Err(Error::field(
                path,
                field,
                format!(
                    "node {bad} does not exist (the mesh has {} nodes)",
                    coordinates.len()
                ),
            ));
        }
        if node_sets.insert(sec.name.clone(), nodes).is_some() {
            return Err(Error::field(
                path,
                format!("{field}.name"),
                format!("node set {:?} given twice", sec.name),
            ));
        }
    }
    let mut dirichlet_sorted = f.mesh.dirichlet.clone();
    dirichlet_sorted.sort_unstable();
    let (interface_contacts, interfaces) = crate::model::interface::build_interfaces(
        &f.interfaces,
        &crate::model::interface::InterfaceMesh {
            x: &coordinates,
            node_sets: &node_sets,
            dofs_per_node,
            dirichlet: &dirichlet_sorted,
        },
        contacts.len(),
        path,
        inputs,
    )?;
    contacts.extend(interface_contacts);
    let model = Model {
        stiffness_file: Some(PathBuf::from(&f.matrices.stiffness)),
        source: path.to_path_buf(),
        input_files: std::mem::take(&mut inputs.read),
        cells: None,
        node_labels: dof_map.as_ref().map(|m| m.labels.clone()),
        node_sets,
        interfaces,
        name: f.name.unwrap_or_else(|| path.display().to_string()),
        mass,
        stiffness,
        damping_matrix,
        coordinates,
        dofs_per_node,
        dirichlet: f.mesh.dirichlet,
        contacts,
        harmonic_load,
        constant_load,
        frictions,
        acceleration: f.load.acceleration,
        damping: f.damping.into(),
    };
    model.validate()?;
    Ok(model)
}

/// The matrix indices of a contact's `name` (`dofs`) or `tangent_…` field: the indices
/// given, or the `[node label, DOF]` pairs of `node_…` mapped by the DOF map of Abaqus
/// matrices ([`DofMap::index`]); exactly one of the two.
fn by_label(
    path: &Path,
    field: &str,
    name: &str,
    dofs: Vec<usize>,
    pairs: Option<Vec<(u64, usize)>>,
    map: &Option<DofMap>,
) -> Result<Vec<usize>> {
    let node_name = name.replace("dofs", "node_dofs");
    let Some(pairs) = pairs else {
        return Ok(dofs);
    };
    if !dofs.is_empty() {
        return Err(Error::field(
            path,
            format!("{field}.{node_name}"),
            format!("give either `{name}` or `{node_name}`, not both"),
        ));
    }
    let Some(map) = map else {
        return Err(Error::field(
            path,
            format!("{field}.{node_name}"),
            "`[node label, DOF]` pairs need matrices with node labels (Abaqus format); give matrix indices in `dofs`",
        ));
    };
    pairs
        .iter()
        .map(|&(label, dof)| {
            map.index(label, dof).ok_or_else(|| {
                Error::field(
                    path,
                    format!("{field}.{node_name}"),
                    format!(
                        "node {label}, DOF {dof} is not in the matrices (nodes {}…{}, DOFs 1 to {})",
                        map.labels.first().copied().unwrap_or(0),
                        map.labels.last().copied().unwrap_or(0),
                        map.dofs_per_node
                    ),
                )
            })
        })
        .collect()
}

/// Model node numbers of node labels of Abaqus matrices.
fn nodes_of_labels(
    path: &Path,
    field: &str,
    labels: &[u64],
    map: &Option<DofMap>,
) -> Result<Vec<usize>> {
    let Some(map) = map else {
        return Err(Error::field(
            path,
            format!("{field}.labels"),
            "node labels need matrices with node labels (Abaqus format); give model node numbers in `nodes`",
        ));
    };
    labels
        .iter()
        .map(|&l| {
            map.node(l).ok_or_else(|| {
                Error::field(
                    path,
                    format!("{field}.labels"),
                    format!("node {l} is not a node of the matrices"),
                )
            })
        })
        .collect()
}

/// Contacts from a CSV file (`contacts_file`): one contact per line, `gap, dof, w, dof, w, …`
/// (the gap `g0`, then the pairs of DOF and coefficient of `W`); blank lines and lines
/// starting with `#` are skipped. Errors name the file and the line.
fn read_contacts(inputs: &mut InputFiles, path: &Path, file: &str) -> Result<Vec<Contact>> {
    let (shown, text) = inputs.read("contacts_file", file)?;
    let mut contacts = Vec::new();
    for (line_number, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let bad = |why: String| {
            Error::field(
                path,
                "contacts_file",
                format!("{}, line {}: {why}", shown.display(), line_number + 1),
            )
        };
        let fields: Vec<&str> = line.split(',').map(str::trim).collect();
        if fields.len() < 3 || fields.len() % 2 == 0 {
            return Err(bad(format!(
                "expected `gap, dof, w[, dof, w …]`, found {} fields",
                fields.len()
            )));
        }
        let gap: f64 = fields[0]
            .parse()
            .map_err(|_| bad(format!("gap {} is not a number", data_excerpt(fields[0]))))?;
        let mut dofs = Vec::new();
        let mut w = Vec::new();
        for pair in fields[1..].chunks(2) {
            dofs.push(pair[0].parse::<usize>().map_err(|_| {
                bad(format!(
                    "DOF {} is not a non-negative integer",
                    data_excerpt(pair[0])
                ))
            })?);
            w.push(pair[1].parse::<f64>().map_err(|_| {
                bad(format!(
                    "coefficient {} is not a number",
                    data_excerpt(pair[1])
                ))
            })?);
        }
        contacts.push(Contact {
            dofs,
            w,
            gap,
            friction: None,
        });
    }
    Ok(contacts)
}

/// Node numbers from a file: separated by commas, blanks or line breaks; `#` starts a
/// comment line.
fn read_node_list(
    inputs: &mut InputFiles,
    path: &Path,
    field: &str,
    file: &str,
) -> Result<Vec<usize>> {
    let (shown, text) = inputs.read(field, file)?;
    let mut nodes = Vec::new();
    for (line_number, line) in text.lines().enumerate() {
        if line.trim_start().starts_with('#') {
            continue;
        }
        for token in line
            .split(|c: char| c == ',' || c.is_whitespace())
            .filter(|t| !t.is_empty())
        {
            nodes.push(token.parse::<usize>().map_err(|_| {
                Error::field(
                    path,
                    field,
                    format!(
                        "{}, line {}: node {} is not a non-negative integer",
                        shown.display(),
                        line_number + 1,
                        data_excerpt(token)
                    ),
                )
            })?);
        }
    }
    Ok(nodes)
}
