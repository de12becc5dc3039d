//! Fourier coefficients of the contact forces `λ(τ)` (the contact part of the paper's
//! eqs. 33–35 in the contact coordinates, docs/theory.md (T128)), by either quadrature:
//!
//! * **sampled** — the DFT over `N_s` equidistant samples (the paper's implementation);
//! * **exact** — the period is cut at the switching times of the active set (roots of the
//!   gaps of open contacts and of the forces of closed ones, which are trigonometric
//!   polynomials between switches), and the Fourier integrals are done in closed form on
//!   each interval. No aliasing; the residual is continuously differentiable.
//!
//! Both give, per distinct active set `A`, a Gram block `Γ_A` (see [`crate::harmonic`]) such
//! that `λ̂ = Σ_A F_A U Γ_Aᵀ` (the Gram form (T40), with exact interval blocks (T45)), where
//! `U` holds the Fourier coefficients of the free gap
//! `γ(τ)` (docs/theory.md (T123)) and `F_A = ∂λ/∂γ` is the force map of the set. The
//! semi-analytical Jacobian follows the same sum (eqs. 36–38: the interval end points drop
//! out because `λ` is continuous in time for the static contact problem, (T46)).
//!
//! Switching times are located cell by cell on a grid of `N_s` points: a gap or force that is
//! negative at the end of a cell, or dips below zero at an interior minimum (grazing, or a
//! release shorter than a cell), starts a new interval at its first root. Each cell is
//! scanned at a few points: the indicators' values and slopes there are two matrix products
//! of their coefficients (formed once per active set) with the trigonometric basis at the
//! points, and only the indicators that may change sign in the earliest scanned
//! sub-interval are located to round-off. Contacts that switch at one instant are flipped
//! one after the other; the LCP decides only where flips undo each other (docs/theory.md
//! §6, "Switches at one instant").

use std::collections::HashMap;
use std::rc::Rc;

use crate::contact::static_contact::{ActiveSet, StaticContact, ACTIVE_SET_CACHE_BYTES};
use crate::error::{Error, Result};
use crate::harmonic::{add_interval_gram, basis_into, n_coefficients, Quadrature, Sampling};

mod cell_scan;

pub(super) use cell_scan::{derivative_into, CellScan};

/// Samples sharing one active set, with their summed Gram block.
pub struct Group {
    pub set: Rc<ActiveSet>,
    /// `Γ_A`, `(2H+1)²`, row-major.
    pub gram: Vec<f64>,
}

/// A located change of active set.
#[derive(Clone, Copy, Debug)]
pub struct Switch {
    /// Normalised time `τ ∈ [0, 2π)`.
    pub tau: f64,
}

/// The active-set decomposition of one period.
#[derive(Default)]
pub struct Integration {
    pub groups: Vec<Group>,
    /// Located switching times (exact quadrature only).
    pub switches: Vec<Switch>,
    /// The period cut into intervals of constant active set, `(τ_start, τ_end, group)`,
    /// in order (exact: at the switching times; sampled: runs of grid cells).
    pub intervals: Vec<(f64, f64, usize)>,
}

/// The signal of `n` components at `τ` from its coefficients (`load[c·n + i]`).
pub fn signal_at(
    load: &[f64],
    n: usize,
    harmonics: usize,
    tau: f64,
    basis: &mut [f64],
) -> Vec<f64> {
    basis_into(harmonics, tau, basis);
    signal_with_basis(load, n, basis)
}

/// The signal of `n` components from its coefficients (`load[c·n + i]`) at the instant whose
/// basis row is `basis` (e.g. a grid sample's, from the sampling's table).
pub fn signal_with_basis(load: &[f64], n: usize, basis: &[f64]) -> Vec<f64> {
    let mut b = vec![0.0; n];
    signal_with_basis_into(load, n, basis, &mut b);
    b
}

/// [`signal_with_basis`] into `b` (`n`).
pub fn signal_with_basis_into(load: &[f64], n: usize, basis: &[f64], b: &mut [f64]) {
    b.fill(0.0);
    for (c, &bc) in basis.iter().enumerate() {
        for i in 0..n {
            b[i] += load[c * n + i] * bc;
        }
    }
}

/// The groups of one integration, by active set. Sets are told apart by their address:
/// the contact's cache returns one `Rc` per set, and a set met twice under two addresses
/// (after the cache started over) gives two groups whose sums add up the same.
struct Groups<'a> {
    index: &'a mut HashMap<*const ActiveSet, usize>,
    groups: &'a mut Vec<Group>,
    /// Gram blocks of an earlier integration, to fill again.
    spare: &'a mut Vec<Vec<f64>>,
    size: usize,
    /// Bytes of the distinct sets the groups hold, and the most they may hold (the exact
    /// quadrature; `usize::MAX` for the sampled one, bounded by its samples).
    held: usize,
    budget: usize,
}

