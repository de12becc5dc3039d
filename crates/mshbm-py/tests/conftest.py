"""Shared fixtures: the repository's examples and the `mshbm` binary the Python results
are compared with (the independent reference: the CLI's own outputs)."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[3]
EXAMPLES = ROOT / "examples"
BAR = EXAMPLES / "clamped_bar.toml"
#: 1 % modal damping of the first mode: a finite resonance peak, as the README's command
DAMPED = {"damping.first_mode_ratio": 0.01}
DAMPED_SET = ["--set", "damping.first_mode_ratio=0.01"]


def cli_path() -> Path:
    """The release binary built by `cargo test --release --workspace` (tools/test-all),
    or $MSHBM_CLI."""
    if "MSHBM_CLI" in os.environ:
        return Path(os.environ["MSHBM_CLI"])
    target = Path(os.environ.get("CARGO_TARGET_DIR", ROOT / "target"))
    return target / "release" / "mshbm"


@pytest.fixture(scope="session")
def cli():
    """Run `mshbm ARGS…`; returns the CompletedProcess (text)."""
    path = cli_path()
    if not path.exists():
        pytest.fail(f"{path} is missing: build it with `cargo build --release -p mshbm-cli` (tools/test-all does)")

    def run(*args, check=True):
        out = subprocess.run([str(path), *map(str, args)], capture_output=True, text=True, cwd=ROOT)
        if check and out.returncode != 0:
            raise AssertionError(f"mshbm {' '.join(map(str, args))} failed ({out.returncode}):\n{out.stderr}")
        return out

    return run


@pytest.fixture(scope="session")
def cli_json(cli):
    def run(*args):
        return json.loads(cli(*args, "--json").stdout)

    return run


@pytest.fixture
def general_model(tmp_path):
    """The bar as a `kind = "matrices"` model in a temporary directory (as the CLI's
    bad-input tests)."""
    for f in ["mass.mtx", "stiffness.mtx", "nodes.txt", "harmonic_load.mtx", "constant_load.mtx", "model.toml"]:
        shutil.copy(EXAMPLES / "bar_matrices" / f, tmp_path / f)
    return tmp_path


def assert_same_numbers(python, reference, rel=1e-12, path="$"):
    """Every number of `reference` (JSON of the CLI) equals the one of `python` (the
    Python result, arrays included) to `rel`; strings and booleans equal."""
    import numpy as np

    if isinstance(reference, dict):
        assert isinstance(python, dict), f"{path}: {type(python)}"
        assert set(reference) <= set(python), f"{path}: missing {set(reference) - set(python)}"
        for k, v in reference.items():
            assert_same_numbers(python[k], v, rel, f"{path}.{k}")
    elif isinstance(reference, list):
        py = python.tolist() if hasattr(python, "tolist") else python
        assert len(py) == len(reference), f"{path}: {len(py)} != {len(reference)}"
        for k, (a, b) in enumerate(zip(py, reference)):
            assert_same_numbers(a, b, rel, f"{path}[{k}]")
    elif isinstance(reference, bool) or isinstance(reference, str) or reference is None:
        assert python == reference, f"{path}: {python!r} != {reference!r}"
    else:
        a, b = float(python), float(reference)
        assert abs(a - b) <= rel * max(abs(b), 1e-300) or a == b, f"{path}: {a!r} != {b!r}"
        assert np.isfinite(a)
