//! Tests of the frictional contact law against independent references: the closed-form
//! hysteresis loop of a Jenkins element, the frictionless LCP, an incremental (catching-up)
//! march of the same quasi-static law by enumeration of every mode, and central
//! differences of the derivative.

use std::f64::consts::PI;

use faer::prelude::Solve;

use super::*;
use crate::harmonic::basis;

/// Gauss–Legendre nodes and weights on [−1, 1] (20 points), by Newton on P_20.
fn gauss_legendre(order: usize) -> Vec<(f64, f64)> {
    (1..=order)
        .map(|i| {
            let mut x = (PI * (i as f64 - 0.25) / (order as f64 + 0.5)).cos();
            let mut dp = 0.0;
            for _ in 0..100 {
                let (mut p0, mut p1) = (1.0, x);
                for k in 2..=order {
                    let p2 = ((2 * k - 1) as f64 * x * p1 - (k - 1) as f64 * p0) / k as f64;
                    p0 = p1;
                    p1 = p2;
                }
                dp = order as f64 * (x * p1 - p0) / (x * x - 1.0);
                let dx = p1 / dp;
                x -= dx;
                if dx.abs() < 1e-16 {
                    break;
                }
            }
            (x, 2.0 / ((1.0 - x * x) * dp * dp))
        })
        .collect()
}

/// Fourier coefficients (T9) of a function smooth between the given breakpoints.
fn fourier_by_pieces(f: impl Fn(f64) -> f64, breaks: &[f64], harmonics: usize) -> Vec<f64> {
    let rule = gauss_legendre(20);
    let ncoef = n_coefficients(harmonics);
    let mut out = vec![0.0; ncoef];
    for w in breaks.windows(2) {
        let (a, b) = (w[0], w[1]);
        // each piece in 8 sub-pieces, 20 points each: exact to round-off for these smooth pieces
        for s in 0..8 {
            let (lo, hi) = (
                a + (b - a) * s as f64 / 8.0,
                a + (b - a) * (s + 1) as f64 / 8.0,
            );
            for &(x, wt) in &rule {
                let t = 0.5 * (lo + hi) + 0.5 * (hi - lo) * x;
                let bt = basis(harmonics, t);
                let v = f(t) * wt * 0.5 * (hi - lo);
                for m in 0..ncoef {
                    out[m] += crate::harmonic::weight(m) / (2.0 * PI) * v * bt[m];
                }
            }
        }
    }
    out
}

/// The Jenkins element's force `k (x − s)` under `x = A cos τ` in its periodic state, with
/// slip force `fs < kA` (Masing loop): stick from the reversal at `τ = 0` until the force
/// reaches `−fs` at `cos τ₁ = 1 − 2 fs/(kA)`, slip until `π`, and the mirror image.
fn jenkins_force(k: f64, amplitude: f64, fs: f64, tau: f64) -> f64 {
    let tau1 = (1.0 - 2.0 * fs / (k * amplitude)).acos();
    let t = tau.rem_euclid(2.0 * PI);
    if t <= tau1 {
        fs + k * amplitude * (t.cos() - 1.0)
    } else if t <= PI {
        -fs
    } else if t <= PI + tau1 {
        -fs + k * amplitude * (t.cos() + 1.0)
    } else {
        fs
    }
}

fn single_contact(kn: f64, kt: f64, mu: f64) -> FrictionalContacts {
    FrictionalContacts::new(vec![1.0 / kn, 0.0, 0.0, 1.0 / kt], vec![mu]).unwrap()
}

/// Free gap of one contact: normal `−preload/kn` (closed with the preload), tangent `A cos τ`.
fn jenkins_gamma(harmonics: usize, kn: f64, preload: f64, amplitude: f64) -> Vec<f64> {
    let m = 2;
    let mut g = vec![0.0; m * n_coefficients(harmonics)];
    g[0] = -preload / kn;
    g[m + 1] = amplitude;
    g
}

