//! `kind = "matrices"`: a general model from Matrix Market files, coordinates, contacts,
//! node sets, interfaces, friction elements and loads (the sections and their reading).

use std::path::{Path, PathBuf};

use serde::Deserialize;

use super::super::damping_section::DampingSection;
use crate::error::{Error, Result};
use crate::limits::Limits;
use crate::model::excerpt::data_excerpt;
use crate::model::input_files::InputFiles;
use crate::model::matrix_market::{declared_dimensions, parse_matrix_with};
use crate::model::{Contact, Friction, FrictionNormal, Model, MODEL_BYTES_PER_DOF};

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
#[serde(deny_unknown_fields)]
struct MatricesSection {
    mass: String,
    stiffness: String,
    damping: Option<String>,
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
    #[serde(default = "one")]
    dofs_per_node: usize,
    coordinates: Coordinates,
    #[serde(default)]
    dirichlet: Vec<usize>,
}

fn one() -> usize {
    1
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ContactSection {
    dofs: Vec<usize>,
    w: Vec<f64>,
    gap: f64,
    /// Coulomb friction along the tangent `tangent_dofs`/`tangent_w` (docs/theory.md §20).
    mu: Option<f64>,
    tangent_dofs: Option<Vec<usize>>,
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
/// Check the matrix in `text` (of `file`, field `field` of the model file `path`) declares
/// no more rows and columns than a model of that many DOFs could hold in memory
/// ([`MODEL_BYTES_PER_DOF`]), before it is parsed.
fn check_declared_dofs(
    path: &Path,
    field: &str,
    file: &Path,
    text: &str,
    limits: &Limits,
) -> Result<(usize, usize)> {
    let (rows, cols) = declared_dimensions(text, file)?;
    limits.check_items(
        &format!(
            "{}: field `{field}`: {} declares a {rows}×{cols} matrix; a model of that many DOFs",
            path.display(),
            file.display()
        ),
        rows.max(cols) as u64,
        MODEL_BYTES_PER_DOF,
    )?;
    Ok((rows, cols))
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

/// Read a square symmetric matrix; errors name the model file, the field and the matrix file.
fn read_square_symmetric(
    inputs: &mut InputFiles,
    path: &Path,
    field: &str,
    file: &str,
) -> Result<crate::sparse::SparseMatrix> {
    let (full, text) = inputs.read(field, file)?;
    let (rows, cols) = check_declared_dofs(path, field, &full, &text, inputs.limits())?;
    if rows != cols {
        return Err(Error::field(
            path,
            field,
            format!("{} is {rows}×{cols}, not square", full.display()),
        ));
    }
    let a = parse_matrix_with(&text, &full, inputs.limits())?;
    if let Some((i, j)) = a.asymmetry(1e-10) {
        return Err(Error::field(
            path,
            field,
            format!(
                "{} is not symmetric: entry ({}, {}) = {:e} but ({}, {}) = {:e} (1-based)",
                full.display(),
                i + 1,
                j + 1,
                a.get(i, j),
                j + 1,
                i + 1,
                a.get(j, i)
            ),
        ));
    }
    Ok(a)
}

pub(super) fn matrices_model(
    f: MatricesFile,
    path: &Path,
    inputs: &mut InputFiles,
) -> Result<Model> {
    let stiffness =
        read_square_symmetric(inputs, path, "matrices.stiffness", &f.matrices.stiffness)?;
    let mass = read_square_symmetric(inputs, path, "matrices.mass", &f.matrices.mass)?;
    let damping_matrix = f
        .matrices
        .damping
        .as_ref()
        .map(|c| read_square_symmetric(inputs, path, "matrices.damping", c))
        .transpose()?;
    for (field, file, a) in [("matrices.mass", &f.matrices.mass, &mass)]
        .into_iter()
        .chain(
            f.matrices
                .damping
                .as_ref()
                .zip(damping_matrix.as_ref())
                .map(|(file, a)| ("matrices.damping", file, a)),
        )
    {
        if a.nrows() != stiffness.nrows() {
            return Err(Error::field(
                path,
                field,
                format!(
                    "{file} is {0}×{0}, the stiffness matrix is {1}×{1}",
                    a.nrows(),
                    stiffness.nrows()
                ),
            ));
        }
    }
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
        let friction = match (c.mu, c.tangent_dofs, c.tangent_w) {
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
            dofs: c.dofs,
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
        let nodes = match (&sec.nodes, &sec.file) {
            (Some(list), None) => list.clone(),
            (None, Some(file)) => read_node_list(inputs, path, &format!("{field}.file"), file)?,
            _ => {
                return Err(Error::field(
                    path,
                    field,
                    "give exactly one of `nodes` and `file`",
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
            dofs_per_node: f.mesh.dofs_per_node,
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
        node_sets,
        interfaces,
        name: f.name.unwrap_or_else(|| path.display().to_string()),
        mass,
        stiffness,
        damping_matrix,
        coordinates,
        dofs_per_node: f.mesh.dofs_per_node,
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
