//! The derivative of the cone law (docs/theory.md (T191), (T214)–(T218)) against the
//! derivative of a closed form and against central differences of the law.

use super::tangent::Anchors;
use super::tests::{coupled_plane, coupled_space, isotropic};
use super::*;

/// The largest difference between the tangent along `direction` and the central difference
/// of the law with step `step`, relative to the largest entry of the latter.
fn tangent_against_central_difference(
    law: &ConeContacts,
    h: usize,
    gamma: &[f64],
    cells: usize,
    direction: &[f64],
    step: f64,
) -> (f64, f64) {
    let periodic = law.periodic(h, gamma, cells).unwrap();
    let tangent = law
        .tangent(&periodic, &[direction.to_vec()], cells)
        .unwrap();
    let shifted = |sign: f64| -> Vec<f64> {
        let g: Vec<f64> = gamma
            .iter()
            .zip(direction)
            .map(|(g, d)| g + sign * step * d)
            .collect();
        law.periodic(h, &g, cells).unwrap().forces
    };
    let (plus, minus) = (shifted(1.0), shifted(-1.0));
    let central: Vec<f64> = plus
        .iter()
        .zip(&minus)
        .map(|(p, m)| (p - m) / (2.0 * step))
        .collect();
    let scale = central.iter().fold(0.0f64, |s, v| s.max(v.abs()));
    let error = central
        .iter()
        .zip(&tangent[0])
        .fold(0.0f64, |e, (c, t)| e.max((c - t).abs()));
    (error / scale.max(f64::MIN_POSITIVE), scale)
}

/// (T192 ii) differentiated: the slider dragged round a circle of radius `A`, whose force
/// lags by `β`, `sin β = F_s/(k_T A)`; its coefficients' derivatives in `A` and in the
/// normal load `P` (`F_s = μ P`) from the closed form.
#[test]
fn the_slider_round_a_circle_has_the_derivative_of_its_closed_form() {
    let (kn, kt, mu, p, amp) = (1e6, 2e5, 0.3, 500.0, 3e-3);
    let law = ConeContacts::new(isotropic(kn, kt), vec![mu]).unwrap();
    let h = 3;
    let nc = 2 * h + 1;
    let mut gamma = vec![0.0; 3 * nc];
    gamma[0] = -p / kn;
    gamma[3 + 1] = amp;
    gamma[2 * 3 + 2] = amp;
    let periodic = law.periodic(h, &gamma, 64).unwrap();
    let mut d_amp = vec![0.0; 3 * nc];
    d_amp[3 + 1] = 1.0;
    d_amp[2 * 3 + 2] = 1.0;
    let mut d_load = vec![0.0; 3 * nc];
    d_load[0] = -1.0 / kn; // δP = 1
    let tangent = law.tangent(&periodic, &[d_amp, d_load], 64).unwrap();
    // λ̂ = (P; −F_s sin β, F_s cos β; −F_s cos β, −F_s sin β) at (0; t₁ cos, t₂ cos; t₁ sin,
    // t₂ sin); with s = sin β = F_s/(k_T A), c = cos β
    let coefficients = |fs: f64, amp: f64| -> [f64; 4] {
        let s = fs / (kt * amp);
        let c = (1.0 - s * s).sqrt();
        [-fs * s, fs * c, -fs * c, -fs * s]
    };
    let fs = mu * p;
    let s = fs / (kt * amp);
    let c = (1.0 - s * s).sqrt();
    // ∂/∂A: ds = −s/A, dc = −s ds / c;  ∂/∂F_s: ds = s/F_s
    let ds_amp = -s / amp;
    let dc_amp = -s * ds_amp / c;
    let by_amp = [-fs * ds_amp, fs * dc_amp, -fs * dc_amp, -fs * ds_amp];
    let ds_fs = s / fs;
    let dc_fs = -s * ds_fs / c;
    let base = coefficients(fs, amp);
    let by_load = [
        mu * (base[0] / fs - fs * ds_fs),
        mu * (base[1] / fs + fs * dc_fs),
        mu * (base[2] / fs - fs * dc_fs),
        mu * (base[3] / fs - fs * ds_fs),
    ];
    let slots = [3 + 1, 2 * 3 + 1, 3 + 2, 2 * 3 + 2];
    for (column, expected, normal) in [(0, by_amp, 0.0), (1, by_load, 1.0)] {
        let t = &tangent[column];
        let scale = expected.iter().fold(0.0f64, |s, v| s.max(v.abs()));
        let mut error = (t[0] - normal).abs() / scale.max(1.0);
        for (slot, want) in slots.iter().zip(&expected) {
            error = error.max((t[*slot] - want).abs() / scale);
        }
        let others = (0..3 * nc)
            .filter(|i| *i != 0 && !slots.contains(i))
            .fold(0.0f64, |e, i| e.max(t[i].abs()));
        assert!(
            error < 1e-7 && others < 1e-7 * scale,
            "column {column}: relative error {error:e}, other coefficients {others:e}; {t:?} \
             against {expected:?}"
        );
    }
}