#[test]
fn the_jenkins_elements_closed_form_hysteresis_loop_is_matched() {
    let (kn, kt, mu, preload, amplitude) = (50.0, 3.0, 0.3, 2.0, 0.7);
    let fs = mu * preload;
    assert!(kt * amplitude > fs);
    for harmonics in [1, 3, 7] {
        let law = single_contact(kn, kt, mu);
        let gamma = jenkins_gamma(harmonics, kn, preload, amplitude);
        let p = law.periodic(harmonics, &gamma, 64).unwrap();
        // samples: λ_T = −(Jenkins force), λ_N = preload
        for j in 0..997 {
            let tau = 2.0 * PI * j as f64 / 997.0;
            let lam = p.force_at(tau);
            assert!(
                (lam[0] - preload).abs() <= 1e-12 * preload,
                "λ_N {}",
                lam[0]
            );
            let reference = -jenkins_force(kt, amplitude, fs, tau);
            assert!(
                (lam[1] - reference).abs() <= 1e-10 * fs,
                "H = {harmonics}, τ = {tau}: λ_T {} against {reference}",
                lam[1]
            );
        }
        // Fourier coefficients against Gauss–Legendre on the closed form's pieces
        let tau1 = (1.0 - 2.0 * fs / (kt * amplitude)).acos();
        let reference = fourier_by_pieces(
            |t| -jenkins_force(kt, amplitude, fs, t),
            &[0.0, tau1, PI, PI + tau1, 2.0 * PI],
            harmonics,
        );
        for (m, r) in reference.iter().enumerate() {
            let got = p.forces[2 * m + 1];
            assert!(
                (got - r).abs() <= 1e-10 * fs,
                "H = {harmonics}, coefficient {m}: {got} against {r}"
            );
        }
        // the first harmonic's closed form (the equivalent stiffness and damping of the loop)
        let (c1, s1) = (
            -(kt * amplitude / PI) * (tau1 - 0.5 * (2.0 * tau1).sin()),
            (4.0 * fs / PI) * (1.0 - fs / (kt * amplitude)),
        );
        assert!(
            (p.forces[2 + 1] - c1).abs() <= 1e-10 * fs,
            "{} {c1}",
            p.forces[3]
        );
        assert!(
            (p.forces[4 + 1] - s1).abs() <= 1e-10 * fs,
            "{} {s1}",
            p.forces[5]
        );
        // the loop's area and the share of the period in stick (T180)–(T181)
        let area = 4.0 * fs * (amplitude - fs / kt);
        let energy = p.dissipated_energy();
        assert!(
            (energy - area).abs() <= 1e-10 * area,
            "H = {harmonics}: energy {energy} against the loop's area {area}"
        );
        let f = p.state_fractions()[0];
        assert!((f.stick - tau1 / PI).abs() <= 1e-10, "{f:?}");
        assert!((f.slip - (1.0 - tau1 / PI)).abs() <= 1e-10, "{f:?}");
        assert_eq!(f.open, 0.0);
    }
}

#[test]
fn a_contact_stuck_all_period_carries_no_mean_tangential_force() {
    let (kn, kt, mu, preload, amplitude) = (50.0, 3.0, 0.3, 2.0, 0.05);
    assert!(kt * amplitude < mu * preload);
    let law = single_contact(kn, kt, mu);
    let mut gamma = jenkins_gamma(3, kn, preload, amplitude);
    gamma[1] = 0.4; // a mean tangential free displacement: the anchor follows it (T157)
    let p = law.periodic(3, &gamma, 32).unwrap();
    assert_eq!(p.phases.len(), 1);
    assert_eq!(p.phases[0].modes, vec![Mode::Stick]);
    for (m, &f) in p.forces.iter().enumerate() {
        let expected = match m {
            0 => preload,
            3 => -kt * amplitude,
            _ => 0.0,
        };
        assert!((f - expected).abs() <= 1e-13, "coefficient {m}: {f}");
    }
}

