//! The march over one period from event to event ([`integrate`]): scanning for impacts and
//! releases, locating them, the critical time's event, the samples and the saltation
//! matrices (docs/theory.md (T143)–(T147)).

use std::cell::RefCell;

use faer::{c64, Mat};

use super::super::set_flow::DenseSubsystem;
use super::{jump_sensitivity, phases, Before, CriticalState, EventPeriod, EventProblem};
use super::{Integration, Interval, Scratch, MAX_EVENTS, MAX_SCAN_STEPS};
use crate::dense::mat_vec;
use crate::error::{Error, Result};
use crate::harmonic::{golden_section_argmax, n_coefficients};
use crate::roots::find_sign_change;

/// Integrate one period (see the module docs) from `(q0, v0)` at `θ = 0`.
pub(in crate::method::general) fn integrate(
    pb: &EventProblem,
    q0: &[f64],
    v0: &[f64],
) -> Result<EventPeriod> {
    let sub = pb.sub;
    let n = sub.n();
    let n_contacts = sub.n_contacts();
    let nq = n * n_coefficients(pb.harmonics);
    // p = (φ, q_0, q̇_0[, θ_c])
    let n_params = nq + 2 * n + usize::from(pb.critical.is_some());
    let period = 2.0 * std::f64::consts::PI / pb.omega;
    let finite = |v: &[f64]| v.iter().all(|x| x.is_finite());
    let usable = period.is_finite()
        && period > 0.0
        && pb.duration.is_finite()
        && pb.sample_offset.is_finite()
        && finite(q0)
        && finite(v0)
        && finite(pb.load)
        && pb.critical.is_none_or(|c| c.time.is_finite());
    if !usable {
        return Err(Error::Numerical(format!(
            "the event-driven period got a value that is not a number (frequency {} rad/s, duration {}, start state finite: {}, load finite: {})",
            pb.omega,
            pb.duration,
            finite(q0) && finite(v0),
            finite(pb.load)
        )));
    }
    let h = period / pb.steps as f64;
    let mut it = Integration {
        pb,
        n,
        n_params,
        sets: vec![],
        e: vec![c64::new(1.0, 0.0); pb.harmonics + 1],
        scratch: RefCell::new(Scratch {
            q: vec![0.0; n],
            v: vec![0.0; n],
            f: vec![0.0; n],
            r: vec![0.0; n],
            ..Default::default()
        }),
    };
    // the initial state: penetrating contacts are projected onto their gaps and their
    // normal velocities removed (only away from solutions: the section is where the gaps
    // are largest)
    let (mut q, mut v) = (q0.to_vec(), v0.to_vec());
    let mut sens = Mat::<f64>::zeros(2 * n, n_params);
    for i in 0..2 * n {
        sens[(i, nq + i)] = 1.0;
    }
    // touching: penetrating, or within the tolerance and not separating (after the
    // section's impact)
    let penetrating: Vec<usize> = (0..n_contacts)
        .filter(|&c| {
            let g = sub.gap(c, &q);
            g < 0.0 || (g <= pb.gap_tolerance && sub.normal_velocity(c, &v) <= 0.0)
        })
        .collect();
    it.at(0.0);
    let first = if penetrating.is_empty() {
        it.set_index(&[])?
    } else {
        let p = sub.impact_projector(&penetrating)?;
        let w = Mat::<f64>::from_fn(n, penetrating.len(), |i, j| {
            sub.normals[(i, penetrating[j])]
        });
        // q ← q − M⁻¹W (WᵀM⁻¹W)⁻¹ g(q): (I − Π) applied to the point that closes the gaps
        let g = Mat::<f64>::from_fn(penetrating.len(), 1, |i, _| sub.gap(penetrating[i], &q));
        let wtw = w.transpose() * &w;
        let lift = &w * faer::linalg::solvers::Solve::solve(&wtw.partial_piv_lu(), &g);
        let shift = (Mat::<f64>::identity(n, n) - &p) * &lift;
        for i in 0..n {
            q[i] -= shift[(i, 0)];
        }
        v = mat_vec(&p, &v);
        let block = Mat::<f64>::from_fn(2 * n, 2 * n, |i, j| {
            if (i < n) == (j < n) {
                p[(i % n, j % n)]
            } else {
                0.0
            }
        });
        sens = &block * &sens;
        it.settle(penetrating, &q, &v)?.0
    };
    let mut armed: Vec<bool> = (0..n_contacts)
        .map(|c| sub.gap(c, &q) > pb.gap_tolerance)
        .collect();
    let mut iv = it.start(first, 0.0, &q, &v, &sens);
    let mut out = EventPeriod {
        samples: Vec::with_capacity(pb.steps * n),
        gaps: Vec::with_capacity(pb.steps * n_contacts),
        forces: Vec::with_capacity(pb.steps * n_contacts),
        end_q: vec![],
        end_v: vec![],
        sample_sensitivity: pb
            .sensitivities
            .then(|| Mat::<f64>::zeros(pb.steps * n, n_params)),
        end_sensitivity: None,
        events: 0,
        critical: None,
        first_impact: None,
    };
    let mut theta = 0.0;
    let mut next_sample = 0usize;
    let sample_time = |j: usize| pb.sample_offset + j as f64 * h;
    let (mut values, mut rates) = (
        Vec::with_capacity(n_contacts),
        Vec::with_capacity(n_contacts),
    );
    let (mut after, mut after_rates) = (
        Vec::with_capacity(n_contacts),
        Vec::with_capacity(n_contacts),
    );
    it.monitors_into(&iv, theta, &mut values, &mut rates);
    let mut step = it.scan_step(iv.set);
    // the phases of the root finders' probes (one buffer for the whole period)
    let mut probe = vec![c64::new(0.0, 0.0); pb.harmonics + 1];
    // contact 0 around the critical time (docs/theory.md (T147)): held (its impacts not
    // located) from the window's start to θ_c, and after θ_c until its gap is positive
    let mut critical_pending = pb.critical.filter(|c| c.time <= pb.duration);
    let mut held_after = false;
    // where an unarmed contact's gap peaks above the arming level within the current step
    let mut armed_at: Vec<Option<f64>> = vec![None; n_contacts];
    let mut scan_steps = 0usize;
    loop {
        if next_sample < pb.steps && sample_time(next_sample) <= theta {
            it.at(theta);
            record(&it, &iv, theta, next_sample, &mut out);
            next_sample += 1;
            continue;
        }
        if let Some(critical) = critical_pending.filter(|c| theta >= c.time) {
            critical_pending = None;
            held_after = true;
            armed[0] = false;
            iv = critical_event(&mut it, iv, critical.time, &mut armed, &mut out)?;
            it.monitors_into(&iv, theta, &mut values, &mut rates);
            step = it.scan_step(iv.set);
            continue;
        }
        if theta >= pb.duration {
            break;
        }
        scan_steps += 1;
        if scan_steps > MAX_SCAN_STEPS {
            return Err(Error::Numerical(format!(
                "more than {MAX_SCAN_STEPS} scan steps in one period at {} rad/s: the period is too long for the fastest mode of the nonlinear subsystem",
                pb.omega
            )));
        }
        let mut target = (theta + step).min(pb.duration);
        if next_sample < pb.steps {
            target = target.min(sample_time(next_sample));
        }
        let mut held_before = false;
        if let Some(critical) = critical_pending {
            let window_start = (critical.time - critical.window).max(0.0);
            if theta < window_start {
                target = target.min(window_start);
            } else {
                target = target.min(critical.time);
                held_before = true;
            }
        }
        it.at(target);
        it.monitors_into(&iv, target, &mut after, &mut after_rates);
        // a gap that is not finite (a flow that overflowed) cannot be scanned for its
        // events: the root finders need a sign at both ends (a NaN panicked there)
        if let Some(c) =
            (0..n_contacts).find(|&c| !(after[c].is_finite() && after_rates[c].is_finite()))
        {
            return Err(Error::Numerical(format!(
                "the gap of contact {c} is not finite at {target:e} rad within the period at {} rad/s: the flow of the nonlinear subsystem overflowed (an indefinite stiffness, or a period far too long for its fastest mode)",
                pb.omega
            )));
        }
        // the earliest contact whose event function crosses zero in (θ, target]
        let mut first: Option<(f64, usize)> = None;
        let mut e = std::mem::take(&mut probe);
        armed_at.iter_mut().for_each(|a| *a = None);
        for c in 0..n_contacts {
            let is_closed = it.sets[iv.set].flow.closed.contains(&c);
            if c == 0 && !is_closed && held_before {
                continue;
            }
            let held = c == 0 && !is_closed && held_after;
            let mut shift = if is_closed || (armed[c] && !held) {
                0.0
            } else {
                pb.gap_tolerance
            };
            let mut from = (theta, values[c], rates[c]);
            if shift > 0.0
                && after[c] <= pb.gap_tolerance
                && after_rates[c] < 0.0
                && (rates[c] > 0.0 || theta == iv.start)
            {
                // a contact not armed (after a release or contact 0's critical time) whose
                // gap turns back within the step (or the step right after its event, where
                // its rate is zero) and ends below the arming level: where its gap peaks
                // above that level, it is armed from its peak on, so that a re-impact in
                // the step is located wherever the step ends fall
                let (peak, gap) = golden_section_argmax(
                    |t| {
                        phases(pb.omega, t, &mut e);
                        it.monitor_with(&e, &iv, t, c)
                    },
                    theta,
                    target,
                );
                if gap > pb.gap_tolerance {
                    from = (peak, gap, 0.0);
                    shift = 0.0;
                    armed_at[c] = Some(peak);
                } else if held {
                    continue;
                }
            } else if held {
                continue;
            }
            // where the gap stays positive at both ends but turns within the scan step, it
            // may dip below zero in between (near grazing): look at its minimum
            let mut end = (target, after[c] + shift);
            if end.1 >= 0.0 && !is_closed && from.2 < 0.0 && after_rates[c] > 0.0 {
                let rate = |t: f64| {
                    phases(pb.omega, t, &mut e);
                    it.gap_rate_with(&e, &iv, t, c)
                };
                let turn = find_sign_change(rate, from.0, target, from.2, after_rates[c]).negative;
                phases(pb.omega, turn, &mut e);
                end = (turn, it.monitor_with(&e, &iv, turn, c) + shift);
            }
            if end.1 >= 0.0 {
                continue;
            }
            let f = |t: f64| {
                phases(pb.omega, t, &mut e);
                it.monitor_with(&e, &iv, t, c) + shift
            };
            let left = (from.1 + shift).max(0.0);
            let root = find_sign_change(f, from.0, end.0, left, end.1).non_negative;
            if first.is_none_or(|(t, _)| root < t) {
                first = Some((root, c));
            }
        }
        probe = e;
        // contacts armed at a peak before the next event (or the step's end)
        let until = first.map_or(target, |(t, _)| t);
        for (k, at) in armed_at.iter().enumerate() {
            if at.is_some_and(|t| t <= until) {
                armed[k] = true;
                if k == 0 {
                    held_after = false;
                }
            }
        }
        let Some((te, c)) = first else {
            for k in 0..n_contacts {
                if after[k] > pb.gap_tolerance {
                    armed[k] = true;
                }
            }
            if after[0] > pb.gap_tolerance && !it.sets[iv.set].flow.closed.contains(&0) {
                held_after = false;
            }
            theta = target;
            std::mem::swap(&mut values, &mut after);
            std::mem::swap(&mut rates, &mut after_rates);
            continue;
        };
        // the event at θ_e
        let closed = it.sets[iv.set].flow.closed.clone();
        out.events += 1;
        if c == 0 && !closed.contains(&0) && out.first_impact.is_none() {
            out.first_impact = Some(te);
        }
        if out.events > MAX_EVENTS {
            return Err(Error::Numerical(format!(
                "more than {MAX_EVENTS} impacts and releases in one period: the impacts accumulate (chatter); use Moreau–Jean time stepping (events = false)"
            )));
        }
        let Before {
            q: qe,
            v: ve,
            sensitivity: sens_before,
            load: f,
            acceleration: accel_before,
        } = it.before_event(&iv, te);
        let (set, v_after, jump) = if closed.contains(&c) {
            // release: no jump, equal vector fields
            let set: Vec<usize> = closed.iter().copied().filter(|&k| k != c).collect();
            armed[c] = false;
            (it.set_index(&set)?, ve.clone(), None)
        } else {
            let (i, p) = it.impact(iv.set, &closed, c, (&qe, &ve), &mut armed)?;
            (i, mat_vec(&p, &ve), Some(p))
        };
        let sens_after = match (&jump, pb.sensitivities) {
            (Some(p), true) => {
                let accel_after = it.sets[set]
                    .flow
                    .acceleration(&sub.unbalanced_force(&f, &qe, &v_after));
                saltation(
                    sub,
                    c,
                    p,
                    &sens_before,
                    (&ve, &accel_before),
                    (&v_after, &accel_after),
                )
            }
            (None, true) => sens_before,
            _ => Mat::<f64>::zeros(0, 0),
        };
        iv = it.start(set, te, &qe, &v_after, &sens_after);
        theta = te;
        it.monitors_into(&iv, te, &mut values, &mut rates);
        step = it.scan_step(iv.set);
    }
    it.at(pb.duration);
    let (q, v) = it.state(&iv, pb.duration);
    out.end_q = q;
    out.end_v = v;
    if pb.sensitivities {
        out.end_sensitivity = Some(it.sensitivity(&iv, pb.duration));
    }
    Ok(out)
}

