//! `mshbm paper --quick`: every figure's image and CSV exist with the documented headers,
//! the values agree with independent references (the continuum's eigenfrequency, the
//! dropped bar's closed form, the gap), and summary.md covers every figure. The full run
//! (a few minutes) is not part of the test suite: `mshbm paper`.

mod common;

use std::collections::HashMap;
use std::path::Path;
use std::process::Output;

use common::{command, FRD_HEADER};

/// Table 1 of the paper.
const DENSITY: f64 = 9e-9;
const YOUNG: f64 = 2.1e5;
const LENGTH: f64 = 20.0;
const GAP: f64 = 0.2;

struct Csv {
    header: String,
    rows: Vec<Vec<String>>,
}

impl Csv {
    fn read(path: &Path) -> Csv {
        let text =
            std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        let mut lines = text.lines();
        let header = lines.next().expect("a header line").to_string();
        let width = header.split(',').count();
        let rows: Vec<Vec<String>> = lines
            .map(|l| l.split(',').map(str::to_string).collect::<Vec<_>>())
            .collect();
        for r in &rows {
            assert_eq!(r.len(), width, "{}: row {r:?}", path.display());
        }
        Csv { header, rows }
    }

    fn column(&self, name: &str) -> usize {
        self.header
            .split(',')
            .position(|c| c == name)
            .unwrap_or_else(|| panic!("no column {name} in {}", self.header))
    }

    fn values(&self, name: &str) -> Vec<f64> {
        let c = self.column(name);
        self.rows
            .iter()
            .map(|r| {
                r[c].parse::<f64>()
                    .unwrap_or_else(|_| panic!("{name}: {}", r[c]))
            })
            .collect()
    }
}

/// `mshbm paper args… --output <dir>`.
fn paper(args: &[&str], dir: &Path) -> Output {
    command()
        .arg("paper")
        .args(args)
        .arg("--output")
        .arg(dir)
        .output()
        .unwrap()
}