/// A coupled interface of three contacts (SPD Delassus matrix with normal–tangential
/// coupling) whose free gap opens, closes, sticks and slips them.
fn coupled() -> (FrictionalContacts, Vec<f64>, usize) {
    let n = 3;
    let m = 2 * n;
    // D = B Bᵀ + diag, B fixed pseudo-random, small off-diagonals
    let bmat = [
        [0.9, 0.1, -0.05, 0.02, 0.1, 0.0],
        [0.1, 1.1, 0.1, 0.0, -0.03, 0.05],
        [-0.05, 0.1, 0.8, 0.04, 0.0, 0.1],
        [0.02, 0.0, 0.04, 0.7, 0.1, -0.02],
        [0.1, -0.03, 0.0, 0.1, 0.6, 0.05],
        [0.0, 0.05, 0.1, -0.02, 0.05, 0.75],
    ];
    let mut d = vec![0.0; m * m];
    for i in 0..m {
        for j in 0..m {
            d[i * m + j] = (0..m).map(|k| bmat[i][k] * bmat[j][k]).sum::<f64>()
                + if i == j { 0.2 } else { 0.0 };
        }
    }
    let law = FrictionalContacts::new(d, vec![0.3, 0.5, 0.2]).unwrap();
    let h = 3;
    let mut gamma = vec![0.0; m * n_coefficients(h)];
    // normals: mean closing, first harmonic lifts some off; tangents: sway of various phases
    let means = [-0.3, -0.5, 0.1, 0.05, -0.1, 0.2];
    let cos1 = [0.6, 0.3, 0.5, 1.2, 0.9, -0.7];
    let sin1 = [0.2, -0.2, 0.4, 0.3, -0.6, 0.5];
    let cos2 = [0.05, 0.1, -0.1, 0.2, 0.1, 0.15];
    let sin3 = [0.0, 0.05, 0.02, -0.1, 0.05, 0.1];
    for r in 0..m {
        gamma[r] = means[r];
        gamma[m + r] = cos1[r];
        gamma[2 * m + r] = sin1[r];
        gamma[3 * m + r] = cos2[r];
        gamma[6 * m + r] = sin3[r];
    }
    (law, gamma, h)
}

#[test]
fn the_coupled_interface_visits_every_mode() {
    let (law, gamma, h) = coupled();
    let p = law.periodic(h, &gamma, 64).unwrap();
    let seen = |mode: Mode| p.phases.iter().any(|ph| ph.modes.contains(&mode));
    for mode in [
        Mode::Open,
        Mode::Stick,
        Mode::SlipPositive,
        Mode::SlipNegative,
    ] {
        assert!(
            seen(mode),
            "{mode:?} never occurs: {:?}",
            p.phases.iter().map(|p| &p.modes).collect::<Vec<_>>()
        );
    }
    // no penetration, forces in the cone, at every sample
    let n = 3;
    for j in 0..2000 {
        let tau = 2.0 * PI * j as f64 / 2000.0;
        let lam = p.force_at(tau);
        let b = basis(h, tau);
        let m = 2 * n;
        for c in 0..n {
            let gamma_c: f64 = (0..b.len()).map(|k| b[k] * gamma[k * m + c]).sum();
            let gap = gamma_c + (0..m).map(|r| law.d(c, r) * lam[r]).sum::<f64>();
            assert!(gap >= -1e-12, "penetration {gap} at τ = {tau}, contact {c}");
            assert!(
                lam[c] >= -1e-12,
                "negative normal force {} at τ = {tau}",
                lam[c]
            );
            assert!(
                lam[n + c].abs() <= law.mu[c] * lam[c] + 1e-12,
                "outside the cone at τ = {tau}"
            );
        }
    }
}

/// One step of [`catching_up`]: the forces, the coordinates `y` and the mode of each contact
/// (0 open, 1 stick, 2 and 3 slip).
struct CatchingUpStep {
    forces: Vec<f64>,
    y: Vec<f64>,
    modes: Vec<usize>,
}

