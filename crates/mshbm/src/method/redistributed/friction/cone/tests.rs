//! The cone law against its references (docs/theory.md (T192)).

use super::*;
use crate::method::redistributed::friction::FrictionalContacts;

/// `3 × 3` Delassus matrix of one isotropic contact decoupled from everything.
pub(super) fn isotropic(kn: f64, kt: f64) -> Vec<f64> {
    vec![1.0 / kn, 0.0, 0.0, 0.0, 1.0 / kt, 0.0, 0.0, 0.0, 1.0 / kt]
}

/// (T192 ii) The isotropic Jenkins element driven round a circle: the slider lags by `β`,
/// `sin β = F_s/(k_T A)`, on the circle of radius `√(A² − (F_s/k_T)²)`, the force of modulus
/// `F_s` rotating with it.
#[test]
fn a_slider_dragged_round_a_circle_lags_by_its_closed_form_angle() {
    let (kn, kt, mu, p, amp) = (1e6, 2e5, 0.3, 500.0, 3e-3);
    let fs = mu * p;
    let law = ConeContacts::new(isotropic(kn, kt), vec![mu]).unwrap();
    let h = 3;
    let mut gamma = vec![0.0; 3 * (2 * h + 1)];
    gamma[0] = -p / kn;
    gamma[3 + 1] = amp; // cos τ in t₁
    gamma[2 * 3 + 2] = amp; // sin τ in t₂
    let periodic = law.periodic(h, &gamma, 64).unwrap();
    let beta = (fs / (kt * amp)).asin();
    // the coefficients: λ_T = −F_s (−sin(τ − β), cos(τ − β))
    let mut expected = vec![0.0; 3 * (2 * h + 1)];
    expected[0] = p;
    expected[3 + 1] = -fs * beta.sin();
    expected[2 * 3 + 1] = fs * beta.cos();
    expected[3 + 2] = -fs * beta.cos();
    expected[2 * 3 + 2] = -fs * beta.sin();
    let error = periodic
        .forces
        .iter()
        .zip(&expected)
        .fold(0.0f64, |e, (a, b)| e.max((a - b).abs()));
    assert!(
        error < 1e-10 * fs,
        "coefficients off by {error:e} (F_s = {fs})"
    );
    assert!(
        periodic.phases.iter().all(|p| p.modes == [ConeMode::Slip]) || periodic.phases.len() <= 2
    );
    assert_lags(&law, &periodic, (p, fs, beta), 1e-10);
}

/// The slider's forces at sixteen instants are the closed form's: normal `p`, tangential
/// `F_s (sin(τ − β), −cos(τ − β))`, to `tolerance · F_s`.
fn assert_lags(
    law: &ConeContacts,
    periodic: &ConePeriodic,
    (p, fs, beta): (f64, f64, f64),
    tolerance: f64,
) {
    for k in 0..16 {
        let tau = 2.0 * PI * k as f64 / 16.0 + 0.1;
        let lambda = law.force_at(periodic, tau).unwrap();
        let want = [p, fs * (tau - beta).sin(), -fs * (tau - beta).cos()];
        for r in 0..3 {
            assert!(
                (lambda[r] - want[r]).abs() < tolerance * fs,
                "τ = {tau}: λ[{r}] = {} against {}",
                lambda[r],
                want[r]
            );
        }
    }
}

/// docs/theory.md (T190), (T224): dragged round a circle barely wider than its cone
/// (`A = 1.005 ρ`), the slider's lag `χ` (`χ̇ = 1 − (A/ρ) cos χ`) contracts near its periodic
/// value by `exp(−2π √((A/ρ)² − 1)) ≈ 0.53` per period: the plain march took forty
/// periods to 10⁻¹², the mixed starts reach the closed-form lag in eleven.
#[test]
fn a_slider_barely_dragged_round_a_circle_reaches_its_lag_in_a_few_passes() {
    let (kn, kt, mu, p) = (1e6, 2e5, 0.3, 500.0);
    let fs = mu * p;
    let amp = 1.005 * fs / kt;
    let law = ConeContacts::new(isotropic(kn, kt), vec![mu]).unwrap();
    let h = 3;
    let mut gamma = vec![0.0; 3 * (2 * h + 1)];
    gamma[0] = -p / kn;
    gamma[3 + 1] = amp;
    gamma[2 * 3 + 2] = amp;
    let periodic = law.periodic(h, &gamma, 64).unwrap();
    let beta = (fs / (kt * amp)).asin();
    assert_lags(&law, &periodic, (p, fs, beta), 1e-9);
    assert!(periodic.passes <= 15, "{} passes", periodic.passes);
}

