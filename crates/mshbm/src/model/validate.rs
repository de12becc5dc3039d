//! The checks of a [`Model`] ([`Model::validate`]): DOFs and directions of contacts and
//! friction elements, their independence, contact friction, loads and damping.

use std::collections::{BTreeMap, HashMap, HashSet};

use super::{ContactFriction, FrictionNormal, Model};
use crate::error::{Error, Result};
use crate::sparse::SparseMatrix;

impl Model {
    /// Check the DOFs and the direction coefficients of a contact (`W`, the gap gradient) or
    /// of a friction element (the slip direction): at least one DOF, one coefficient per
    /// DOF, every DOF in range and not a Dirichlet DOF, coefficients finite and not all
    /// zero. `field` names a field of the element (`field("dofs")`); `element` and
    /// `direction` name the element and its coefficients in the messages.
    ///
    /// The coefficients of a DOF that appears more than once are summed; the direction
    /// must not vanish after that (`dofs = [3, 3]`, `w = [-1, 1]` would be a contact that
    /// never acts). Returns the merged direction ([`merged_direction`]).
    /// Check the Coulomb friction of contact `k` (docs/theory.md (T150)): `μ` finite and
    /// non-negative; the tangent (in space both tangents, (T185)) a valid direction
    /// ([`Model::check_direction`]), orthogonal to the contact's normal `normal` (merged) and
    /// to the other tangent, and of the normal's norm, so that the friction force and its
    /// bound `μ λ_N` are measured alike.
    fn check_contact_friction(
        &self,
        dirichlet: &HashSet<usize>,
        k: usize,
        friction: &ContactFriction,
        normal: &[(usize, f64)],
    ) -> Result<()> {
        let file = &self.source;
        if !(friction.mu.is_finite() && friction.mu >= 0.0) {
            return Err(Error::field(
                file,
                format!("contacts[{k}].mu"),
                format!(
                    "the friction coefficient must be finite and ≥ 0, got {}",
                    friction.mu
                ),
            ));
        }
        let norm = |v: &[(usize, f64)]| v.iter().map(|(_, x)| x * x).sum::<f64>().sqrt();
        let product = |a: &[(usize, f64)], b: &[(usize, f64)]| -> f64 {
            a.iter()
                .filter_map(|(d, t)| b.iter().find(|(e, _)| e == d).map(|(_, n)| n * t))
                .sum()
        };
        let nn = norm(normal);
        // the tangents: orthogonal to the normal and to each other, of the normal's norm
        let mut tangents: Vec<Vec<(usize, f64)>> = Vec::new();
        let second = friction.second.as_ref();
        for (prefix, dofs, w) in std::iter::once(("tangent", &friction.dofs, &friction.w))
            .chain(second.map(|t| ("tangent2", &t.dofs, &t.w)))
        {
            let field = |f: &str| format!("contacts[{k}].{prefix}_{f}");
            let tangent = self.check_direction(
                dirichlet,
                dofs,
                w,
                field,
                "the tangent of a contact with friction",
                "the tangent",
            )?;
            let nt = norm(&tangent);
            let dot = product(&tangent, normal);
            if dot.abs() > 1e-9 * nn * nt {
                return Err(Error::field(
                    file,
                    field("w"),
                    format!(
                        "the tangent is not orthogonal to the contact's normal w (their product is {dot:e}, the norms {nn:e} and {nt:e})"
                    ),
                ));
            }
            if (nt - nn).abs() > 1e-9 * nn {
                return Err(Error::field(
                    file,
                    field("w"),
                    format!(
                        "the tangent's norm {nt:e} differs from the normal's {nn:e}: the friction force and its bound mu * lambda_N would be measured in different units"
                    ),
                ));
            }
            if let Some(first) = tangents.first() {
                let dot = product(&tangent, first);
                if dot.abs() > 1e-9 * nt * nt {
                    return Err(Error::field(
                        file,
                        field("w"),
                        format!(
                            "the second tangent is not orthogonal to the first (their product is {dot:e})"
                        ),
                    ));
                }
            }
            tangents.push(tangent);
        }
        Ok(())
    }

