//! The cost of the 3D friction cone law (docs/theory.md (T186)–(T194)) against the number of
//! contacts, on a dense coupled Delassus matrix (BENCHMARKS.md §14d):
//! `cargo bench -p mshbm --bench friction_cone`. Two drives: most contacts slipping most of
//! the period, and a preloaded patch where only the edge slips (a joint's microslip), with
//! the cost of a product `S v` (T225) against the dense `S` there.

use std::time::Instant;

use mshbm::method::redistributed::friction::cone::{ConeContacts, ConeMode};

/// A symmetric positive definite `3n × 3n` matrix `I + 0.2 BᵀB`, `B` pseudo-random in
/// `[−½, ½)` (a linear congruential sequence from `seed`).
fn delassus(n: usize, seed: u64) -> Vec<f64> {
    let m = 3 * n;
    let mut state = seed;
    let b: Vec<f64> = std::iter::repeat_with(|| {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((state >> 11) as f64 / (1u64 << 53) as f64) - 0.5
    })
    .take(m * m)
    .collect();
    let mut d = vec![0.0; m * m];
    for (i, j) in (0..m).flat_map(|i| (0..m).map(move |j| (i, j))) {
        let dot: f64 = (0..m).map(|k| b[k * m + i] * b[k * m + j]).sum();
        d[i * m + j] = 0.2 * dot + if i == j { 1.0 } else { 0.0 };
    }
    d
}

fn run(label: &str, n: usize, gamma: &[f64], seed: u64) {
    let (h, mu) = (5, vec![0.3; n]);
    let law = ConeContacts::new(delassus(n, seed), mu).expect("a valid law");
    let start = Instant::now();
    match law.periodic(h, gamma, 8 * (2 * h + 1)) {
        Ok(p) => {
            let slipping = (0..n)
                .filter(|&c| p.phases.iter().any(|ph| ph.modes[c] == ConeMode::Slip))
                .count();
            println!(
                "{label} n = {n}: {:.2} s, {} phases, {} passes, {} steps (+{} trial steps locating \
                 switches), {slipping} contacts slip",
                start.elapsed().as_secs_f64(),
                p.phases.len(),
                p.passes,
                p.steps,
                p.trial_steps
            );
            // the derivative (T191) along one direction and along ten (only one at 48
            // slipping contacts: 266 s with the unit anchors of (T218), BENCHMARKS.md §14d)
            let m = 3 * n;
            for columns in [1usize, 10]
                .into_iter()
                .filter(|&k| n < 48 || k == 1 && n <= 50)
            {
                let directions: Vec<Vec<f64>> = (0..columns)
                    .map(|j| {
                        (0..gamma.len())
                            .map(|i| if i % m == (j * 7) % m { 1.0 } else { 0.0 })
                            .collect()
                    })
                    .collect();
                let start = Instant::now();
                match law.tangent(&p, &directions, 8 * (2 * h + 1)) {
                    Ok(_) => println!(
                        "  tangent along {columns} direction(s): {:.2} s",
                        start.elapsed().as_secs_f64()
                    ),
                    Err(e) => println!("  tangent along {columns} direction(s) failed: {e}"),
                }
            }
            // products `S v` (T225): the anchors' response once, then one march per product
            // (its primal path replayed); the dense `S` of the `3n(2H+1)` columns beside
            // them at 50 contacts
            if label == "microslip" {
                let cells = 8 * (2 * h + 1);
                let start = Instant::now();
                let Ok(response) = law.anchor_response(&p, cells) else {
                    println!("  the anchors' response failed");
                    return;
                };
                let response_time = start.elapsed().as_secs_f64();
                let v: Vec<f64> = (0..gamma.len())
                    .map(|i| ((i as f64 + 1.0) * 0.7548776662).fract() - 0.5)
                    .collect();
                let start = Instant::now();
                let product = law.tangent_with(&p, &response, &[v], cells);
                println!(
                    "  anchors' response ({} anchors): {response_time:.2} s; a product: {:.2} s{}",
                    response.anchors(),
                    start.elapsed().as_secs_f64(),
                    if product.is_ok() { "" } else { " (failed)" }
                );
                if n <= 50 {
                    let start = Instant::now();
                    let dense = law.jacobian_with(&p, &response, cells);
                    println!(
                        "  the dense S ({} columns): {:.2} s{}",
                        gamma.len(),
                        start.elapsed().as_secs_f64(),
                        if dense.is_ok() { "" } else { " (failed)" }
                    );
                }
            }
        }
        Err(e) => println!(
            "{label} n = {n}: failed after {:.2} s: {e}",
            start.elapsed().as_secs_f64()
        ),
    }
}

fn main() {
    let h = 5;
    let nc = 2 * h + 1;
    for n in [10usize, 30, 48] {
        let m = 3 * n;
        let mut gamma = vec![0.0; m * nc];
        for c in 0..n {
            let phase = c as f64 / n as f64 * 2.0;
            gamma[c] = -0.5;
            gamma[m + c] = 0.3 * phase.cos();
            gamma[2 * m + c] = 0.3 * phase.sin();
            gamma[m + n + c] = 0.8 * phase.cos();
            gamma[2 * m + n + c] = 0.8 * phase.sin();
            gamma[m + 2 * n + c] = -0.5 * phase.sin();
            gamma[2 * m + 2 * n + c] = 0.5 * phase.cos();
        }
        run("slipping", n, &gamma, 3);
    }
    for n in [50usize, 100] {
        let m = 3 * n;
        let mut gamma = vec![0.0; m * nc];
        for c in 0..n {
            // the tangential drive grows towards the patch's edge (the last tenth slips)
            let edge = (c as f64 / n as f64).powi(8);
            gamma[c] = -1.0;
            gamma[m + n + c] = 0.6 * edge;
            gamma[2 * m + 2 * n + c] = 0.4 * edge;
        }
        run("microslip", n, &gamma, 5);
    }
}