/// A small coupled interface: `n` contacts whose second tangents are decoupled from the rest,
/// so that motion along the first tangents stays there.
pub(super) fn coupled_plane(n: usize) -> Vec<f64> {
    // D = Bᵀ B + diag, B pseudo-random
    let m = 2 * n;
    let mut seed = 7u64;
    let mut rnd = || {
        seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((seed >> 11) as f64 / (1u64 << 53) as f64) - 0.5
    };
    let b: Vec<f64> = (0..m * m).map(|_| rnd()).collect();
    let mut d2 = vec![0.0; m * m];
    for i in 0..m {
        for j in 0..m {
            d2[i * m + j] = 0.2 * (0..m).map(|k| b[k * m + i] * b[k * m + j]).sum::<f64>();
        }
        d2[i * m + i] += 1.0;
    }
    let mut d3 = vec![0.0; 9 * n * n];
    for i in 0..m {
        for j in 0..m {
            d3[i * 3 * n + j] = d2[i * m + j];
        }
    }
    for c in 0..n {
        d3[(2 * n + c) * 3 * n + 2 * n + c] = 0.8;
    }
    d3
}

/// (T192 i) Motion along the first tangents of a coupled interface (the second tangents
/// decoupled and undriven): the plane law's forces.
#[test]
fn motion_along_one_tangent_gives_the_plane_law() {
    let n = 3;
    let d3 = coupled_plane(n);
    let d2: Vec<f64> = (0..4 * n * n)
        .map(|e| d3[(e / (2 * n)) * 3 * n + e % (2 * n)])
        .collect();
    let mu = vec![0.3, 0.5, 0.2];
    let h = 3;
    let nc = 2 * h + 1;
    let mut gamma2 = vec![0.0; 2 * n * nc];
    for c in 0..n {
        gamma2[c] = -0.4 + 0.1 * c as f64; // closing normal load
        gamma2[2 * n + c] = 0.5 + 0.05 * c as f64; // cos τ normal: opens part of the period
        gamma2[2 * 2 * n + n + c] = 0.9 - 0.2 * c as f64; // sin τ tangential
        gamma2[3 * 2 * n + n + c] = 0.3; // cos 2τ tangential
        gamma2[6 * 2 * n + c] = 0.05; // sin 3τ normal
    }
    let mut gamma3 = vec![0.0; 3 * n * nc];
    for q in 0..nc {
        gamma3[q * 3 * n..q * 3 * n + 2 * n].copy_from_slice(&gamma2[q * 2 * n..(q + 1) * 2 * n]);
    }
    let plane = FrictionalContacts::new(d2, mu.clone())
        .unwrap()
        .periodic(h, &gamma2, 8 * nc)
        .unwrap();
    let cone = ConeContacts::new(d3, mu)
        .unwrap()
        .periodic(h, &gamma3, 8 * nc)
        .unwrap();
    let scale = plane.forces.iter().fold(0.0f64, |s, v| s.max(v.abs()));
    let mut error = 0.0f64;
    for q in 0..nc {
        for r in 0..2 * n {
            error = error.max((plane.forces[q * 2 * n + r] - cone.forces[q * 3 * n + r]).abs());
        }
        for c in 0..n {
            error = error.max(cone.forces[q * 3 * n + 2 * n + c].abs());
        }
    }
    assert!(
        error < 1e-9 * scale,
        "cone against plane law: {error:e} of {scale:e} ({} phases, {} passes)",
        cone.phases.len(),
        cone.passes
    );
    let slips = cone
        .phases
        .iter()
        .filter(|p| p.modes.contains(&ConeMode::Slip))
        .count();
    let opens = cone
        .phases
        .iter()
        .filter(|p| p.modes.contains(&ConeMode::Open))
        .count();
    let sticks = cone
        .phases
        .iter()
        .filter(|p| p.modes.contains(&ConeMode::Stick))
        .count();
    assert!(slips > 0 && opens > 0 && sticks > 0, "{:?}", cone.phases);
}

