//! What `mshbm simulate` computes around a time integration ([`crate::integrate`]): the
//! reference period of a run, the start from a periodic solution, and the statistics of a
//! transient run (extremes of gaps and forces, contact fraction, energy range).

use std::path::Path;

use crate::error::{Error, Result};
use crate::integrate::initial::{harmonics_from_known, state_from_harmonics};
use crate::integrate::Integrator;
use crate::model::dropped_bar::DroppedBarParameters;
use crate::model::{Model, System};
use crate::solution::PeriodicSolution;

/// The period (s) that sets the time scale of a run: `1/f` of the forcing frequency; for a
/// dropped bar its closed-form period `4(κ+1)L/c` (docs/theory.md (T89); exactly periodic
/// for integer κ, and still the time scale otherwise); else the first eigenperiod of
/// `system`. `None` for a free structure without forcing.
pub fn reference_period(
    system: &System,
    frequency_hz: Option<f64>,
    dropped: Option<&DroppedBarParameters>,
) -> Option<f64> {
    match (frequency_hz, dropped) {
        (Some(f), _) => Some(1.0 / f),
        (None, Some(p)) => Some(match p.analytic() {
            Ok(a) => a.period(),
            Err(_) => 4.0 * (p.kappa() + 1.0) * p.length / p.wave_speed(),
        }),
        (None, None) => crate::modes::first_angular_frequency(&system.mass, &system.stiffness)
            .ok()
            .map(|w| 2.0 * std::f64::consts::PI / w),
    }
}

/// The initial state `(q(0), q̇(0))` (system numbering) of the periodic `solution` at
/// `omega` [rad/s]: the harmonics of its contact-node DOFs extended to all DOFs
/// ([`state_from_harmonics`]; docs/theory.md (T17) and the end of §3). `source` names where
/// the solution came from, for errors.
pub fn state_from_solution(
    system: &System,
    model: &Model,
    solution: &PeriodicSolution,
    omega: f64,
    source: &Path,
) -> Result<(Vec<f64>, Vec<f64>)> {
    let (known, field) = known_harmonics(system, model, solution, source)?;
    state_from_harmonics(system, omega, &known).map_err(|e| {
        Error::field(
            source,
            field,
            format!("cannot start from this solution: {e}"),
        )
    })
}

/// The Fourier coefficients `[a0, a1, b1, …]` of every **model** DOF of the periodic
/// `solution` at `omega` [rad/s] (Dirichlet DOFs zero): its contact-node harmonics extended
/// by the linear equations ([`harmonics_from_known`], docs/theory.md (T17)). `system` is
/// the system of the solution's method (its mass).
pub fn field_harmonics(
    system: &System,
    model: &Model,
    solution: &PeriodicSolution,
    omega: f64,
    source: &Path,
) -> Result<Vec<Vec<f64>>> {
    let (known, field) = known_harmonics(system, model, solution, source)?;
    let coef = harmonics_from_known(system, omega, &known)
        .map_err(|e| Error::field(source, field, format!("cannot extend this solution: {e}")))?;
    let nc = 2 * solution.harmonics + 1;
    let mut out = vec![vec![0.0; nc]; system.n_model_dofs];
    for (s, c) in coef.into_iter().enumerate() {
        out[system.model_dof[s]] = c;
    }
    Ok(out)
}

/// `(system DOF, [a0, a1, b1, …])` pairs.
type KnownHarmonics = Vec<(usize, Vec<f64>)>;

/// The harmonics of every contact-node DOF of `solution` (system numbering) and the field
/// of the solution they come from: its contact-node harmonics (`x = q̂_N`, harmonic-major,
/// eq. 31) when it reports them, or its unknowns when they are those (HBM-AFT), else its
/// contact series (enough when each contact node has one DOF).
fn known_harmonics(
    system: &System,
    model: &Model,
    solution: &PeriodicSolution,
    source: &Path,
) -> Result<(KnownHarmonics, &'static str)> {
    // another model's solution of as many unknowns would be extended silently
    if let Some(why) = solution.other_model(model) {
        return Err(Error::field(
            source,
            "contact_dofs",
            format!("cannot start from this solution: {why}"),
        ));
    }
    let n = system.nonlinear_dofs.len();
    let nc = 2 * solution.harmonics + 1;
    // the redistributed MS-HBM's unknowns are free gaps: its contact-node harmonics are
    // reported apart; every other method's unknowns start with them
    let harmonics = match solution.method {
        crate::solution::MethodKind::Redistributed => solution.contact_node_harmonics.as_ref(),
        _ => solution
            .contact_node_harmonics
            .as_ref()
            .or(solution.unknowns.as_ref()),
    };
    if let Some(x) = harmonics.filter(|x| x.len() == n * nc) {
        let known = system
            .nonlinear_dofs
            .iter()
            .enumerate()
            .map(|(i, &d)| (d, (0..nc).map(|c| x[c * n + i]).collect()))
            .collect();
        return Ok((known, "unknowns"));
    }
    let mut known = Vec::new();
    for c in &solution.contacts {
        if c.dof >= model.n_dofs() {
            return Err(Error::field(
                source,
                "contacts.dof",
                format!(
                    "contact DOF {} does not exist in the model (DOFs 0..{})",
                    c.dof,
                    model.n_dofs() - 1
                ),
            ));
        }
        let Some(s) = system.system_dof(c.dof) else {
            return Err(Error::field(
                source,
                "contacts.dof",
                format!("contact DOF {} is a Dirichlet DOF of the model", c.dof),
            ));
        };
        known.push((s, c.coefficients.clone()));
    }
    Ok((known, "contacts"))
}