/// The critical time's event at `θ_c` (docs/theory.md (T147)): contact 0's gap and normal
/// velocity are recorded with their sensitivities, and Newton's impact law is applied to it
/// whatever its gap: with `e_N = 0` the plastic impact map of the closed set with contact 0
/// added, after which contacts whose force would pull are released (contact 0 among them
/// where it is not pressed on), with `e_N > 0` its normal velocity reversed and scaled.
/// The sensitivity jumps by `J` and, in the `θ_c` column, by `J f⁻ − f⁺` (the jump time
/// moves with `θ_c`). Returns the interval that starts at `θ_c`.
fn critical_event<'a>(
    it: &mut Integration<'a>,
    iv: Interval,
    tc: f64,
    armed: &mut [bool],
    out: &mut EventPeriod,
) -> Result<Interval> {
    let pb = it.pb;
    let sub = pb.sub;
    let n = it.n;
    let last = it.n_params - 1;
    let Before {
        q: qe,
        v: ve,
        sensitivity: sens_before,
        load: f,
        acceleration: accel_before,
    } = it.before_event(&iv, tc);
    let closed = it.sets[iv.set].flow.closed.clone();
    let normal_row = |offset: usize, j: usize| -> f64 {
        (0..n)
            .map(|i| sub.normals[(i, 0)] * sens_before[(offset + i, j)])
            .sum()
    };
    let (gap, rate) = (sub.gap(0, &qe), sub.normal_velocity(0, &ve));
    let (mut gap_sensitivity, mut rate_sensitivity) = (vec![], vec![]);
    if pb.sensitivities {
        gap_sensitivity = (0..it.n_params).map(|j| normal_row(0, j)).collect();
        rate_sensitivity = (0..it.n_params).map(|j| normal_row(n, j)).collect();
        gap_sensitivity[last] = rate;
        rate_sensitivity[last] = sub.normal_velocity(0, &accel_before);
    }
    out.critical = Some(CriticalState {
        gap,
        rate,
        gap_sensitivity,
        rate_sensitivity,
    });
    if closed.contains(&0) {
        return Ok(iv);
    }
    let (index, p) = it.impact(iv.set, &closed, 0, (&qe, &ve), armed)?;
    let va = mat_vec(&p, &ve);
    let sens_after = if pb.sensitivities {
        let accel_after = it.sets[index]
            .flow
            .acceleration(&sub.unbalanced_force(&f, &qe, &va));
        let pa = mat_vec(&p, &accel_before);
        let mut s = jump_sensitivity(&p, &sens_before);
        for i in 0..n {
            s[(i, last)] += ve[i] - va[i];
            s[(n + i, last)] += pa[i] - accel_after[i];
        }
        s
    } else {
        Mat::<f64>::zeros(0, 0)
    };
    Ok(it.start(index, tc, &qe, &va, &sens_after))
}

