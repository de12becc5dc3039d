//! Why Newton stalls at a point: the redistributed MS-HBM's Jacobian at the unknowns of a
//! `solve --json` output (converged or not; its `harmonics`, `frequency_hz` and `unknowns`)
//! checked against central differences in a random direction, and the Newton step from
//! there: its size, the unknowns it moves most, and how far the residual along it departs
//! from the linear model `(1 − s) R` (a smooth residual departs like `s²`, a kinked one like
//! `s`; a step much longer than the solution means a nearly singular Jacobian).
//!
//! ```text
//! cargo run --release -p mshbm --example jacobian_probe -- MODEL.toml SOLUTION.json
//! ```
//!
//! With `COLUMNS_CHECK=1` in the environment every column of J is compared with its central
//! difference as well (two residuals per unknown).
//!
//! The method is built with its defaults (`MethodSettings::redistributed(H)`); the model
//! file must be readable without `--set` overrides.

use mshbm::method::settings::MethodSettings;
use mshbm::model::file::load_model;

/// `(R₊ − R₋) / 2h`.
fn central(plus: &[f64], minus: &[f64], h: f64) -> Vec<f64> {
    plus.iter()
        .zip(minus)
        .map(|(p, m)| (p - m) / (2.0 * h))
        .collect()
}

