//! The breathing crack of examples/cracked_beam (node-to-node contact on the two lips,
//! docs/theory.md (T110)) against the bilinear-oscillator estimate: the beam is stiff while
//! the crack is closed and soft while it is open, half a period each, so its primary
//! resonance lies at `f_b = 2 f_open f_closed / (f_open + f_closed)` from the eigenfrequencies
//! of the open-crack and the uncracked (tied) beam, and a superharmonic resonance near
//! `f_b / 2`. The example's mesh is coarsened to 40 × 4 to keep the test fast.

use std::path::Path;

use mshbm::method::settings::MethodSettings;
use mshbm::model::file::parse_model;
use mshbm::solve::{solve_periodic, SolveSettings, SolveStart};
use mshbm::Model;

fn model(text: &str) -> Model {
    parse_model(text, Path::new("cracked_beam.toml"), &[]).unwrap()
}

fn example_text() -> String {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/cracked_beam/model.toml");
    std::fs::read_to_string(path)
        .unwrap()
        .replace("divisions = [80, 8]", "divisions = [40, 4]")
}

/// The largest response maximum over `frequencies` (Hz, ascending), by the redistributed
/// MS-HBM with `harmonics` (each solve starting from the previous solution, or as `mshbm
/// solve` starts when that fails), and where it
/// is (a parabola through the best sample and its neighbours).
fn peak(m: &Model, harmonics: usize, frequencies: &[f64]) -> (f64, f64) {
    let method = MethodSettings::redistributed(harmonics);
    let mut start = SolveStart::Auto;
    let maxima: Vec<f64> = frequencies
        .iter()
        .map(|&f| {
            let settings = SolveSettings {
                stability: false,
                start: start.clone(),
                ..SolveSettings::default()
            };
            let mut s = solve_periodic(m, &method, f, &settings).unwrap();
            if !s.outcome.converged {
                // near the peak the previous point's branch may end between two grid
                // frequencies (a fold): start as `mshbm solve` does by default
                let settings = SolveSettings {
                    stability: false,
                    ..SolveSettings::default()
                };
                s = solve_periodic(m, &method, f, &settings).unwrap();
            }
            assert!(s.outcome.converged, "{f} Hz: {:?}", s.outcome.reason);
            start = SolveStart::Unknowns(s.solution.unknowns.clone().unwrap());
            s.solution.response.max
        })
        .collect();
    let k = (1..maxima.len() - 1)
        .max_by(|&a, &b| maxima[a].total_cmp(&maxima[b]))
        .unwrap();
    let (y0, y1, y2) = (maxima[k - 1], maxima[k], maxima[k + 1]);
    let h = frequencies[k + 1] - frequencies[k];
    let shift = 0.5 * (y0 - y2) / (y0 - 2.0 * y1 + y2);
    assert!(
        maxima[k] > 1.5 * maxima[0].max(*maxima.last().unwrap()),
        "no peak in {frequencies:?}: {maxima:?}"
    );
    (frequencies[k] + shift * h, y1)
}

#[test]
fn the_breathing_crack_resonates_at_the_bilinear_frequency_and_at_half_of_it() {
    let text = example_text();
    let cracked = model(&text);
    assert_eq!(
        cracked.contacts.len(),
        2,
        "five lip pairs on the 80 x 8 mesh, two on 40 x 4"
    );
    // the tied crack: the same beam without the crack (tests/solid_elements.rs shows that
    // tying the lips gives exactly these matrices)
    let tied_text = text
        .lines()
        .filter(|l| !l.starts_with("crack ="))
        .collect::<Vec<_>>()
        .join("\n");
    let tied_text = tied_text[..tied_text.find("[[interfaces]]").unwrap()].to_string()
        + &tied_text[tied_text.find("[damping]").unwrap()..];
    let tied = model(&tied_text);
    assert!(tied.contacts.is_empty());
    let f_open = cracked.compare_masses(1).unwrap().original_hz[0];
    let f_closed = mshbm::modes::eigenfrequencies_hz(
        &tied.system(mshbm::MassKind::Consistent).unwrap().mass,
        &tied.system(mshbm::MassKind::Consistent).unwrap().stiffness,
        1,
    )
    .unwrap()[0];
    let bilinear = 2.0 * f_open * f_closed / (f_open + f_closed);
    assert!(f_open < bilinear && bilinear < f_closed);
    let grid = |lo: f64, hi: f64, n: usize| -> Vec<f64> {
        (0..=n)
            .map(|i| lo + (hi - lo) * i as f64 / n as f64)
            .collect()
    };
    let (primary, amplitude) = peak(&cracked, 5, &grid(0.95 * bilinear, 1.05 * bilinear, 40));
    println!("f_open {f_open:.2} Hz, f_closed {f_closed:.2} Hz, bilinear {bilinear:.2} Hz, primary resonance {primary:.2} Hz");
    assert!(
        ((primary - bilinear) / bilinear).abs() < 0.02,
        "primary resonance {primary} Hz, bilinear frequency {bilinear} Hz"
    );
    let (superharmonic, small) = peak(&cracked, 5, &grid(0.44 * bilinear, 0.56 * bilinear, 48));
    println!(
        "superharmonic resonance {superharmonic:.2} Hz = {:.3} of the bilinear frequency",
        superharmonic / bilinear
    );
    assert!(
        (superharmonic / bilinear - 0.5).abs() < 0.03,
        "superharmonic resonance at {superharmonic} Hz"
    );
    assert!(small < amplitude);
}