    fn check_direction(
        &self,
        dirichlet: &HashSet<usize>,
        dofs: &[usize],
        w: &[f64],
        field: impl Fn(&str) -> String,
        element: &str,
        direction: &str,
    ) -> Result<Vec<(usize, f64)>> {
        let file = &self.source;
        let n = self.n_dofs();
        if dofs.is_empty() {
            return Err(Error::field(
                file,
                field("dofs"),
                format!("{element} needs at least one DOF"),
            ));
        }
        if dofs.len() != w.len() {
            return Err(Error::field(
                file,
                field("w"),
                format!("{} coefficients for {} DOFs", w.len(), dofs.len()),
            ));
        }
        for &d in dofs {
            if d >= n {
                return Err(Error::field(
                    file,
                    field("dofs"),
                    format!("DOF {d} out of range (the model has DOFs 0..{})", n - 1),
                ));
            }
            if dirichlet.contains(&d) {
                return Err(Error::field(
                    file,
                    field("dofs"),
                    format!("DOF {d} is also a Dirichlet DOF"),
                ));
            }
        }
        if w.iter().any(|v| !v.is_finite()) || w.iter().all(|&v| v == 0.0) {
            return Err(Error::field(
                file,
                field("w"),
                format!("{direction} must be finite and non-zero"),
            ));
        }
        let merged = merged_direction(dofs, w);
        if merged.is_empty() {
            return Err(Error::field(
                file,
                field("w"),
                format!("{direction} vanishes: the coefficients of each DOF sum to zero (a DOF listed twice with opposite coefficients cancels)"),
            ));
        }
        Ok(merged)
    }

    /// Refuse two elements of `directions` (contacts or friction elements, merged
    /// directions with their indices) on the same DOFs with parallel directions: their
    /// columns of `W` are linearly dependent, so the Delassus matrix `Wᵀ M⁻¹ W` of the
    /// contact problem (docs/theory.md (T3)–(T5)) is singular. `allowed_opposite(a, b, ratio)`
    /// decides on a pair whose directions are opposite (`w_b = −ratio · w_a`, `ratio > 0`).
    fn check_independent(
        &self,
        directions: &[Vec<(usize, f64)>],
        kind: &str,
        allowed_opposite: impl Fn(usize, usize, f64) -> Result<()>,
    ) -> Result<()> {
        let mut groups: HashMap<Vec<usize>, Vec<usize>> = HashMap::new();
        for (k, d) in directions.iter().enumerate() {
            groups
                .entry(d.iter().map(|&(dof, _)| dof).collect())
                .or_default()
                .push(k);
        }
        let mut groups: Vec<Vec<usize>> = groups.into_values().filter(|g| g.len() > 1).collect();
        groups.sort_unstable();
        for group in groups {
            for (x, &a) in group.iter().enumerate() {
                for &b in &group[x + 1..] {
                    let (wa, wb) = (&directions[a], &directions[b]);
                    let dot: f64 = wa.iter().zip(wb).map(|(p, q)| p.1 * q.1).sum();
                    let na = wa.iter().map(|p| p.1 * p.1).sum::<f64>().sqrt();
                    let nb = wb.iter().map(|p| p.1 * p.1).sum::<f64>().sqrt();
                    if dot.abs() < (1.0 - PARALLEL_TOLERANCE) * na * nb {
                        continue;
                    }
                    if dot < 0.0 {
                        allowed_opposite(a, b, nb / na)?;
                        continue;
                    }
                    return Err(Error::field(
                        &self.source,
                        format!("{kind}[{b}]"),
                        format!("acts on the same DOFs as {kind}[{a}] in the same direction: the two are one {} given twice, and the contact problem would be singular; give it once", if kind == "contacts" { "contact" } else { "friction element" }),
                    ));
                }
            }
        }
        Ok(())
    }