/// The same quasi-static law marched on a fine grid by the catching-up scheme: at each step
/// the forces and displacements `y = γ + Dλ` of the mode combination (of all 4ⁿ) whose
/// conditions hold, stick meaning `y_T` kept from the previous step and slip a direction of
/// its increment. First-order accurate, sharing no code with the event-driven march.
fn catching_up(
    law: &FrictionalContacts,
    harmonics: usize,
    gamma: &[f64],
    steps: usize,
    periods: usize,
) -> Vec<CatchingUpStep> {
    let n = law.n;
    let m = 2 * n;
    let ncoef = n_coefficients(harmonics);
    let gamma_at = |tau: f64| -> Vec<f64> {
        let b = basis(harmonics, tau);
        (0..m)
            .map(|r| (0..ncoef).map(|k| b[k] * gamma[k * m + r]).sum())
            .collect()
    };
    let mut y_prev: Vec<f64> = gamma_at(0.0);
    let mut out = Vec::new();
    for step in 0..=steps * periods {
        let tau = 2.0 * PI * step as f64 / steps as f64;
        let g = gamma_at(tau);
        let mut found = None;
        'combos: for code in 0..4usize.pow(n as u32) {
            let modes: Vec<usize> = (0..n).map(|c| (code / 4usize.pow(c as u32)) % 4).collect();
            // unknowns [λ (m); y (m)]: y − Dλ = γ, and two conditions per contact
            let size = 2 * m;
            let mut a = Mat::<f64>::zeros(size, size);
            let mut rhs = Mat::<f64>::zeros(size, 1);
            for i in 0..m {
                a[(i, m + i)] = 1.0;
                for k in 0..m {
                    a[(i, k)] = -law.d(i, k);
                }
                rhs[(i, 0)] = g[i];
            }
            for c in 0..n {
                let (r1, r2) = (m + 2 * c, m + 2 * c + 1);
                match modes[c] {
                    0 => {
                        a[(r1, c)] = 1.0;
                        a[(r2, n + c)] = 1.0;
                    }
                    1 => {
                        a[(r1, m + c)] = 1.0;
                        a[(r2, m + n + c)] = 1.0;
                        rhs[(r2, 0)] = y_prev[n + c];
                    }
                    s => {
                        let sign = if s == 2 { 1.0 } else { -1.0 };
                        a[(r1, m + c)] = 1.0;
                        a[(r2, n + c)] = 1.0;
                        a[(r2, c)] = sign * law.mu[c];
                    }
                }
            }
            let x = a.partial_piv_lu().solve(&rhs);
            let tol = 1e-12;
            for c in 0..n {
                let (ln, lt, yn, yt) = (x[(c, 0)], x[(n + c, 0)], x[(m + c, 0)], x[(m + n + c, 0)]);
                let ok = match modes[c] {
                    0 => yn >= -tol,
                    1 => ln >= -tol && lt.abs() <= law.mu[c] * ln + tol,
                    2 => ln >= -tol && yt - y_prev[n + c] >= -tol,
                    _ => ln >= -tol && yt - y_prev[n + c] <= tol,
                };
                if !ok || !ln.is_finite() {
                    continue 'combos;
                }
            }
            found = Some((x, modes));
            break;
        }
        let (x, modes) = found.expect("a valid mode combination");
        y_prev = (0..m).map(|i| x[(m + i, 0)]).collect();
        if step >= steps * (periods - 1) && step <= steps * periods {
            out.push(CatchingUpStep {
                forces: (0..m).map(|i| x[(i, 0)]).collect(),
                y: y_prev.clone(),
                modes,
            });
        }
    }
    out
}

#[test]
fn the_event_driven_march_agrees_with_a_fine_catching_up_march() {
    let (law, gamma, h) = coupled();
    let p = law.periodic(h, &gamma, 64).unwrap();
    let steps = 20000;
    let reference = catching_up(&law, h, &gamma, steps, 3);
    let scale = p.forces.iter().fold(0.0f64, |s, v| s.max(v.abs()));
    let mut worst = 0.0f64;
    for (j, step) in reference.iter().enumerate() {
        let lam = p.force_at(2.0 * PI * j as f64 / steps as f64);
        for (a, b) in lam.iter().zip(&step.forces) {
            worst = worst.max((a - b).abs());
        }
    }
    // first order in the step 2π/20000 ≈ 3e-4
    assert!(
        worst <= 2e-3 * scale,
        "largest difference {worst:e} of {scale:e}"
    );
}

