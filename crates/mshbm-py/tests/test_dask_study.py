"""The Dask example (examples/python/frd_study.py) on a LocalCluster with 2 workers: its
table equals the same diagrams run serially, and it draws the overlay."""

from __future__ import annotations

import importlib.util
import sys

import pandas as pd
import pytest

from conftest import ROOT

distributed = pytest.importorskip("distributed", reason="dask.distributed is part of requirements-test.txt")


def load_study():
    path = ROOT / "examples" / "python" / "frd_study.py"
    spec = importlib.util.spec_from_file_location("frd_study", path)
    module = importlib.util.module_from_spec(spec)
    sys.modules["frd_study"] = module  # workers unpickle the task function by this name
    spec.loader.exec_module(module)
    return module


def test_study_on_a_local_cluster_equals_the_serial_run(tmp_path):
    study = load_study()
    points = study.grid({"gap": [0.1, 0.2], "damping": [0.01], "force": [2000.0, 4000.0]})
    sweep = {"from_hz": 20000.0, "to_hz": 45000.0, "harmonics": [1, 2]}
    assert len(points) == 4
    base = study.mshbm.Model.from_toml(study.BAR)
    serial = study.run_serial(base, points, sweep)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster, distributed.Client(cluster) as client:
        parallel = study.run_dask(client, base, points, sweep, timeout=600)
        # both workers took part
        assert len(client.scheduler_info()["workers"]) == 2
    assert len(serial) > 100
    assert set(map(tuple, serial[["gap", "damping", "force"]].drop_duplicates().values)) == {
        (p["gap"], p["damping"], p["force"]) for p in points}
    pd.testing.assert_frame_equal(parallel, serial, check_exact=True)
    # a different grid point gives a different diagram: the comparison can fail
    assert not serial[serial["gap"] == 0.1]["min_qn"].reset_index(drop=True).equals(
        serial[serial["gap"] == 0.2]["min_qn"].reset_index(drop=True))
    study.plot(serial, tmp_path / "overlay.png")
    assert (tmp_path / "overlay.png").stat().st_size > 10_000