/// The vector play operator on a fine grid (T192 iii): one decoupled isotropic contact,
/// `λ_N = max(0, −k_N γ_N)`, the slider `s` kept within `μ λ_N / k_T` of `γ_T` by projection,
/// `λ_T = k_T (s − γ_T)`; Fourier coefficients by the trapezoidal rule over the last period.
fn play_operator(kn: f64, kt: f64, mu: f64, h: usize, gamma: &[f64], steps: usize) -> Vec<f64> {
    let nc = 2 * h + 1;
    let at = |tau: f64| {
        let mut b = vec![0.0; nc];
        basis_into(h, tau, &mut b);
        let mut g = [0.0; 3];
        for q in 0..nc {
            for r in 0..3 {
                g[r] += b[q] * gamma[q * 3 + r];
            }
        }
        (g, b)
    };
    let mut s = [0.0, 0.0];
    let mut coefficients = vec![0.0; 3 * nc];
    for period in 0..40 {
        for k in 0..steps {
            let tau = 2.0 * PI * (k + 1) as f64 / steps as f64;
            let (g, b) = at(tau);
            let ln = (-kn * g[0]).max(0.0);
            let radius = mu * ln / kt;
            let d = [s[0] - g[1], s[1] - g[2]];
            let norm = d[0].hypot(d[1]);
            let f = if norm > radius { radius / norm } else { 1.0 };
            s = [g[1] + f * d[0], g[2] + f * d[1]];
            if period == 39 {
                let lambda = [ln, kt * (s[0] - g[1]), kt * (s[1] - g[2])];
                for q in 0..nc {
                    let w = if q == 0 { 1.0 } else { 2.0 } / steps as f64;
                    for r in 0..3 {
                        coefficients[q * 3 + r] += w * lambda[r] * b[q];
                    }
                }
            }
        }
    }
    coefficients
}

/// (T192 iii) An elliptic and a two-harmonic tangential orbit with a varying normal load
/// that opens the contact for part of the period: the event-driven law against the play
/// operator's projection scheme (first order: 2·10⁵ steps give ~10⁻⁵).
#[test]
fn general_orbits_match_the_projection_scheme_of_the_play_operator() {
    let (kn, kt, mu) = (1e6, 3e5, 0.4);
    let h = 2;
    let nc = 2 * h + 1;
    for case in 0..2 {
        let mut gamma = vec![0.0; 3 * nc];
        gamma[0] = -4e-4;
        gamma[3] = if case == 0 { 2e-4 } else { 5e-4 }; // cos τ in the normal: opens if > 4e-4
        gamma[3 + 1] = 2e-3; // cos τ, t₁
        gamma[2 * 3 + 2] = 7e-4; // sin τ, t₂: an ellipse
        gamma[4 * 3 + 1] = if case == 0 { 0.0 } else { 6e-4 }; // sin 2τ, t₁
        gamma[3 * 3 + 2] = if case == 0 { 3e-4 } else { -4e-4 }; // cos 2τ, t₂
        let law = ConeContacts::new(isotropic(kn, kt), vec![mu]).unwrap();
        let periodic = law.periodic(h, &gamma, 8 * nc).unwrap();
        let reference = play_operator(kn, kt, mu, h, &gamma, 200_000);
        let scale = reference.iter().fold(0.0f64, |s, v| s.max(v.abs()));
        let error = periodic
            .forces
            .iter()
            .zip(&reference)
            .fold(0.0f64, |e, (a, b)| e.max((a - b).abs()));
        assert!(
            error < 1e-4 * scale,
            "case {case}: {error:e} of {scale:e}\n{:?}\n{:?}",
            periodic.forces,
            reference
        );
        let opens = periodic.phases.iter().any(|p| p.modes == [ConeMode::Open]);
        assert_eq!(opens, case == 1, "case {case}: {:?}", periodic.phases);
    }
}