impl Groups<'_> {
    /// The group of `set`, a new one the first time the set is met; refused (the exact
    /// quadrature on a large interface) when the sets held would exceed the budget.
    fn of(&mut self, set: &Rc<ActiveSet>) -> Result<usize> {
        if let Some(&g) = self.index.get(&Rc::as_ptr(set)) {
            return Ok(g);
        }
        self.held = self.held.saturating_add(set.bytes());
        if self.held > self.budget {
            return Err(Error::argument(
                "quadrature",
                format!(
                    "the exact quadrature met more than {} active sets of the {} contacts in \
                     one period, more than the {} their force maps may hold (the sets a \
                     period passes through grow with the contacts that switch); use the \
                     sampled quadrature (`--quadrature sampled`, `Quadrature::Sampled`) on \
                     an interface this large",
                    self.groups.len(),
                    set.closed.len(),
                    crate::limits::human_bytes(self.budget as u64),
                ),
            ));
        }
        let mut gram = self.spare.pop().unwrap_or_default();
        gram.clear();
        gram.resize(self.size * self.size, 0.0);
        self.groups.push(Group {
            set: set.clone(),
            gram,
        });
        self.index.insert(Rc::as_ptr(set), self.groups.len() - 1);
        Ok(self.groups.len() - 1)
    }
}

/// Decompose one period into active-set groups for the free gap with coefficients `gamma`
/// (harmonic-major, `n_c` per coefficient).
pub fn integrate(
    contact: &mut StaticContact,
    gamma: &[f64],
    sampling: &Sampling,
    quadrature: Quadrature,
) -> Result<Integration> {
    let mut out = Integration::default();
    integrate_into(
        contact,
        gamma,
        sampling,
        quadrature,
        &mut out,
        &mut QuadratureWorkspace::default(),
    )?;
    Ok(out)
}

/// The working storage of [`integrate_into`], kept between integrations so that one
/// allocates nothing once it has grown (for one contact: the static problem's solves and
/// indicators of more contacts allocate).
#[derive(Default)]
pub struct QuadratureWorkspace {
    index: HashMap<*const ActiveSet, usize>,
    spare_grams: Vec<Vec<f64>>,
    grid: Option<GridIndicators>,
    scan: Option<CellScan>,
    free_gap: Vec<f64>,
    basis: Vec<f64>,
    closed: Vec<bool>,
    /// Bytes the active sets of one exact integration may hold; `None`:
    /// [`ACTIVE_SET_CACHE_BYTES`], as much as the static problem's cache.
    pub(super) set_budget: Option<usize>,
}

/// [`integrate`] into `out` (its storage reused), with the working storage `workspace`.
pub fn integrate_into(
    contact: &mut StaticContact,
    gamma: &[f64],
    sampling: &Sampling,
    quadrature: Quadrature,
    out: &mut Integration,
    workspace: &mut QuadratureWorkspace,
) -> Result<()> {
    let ncoef = n_coefficients(sampling.harmonics);
    workspace
        .spare_grams
        .extend(out.groups.drain(..).map(|g| g.gram));
    workspace.index.clear();
    out.switches.clear();
    out.intervals.clear();
    let mut groups = Groups {
        index: &mut workspace.index,
        groups: &mut out.groups,
        spare: &mut workspace.spare_grams,
        size: ncoef,
        held: 0,
        budget: match quadrature {
            Quadrature::Exact => workspace.set_budget.unwrap_or(ACTIVE_SET_CACHE_BYTES),
            Quadrature::Sampled => usize::MAX,
        },
    };
    match quadrature {
        Quadrature::Sampled => {
            sampled(contact, gamma, sampling, &mut groups, &mut out.intervals)?;
        }
        Quadrature::Exact => {
            let harmonics = sampling.harmonics;
            let grid = match &mut workspace.grid {
                Some(g) if g.ncoef == ncoef => g,
                slot => slot.insert(GridIndicators::new(ncoef)),
            };
            grid.of = None;
            let scan = match &mut workspace.scan {
                Some(s) if s.harmonics == harmonics => s,
                slot => slot.insert(CellScan::new(harmonics)),
            };
            let buffers = ExactBuffers {
                grid,
                scan,
                free_gap: &mut workspace.free_gap,
                basis: &mut workspace.basis,
                closed: &mut workspace.closed,
            };
            exact(
                contact,
                gamma,
                sampling,
                &mut groups,
                &mut out.intervals,
                &mut out.switches,
                buffers,
            )?;
        }
    }
    Ok(())
}