/// Record sample `j` at `θ` (phases already at `θ`).
fn record(it: &Integration, iv: &Interval, theta: f64, j: usize, out: &mut EventPeriod) {
    let (q, v) = it.state(iv, theta);
    let sub = it.pb.sub;
    let flow = &it.sets[iv.set].flow;
    let forces = if flow.closed.is_empty() {
        vec![]
    } else {
        flow.contact_forces(&sub.unbalanced_force(&it.load(), &q, &v))
    };
    for c in 0..sub.n_contacts() {
        out.gaps.push(sub.gap(c, &q));
        out.forces.push(
            flow.closed
                .iter()
                .position(|&k| k == c)
                .map_or(0.0, |r| forces[r]),
        );
    }
    out.samples.extend_from_slice(&q);
    if let Some(s) = out.sample_sensitivity.as_mut() {
        it.position_sensitivity_into(iv, theta, s, j * it.n);
    }
}

/// The saltation matrix of an impact on contact `c` (docs/theory.md (T145)) applied to the
/// sensitivity before it: `S⁺ = J S⁻ + (f⁺ − J f⁻) (∇g_c S⁻)/(∇g_c f⁻)`, with the jump
/// `J = diag(I, P)` (`P` the velocity map of the impact) and `f = (q̇, q̈)` the vector
/// fields before and after.
fn saltation(
    sub: &DenseSubsystem,
    c: usize,
    p: &Mat<f64>,
    before: &Mat<f64>,
    (v0, a0): (&[f64], &[f64]),
    (v1, a1): (&[f64], &[f64]),
) -> Mat<f64> {
    let n = sub.n();
    let cols = before.ncols();
    let mut after = jump_sensitivity(p, before);
    let rate = sub.normal_velocity(c, v0);
    if rate == 0.0 {
        return after;
    }
    let pa0 = mat_vec(p, a0);
    // f⁺ − J f⁻ = (v⁺ − v⁻, a⁺ − P a⁻)
    let jump: Vec<f64> = (0..n)
        .map(|i| v1[i] - v0[i])
        .chain((0..n).map(|i| a1[i] - pa0[i]))
        .collect();
    for j in 0..cols {
        let dg = (0..n)
            .map(|i| sub.normals[(i, c)] * before[(i, j)])
            .sum::<f64>()
            / rate;
        for (i, d) in jump.iter().enumerate() {
            after[(i, j)] += d * dg;
        }
    }
    after
}