/// A general `3n × 3n` Delassus matrix: `I + 0.2 BᵀB`, `B` pseudo-random.
pub(super) fn coupled_space(n: usize, seed: u64) -> Vec<f64> {
    let m = 3 * n;
    let mut seed = seed;
    let mut rnd = || {
        seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((seed >> 11) as f64 / (1u64 << 53) as f64) - 0.5
    };
    let b: Vec<f64> = (0..m * m).map(|_| rnd()).collect();
    let mut d = vec![0.0; m * m];
    for i in 0..m {
        for j in 0..m {
            d[i * m + j] = 0.2 * (0..m).map(|k| b[k * m + i] * b[k * m + j]).sum::<f64>();
        }
        d[i * m + i] += 1.0;
    }
    d
}

/// The catching-up scheme of the quasi-static law on a fine grid (T192 iii, coupled): each
/// step the forces `λ` with `y = γ_{k+1} + D λ` such that every contact satisfies Signorini
/// in `y_N` and Coulomb in its tangential increment `Δ = y_T − y_T^k` — written as the cone
/// complementarity `K* ∋ (y_N + μ|Δ|, Δ) ⊥ λ ∈ K` (De Saxcé's modified velocity) and solved
/// by projected Gauss–Seidel, `λ_c ← Π_K(λ_c − ρ_c û_c)`. First-order accurate in the step.
fn catching_up(d: &[f64], mu: &[f64], h: usize, gamma: &[f64], steps: usize) -> Vec<f64> {
    let n = mu.len();
    let m = 3 * n;
    let nc = 2 * h + 1;
    let mut lambda = vec![0.0; m];
    let mut y_t = vec![0.0; 2 * n];
    let mut coefficients = vec![0.0; m * nc];
    let periods = 30;
    let rho: Vec<f64> = (0..n)
        .map(|c| 0.5 / d[c * m + c].max(d[(n + c) * m + n + c]))
        .collect();
    for period in 0..periods {
        for k in 0..steps {
            let tau = 2.0 * PI * (k + 1) as f64 / steps as f64;
            let mut b = vec![0.0; nc];
            basis_into(h, tau, &mut b);
            let mut g = vec![0.0; m];
            for q in 0..nc {
                for r in 0..m {
                    g[r] += b[q] * gamma[q * m + r];
                }
            }
            for _sweep in 0..20_000 {
                let mut change = 0.0f64;
                for c in 0..n {
                    let rows = [c, n + c, 2 * n + c];
                    let y: Vec<f64> = rows
                        .iter()
                        .map(|&r| g[r] + (0..m).map(|j| d[r * m + j] * lambda[j]).sum::<f64>())
                        .collect();
                    let delta = [y[1] - y_t[c], y[2] - y_t[n + c]];
                    let u = [y[0] + mu[c] * delta[0].hypot(delta[1]), delta[0], delta[1]];
                    let z = [
                        lambda[c] - rho[c] * u[0],
                        lambda[n + c] - rho[c] * u[1],
                        lambda[2 * n + c] - rho[c] * u[2],
                    ];
                    // projection onto the cone |λ_T| ≤ μ λ_N
                    let t = z[1].hypot(z[2]);
                    let p = if t <= mu[c] * z[0] {
                        z
                    } else if mu[c] * t <= -z[0] {
                        [0.0, 0.0, 0.0]
                    } else {
                        let ln = (z[0] + mu[c] * t) / (1.0 + mu[c] * mu[c]);
                        [ln, mu[c] * ln * z[1] / t, mu[c] * ln * z[2] / t]
                    };
                    for (i, &r) in rows.iter().enumerate() {
                        change = change.max((p[i] - lambda[r]).abs());
                        lambda[r] = p[i];
                    }
                }
                if change < 1e-15 {
                    break;
                }
            }
            for t in 0..2 * n {
                y_t[t] = g[n + t] + (0..m).map(|j| d[(n + t) * m + j] * lambda[j]).sum::<f64>();
            }
            if period == periods - 1 {
                for q in 0..nc {
                    let w = if q == 0 { 1.0 } else { 2.0 } / steps as f64;
                    for r in 0..m {
                        coefficients[q * m + r] += w * lambda[r] * b[q];
                    }
                }
            }
        }
    }
    coefficients
}

