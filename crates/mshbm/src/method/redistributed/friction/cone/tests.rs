//! The cone law against its references (docs/theory.md (T192)).

use super::*;
use crate::method::redistributed::friction::FrictionalContacts;

/// `3 × 3` Delassus matrix of one isotropic contact decoupled from everything.
fn isotropic(kn: f64, kt: f64) -> Vec<f64> {
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
    for k in 0..16 {
        let tau = 2.0 * PI * k as f64 / 16.0 + 0.1;
        let lambda = law.force_at(&periodic, tau).unwrap();
        let want = [p, fs * (tau - beta).sin(), -fs * (tau - beta).cos()];
        for r in 0..3 {
            assert!(
                (lambda[r] - want[r]).abs() < 1e-10 * fs,
                "τ = {tau}: λ[{r}] = {} against {}",
                lambda[r],
                want[r]
            );
        }
    }
}

/// A small coupled interface: `n` contacts whose second tangents are decoupled from the rest,
/// so that motion along the first tangents stays there.
fn coupled_plane(n: usize) -> Vec<f64> {
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
