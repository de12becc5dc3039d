"""The friction damper's preload study (examples/friction_damper/preload_study.py): seven
diagrams, each completed, whose peaks show the friction damper's classic behaviour — the
lowest peak at an intermediate preload, and the heaviest preload's peak at the resonance of
the beam with its tip stuck, an independent eigenvalue solve (stuck.toml) — as the script
checks them itself."""

from __future__ import annotations

import importlib.util

from conftest import EXAMPLES


def load_study():
    path = EXAMPLES / "friction_damper" / "preload_study.py"
    spec = importlib.util.spec_from_file_location("preload_study", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_preload_study_shows_an_optimal_preload(tmp_path, capsys):
    study = load_study()
    csv = tmp_path / "study.csv"
    rc = study.main(["--csv", str(csv), "--peaks-plot", str(tmp_path / "peaks.png")])
    out = capsys.readouterr()
    assert rc == 0, out.err
    assert (tmp_path / "peaks.png").stat().st_size > 0
    import pandas as pd

    table = pd.read_csv(csv)
    assert sorted(table["preload"].unique()) == study.PRELOADS
    # every point's state fractions add up, and the friction dissipates
    assert ((table["stick"] + table["slip"] + table["open"] - 1.0).abs() < 1e-6).all()
    assert (table["dissipated_energy"] >= 0.0).all()
    peaks = study.peaks(table)
    best = peaks.loc[peaks["peak"].idxmin()]
    assert 2.0 < best["preload"] < 200.0
    # the optimum damps the peak several times below both extremes
    assert peaks["peak"].iloc[0] > 3 * best["peak"] and peaks["peak"].iloc[-1] > 3 * best["peak"]
