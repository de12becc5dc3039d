//! Steady state by simulation: integrate period by period until the response repeats, then
//! report the last period in the same form as the MS-HBM ([`PeriodicSolution`]).
//!
//! The forcing period `T = 2π/ω` is split into `N` steps (`dt = T/N`, so the samples of a
//! period are the step times `t_p + jT/N`, the MS-HBM's `τ_j = 2πj/N`). After each period
//! the period-to-period change `δ_p` of [`SteadyStateOptions::periodicity`] is measured
//! ([`Periodicity`]):
//!
//! * [`Periodicity::Response`] (default, docs/theory.md (T97)): the harmonics `0..=H` of the
//!   displacements of the reported DOFs (the response DOF and the first DOF of each contact)
//!   against those of the previous period, relative to the largest displacement magnitude
//!   of those DOFs (with a floor of `10⁻⁶` times the largest gap, so that a response at rest
//!   repeats exactly). This is what an engineer reads off the output: the reported
//!   harmonics, maxima and minima repeat. Default tolerance `1e-3`.
//! * [`Periodicity::State`] (docs/theory.md (T70)): the state of the DOFs with mass
//!   (massless DOFs are statically determined) at the end of the period against the state
//!   one period earlier, `max(‖Δq‖∞, ‖Δv‖∞/ω) / A`, `A = max_i (max_t q_i − min_t q_i)/2`
//!   over the period (the largest displacement amplitude of the structure). Every mode
//!   counts, also high modes that no output shows. Default tolerance `1e-6`.
//!
//! The response is **periodic** when `δ_p < tolerance` for two successive periods; the
//! last period is then reported with `converged = true`, and the largest of those two
//! changes as the measured period-to-period scatter ([`SteadyState::period_scatter`]).
//! Otherwise, after the period limit, the last period is still reported, but with
//! `periodic = false` and the scatter of the last two periods, so a quasi-periodic or
//! chaotic response (light damping, contact exciting high modes that ring) is never
//! presented as a steady state. When such a run ends with the response repeating after
//! `k = 2, 3, 4` periods instead (to the tolerance, twice in a row), it is reported as
//! `subharmonic = k`. (Subharmonics do not stop the run early: a decaying transient whose
//! frequency is close to a rational multiple of the forcing passes that test long before it
//! has decayed.)
//!
//! Fourier coefficients are the DFT of the `N` samples (docs/theory.md (T10), mean `1/N`); max/min are
//! those of the samples.
//!
//! **Damping decides whether there is a steady state to find.** With mass-proportional
//! damping alone (`damping.first_mode_ratio`), mode `k` has the damping ratio `ζ₁ ω₁/ω_k`:
//! the high modes that every impact excites ring for many periods and the next impact
//! meets them in a different state. On the paper's bar with 1 % at the first mode the
//! whole state then does not repeat anywhere in 30–90 kHz (criterion (T70)); the response
//! wanders around the MS-HBM orbit by 0.2 % of the contact DOF's minimum at 30 and 60 kHz,
//! 1.3 % at 90 kHz, 20–40 % at 45, 55 and 65 kHz. At 30 kHz its harmonics repeat to about
//! 0.1 % of the response, so the response criterion (T97) finds it periodic, at 45 and
//! 90 kHz it does not. With damping that also reaches the high modes (Rayleigh damping on
//! the linear block, 1 % at `ω₁` and `10 ω₁`) the whole state becomes periodic within tens
//! of periods and agrees with the MS-HBM, which converges to it as `H` grows
//! (tests/time_integration.rs).

use serde::{Deserialize, Serialize};

use std::collections::VecDeque;

use crate::error::{Error, Result};
use crate::harmonic::{n_coefficients, Sampling};
use crate::solution::{ContactSeries, DofResponse, FrictionSeries, PeriodicSolution};

use super::periodicity::PeriodRecord;
pub use super::periodicity::Periodicity;
use super::{Integrator, Scheme};

/// Settings of [`simulate_to_steady_state`].
#[derive(Clone, Debug, PartialEq)]
pub struct SteadyStateOptions {
    /// Steps per forcing period `N ≥ 2H + 1` (the integrator's `dt` must be `T/N`).
    pub steps_per_period: usize,
    /// Period limit (at least 2 for [`Periodicity::Response`], which compares whole
    /// periods).
    pub max_periods: usize,
    /// Period-to-period change below which the response repeats
    /// ([`Periodicity::default_tolerance`]: 1e-3 for the response, 1e-6 for the state).
    pub tolerance: f64,
    /// Harmonics `H` of the reported coefficients (default 10); the response criterion
    /// compares these.
    pub harmonics: usize,
    /// Model DOF of the reported response (e.g. the first contact DOF).
    pub response_dof: usize,
    /// What must repeat: the reported response (docs/theory.md (T97)) or the whole state
    /// (T70).
    pub periodicity: Periodicity,
}