/// The plane law's motion (three coupled contacts that stick, slip and open, second
/// tangents undriven) and a general coupled interface in space: the tangent along pseudo-
/// random directions against central differences of the law (T191).
#[test]
fn the_tangent_of_the_law_is_its_central_difference() {
    let mut seed = 3u64;
    let mut rnd = move || {
        seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((seed >> 11) as f64 / (1u64 << 53) as f64) - 0.5
    };
    // (1) the plane case of `motion_along_one_tangent_gives_the_plane_law`
    let n = 3;
    let h = 3;
    let nc = 2 * h + 1;
    let mut gamma = vec![0.0; 3 * n * nc];
    for c in 0..n {
        gamma[c] = -0.4 + 0.1 * c as f64;
        gamma[3 * n + c] = 0.5 + 0.05 * c as f64;
        gamma[2 * 3 * n + n + c] = 0.9 - 0.2 * c as f64;
        gamma[3 * 3 * n + n + c] = 0.3;
        gamma[6 * 3 * n + c] = 0.05;
    }
    let law = ConeContacts::new(coupled_plane(n), vec![0.3, 0.5, 0.2]).unwrap();
    let mut results = Vec::new();
    for _ in 0..3 {
        let direction: Vec<f64> = (0..3 * n * nc).map(|_| rnd()).collect();
        results.push(tangent_against_central_difference(
            &law,
            h,
            &gamma,
            8 * nc,
            &direction,
            1e-5,
        ));
    }
    // (2) two coupled contacts in space, one opening (the catching-up test's case)
    let n = 2;
    let m = 3 * n;
    let h = 2;
    let nc = 2 * h + 1;
    let mut gamma = vec![0.0; m * nc];
    gamma[0] = -0.5;
    gamma[1] = -0.3;
    gamma[m + 1] = 0.4;
    gamma[m + n] = 0.8;
    gamma[2 * m + 2 * n] = 0.5;
    gamma[2 * m + n + 1] = -0.6;
    gamma[3 * m + 2 * n + 1] = 0.4;
    gamma[4 * m + 2 * n] = 0.2;
    let law = ConeContacts::new(coupled_space(n, 11), vec![0.3, 0.5]).unwrap();
    for _ in 0..3 {
        let direction: Vec<f64> = (0..m * nc).map(|_| rnd()).collect();
        results.push(tangent_against_central_difference(
            &law,
            h,
            &gamma,
            8 * nc,
            &direction,
            1e-5,
        ));
    }
    // (3) three coupled contacts in space, one loaded hard enough to stick all period (its
    // anchor the frictionless state's at τ = 0, (T218)), one slipping, one opening
    let n = 3;
    let m = 3 * n;
    let mut gamma = vec![0.0; m * nc];
    gamma[0] = -0.5;
    gamma[1] = -0.3;
    gamma[2] = -3.0;
    gamma[m + 1] = 0.4;
    gamma[m + n] = 0.8;
    gamma[2 * m + 2 * n] = 0.5;
    gamma[2 * m + n + 1] = -0.6;
    gamma[3 * m + 2 * n + 1] = 0.4;
    gamma[4 * m + 2 * n] = 0.2;
    gamma[m + n + 2] = 0.05;
    let law = ConeContacts::new(coupled_space(n, 5), vec![0.3, 0.5, 0.6]).unwrap();
    let periodic = law.periodic(h, &gamma, 8 * nc).unwrap();
    assert!(
        periodic
            .phases
            .iter()
            .all(|p| p.modes[2] == ConeMode::Stick)
            && periodic.phases.iter().any(|p| p.modes[0] == ConeMode::Slip),
        "{:?}",
        periodic.phases
    );
    for _ in 0..3 {
        let direction: Vec<f64> = (0..m * nc).map(|_| rnd()).collect();
        results.push(tangent_against_central_difference(
            &law,
            h,
            &gamma,
            8 * nc,
            &direction,
            1e-5,
        ));
    }
    for (i, (error, scale)) in results.iter().enumerate() {
        assert!(
            *error < 1e-6,
            "case {i}: relative error {error:e} (scale {scale:e}); all {results:?}"
        );
    }
}