#[test]
fn the_dissipated_energy_and_the_state_fractions_match_the_catching_up_march() {
    let (law, gamma, h) = coupled();
    let p = law.periodic(h, &gamma, 64).unwrap();
    let steps = 20000;
    let reference = catching_up(&law, h, &gamma, steps, 3);
    let n = law.n;
    // −∮ λ_Tᵀ dy_T by the trapezoidal rule on the march's steps (one period: steps + 1 states)
    let mut energy = 0.0;
    for pair in reference.windows(2) {
        for c in 0..n {
            let force = 0.5 * (pair[0].forces[n + c] + pair[1].forces[n + c]);
            energy -= force * (pair[1].y[n + c] - pair[0].y[n + c]);
        }
    }
    let exact = p.dissipated_energy();
    assert!(energy > 0.0, "the interface slips: {energy:e}");
    assert!(
        (exact - energy).abs() <= 2e-3 * energy,
        "energy {exact:e} against the march's {energy:e}"
    );
    // fractions: the share of the march's steps in each mode
    let fractions = p.state_fractions();
    let mut states_met = [false; 3];
    for c in 0..n {
        let f = fractions[c];
        assert!((f.stick + f.slip + f.open - 1.0).abs() <= 1e-12, "{f:?}");
        let share = |wanted: &[usize]| {
            reference[..steps]
                .iter()
                .filter(|s| wanted.contains(&s.modes[c]))
                .count() as f64
                / steps as f64
        };
        for (got, want, k) in [
            (f.open, share(&[0]), 0),
            (f.stick, share(&[1]), 1),
            (f.slip, share(&[2, 3]), 2),
        ] {
            assert!(
                (got - want).abs() <= 2e-3,
                "contact {c}: {got} against the march's {want} ({f:?})"
            );
            states_met[k] |= got > 0.01;
        }
    }
    assert_eq!(
        states_met, [true; 3],
        "the interface opens, sticks and slips"
    );
    // each sample's state is its phase's
    for j in 0..64 {
        let tau = 2.0 * PI * j as f64 / 64.0;
        let step = &reference[(j * steps) / 64];
        for c in 0..n {
            let want = match step.modes[c] {
                0 => ContactState::Open,
                1 => ContactState::Stick,
                _ => ContactState::Slip,
            };
            let got: ContactState = p.modes_at(tau)[c].into();
            // a sample within a step of a switch may fall on either side
            let near_switch = p
                .phases
                .iter()
                .any(|ph| (ph.start - tau).abs() < 1e-3 || (ph.end - tau).abs() < 1e-3);
            assert!(
                near_switch || got == want,
                "τ = {tau}, contact {c}: {got:?} against {want:?}"
            );
        }
    }
}

#[test]
fn without_friction_the_normal_forces_are_the_lcps_and_no_tangential_force_acts() {
    let (law, gamma, h) = coupled();
    let frictionless = FrictionalContacts::new(law.delassus.clone(), vec![0.0; 3]).unwrap();
    let p = frictionless.periodic(h, &gamma, 64).unwrap();
    let n = 3;
    let m = 2 * n;
    let dnn: Vec<f64> = (0..n * n).map(|k| law.d(k / n, k % n)).collect();
    let mut lcp = LcpSolver::new(LcpMatrix::new(n, dnn));
    for j in 0..500 {
        let tau = 2.0 * PI * j as f64 / 500.0;
        let b = basis(h, tau);
        let q: Vec<f64> = (0..n)
            .map(|c| (0..b.len()).map(|k| b[k] * gamma[k * m + c]).sum())
            .collect();
        let reference = lcp.solve(&q).unwrap();
        let lam = p.force_at(tau);
        for c in 0..n {
            assert!(
                (lam[c] - reference.lambda[c]).abs() <= 1e-12,
                "τ = {tau}: {} against {}",
                lam[c],
                reference.lambda[c]
            );
            assert_eq!(lam[n + c], 0.0);
        }
    }
}