/// The working storage of [`exact`].
struct ExactBuffers<'a> {
    grid: &'a mut GridIndicators,
    scan: &'a mut CellScan,
    free_gap: &'a mut Vec<f64>,
    basis: &'a mut Vec<f64>,
    closed: &'a mut Vec<bool>,
}

/// The sampled quadrature: the LCP at every grid sample, whose set holds on its cell.
fn sampled(
    contact: &mut StaticContact,
    gamma: &[f64],
    sampling: &Sampling,
    groups: &mut Groups,
    intervals: &mut Vec<(f64, f64, usize)>,
) -> Result<()> {
    let nc = contact.n_contacts();
    let two_pi = 2.0 * std::f64::consts::PI;
    let mut free_gap = vec![0.0; nc];
    for (j, &tau) in sampling.taus.iter().enumerate() {
        sampling.synthesize_into(j, gamma, nc, &mut free_gap);
        let g = groups.of(&contact.solve(&free_gap)?)?;
        sampling.add_sample_gram(j, &mut groups.groups[g].gram);
        // the sample's set holds on its cell [τ_j, τ_j+1)
        let end = sampling.taus.get(j + 1).copied().unwrap_or(two_pi);
        match intervals.last_mut() {
            Some(last) if last.2 == g => last.1 = end,
            _ => intervals.push((tau, end, g)),
        }
    }
    Ok(())
}

/// The indicators of the current active set on the sample grid: their coefficients, their
/// values at the grid points from the sampling's basis table (no trigonometry), and what a
/// cell needs to be passed without a scan.
struct GridIndicators {
    ncoef: usize,
    /// The set the data is of.
    of: Option<Rc<ActiveSet>>,
    /// `n_c × (2H+1)`, row-major.
    coefs: Vec<f64>,
    /// Per indicator, `Σ_k k² (|a_k| + |b_k|)`, a bound of its second derivative.
    curvature: Vec<f64>,
    /// Per indicator, the round-off of its value: `10⁻¹⁴ Σ_m |c_m|`.
    rounding: Vec<f64>,
    /// Per indicator, the tolerance to which the set holds at a grid point:
    /// `h_c ≥ −10⁻¹² (1 + max_m |c_m|)`.
    holds_tolerance: Vec<f64>,
    /// Values at the start and the end of the current cell.
    start: Vec<f64>,
    end: Vec<f64>,
}

impl GridIndicators {
    fn new(ncoef: usize) -> Self {
        GridIndicators {
            ncoef,
            of: None,
            coefs: Vec::new(),
            curvature: Vec::new(),
            rounding: Vec::new(),
            holds_tolerance: Vec::new(),
            start: Vec::new(),
            end: Vec::new(),
        }
    }

    /// Make the data that of `set`; `true` when it changed.
    fn track(&mut self, set: &Rc<ActiveSet>, gamma: &[f64]) -> bool {
        if self.of.as_ref().is_some_and(|s| Rc::ptr_eq(s, set)) {
            return false;
        }
        set.indicator_coefficients_into(gamma, self.ncoef, &mut self.coefs);
        self.curvature.clear();
        self.rounding.clear();
        self.holds_tolerance.clear();
        for c in self.coefs.chunks_exact(self.ncoef) {
            let curvature = c
                .iter()
                .enumerate()
                .skip(1)
                .map(|(m, v)| {
                    let k = m.div_ceil(2) as f64;
                    k * k * v.abs()
                })
                .sum();
            self.curvature.push(curvature);
            self.rounding
                .push(1e-14 * c.iter().map(|v| v.abs()).sum::<f64>());
            self.holds_tolerance
                .push(1e-12 * (1.0 + c.iter().fold(0.0f64, |m, v| m.max(v.abs()))));
        }
        self.of = Some(Rc::clone(set));
        true
    }

    /// The indicators' values at grid point `j` (`j = N_s`: the end of the period).
    fn values_at(&self, sampling: &Sampling, j: usize, out: &mut Vec<f64>) {
        let basis = &sampling.basis[j % sampling.len()];
        out.clear();
        out.extend(
            self.coefs
                .chunks_exact(self.ncoef)
                .map(|c| crate::dense::dot(c, basis)),
        );
    }

    /// Whether every indicator is non-negative at the start of the cell, to round-off.
    fn hold_at_start(&self) -> bool {
        self.start
            .iter()
            .zip(&self.holds_tolerance)
            .all(|(v, t)| *v >= -t)
    }

    /// Whether every indicator stays positive on the cell of width `width` between the
    /// values `start` and `end` (docs/theory.md (T137)): with `|h''| ≤ M`, `h ≥ min(h(a), h(b)) − M (b − a)²/8` on
    /// `[a, b]` (the chord minus the largest deviation of a function of bounded curvature
    /// that meets it at both ends).
    fn positive_on_cell(&self, width: f64) -> bool {
        let w2 = width * width / 8.0;
        (0..self.start.len())
            .all(|c| self.start[c].min(self.end[c]) > self.curvature[c] * w2 + self.rounding[c])
    }
}