/// (T218) solved by unit anchor columns and by iterating the march with the directions
/// alone give one derivative: on two contacts in space and the slider round a circle; on
/// three contacts (one stuck all period, one whose anchor the march forgets slowly) the
/// cheaper choice, which abandons the iteration there, agrees with the unit columns.
#[test]
fn the_anchors_derivative_is_the_same_solved_either_way() {
    let mut seed = 17u64;
    let mut rnd = move || {
        seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((seed >> 11) as f64 / (1u64 << 53) as f64) - 0.5
    };
    let h = 2;
    let nc = 2 * h + 1;
    let mut cases = Vec::new();
    for (n, stuck) in [(2usize, false), (3, true)] {
        let m = 3 * n;
        let mut gamma = vec![0.0; m * nc];
        gamma[0] = -0.5;
        gamma[1] = -0.3;
        gamma[m + 1] = 0.4;
        gamma[m + n] = 0.8;
        gamma[2 * m + 2 * n] = 0.5;
        gamma[2 * m + n + 1] = -0.6;
        gamma[3 * m + 2 * n + 1] = 0.4;
        gamma[4 * m + 2 * n] = 0.2;
        let mu = if stuck {
            gamma[2] = -3.0;
            gamma[m + n + 2] = 0.05;
            vec![0.3, 0.5, 0.6]
        } else {
            vec![0.3, 0.5]
        };
        let d = coupled_space(n, if stuck { 5 } else { 11 });
        cases.push((ConeContacts::new(d, mu).unwrap(), gamma, m));
    }
    let mut gamma = vec![0.0; 3 * nc];
    gamma[0] = -500.0 / 1e6;
    gamma[3 + 1] = 3e-3;
    gamma[2 * 3 + 2] = 3e-3;
    cases.push((
        ConeContacts::new(isotropic(1e6, 2e5), vec![0.3]).unwrap(),
        gamma,
        3,
    ));
    for (k, (law, gamma, m)) in cases.iter().enumerate() {
        let periodic = law.periodic(h, gamma, 8 * nc).unwrap();
        let directions: Vec<Vec<f64>> = (0..2)
            .map(|_| (0..m * nc).map(|_| rnd()).collect())
            .collect();
        let by_units = law
            .tangent_by(&periodic, &directions, 8 * nc, Anchors::UnitColumns)
            .unwrap();
        let how = if k == 1 {
            Anchors::Cheaper
        } else {
            Anchors::Iteration
        };
        let by_iteration = law.tangent_by(&periodic, &directions, 8 * nc, how).unwrap();
        for (a, b) in by_units.iter().zip(&by_iteration) {
            let scale = a.iter().fold(0.0f64, |s, v| s.max(v.abs()));
            let error = a
                .iter()
                .zip(b)
                .fold(0.0f64, |e, (x, y)| e.max((x - y).abs()));
            assert!(
                error <= 1e-8 * scale,
                "case {k}: {error:e} of {scale:e} between the two ways"
            );
        }
    }
}