#[test]
fn quick_paper_run_writes_every_figure_with_sane_values() {
    let dir = tempfile::tempdir().unwrap();
    let out_dir = dir.path().join("figures");
    let out = paper(&["--quick"], &out_dir);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    // progress names every part
    for part in [
        "Fig. 5",
        "Fig. 8",
        "Fig. 9 branch H = 1",
        "Fig. 9 branch H = 10",
        "Fig. 9 time integration",
        "Fig. 10",
        "Fig. 11 branch MS-HBM",
        "Fig. 11 branch HBM-AFT kp = 1e8",
    ] {
        assert!(stderr.contains(part), "no progress for {part}: {stderr}");
    }

    // every file, images are PNG
    for image in [
        "fig5_dropped_bar",
        "fig8_eigenfrequencies",
        "fig9_frd",
        "fig10_periodic_solution",
        "fig11_frd",
    ] {
        let bytes = std::fs::read(out_dir.join(format!("{image}.png"))).unwrap();
        assert!(bytes.starts_with(b"\x89PNG"), "{image}.png is not a PNG");
    }

    // Fig. 8: the first eigenfrequency of the redistributed mass is the paper's 60335 Hz,
    // and its error against the continuum c/(4L) = 60380.74 Hz is (60335.209 − c/4L)/(c/4L)
    let fig8 = Csv::read(&out_dir.join("fig8_eigenfrequencies.csv"));
    assert_eq!(
        fig8.header,
        "mode,consistent_hz,redistributed_hz,continuum_hz,error_redistributed_vs_consistent,error_redistributed_vs_continuum,error_consistent_vs_continuum"
    );
    assert_eq!(fig8.rows.len(), 30);
    let continuum_f1 = (YOUNG / DENSITY).sqrt() / (4.0 * LENGTH);
    assert!((fig8.values("continuum_hz")[0] - continuum_f1).abs() < 1e-3);
    let f1 = fig8.values("redistributed_hz")[0];
    assert!((f1 - 60335.0).abs() < 0.5, "f1 = {f1}");
    // (60335.209 rounded to 1 mHz: 2e-8 relative)
    let expected = (60335.209 - continuum_f1) / continuum_f1;
    assert!((continuum_f1 - 60380.74).abs() < 0.005);
    let error = fig8.values("error_redistributed_vs_continuum")[0];
    assert!((error - expected).abs() < 2e-8, "{error} vs {expected}");
    // "the shift is negligible": below 1 % for all 30 modes
    assert!(fig8
        .values("error_redistributed_vs_consistent")
        .iter()
        .all(|e| e.abs() < 0.01));

    // Fig. 5: the closed-form column is the free fall h0 − g t²/2 until the impact at
    // t1 = v0/g = 3; the redistributed bar's first contact lasts about 2L/c = 2; e_N = 1 and
    // m_red keep the energy, e_N = 0 loses some at each impact
    let fig5 = Csv::read(&out_dir.join("fig5_dropped_bar.csv"));
    assert_eq!(
        fig5.header,
        "time_s,gap_closed_form,gap_e0,gap_e1,gap_mred,energy_normalized_e0,energy_normalized_e1,energy_normalized_mred"
    );
    let t = fig5.values("time_s");
    let exact = fig5.values("gap_closed_form");
    for (t, g) in t.iter().zip(&exact).filter(|(t, _)| **t < 3.0) {
        assert!((g - (4.5 - t * t / 2.0)).abs() < 1e-9, "t = {t}: {g}");
    }
    let mred = fig5.values("gap_mred");
    assert!(mred.iter().all(|&g| g >= 0.0), "m_red never penetrates");
    let start = mred.iter().position(|&g| g <= 1e-3).unwrap();
    let end = start + mred[start..].iter().position(|&g| g > 1e-3).unwrap();
    let duration = t[end] - t[start];
    assert!((t[start] - 3.0).abs() < 0.05, "impact at {}", t[start]);
    assert!(
        (duration - 2.0).abs() < 0.15,
        "contact lasts {duration}, 2L/c = 2"
    );
    let last = |name: &str| *fig5.values(name).last().unwrap();
    assert!((last("energy_normalized_mred") - 1.0).abs() < 1e-3);
    assert!((last("energy_normalized_e1") - 1.0).abs() < 1e-3);
    assert!(last("energy_normalized_e0") < 0.99);

    // Fig. 9: four branches in the range, never beyond the gap, stability filled
    let fig9 = Csv::read(&out_dir.join("fig9_frd.csv"));
    assert_eq!(fig9.header, FRD_HEADER);
    let mut per_h: HashMap<String, usize> = HashMap::new();
    let (hc, fc, sc) = (
        fig9.column("harmonics"),
        fig9.column("fold"),
        fig9.column("stable"),
    );
    for r in &fig9.rows {
        *per_h.entry(r[hc].clone()).or_default() += 1;
        if r[fc] == "false" {
            assert!(r[sc] == "true" || r[sc] == "false", "{r:?}");
        }
    }
    for h in ["1", "3", "5", "10"] {
        assert!(
            per_h.get(h).copied().unwrap_or(0) >= 2,
            "H = {h}: {per_h:?}"
        );
    }
    for f in fig9.values("frequency_hz") {
        assert!((15000.0 - 1e-6..=17000.0 + 1e-6).contains(&f), "{f}");
    }
    for (mx, mn) in fig9.values("max_qn").iter().zip(fig9.values("min_qn")) {
        assert!(*mx <= GAP * (1.0 + 1e-9) && mn <= *mx, "{mx} {mn}");
    }
    let ti = Csv::read(&out_dir.join("fig9_time_integration.csv"));
    assert_eq!(
        ti.header,
        "frequency_hz,periodic,periods_simulated,period_change,max_qn,min_qn,band_periods,band_max_qn,band_min_qn"
    );
    assert_eq!(ti.rows.len(), 2);
    let (mx, mn) = (ti.values("max_qn"), ti.values("min_qn"));
    let (bmx, bmn) = (ti.values("band_max_qn"), ti.values("band_min_qn"));
    for k in 0..2 {
        assert!(mn[k] <= mx[k] && bmn[k] <= mn[k] && mx[k] <= bmx[k]);
        // e_N = 0 at velocity level lets the node drift slightly past the support
        assert!(mx[k] < GAP + 0.01, "{}", mx[k]);
    }
    // 10 kHz is below the contact (the linear amplitude stays under the gap) and 16 kHz hits
    assert!(mx[0] < GAP && mx[1] > 0.99 * GAP);

    // Fig. 10: no penetration for any H, one block per H
    let fig10 = Csv::read(&out_dir.join("fig10_periodic_solution.csv"));
    assert_eq!(fig10.header, "harmonics,time_s,q_dof100,gap_c0,force_c0");
    let q = fig10.values("q_dof100");
    assert!(q.iter().all(|&q| q <= GAP * (1.0 + 1e-9)));
    assert!(
        q.iter().any(|&q| q > GAP * (1.0 - 1e-9)),
        "the contact closes"
    );
    assert!(fig10.values("gap_c0").iter().all(|&g| g >= -1e-12));
    let hs: std::collections::BTreeSet<String> = fig10.rows.iter().map(|r| r[0].clone()).collect();
    assert_eq!(hs.into_iter().collect::<Vec<_>>(), ["1", "10", "3", "5"]);

    // Fig. 11: MS-HBM and three penalties; the penetration shrinks as kp grows
    let fig11 = Csv::read(&out_dir.join("fig11_frd.csv"));
    assert_eq!(
        fig11.header,
        format!("{FRD_HEADER},method,penalty,max_penetration")
    );
    let (mc, pc, xc) = (
        fig11.column("method"),
        fig11.column("penalty"),
        fig11.column("max_penetration"),
    );
    let mut penetration: Vec<(f64, f64)> = Vec::new();
    for r in &fig11.rows {
        if r[mc] == "hbm-aft" {
            let kp: f64 = r[pc].parse().unwrap();
            let p: f64 = r[xc].parse().unwrap();
            match penetration.iter_mut().find(|(k, _)| *k == kp) {
                Some(e) => e.1 = e.1.max(p),
                None => penetration.push((kp, p)),
            }
        } else {
            assert_eq!(r[mc], "redistributed");
            assert!(r[xc].is_empty());
        }
    }
    penetration.sort_by(|a, b| a.0.total_cmp(&b.0));
    assert_eq!(penetration.len(), 3, "{penetration:?}");
    assert!(penetration[0].1 > penetration[1].1 && penetration[1].1 > penetration[2].1);

    // summary.md: every figure, the damping, the paper's first eigenfrequency
    let summary = std::fs::read_to_string(out_dir.join("summary.md")).unwrap();
    for needle in [
        "## Fig. 5",
        "## Fig. 8",
        "## Fig. 9",
        "## Fig. 10",
        "## Fig. 11",
        "1 % modal damping of mode 1",
        "60335 Hz",
        "QUICK MODE",
        "every part complete",
    ] {
        assert!(summary.contains(needle), "summary.md lacks {needle:?}");
    }
}