/// (T192 iii, coupled) Two contacts coupled in all their coordinates, driven round different
/// orbits with a normal load that opens one of them for part of the period: the event-driven
/// law against the catching-up scheme (first order: 3.2·10⁻⁴ and 1.6·10⁻⁴ of the largest
/// coefficient with 2500 and 5000 steps per period).
#[test]
fn coupled_contacts_in_space_match_the_catching_up_scheme() {
    let n = 2;
    let m = 3 * n;
    let d = coupled_space(n, 11);
    let mu = vec![0.3, 0.5];
    let h = 2;
    let nc = 2 * h + 1;
    let mut gamma = vec![0.0; m * nc];
    gamma[0] = -0.5; // normal loads
    gamma[1] = -0.3;
    gamma[m + 1] = 0.4; // cos τ in contact 1's normal: opens
    gamma[m + n] = 0.8; // cos τ, t₁ of contact 0
    gamma[2 * m + 2 * n] = 0.5; // sin τ, t₂ of contact 0
    gamma[2 * m + n + 1] = -0.6; // sin τ, t₁ of contact 1
    gamma[3 * m + 2 * n + 1] = 0.4; // cos 2τ, t₂ of contact 1
    gamma[4 * m + 2 * n] = 0.2; // sin 2τ, t₂ of contact 0
    let law = ConeContacts::new(d.clone(), mu.clone()).unwrap();
    let periodic = law.periodic(h, &gamma, 8 * nc).unwrap();
    let scale = periodic.forces.iter().fold(0.0f64, |s, v| s.max(v.abs()));
    let errors: Vec<f64> = [2500, 5000]
        .iter()
        .map(|&steps| {
            let reference = catching_up(&d, &mu, h, &gamma, steps);
            periodic
                .forces
                .iter()
                .zip(&reference)
                .fold(0.0f64, |e, (a, b)| e.max((a - b).abs()))
                / scale
        })
        .collect();
    // first order: the error halves with the step, and is small
    assert!(errors[1] < 3e-4, "relative errors {errors:?}");
    assert!(
        errors[1] < 0.6 * errors[0],
        "the scheme does not converge towards the law: {errors:?}"
    );
    let slips = periodic
        .phases
        .iter()
        .any(|p| p.modes.contains(&ConeMode::Slip));
    let opens = periodic
        .phases
        .iter()
        .any(|p| p.modes.contains(&ConeMode::Open));
    assert!(slips && opens, "{:?}", periodic.phases);
}

/// `x = M⁻¹ b` by Gaussian elimination with partial pivoting (`M` row-major, `m × m`).
fn gauss(mut a: Vec<f64>, mut b: Vec<f64>) -> Vec<f64> {
    let m = b.len();
    for col in 0..m {
        let p = (col..m)
            .max_by(|&i, &j| a[i * m + col].abs().total_cmp(&a[j * m + col].abs()))
            .unwrap();
        for j in 0..m {
            a.swap(col * m + j, p * m + j);
        }
        b.swap(col, p);
        for i in col + 1..m {
            let f = a[i * m + col] / a[col * m + col];
            for j in col..m {
                a[i * m + j] -= f * a[col * m + j];
            }
            b[i] -= f * b[col];
        }
    }
    for i in (0..m).rev() {
        let s: f64 = (i + 1..m).map(|j| a[i * m + j] * b[j]).sum();
        b[i] = (b[i] - s) / a[i * m + i];
    }
    b
}