/// Statistics of a run, updated step by step ([`TransientStatistics::record`]).
#[derive(Clone, Debug)]
pub struct TransientStatistics {
    /// Energies are divided by this when set (free problems: the initial energy).
    pub energy_norm: Option<f64>,
    /// Smallest gap and largest force per contact.
    pub min_gap: Vec<f64>,
    pub max_force: Vec<f64>,
    /// Recorded states with a positive contact force, per contact.
    pub closed_steps: Vec<u64>,
    /// Recorded states.
    pub steps: u64,
    /// Smallest and largest (normalised) energy.
    pub energy_range: (f64, f64),
    /// The last energy (not normalised).
    pub energy_last: f64,
}

impl TransientStatistics {
    pub fn new(contacts: usize, energy_norm: Option<f64>) -> Self {
        TransientStatistics {
            energy_norm,
            min_gap: vec![f64::INFINITY; contacts],
            max_force: vec![0.0; contacts],
            closed_steps: vec![0; contacts],
            steps: 0,
            energy_range: (f64::INFINITY, f64::NEG_INFINITY),
            energy_last: 0.0,
        }
    }

    /// Take the integrator's current state into account; returns its energy, normalised
    /// when [`TransientStatistics::energy_norm`] is set.
    pub fn record(&mut self, it: &Integrator) -> f64 {
        let e = it.energy();
        let shown = self.energy_norm.map_or(e, |e0| e / e0);
        self.energy_range = (
            self.energy_range.0.min(shown),
            self.energy_range.1.max(shown),
        );
        self.energy_last = e;
        for (c, (&g, &f)) in it.gaps().iter().zip(it.forces()).enumerate() {
            self.min_gap[c] = self.min_gap[c].min(g);
            self.max_force[c] = self.max_force[c].max(f);
            if f > 0.0 {
                self.closed_steps[c] += 1;
            }
        }
        self.steps += 1;
        shown
    }

    /// The fraction of the recorded states in which contact `c` carried a force.
    pub fn closed_fraction(&self, c: usize) -> f64 {
        self.closed_steps[c] as f64 / self.steps as f64
    }
}

/// Contact phases in a gap history sampled at equidistant `time`: (start, duration) of each
/// maximal run of samples with `gap <= tolerance` (a run lasts its number of samples times
/// the sampling interval), and the total closed time.
pub fn contact_intervals(time: &[f64], gap: &[f64], tolerance: f64) -> (Vec<(f64, f64)>, f64) {
    let dt = if time.len() > 1 {
        time[1] - time[0]
    } else {
        0.0
    };
    let mut runs = Vec::new();
    let mut start: Option<usize> = None;
    for (i, &g) in gap.iter().enumerate() {
        match (g <= tolerance, start) {
            (true, None) => start = Some(i),
            (false, Some(s)) => {
                runs.push((time[s], (i - s) as f64 * dt));
                start = None;
            }
            _ => {}
        }
    }
    if let Some(s) = start {
        runs.push((time[s], (gap.len() - s) as f64 * dt));
    }
    let total = runs.iter().map(|r| r.1).sum();
    (runs, total)
}

#[cfg(test)]
mod tests {
    use super::contact_intervals;

    #[test]
    fn contact_intervals_of_a_square_wave() {
        let time: Vec<f64> = (0..10).map(|i| i as f64 * 0.5).collect();
        let gap = [1.0, 0.0, 0.0, 0.0, 1.0, 1.0, 0.0, 1.0, 0.0, 0.0];
        let (runs, total) = contact_intervals(&time, &gap, 1e-12);
        assert_eq!(runs, vec![(0.5, 1.5), (3.0, 0.5), (4.0, 1.0)]);
        assert_eq!(total, 3.0);
    }
}
