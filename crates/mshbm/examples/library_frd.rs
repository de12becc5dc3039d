//! The paper's bar traced through the library, as `mshbm frf` does it: a model file with an
//! override, the redistributed MS-HBM for H = 1 and 3, an observer that prints progress,
//! and the report (branches, folds, why each branch stopped).
//!
//! `cargo run --release -p mshbm --example library_frd` (from the repository root).

use mshbm::frd::{trace_diagram, BranchReport, FrdObserver, FrdSettings, PointEvent};
use mshbm::method::settings::MethodSettings;
use mshbm::model::file::load_model;

/// Prints every 100th point and each branch's end.
struct Progress;

impl FrdObserver for Progress {
    fn point(&mut self, event: &PointEvent<'_>) -> mshbm::Result<()> {
        let PointEvent {
            branch,
            point,
            points,
            ..
        } = *event;
        if points % 100 == 0 {
            println!(
                "{}: {:.1} Hz, max {:.4}",
                branch.label, point.frequency_hz, point.max_qn
            );
        }
        Ok(())
    }

    fn finish(&mut self, branch: &BranchReport) {
        println!(
            "{}: {} points, {}",
            branch.label,
            branch.points.len(),
            branch.stop
        );
    }
}

fn main() -> mshbm::Result<()> {
    let path =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/clamped_bar.toml");
    let model = load_model(&path, &["damping.first_mode_ratio=0.01".to_string()])?;
    let settings = FrdSettings::new(20_000.0, 40_000.0);
    let report = trace_diagram(
        &model,
        &[MethodSettings::redistributed(1)],
        &[1, 3],
        &settings,
        &mut Progress,
    )?;
    for fold in &report.folds {
        println!("fold ({}): {:.3} Hz", fold.label, fold.frequency_hz);
    }
    Ok(())
}