/// (T193) Contacts that all stick on the boundary of their cones, coupled through a general
/// Delassus matrix: the slipping set chosen is the one, among all `2ⁿ`, whose slip speeds
/// are non-negative and whose stuck contacts' cone margins do not decrease — each candidate
/// set's rates derived here from (T186) by solves with `D` itself.
#[test]
fn the_contacts_that_slip_on_the_cone_boundary_are_the_consistent_set() {
    let (n, h) = (4, 1);
    let m = 3 * n;
    for seed in 0..6u64 {
        let d = coupled_space(n, 11 + seed);
        let mu = vec![0.6; n];
        // forces on the cone's boundary, tangential displacements, free-gap rates
        let mut lambda = vec![0.0; m];
        let mut anchors = vec![0.0; 2 * n];
        for c in 0..n {
            let theta = 1.3 * c as f64 + 0.7 * seed as f64;
            lambda[c] = 1.0 + 0.2 * c as f64;
            lambda[n + c] = mu[c] * lambda[c] * theta.cos();
            lambda[2 * n + c] = mu[c] * lambda[c] * theta.sin();
            anchors[c] = 0.1 * (c as f64 + seed as f64).sin();
            anchors[n + c] = 0.1 * (2.0 * c as f64 - seed as f64).cos();
        }
        // γ(0) = [0; a] − D λ, γ̇(0) = γ̂_sin
        let mut gamma = vec![0.0; m * (2 * h + 1)];
        let mut rate = vec![0.0; m];
        for r in 0..m {
            let dl: f64 = (0..m).map(|j| d[r * m + j] * lambda[j]).sum();
            let held = if r < n { 0.0 } else { anchors[r - n] };
            gamma[m + r] = 0.3 * ((r * 7 + seed as usize) as f64).sin();
            gamma[r] = held - dl - gamma[m + r];
            rate[r] = ((r * 5 + 3 * seed as usize) as f64).cos();
            gamma[2 * m + r] = rate[r];
        }
        let law = ConeContacts::new(d.clone(), mu.clone()).unwrap();
        let mut march = march::March::new(&law, h, &gamma, 64);
        let mut modes = vec![ConeMode::Stick; n];
        assert!(march.choose_slip(0.0, &mut modes, &anchors).is_ok());
        // the reference: every slipping set, its speeds and its margins' rates
        let e: Vec<[f64; 2]> = (0..n)
            .map(|c| {
                let t = lambda[n + c].hypot(lambda[2 * n + c]);
                [-lambda[n + c] / t, -lambda[2 * n + c] / t]
            })
            .collect();
        let margin_rates = |kappa: &[f64]| -> Vec<f64> {
            let mut rhs: Vec<f64> = rate.iter().map(|v| -v).collect();
            for c in 0..n {
                rhs[n + c] += kappa[c] * e[c][0];
                rhs[2 * n + c] += kappa[c] * e[c][1];
            }
            let dl = gauss(d.clone(), rhs);
            (0..n)
                .map(|c| mu[c] * dl[c] + e[c][0] * dl[n + c] + e[c][1] * dl[2 * n + c])
                .collect()
        };
        let base = margin_rates(&vec![0.0; n]);
        let columns: Vec<Vec<f64>> = (0..n)
            .map(|s| {
                let mut unit = vec![0.0; n];
                unit[s] = 1.0;
                let r = margin_rates(&unit);
                (0..n).map(|c| r[c] - base[c]).collect()
            })
            .collect();
        let mut consistent = Vec::new();
        for set in 0..1usize << n {
            let s: Vec<usize> = (0..n).filter(|&c| set >> c & 1 == 1).collect();
            let a: Vec<f64> = s
                .iter()
                .flat_map(|&c| s.iter().map(move |&q| (c, q)))
                .map(|(c, q)| columns[q][c])
                .collect();
            let kappa_s = if s.is_empty() {
                Vec::new()
            } else {
                gauss(a, s.iter().map(|&c| -base[c]).collect())
            };
            let mut kappa = vec![0.0; n];
            for (i, &c) in s.iter().enumerate() {
                kappa[c] = kappa_s[i];
            }
            let rates = margin_rates(&kappa);
            if kappa.iter().all(|&k| k >= -1e-12) && rates.iter().all(|&r| r >= -1e-12) {
                consistent.push(set);
            }
        }
        assert_eq!(
            consistent.len(),
            1,
            "seed {seed}: consistent sets {consistent:?}"
        );
        let chosen = (0..n)
            .filter(|&c| modes[c] == ConeMode::Slip)
            .fold(0usize, |s, c| s | 1 << c);
        assert_eq!(chosen, consistent[0], "seed {seed}: modes {modes:?}");
    }
}