/// The coefficients of `γ(τ + φ)` (harmonic-major, `m` signals).
fn shifted(coefficients: &[f64], m: usize, harmonics: usize, phi: f64) -> Vec<f64> {
    let mut out = coefficients.to_vec();
    for k in 1..=harmonics {
        let (s, c) = (k as f64 * phi).sin_cos();
        for r in 0..m {
            let (a, b) = (
                coefficients[(2 * k - 1) * m + r],
                coefficients[2 * k * m + r],
            );
            out[(2 * k - 1) * m + r] = a * c + b * s;
            out[2 * k * m + r] = b * c - a * s;
        }
    }
    out
}

#[test]
fn the_periodic_state_does_not_depend_on_where_the_period_starts() {
    // shifts that start the period in stick, slip and open phases of the contacts, so that
    // the fixed point (T156) has stuck contacts at τ = 0 whose anchors it must find
    let (law, gamma, h) = coupled();
    let m = 6;
    let p = law.periodic(h, &gamma, 64).unwrap();
    let mut stuck_at_start = 0;
    for phi in [0.7, 2.0, 2.8, 3.5, 4.0, 5.3] {
        let q = law.periodic(h, &shifted(&gamma, m, h, phi), 64).unwrap();
        stuck_at_start += q.phases[0]
            .modes
            .iter()
            .filter(|&&md| md == Mode::Stick)
            .count();
        let expected = shifted(&p.forces, m, h, phi);
        for (a, b) in q.forces.iter().zip(&expected) {
            assert!((a - b).abs() <= 1e-12, "φ = {phi}: {a} against {b}");
        }
    }
    assert!(
        stuck_at_start >= 3,
        "the shifts start too few stuck contacts"
    );
}

/// [`coupled`] with contact 2 pressed hard and barely swayed: stuck all period (T157).
fn coupled_with_a_stuck_contact() -> (FrictionalContacts, Vec<f64>, usize) {
    let (law, mut gamma, h) = coupled();
    let m = 6;
    gamma[2] = -4.0;
    for k in 1..n_coefficients(h) {
        gamma[k * m + 5] *= 0.05;
        gamma[k * m + 2] *= 0.05;
    }
    (law, gamma, h)
}

#[test]
fn the_derivative_equals_central_differences() {
    let cases = [
        coupled(),
        coupled_with_a_stuck_contact(),
        {
            let (law, gamma, h) = coupled();
            let g = shifted(&gamma, 6, h, 3.5);
            (law, g, h)
        },
        (
            single_contact(50.0, 3.0, 0.3),
            jenkins_gamma(3, 50.0, 2.0, 0.7),
            3,
        ),
    ];
    for (case, (law, gamma, h)) in cases.into_iter().enumerate() {
        let p = law.periodic(h, &gamma, 64).unwrap();
        if case == 1 {
            assert!(
                p.phases.iter().all(|ph| ph.modes[2] == Mode::Stick),
                "contact 2 not stuck all period"
            );
            assert!(p.phases.iter().any(|ph| ph.modes[0] != Mode::Stick));
        }
        if case == 2 {
            assert!(
                p.phases[0].modes.contains(&Mode::Stick),
                "no contact stuck at τ = 0"
            );
        }
        let nu = gamma.len();
        let scale = p.jacobian.iter().fold(0.0f64, |s, v| s.max(v.abs()));
        for col in 0..nu {
            let step = 1e-6;
            let mut plus = gamma.clone();
            plus[col] += step;
            let mut minus = gamma.clone();
            minus[col] -= step;
            let fp = law.periodic(h, &plus, 64).unwrap().forces;
            let fm = law.periodic(h, &minus, 64).unwrap().forces;
            for row in 0..nu {
                let fd = (fp[row] - fm[row]) / (2.0 * step);
                let exact = p.jacobian[row * nu + col];
                assert!(
                    (fd - exact).abs() <= 1e-6 * scale,
                    "case {case}: ∂λ̂[{row}]/∂γ̂[{col}]: {exact} against central differences {fd}"
                );
            }
        }
    }
}
