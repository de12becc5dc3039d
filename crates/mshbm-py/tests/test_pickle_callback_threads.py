"""Pickling of models and results, the per-point callback of `frf` (progress, early
stop), the GIL released during computation, and the thread count of a call."""

from __future__ import annotations

import pickle
import threading
import time

import numpy as np
import pytest

import mshbm
from conftest import BAR, DAMPED


@pytest.fixture(scope="module")
def bar():
    return mshbm.Model.from_toml(BAR, DAMPED)


def test_models_pickle(bar):
    again = pickle.loads(pickle.dumps(bar))
    assert again.name == bar.name and again.source == bar.source
    a = mshbm.solve(bar, 30000, 2, stability=False)
    b = mshbm.solve(again, 30000, 2, stability=False)
    assert np.array_equal(a.unknowns, b.unknowns)
    # the overrides travel with the model: without them the answer differs
    undamped = mshbm.solve(mshbm.Model.from_toml(BAR), 30000, 2, stability=False)
    assert not np.array_equal(a.unknowns, undamped.unknowns)
    arrays = mshbm.Model.from_arrays(**bar.arrays())
    c = mshbm.solve(pickle.loads(pickle.dumps(arrays)), 30000, 2, stability=False)
    assert np.array_equal(a.unknowns, c.unknowns)


def test_with_overrides_adds_to_the_overrides_of_the_file(bar):
    gap = bar.with_overrides({"contact.gap": 0.1})
    direct = mshbm.Model.from_toml(BAR, {**DAMPED, "contact.gap": 0.1})
    assert gap.arrays()["contacts"] == direct.arrays()["contacts"] == [{"dofs": [100], "w": [-1.0], "gap": 0.1}]
    again = pickle.loads(pickle.dumps(gap))
    a = mshbm.solve(again, 30000, 2, stability=False)
    assert np.array_equal(a.unknowns, mshbm.solve(direct, 30000, 2, stability=False).unknowns)
    assert not np.array_equal(a.unknowns, mshbm.solve(bar, 30000, 2, stability=False).unknowns)


def test_results_pickle(bar):
    results = [
        mshbm.solve(bar, 30000, 2),
        mshbm.frf(bar, 20000, 30000, [1, 2]),
        mshbm.modes(bar, 3),
        mshbm.simulate(bar, 30000, periods=2),
    ]
    for r in results:
        again = pickle.loads(pickle.dumps(r))
        assert type(again) is type(r) and again == r
        assert list(again.to_dict()) == list(r.to_dict())
    assert results[0] != mshbm.solve(bar, 31000, 2)


def test_the_callback_sees_every_point_and_can_stop_the_diagram(bar):
    full = mshbm.frf(bar, 20000, 40000, [1, 3])
    seen = []
    d = mshbm.frf(bar, 20000, 40000, [1, 3], callback=seen.append)  # None: go on
    assert d == full and len(seen) == len(full.to_dict()["frequency_hz"])
    assert seen[0]["label"] == "H = 1" and seen[-1]["harmonics"] == 3

    calls = []

    def stop_at_40(point):
        calls.append(point)
        return len(calls) < 40

    d = mshbm.frf(bar, 20000, 40000, [1, 3], callback=stop_at_40)
    assert not d.completed and d.stopped_by_callback
    assert "stopped by the callback" in d.stop_reason
    points = d.to_dict()
    assert len(points["frequency_hz"]) == len(calls) == 40
    # the partial result is the beginning of the full diagram
    ref = full.to_dict()
    n = len(points["frequency_hz"])
    for key in ("frequency_hz", "max_qn", "min_qn", "harmonics"):
        assert np.array_equal(points[key], ref[key][:n]), key
    assert d.branches[-1].completed is False and d.branches[-1].stop == d.stop_reason.split(": ", 1)[1]


def test_a_callback_exception_stops_the_diagram_and_propagates(bar):
    def boom(point):
        if point["frequency_hz"] > 25000:
            raise RuntimeError("enough")

    with pytest.raises(RuntimeError, match="enough"):
        mshbm.frf(bar, 20000, 40000, 1, callback=boom)


def test_the_gil_is_released_while_computing(bar):
    """A Python thread keeps running while another solves: with the GIL held it would
    be frozen for the whole call."""
    ticks = []
    done = threading.Event()

    def tick():
        while not done.is_set():
            ticks.append(time.perf_counter())
            time.sleep(0.001)

    t = threading.Thread(target=tick)
    t.start()
    start = time.perf_counter()
    mshbm.frf(bar, 1000, 100000, [3, 5, 10])
    end = time.perf_counter()
    done.set()
    t.join()
    during = [x for x in ticks if start < x < end]
    gaps = np.diff(during)
    assert end - start > 0.3, "the computation is too short to tell"
    assert len(during) > 50 and gaps.max() < 0.1, (len(during), gaps.max())


def test_threads_bound_the_call_and_change_no_number(bar):
    a = mshbm.frf(bar, 28000, 32000, 3, threads=1)
    b = mshbm.frf(bar, 28000, 32000, 3)
    assert a == b
    s1 = mshbm.solve(bar, 60000, 1, method="mshbm", threads=1, stability=False)
    s2 = mshbm.solve(bar, 60000, 1, method="mshbm", threads=2, stability=False)
    assert np.array_equal(s1.unknowns, s2.unknowns)


def test_a_pickled_matrices_model_reads_its_files_from_another_directory(tmp_path, monkeypatch):
    from conftest import ROOT

    monkeypatch.chdir(ROOT)
    m = mshbm.Model.from_toml("examples/bar_matrices/model.toml", ["contacts.0.gap=0.1"])
    blob = pickle.dumps(m)
    monkeypatch.chdir(tmp_path)
    again = pickle.loads(blob)
    assert again.n_dofs == 101 and again.arrays()["contacts"][0]["gap"] == 0.1


def test_the_callback_runs_in_a_thread_pool_too(bar):
    seen = []
    d = mshbm.frf(bar, 20000, 40000, 1, threads=1, callback=lambda p: seen.append(p) or len(seen) < 5)
    assert d.stopped_by_callback and len(seen) == 5 == len(d.branches[0])


def test_a_numpy_false_from_the_callback_stops_the_diagram(bar):
    """A comparison of numpy values returns `numpy.False_`, which stops like `False`;
    `numpy.True_` goes on."""
    seen = []

    def callback(p):
        seen.append(p)
        return np.float64(p["min_qn"]) < np.float64(np.inf) if len(seen) < 3 else np.bool_(False)

    d = mshbm.frf(bar, 20000, 40000, 1, threads=1, callback=callback)
    assert d.stopped_by_callback and len(seen) == 3 == len(d.branches[0])