/// The exact quadrature (module docs): cell by cell, the switching times of the current set.
/// A cell on which every indicator provably stays positive ([`GridIndicators::positive_on_cell`])
/// is passed without a scan; the LCP is asked at a grid point only where the set carried into
/// the cell does not hold there.
fn exact(
    contact: &mut StaticContact,
    gamma: &[f64],
    sampling: &Sampling,
    groups: &mut Groups,
    intervals: &mut Vec<(f64, f64, usize)>,
    switches: &mut Vec<Switch>,
    buffers: ExactBuffers<'_>,
) -> Result<()> {
    let h = sampling.harmonics;
    let ncoef = n_coefficients(h);
    let nc = contact.n_contacts();
    let ns = sampling.len();
    let two_pi = 2.0 * std::f64::consts::PI;
    let ExactBuffers {
        grid,
        scan,
        free_gap,
        basis,
        closed,
    } = buffers;
    free_gap.clear();
    free_gap.resize(nc, 0.0);
    basis.clear();
    basis.resize(ncoef, 0.0);
    sampling.synthesize_into(0, gamma, nc, free_gap);
    let mut set = contact.solve(free_gap)?;
    let mut start_known = false;
    let mut run_start = 0.0;
    for j in 0..ns {
        let mut a = sampling.taus[j];
        let end = if j + 1 < ns {
            sampling.taus[j + 1]
        } else {
            two_pi
        };
        if grid.track(&set, gamma) || !start_known {
            let mut start = std::mem::take(&mut grid.start);
            grid.values_at(sampling, j, &mut start);
            grid.start = start;
        }
        // a set carried over from the previous cell that does not hold at this grid point
        // is replaced by the LCP's there (a double switch was missed)
        if !grid.hold_at_start() {
            sampling.synthesize_into(j, gamma, nc, free_gap);
            let solved = contact.solve(free_gap)?;
            if !Rc::ptr_eq(&solved, &set) {
                let g = groups.of(&set)?;
                add_interval_gram(h, run_start, a, &mut groups.groups[g].gram);
                intervals.push((run_start, a, g));
                run_start = a;
                set = solved;
                grid.track(&set, gamma);
                let mut start = std::mem::take(&mut grid.start);
                grid.values_at(sampling, j, &mut start);
                grid.start = start;
            }
        }
        let mut end_values = std::mem::take(&mut grid.end);
        grid.values_at(sampling, j + 1, &mut end_values);
        grid.end = end_values;
        if grid.positive_on_cell(end - a) {
            std::mem::swap(&mut grid.start, &mut grid.end);
            start_known = true;
            continue;
        }
        let cell_set = Rc::clone(&set);
        let mut guard = 0;
        // the contact flipped at the last switch, to see flips undo each other
        let mut last_flip: Option<usize> = None;
        loop {
            grid.track(&set, gamma);
            scan.fill(&grid.coefs, a, end);
            let Some((root, component)) = scan.earliest_root(&grid.coefs, ncoef) else {
                break;
            };
            let g = groups.of(&set)?;
            add_interval_gram(h, run_start, root, &mut groups.groups[g].gram);
            intervals.push((run_start, root, g));
            switches.push(Switch { tau: root });
            run_start = root;
            guard += 1;
            // contacts that switch at one instant (to round-off) are flipped one after
            // the other, like pivots; only when a flip undoes the previous one at the same
            // instant do the signs there depend on round-off, and the set is then the
            // LCP's a little later, which holds from the root
            let same_instant = root - a <= 1e-13 * two_pi;
            if (same_instant && last_flip == Some(component)) || guard > 2 * nc + 4 {
                let t = root + 1e-9 * (end - root);
                basis_into(h, t, basis);
                signal_with_basis_into(gamma, nc, basis, free_gap);
                set = contact.solve(free_gap)?;
                a = t;
                last_flip = None;
            } else {
                closed.clone_from(&set.closed);
                closed[component] = !closed[component];
                set = contact.active_set(closed)?;
                a = root;
                last_flip = Some(component);
            }
            if guard > 4 * nc + 8 {
                break;
            }
        }
        // the end values are those of the set the cell ends with
        if Rc::ptr_eq(&cell_set, &set) {
            std::mem::swap(&mut grid.start, &mut grid.end);
            start_known = true;
        } else {
            start_known = false;
        }
    }
    let g = groups.of(&set)?;
    add_interval_gram(h, run_start, two_pi, &mut groups.groups[g].gram);
    intervals.push((run_start, two_pi, g));
    Ok(())
}

#[cfg(test)]
mod tests;