    /// Check the consistency of the model; errors name the field (with the model's source).
    pub fn validate(&self) -> Result<()> {
        let file = &self.source;
        let n = self.n_dofs();
        let square = |name: &str, a: &SparseMatrix| -> Result<()> {
            if a.nrows() != a.ncols() {
                return Err(Error::field(
                    file,
                    name,
                    format!("matrix is not square ({}×{})", a.nrows(), a.ncols()),
                ));
            }
            if a.nrows() != n {
                return Err(Error::field(
                    file,
                    name,
                    format!(
                        "matrix is {}×{}, the stiffness matrix is {n}×{n}",
                        a.nrows(),
                        a.ncols()
                    ),
                ));
            }
            if let Some((i, j, v)) = a.iter().find(|(_, _, v)| !v.is_finite()) {
                return Err(Error::field(
                    file,
                    name,
                    format!(
                        "entry ({}, {}) is {v:e}: every entry must be finite (1-based)",
                        i + 1,
                        j + 1
                    ),
                ));
            }
            if let Some((i, j)) = a.asymmetry(1e-10) {
                return Err(Error::field(
                    file,
                    name,
                    format!("matrix is not symmetric: entry ({}, {}) = {:e} but ({}, {}) = {:e} (1-based)", i + 1, j + 1, a.get(i, j), j + 1, i + 1, a.get(j, i)),
                ));
            }
            Ok(())
        };
        square("matrices.stiffness", &self.stiffness)?;
        square("matrices.mass", &self.mass)?;
        // a mass matrix is positive semidefinite: no negative diagonal entry (it was blamed
        // on the mass redistribution's correction, and HBM-AFT solved with it)
        if let Some((i, v)) = (0..self.mass.nrows())
            .map(|i| (i, self.mass.get(i, i)))
            .find(|&(_, v)| v < 0.0)
        {
            return Err(Error::field(
                file,
                "matrices.mass",
                format!(
                    "diagonal entry ({}, {}) = {v:e} is negative: a mass matrix has no negative diagonal entry (1-based)",
                    i + 1,
                    i + 1
                ),
            ));
        }
        if let Some(c) = &self.damping_matrix {
            square("matrices.damping", c)?;
        }
        if n == 0 {
            return Err(Error::field(
                file,
                "matrices.stiffness",
                "the model has no DOFs",
            ));
        }
        if self.dofs_per_node == 0 {
            return Err(Error::field(
                file,
                "mesh.dofs_per_node",
                "must be at least 1",
            ));
        }
        let mesh_dofs = self.coordinates.len().checked_mul(self.dofs_per_node);
        if mesh_dofs != Some(n) {
            return Err(Error::field(
                file,
                "mesh.coordinates",
                format!(
                    "{} nodes × {} DOFs per node = {} DOFs, but the matrices have {n}",
                    self.coordinates.len(),
                    self.dofs_per_node,
                    mesh_dofs.map_or_else(|| "more than 2^64".to_string(), |d| d.to_string())
                ),
            ));
        }
        let dim = self.coordinates.first().map_or(0, Vec::len);
        if !(1..=3).contains(&dim) {
            return Err(Error::field(
                file,
                "mesh.coordinates",
                format!("nodes must have 1, 2 or 3 coordinates, found {dim}"),
            ));
        }
        for (k, c) in self.coordinates.iter().enumerate() {
            if c.len() != dim || c.iter().any(|v| !v.is_finite()) {
                return Err(Error::field(
                    file,
                    "mesh.coordinates",
                    format!("node {k}: expected {dim} finite coordinates, found {c:?}"),
                ));
            }
        }
        for (k, &d) in self.dirichlet.iter().enumerate() {
            if d >= n {
                return Err(Error::field(
                    file,
                    format!("mesh.dirichlet[{k}]"),
                    format!("DOF {d} out of range (the model has DOFs 0..{})", n - 1),
                ));
            }
        }
        let dirichlet: HashSet<usize> = self.dirichlet.iter().copied().collect();
        let mut contact_directions = Vec::with_capacity(self.contacts.len());
        for (k, c) in self.contacts.iter().enumerate() {
            let field = |f: &str| format!("contacts[{k}].{f}");
            contact_directions.push(self.check_direction(
                &dirichlet,
                &c.dofs,
                &c.w,
                field,
                "a contact",
                "the gap gradient",
            )?);
            if !c.gap.is_finite() {
                return Err(Error::field(file, field("gap"), "must be finite"));
            }
            if let Some(fr) = &c.friction {
                self.check_contact_friction(
                    &dirichlet,
                    k,
                    fr,
                    contact_directions.last().expect("just pushed"),
                )?;
            }
        }
        // two opposing contacts on the same DOFs (a clearance between two stops) are
        // allowed while the clearance is positive: g_a + g_b / ratio > 0 for w_b = −ratio w_a
        self.check_independent(&contact_directions, "contacts", |a, b, ratio| {
            let clearance = self.contacts[a].gap + self.contacts[b].gap / ratio;
            if clearance > 0.0 {
                Ok(())
            } else {
                Err(Error::field(
                    file,
                    format!("contacts[{b}]"),
                    format!("opposes contacts[{a}] on the same DOFs with no clearance left between them ({clearance:e}): the two would lock the DOFs or contradict each other"),
                ))
            }
        })?;
        for (k, i) in self.interfaces.iter().enumerate() {
            let count = i.contacts.len();
            if i.contacts.end > self.contacts.len()
                || i.positions.len() != count
                || i.nodes.len() != count
            {
                return Err(Error::field(
                    file,
                    format!("interfaces[{k}]"),
                    format!(
                        "interface {:?} refers to contacts {:?} with {} positions and {} node lists, but the model has {} contacts",
                        i.name,
                        i.contacts,
                        i.positions.len(),
                        i.nodes.len(),
                        self.contacts.len()
                    ),
                ));
            }
        }
        let mut friction_directions = Vec::with_capacity(self.frictions.len());
        for (k, f) in self.frictions.iter().enumerate() {
            let field = |x: &str| format!("frictions[{k}].{x}");
            friction_directions.push(self.check_direction(
                &dirichlet,
                &f.dofs,
                &f.w,
                field,
                "a friction element",
                "the slip direction",
            )?);
            if !(f.mu.is_finite() && f.mu >= 0.0) {
                return Err(Error::field(
                    file,
                    field("mu"),
                    format!("must be a finite non-negative number, got {}", f.mu),
                ));
            }
            match f.normal {
                FrictionNormal::Force(p) if !(p.is_finite() && p >= 0.0) => {
                    return Err(Error::field(
                        file,
                        field("normal_force"),
                        format!("must be a finite non-negative number, got {p}"),
                    ))
                }
                FrictionNormal::Contact(c) if c >= self.contacts.len() => {
                    return Err(Error::field(
                        file,
                        field("contact"),
                        format!(
                            "contact {c} does not exist (the model has {} contacts)",
                            self.contacts.len()
                        ),
                    ))
                }
                _ => {}
            }
        }
        // a friction law is odd in the slip direction: opposite directions are duplicates too
        self.check_independent(&friction_directions, "frictions", |a, b, _| {
            Err(Error::field(
                file,
                format!("frictions[{b}]"),
                format!("acts on the same DOFs as frictions[{a}] along the same line: the two are one friction element given twice, and the friction problem would be singular; give it once"),
            ))
        })?;
        for (name, v) in [
            ("load.harmonic", &self.harmonic_load),
            ("load.constant", &self.constant_load),
        ] {
            if v.len() != n {
                return Err(Error::field(
                    file,
                    name,
                    format!("load vector has {} entries for {n} DOFs", v.len()),
                ));
            }
            if v.iter().any(|x| !x.is_finite()) {
                return Err(Error::field(file, name, "load values must be finite"));
            }
        }
        if let Some(a) = &self.acceleration {
            if a.len() != self.dofs_per_node || a.iter().any(|x| !x.is_finite()) {
                return Err(Error::field(
                    file,
                    "load.acceleration",
                    format!(
                        "expected {} finite values (one per DOF of a node)",
                        self.dofs_per_node
                    ),
                ));
            }
        }
        let d = &self.damping;
        for (name, v) in [
            ("damping.alpha", d.alpha),
            ("damping.beta", d.beta),
            ("damping.beta_linear", d.beta_linear),
            ("damping.beta_condensed", d.beta_condensed),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(Error::field(
                    file,
                    name,
                    format!("must be a finite non-negative number, got {v}"),
                ));
            }
        }
        if let Some(z) = d.first_mode_ratio {
            if !(z.is_finite() && z >= 0.0) {
                return Err(Error::field(
                    file,
                    "damping.first_mode_ratio",
                    format!("must be a finite non-negative number, got {z}"),
                ));
            }
            if d.alpha != 0.0 {
                return Err(Error::field(
                    file,
                    "damping.first_mode_ratio",
                    "set either `alpha` or `first_mode_ratio`, not both",
                ));
            }
        }
        Ok(())
    }
}

/// Relative tolerance below which two directions count as parallel (`|cos| ≥ 1 − tol`)
/// and a merged coefficient counts as cancelled (`|Σ w| ≤ tol · max |w_i|`).
const PARALLEL_TOLERANCE: f64 = 1e-12;

/// The direction `Σ_i w_i e_{dofs_i}` as `(dof, coefficient)` in DOF order: coefficients
/// of a repeated DOF are summed, and sums that cancel (`|Σ| ≤ 1e-12 · max |w_i|`) are
/// dropped.
fn merged_direction(dofs: &[usize], w: &[f64]) -> Vec<(usize, f64)> {
    let scale = w.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
    let mut sums: BTreeMap<usize, f64> = BTreeMap::new();
    for (&d, &v) in dofs.iter().zip(w) {
        *sums.entry(d).or_insert(0.0) += v;
    }
    sums.into_iter()
        .filter(|&(_, v)| v.abs() > PARALLEL_TOLERANCE * scale)
        .collect()
}
