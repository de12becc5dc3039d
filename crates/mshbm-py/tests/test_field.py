"""Full-field results (issue 44): `solve(dofs="all")` keeps every model DOF's harmonics, and
they are the field `mshbm solve --vtk` writes: evaluated at the CLI's sample times they
equal the displacements of its `.vtu` files to 1e-12 (the CLI's own output is the
reference). A list of DOFs selects rows; bad `dofs` raise ArgumentError naming it."""

from __future__ import annotations

import base64
import re

import numpy as np
import pytest

import mshbm
from conftest import BAR, DAMPED, DAMPED_SET

SAMPLES = 8


def vtu_displacement(path) -> np.ndarray:
    """The `displacement` point vectors (nodes × 3) of a `.vtu` of the CLI (binary inline
    data, UInt64 header: the byte count, then little-endian float64)."""
    text = path.read_text()
    found = re.search(r'<DataArray type="Float64" Name="displacement" format="binary"[^>]*>\s*([^<]+?)\s*<', text)
    assert found, f"{path}: no displacement array"
    raw = base64.b64decode(found.group(1))
    size = int.from_bytes(raw[:8], "little")
    return np.frombuffer(raw[8 : 8 + size], dtype="<f8").reshape(-1, 3)


def evaluate(harmonics: np.ndarray, omega: float, t: float) -> np.ndarray:
    h = (harmonics.shape[1] - 1) // 2
    k = np.arange(1, h + 1)
    return harmonics[:, 0] + harmonics[:, 1::2] @ np.cos(k * omega * t) + harmonics[:, 2::2] @ np.sin(k * omega * t)


@pytest.mark.parametrize("method", ["redistributed", "hbm-aft"])
def test_dofs_all_is_the_vtk_field_of_the_cli(cli, tmp_path, method):
    bar = mshbm.Model.from_toml(BAR, DAMPED)
    s = mshbm.solve(bar, 30000, harmonics=3, method=method, stability=False, dofs="all")
    assert s.field_harmonics.shape == (bar.n_dofs, 7)
    assert list(s.field_dofs) == list(range(bar.n_dofs))
    cli("solve", BAR, *DAMPED_SET, "--frequency", 30000, "--harmonics", 3, "--method", method,
        "--no-stability", "--vtk", tmp_path / "bar.pvd", "--vtk-samples", SAMPLES)
    files = sorted((tmp_path / "bar.pvd").glob("*.vtu"))
    assert len(files) == SAMPLES
    omega = 2 * np.pi * s.frequency_hz
    scale = np.abs(s.field_harmonics).max()
    assert scale > 0
    for j, f in enumerate(files):
        t = j / (SAMPLES * s.frequency_hz)
        reference = vtu_displacement(f)[:, 0]  # the bar: one DOF per node, along x
        assert np.abs(evaluate(s.field_harmonics, omega, t) - reference).max() <= 1e-12 * scale, f.name


def test_a_list_of_dofs_selects_rows_and_the_complex_view_matches():
    bar = mshbm.Model.from_toml(BAR, DAMPED)
    full = mshbm.solve(bar, 30000, harmonics=3, stability=False, dofs="all")
    some = mshbm.solve(bar, 30000, harmonics=3, stability=False, dofs=[100, 50, 0])
    assert list(some.field_dofs) == [100, 50, 0]
    np.testing.assert_array_equal(some.field_harmonics, full.field_harmonics[[100, 50, 0]])
    # the contact DOF's harmonics are the solution's own (its unknowns)
    np.testing.assert_allclose(some.field_harmonics[0], some.harmonics_of_contacts[0], rtol=0, atol=1e-12 * np.abs(some.field_harmonics).max())
    c = some.field_complex
    assert c.shape == (3, 4)
    omega, t = 2 * np.pi * some.frequency_hz, 1.234e-6
    q = (c * np.exp(1j * np.arange(4) * omega * t)).real.sum(axis=1)
    np.testing.assert_allclose(q, evaluate(some.field_harmonics, omega, t), rtol=1e-13, atol=1e-18)
    assert mshbm.solve(bar, 30000, harmonics=3, stability=False).field_harmonics is None


@pytest.mark.parametrize("dofs, message", [
    ("every", "dofs='every'"),
    ([101], "DOF 101 is out of range"),
    ([-1], "DOF -1 is out of range"),
    ([1.0], "dofs: 1.0 is not a DOF number"),
    ([True], "dofs: True is not a DOF number"),
    (3, "dofs=3: expected 'all'"),
])
def test_bad_dofs_raise_argument_error_naming_it(dofs, message):
    bar = mshbm.Model.from_toml(BAR, DAMPED)
    with pytest.raises(mshbm.ArgumentError, match=re.escape(message)):
        mshbm.solve(bar, 30000, harmonics=3, stability=False, dofs=dofs)