/// Result of [`simulate_to_steady_state`]: the last period as a [`PeriodicSolution`]
/// (`method = "time-integration"`, `quadrature = "sampled"`, `samples` = steps per period,
/// `converged` = periodic, `iterations` = periods simulated, `residual_norm` = the last
/// period-to-period change), with the periodicity information alongside (flattened into
/// one JSON object).
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct SteadyState {
    #[serde(flatten)]
    pub solution: PeriodicSolution,
    /// The measure of [`SteadyStateOptions::periodicity`] stayed below the tolerance for two
    /// successive periods.
    pub periodic: bool,
    /// The criterion used (`"response"` or `"state"` in JSON).
    pub periodicity: Periodicity,
    /// The tolerance it was held to.
    pub tolerance: f64,
    /// Period-to-period change over the last period (see the module docs).
    pub period_change: f64,
    /// The measured period-to-period scatter: the largest change of the last two periods
    /// (periodic exactly when it is below the tolerance).
    pub period_scatter: f64,
    pub periods_simulated: usize,
    /// `k ≥ 2` when, at the end of a run that did not become periodic, the response
    /// repeated after `k` periods (twice in a row).
    pub subharmonic: Option<usize>,
    /// Period-to-period change after each period that has a predecessor to compare with:
    /// from the first period on for the state criterion (compared with the initial state),
    /// from the second on for the response criterion.
    pub period_change_history: Vec<f64>,
}

/// How many successive comparisons below the tolerance make a steady state.
const SUCCESSIVE: usize = 2;
/// Largest subharmonic order detected.
const MAX_SUBHARMONIC: usize = 4;