#[test]
fn paper_rejects_zero_jobs_and_unknown_formats() {
    let dir = tempfile::tempdir().unwrap();
    let out = paper(&["--jobs", "0"], dir.path());
    assert!(!out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("--jobs"), "{stderr}");
    let out = paper(&["--format", "jpg"], dir.path());
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("jpg"));
}

#[test]
fn a_failing_figure_does_not_lose_the_others() {
    // Fig. 8 cannot write its CSV (a directory is in the way); every other figure is
    // written, summary.md says what failed, and the exit status says so at the end
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir(dir.path().join("fig8_eigenfrequencies.csv")).unwrap();
    let out = paper(&["--quick", "--format", "svg"], dir.path());
    assert!(!out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!stderr.contains("panicked"), "{stderr}");
    let last = stderr.lines().last().unwrap();
    assert!(
        last.starts_with("error: ") && last.contains("Fig. 8"),
        "{stderr}"
    );
    for file in [
        "fig5_dropped_bar.svg",
        "fig9_frd.svg",
        "fig10_periodic_solution.svg",
        "fig11_frd.svg",
        "fig9_frd.csv",
    ] {
        let text = std::fs::read_to_string(dir.path().join(file)).unwrap();
        assert!(file.ends_with(".csv") || text.contains("<svg"), "{file}");
    }
    let summary = std::fs::read_to_string(dir.path().join("summary.md")).unwrap();
    assert!(summary.contains("Status: INCOMPLETE"), "{summary}");
    assert!(summary.contains("## Fig. 8\n\n**FAILED**"), "{summary}");
    assert!(summary.contains("## Fig. 11"), "{summary}");
}