fn norm(v: &[f64]) -> f64 {
    v.iter().map(|a| a * a).sum::<f64>().sqrt()
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let [_, model_path, solution_path] = &args[..] else {
        eprintln!("usage: jacobian_probe MODEL.toml SOLUTION.json");
        std::process::exit(2);
    };
    let model = load_model(std::path::Path::new(model_path), &[]).unwrap_or_else(|e| {
        eprintln!("{e}");
        std::process::exit(1)
    });
    let text = std::fs::read_to_string(solution_path).unwrap_or_else(|e| {
        eprintln!("{solution_path}: {e}");
        std::process::exit(1)
    });
    let json: serde_json::Value = serde_json::from_str(&text).unwrap_or_else(|e| {
        eprintln!("{solution_path}: {e}");
        std::process::exit(1)
    });
    let field = |name: &str| -> &serde_json::Value {
        json.get(name).unwrap_or_else(|| {
            eprintln!("{solution_path}: no field `{name}` (the output of `mshbm solve --json`)");
            std::process::exit(1)
        })
    };
    let (Some(harmonics), Some(hz), Some(unknowns)) = (
        field("harmonics").as_u64(),
        field("frequency_hz").as_f64(),
        field("unknowns").as_array(),
    ) else {
        eprintln!("{solution_path}: `harmonics`, `frequency_hz` or `unknowns` of the wrong type");
        std::process::exit(1)
    };
    let x: Vec<f64> = unknowns.iter().filter_map(|v| v.as_f64()).collect();
    let omega = 2.0 * std::f64::consts::PI * hz;
    let mut problem = MethodSettings::redistributed(harmonics as usize)
        .build(&model)
        .unwrap_or_else(|e| {
            eprintln!("{e}");
            std::process::exit(1)
        })
        .problem;
    if x.len() != problem.dimension() {
        eprintln!(
            "{solution_path}: {} unknowns, the method at H = {harmonics} has {}",
            x.len(),
            problem.dimension()
        );
        std::process::exit(1);
    }
    let lin = problem.linearize(&x, omega).unwrap_or_else(|e| {
        eprintln!("linearize: {e}");
        std::process::exit(1)
    });
    // the contacts' states over the period, where the method models friction
    if let Ok(solution) = problem.solution(&x, omega, 0) {
        for (c, friction) in solution.frictions.iter().enumerate() {
            let states: String = friction
                .state
                .iter()
                .map(|s| match s {
                    mshbm::solution::ContactState::Stick => 'k',
                    mshbm::solution::ContactState::Slip => 's',
                    _ => 'o',
                })
                .collect();
            println!(
                "contact {c}: {states} (max |λ_T1| {:e})",
                friction.force.iter().fold(0.0f64, |m, v| m.max(v.abs()))
            );
        }
    }
    let mut residual = |x: &[f64]| {
        problem.residual(x, omega).unwrap_or_else(|e| {
            eprintln!("residual: {e}");
            std::process::exit(1)
        })
    };
    let (r, xn) = (&lin.residual, norm(&x));
    let rn = norm(r);
    println!(
        "H = {harmonics}, {} unknowns, |R| = {rn:e}, |x| = {xn:e}",
        x.len()
    );

    // J v against central differences, v random with |v| = |x|
    let mut seed = 0x9e37_79b9_7f4a_7c15_u64;
    let mut random = || {
        seed = seed
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
    };
    let v: Vec<f64> = (0..x.len()).map(|_| random()).collect();
    let scale = xn / norm(&v);
    let v: Vec<f64> = v.iter().map(|a| a * scale).collect();
    let jv = lin.jacobian.apply(&v);
    for eps in [1e-3, 1e-4, 1e-5, 1e-6, 1e-7] {
        let plus: Vec<f64> = x.iter().zip(&v).map(|(a, b)| a + eps * b).collect();
        let minus: Vec<f64> = x.iter().zip(&v).map(|(a, b)| a - eps * b).collect();
        let (rp, rm) = (residual(&plus), residual(&minus));
        let fd = central(&rp, &rm, eps);
        let difference: Vec<f64> = fd.iter().zip(&jv).map(|(f, j)| f - j).collect();
        println!(
            "central difference, step {eps:e} |x|: |FD - J v| / |J v| = {:e} \
             (|FD| / |J v| = {:e}, |J v| = {:e})",
            norm(&difference) / norm(&jv),
            norm(&fd) / norm(&jv),
            norm(&jv)
        );
    }

    // with COLUMNS_CHECK set: every column of J against its central difference (step 1e-6 |x|),
    // the worst columns and, in the worst column, the worst rows
    if std::env::var_os("COLUMNS_CHECK").is_some() {
        let dense = lin.jacobian.to_dense();
        let eps = 1e-6 * xn;
        let mut worst: Vec<(f64, usize, Vec<f64>)> = Vec::new();
        for j in 0..x.len() {
            let mut plus = x.clone();
            plus[j] += eps;
            let mut minus = x.clone();
            minus[j] -= eps;
            let (rp, rm) = (residual(&plus), residual(&minus));
            let fd = central(&rp, &rm, eps);
            let column: Vec<f64> = (0..x.len()).map(|i| dense[(i, j)]).collect();
            let difference: Vec<f64> = fd.iter().zip(&column).map(|(a, b)| a - b).collect();
            let error = norm(&difference) / norm(&fd).max(norm(&column));
            worst.push((error, j, difference));
            println!(
                "column {j}: |FD - J e_j| / max(|FD|, |J e_j|) = {error:.3e}, |J e_j| / |FD| = {:.3e}",
                norm(&column) / norm(&fd)
            );
        }
        worst.sort_by(|a, b| b.0.total_cmp(&a.0));
        let (error, j, difference) = &worst[0];
        let mut rows: Vec<usize> = (0..x.len()).collect();
        rows.sort_by(|&a, &b| difference[b].abs().total_cmp(&difference[a].abs()));
        println!("worst column {j} ({error:.3e}); its worst rows:");
        for &i in rows.iter().take(6) {
            println!(
                "  row {i}: J {:e}, FD - J {:e}",
                dense[(i, *j)],
                difference[i]
            );
        }
    }

    // the Newton step d = J⁻¹ R and the residual along it
    let Some(d) = lin.jacobian.solve(|i| r[i]) else {
        println!("the Jacobian is singular");
        return;
    };
    let dn = norm(&d);
    println!("Newton step: |d| = {dn:e} = {:.3e} |x|", dn / xn);
    let mut order: Vec<usize> = (0..d.len()).collect();
    order.sort_by(|&a, &b| d[b].abs().total_cmp(&d[a].abs()));
    for &i in order.iter().take(8) {
        println!("  d[{i}] = {:e}, x[{i}] = {:e}", d[i], x[i]);
    }
    for s in [1.0, 0.5, 0.1, 0.01, 0.001] {
        let moved: Vec<f64> = x.iter().zip(&d).map(|(a, b)| a - s * b).collect();
        let rs = residual(&moved);
        let departure: Vec<f64> = rs.iter().zip(r).map(|(a, b)| a - (1.0 - s) * b).collect();
        println!(
            "step {s}: |R(x - s d)| / |R| = {:.6}, |R(x - s d) - (1 - s) R| / (s |R|) = {:e}",
            norm(&rs) / rn,
            norm(&departure) / (s * rn)
        );
    }
}