/// Integrate `integrator` (harmonic load at `omega` rad/s, `dt = 2π/(ω N)`, current time a
/// multiple of the period) period by period until the response repeats or `max_periods` are
/// done. A system without load is fine: `omega` then only sets the period. `on_step` is
/// called after every step (e.g. to stream output), `on_period` after every period with
/// `(periods done, change)` (e.g. for progress; the change is `∞` while there is nothing
/// to compare with).
pub fn simulate_to_steady_state(
    integrator: &mut Integrator,
    omega: f64,
    options: &SteadyStateOptions,
    mut on_step: impl FnMut(&Integrator),
    mut on_period: impl FnMut(usize, f64),
) -> Result<SteadyState> {
    let n = options.steps_per_period;
    let h = options.harmonics;
    if h == 0 {
        return Err(Error::argument("harmonics", "must be at least 1"));
    }
    if n < n_coefficients(h) {
        return Err(Error::argument(
            "steps per period",
            format!(
                "{n} steps per period cannot resolve {h} harmonics: need at least 2H+1 = {}",
                n_coefficients(h)
            ),
        ));
    }
    if !(omega.is_finite() && omega > 0.0) {
        return Err(Error::argument(
            "frequency",
            format!("must be positive, got {omega} rad/s"),
        ));
    }
    let period = 2.0 * std::f64::consts::PI / omega;
    if ((integrator.dt() * n as f64) / period - 1.0).abs() > 1e-9 {
        return Err(Error::argument(
            "time step",
            format!(
                "dt = {} is not the period {period} divided by {n} steps",
                integrator.dt()
            ),
        ));
    }
    let phase = integrator.time() / period;
    if (phase - phase.round()).abs() > 1e-6 {
        return Err(Error::argument(
            "initial time",
            format!(
                "t = {} is not a multiple of the period {period}",
                integrator.time()
            ),
        ));
    }
    let min_periods = match options.periodicity {
        Periodicity::Response => 2,
        Periodicity::State => 1,
    };
    if options.max_periods < min_periods {
        return Err(Error::argument(
            "periods",
            format!(
                "must be at least {min_periods} for the {} criterion, got {}",
                options.periodicity.name(),
                options.max_periods
            ),
        ));
    }
    if !(options.tolerance.is_finite() && options.tolerance > 0.0) {
        return Err(Error::argument(
            "tolerance",
            format!("must be positive, got {}", options.tolerance),
        ));
    }
    let system_contacts = integrator.contact_first_dofs();
    let response_system = integrator.system_dof(options.response_dof)?;
    let massive: Vec<usize> = integrator.massive_dofs().to_vec();
    let gap_scale = integrator
        .contact_initial_gaps()
        .iter()
        .fold(0.0f64, |m, g| m.max(g.abs()));
    let sampling = Sampling::new(h, n);
    // with Coulomb friction the stuck contacts' anchors are state too (docs/theory.md (T175))
    let frictions = integrator.contact_frictions();
    let frictional: Vec<usize> = (0..frictions.len())
        .filter(|&c| frictions[c].is_some())
        .collect();
    let state_record = |it: &Integrator| {
        let tangents = it.tangents();
        PeriodRecord::State {
            q: massive
                .iter()
                .map(|&i| it.q()[i])
                .chain(frictional.iter().map(|&c| tangents[c]))
                .collect(),
            v: massive.iter().map(|&i| it.v()[i]).collect(),
        }
    };
    let nc = system_contacts.len();
    let mut tangents = vec![vec![0.0; n]; frictional.len()];
    let mut tangential = vec![vec![0.0; n]; frictional.len()];
    let mut disp = vec![vec![0.0; n]; nc];
    let mut gaps = vec![vec![0.0; n]; nc];
    let mut forces = vec![vec![0.0; n]; nc];
    let mut response = vec![0.0; n];
    // the N displacements over the period, for the redistributed MS-HBM's unknowns (its
    // model: the same redistributed system)
    let unknown_dofs: &[usize] = if integrator.scheme() == Scheme::PositionNewmark {
        integrator.nonlinear_dofs()
    } else {
        &[]
    };
    let unknown_dofs = unknown_dofs.to_vec();
    let mut nonlinear = vec![vec![0.0; n]; unknown_dofs.len()];
    // the records of the last MAX_SUBHARMONIC periods (state: and of the initial state)
    let mut records: VecDeque<PeriodRecord> = VecDeque::with_capacity(MAX_SUBHARMONIC + 1);
    if options.periodicity == Periodicity::State {
        records.push_back(state_record(integrator));
    }
    let mut history = Vec::new();
    let mut below = [0usize; MAX_SUBHARMONIC + 1];
    let mut periodic = false;

    let mut lo = vec![0.0; massive.len()];
    let mut hi = vec![0.0; massive.len()];
    let mut p = 0;
    while p < options.max_periods {
        for (k, &i) in massive.iter().enumerate() {
            lo[k] = integrator.q()[i];
            hi[k] = lo[k];
        }
        for j in 0..n {
            for (c, &(_, dof)) in system_contacts.iter().enumerate() {
                disp[c][j] = integrator.q()[dof];
                gaps[c][j] = integrator.gaps()[c];
                forces[c][j] = integrator.forces()[c];
            }
            response[j] = response_system.map_or(0.0, |d| integrator.q()[d]);
            if !frictional.is_empty() {
                let y = integrator.tangents();
                for (k, &c) in frictional.iter().enumerate() {
                    tangents[k][j] = y[c];
                    tangential[k][j] = integrator.tangential_forces()[c];
                }
            }
            for (series, &dof) in nonlinear.iter_mut().zip(&unknown_dofs) {
                series[j] = integrator.q()[dof];
            }
            integrator.step()?;
            on_step(integrator);
            for (k, &i) in massive.iter().enumerate() {
                let q = integrator.q()[i];
                lo[k] = lo[k].min(q);
                hi[k] = hi[k].max(q);
            }
        }
        p += 1;
        let amplitude = lo
            .iter()
            .zip(&hi)
            .fold(0.0f64, |m, (a, b)| m.max(0.5 * (b - a)));
        let now = match options.periodicity {
            Periodicity::State => state_record(integrator),
            Periodicity::Response => {
                // the reported DOFs: every contact's first DOF and the response DOF, and the
                // tangential coordinates of the frictional contacts (T175)
                let reported = disp
                    .iter()
                    .chain(response_system.map(|_| &response))
                    .chain(&tangents)
                    .map(Vec::as_slice);
                let mut coefficients = Vec::with_capacity(nc + 1);
                let mut magnitude = 0.0f64;
                for series in reported {
                    coefficients.push(sampling.dft(series));
                    magnitude = series.iter().fold(magnitude, |m, q| m.max(q.abs()));
                }
                PeriodRecord::Response {
                    coefficients,
                    magnitude,
                }
            }
        };
        let mut changes = [f64::INFINITY; MAX_SUBHARMONIC + 1];
        for (k, change) in changes.iter_mut().enumerate().skip(1) {
            if let Some(old) = records.len().checked_sub(k).map(|i| &records[i]) {
                *change = now.change_from(old, omega, amplitude, gap_scale);
            }
        }
        let change = changes[1];
        if !records.is_empty() {
            history.push(change);
        }
        on_period(p, change);
        records.push_back(now);
        if records.len() > MAX_SUBHARMONIC {
            records.pop_front();
        }
        for k in 1..=MAX_SUBHARMONIC {
            below[k] = if changes[k] < options.tolerance {
                below[k] + 1
            } else {
                0
            };
        }
        if below[1] >= SUCCESSIVE {
            periodic = true;
            break;
        }
    }
    let subharmonic = if periodic {
        None
    } else {
        (2..=MAX_SUBHARMONIC).find(|&k| below[k] >= SUCCESSIVE)
    };
    let dt = integrator.dt();
    let time_s: Vec<f64> = (0..n).map(|j| j as f64 * dt).collect();
    let extremes = |v: &[f64]| -> (f64, f64) {
        v.iter()
            .fold((f64::NEG_INFINITY, f64::INFINITY), |(mx, mn), &x| {
                (mx.max(x), mn.min(x))
            })
    };
    let contacts: Vec<ContactSeries> = (0..nc)
        .map(|c| {
            let (max, min) = extremes(&disp[c]);
            ContactSeries {
                dof: system_contacts[c].0,
                coefficients: sampling.dft(&disp[c]),
                displacement: disp[c].clone(),
                gap: gaps[c].clone(),
                force: forces[c].clone(),
                max,
                min,
            }
        })
        .collect();
    let (rmax, rmin) = extremes(&response);
    let change = history.last().copied().unwrap_or(f64::INFINITY);
    let scatter = history
        .iter()
        .rev()
        .take(SUCCESSIVE)
        .fold(0.0f64, |m, &c| m.max(c));
    // the redistributed MS-HBM's unknowns (the contacts' displacements Wᵀ q = g − g0,
    // docs/theory.md (T128)) and the harmonics of every contact-node DOF (eq. 31),
    // harmonic-major
    let (contact_displacements, contact_node_harmonics) = if unknown_dofs.is_empty() {
        (None, None)
    } else {
        let harmonic_major = |series: &[Vec<f64>]| -> Vec<f64> {
            let coefficients: Vec<Vec<f64>> = series.iter().map(|s| sampling.dft(s)).collect();
            let count = coefficients.len();
            let mut x = vec![0.0; count * (2 * h + 1)];
            for (i, c) in coefficients.iter().enumerate() {
                for (m, v) in c.iter().enumerate() {
                    x[m * count + i] = *v;
                }
            }
            x
        };
        let g0 = integrator.contact_initial_gaps();
        let displacements: Vec<Vec<f64>> = gaps
            .iter()
            .zip(g0)
            .map(|(g, g0)| g.iter().map(|g| g - g0).collect())
            .collect();
        (
            Some(harmonic_major(&displacements)),
            Some(harmonic_major(&nonlinear)),
        )
    };
    Ok(SteadyState {
        solution: PeriodicSolution {
            frequency_hz: omega / (2.0 * std::f64::consts::PI),
            harmonics: h,
            samples: n,
            quadrature: crate::harmonic::Quadrature::Sampled,
            method: crate::solution::MethodKind::TimeIntegration,
            converged: periodic,
            iterations: p,
            residual_norm: change,
            time_s,
            contact_dofs: system_contacts.iter().map(|c| c.0).collect(),
            contacts,
            frictions: frictional
                .iter()
                .enumerate()
                .map(|(k, &c)| {
                    let (mu, dof) = frictions[c].expect("a frictional contact");
                    let force = tangential[k].clone();
                    let limit: Vec<f64> = forces[c].iter().map(|l| mu * l).collect();
                    // the state of each step from its forces: no normal force, on the
                    // cone, inside it
                    let state = forces[c]
                        .iter()
                        .zip(force.iter().zip(&limit))
                        .map(|(&normal, (&t, &l))| {
                            if normal <= 0.0 {
                                crate::solution::ContactState::Open
                            } else if t.abs() >= l * (1.0 - 1e-9) {
                                crate::solution::ContactState::Slip
                            } else {
                                crate::solution::ContactState::Stick
                            }
                        })
                        .collect();
                    FrictionSeries {
                        force2: Vec::new(),
                        dof,
                        max: force.iter().copied().fold(f64::NEG_INFINITY, f64::max),
                        min: force.iter().copied().fold(f64::INFINITY, f64::min),
                        limit,
                        force,
                        state,
                    }
                })
                .collect(),
            response: DofResponse {
                dof: options.response_dof,
                coefficients: sampling.dft(&response),
                max: rmax,
                min: rmin,
            },
            stability: None,
            stability_unknown: None,
            unknowns: contact_displacements,
            contact_node_harmonics,
            dissipated_energy: None,
            state_fractions: None,
        },
        periodic,
        periodicity: options.periodicity,
        tolerance: options.tolerance,
        period_change: change,
        period_scatter: scatter,
        periods_simulated: p,
        subharmonic,
        period_change_history: history,
    })
}
