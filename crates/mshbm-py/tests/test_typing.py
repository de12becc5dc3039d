"""The package is typed (issue 44): it ships `py.typed` and stubs of its compiled core
(`mshbm/_native.pyi`), the stubs agree with the compiled module (mypy's stubtest), and the
README's Python example passes `mypy --strict` against the installed package."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import mshbm
from conftest import ROOT


def readme_example() -> str:
    text = (ROOT / "README.md").read_text()
    found = re.search(r"```python\n(.*?)```", text, re.S)
    assert found, "README.md has no Python example"
    return found.group(1)


def mypy(*args: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", *args], capture_output=True, text=True, cwd=cwd)


def test_the_installed_package_ships_its_types():
    package = Path(mshbm.__file__).parent
    assert (package / "py.typed").is_file() and (package / "_native.pyi").is_file()


def test_the_stubs_agree_with_the_compiled_module(tmp_path):
    # run outside the source tree, so that the installed package is checked
    out = mypy("mypy.stubtest", "mshbm._native", cwd=tmp_path)
    assert out.returncode == 0, out.stdout + out.stderr


def test_the_readme_example_passes_mypy_strict(tmp_path):
    example = tmp_path / "readme_example.py"
    example.write_text(readme_example())
    out = mypy("mypy", "--strict", "--no-incremental", str(example), cwd=tmp_path)
    assert out.returncode == 0, out.stdout + out.stderr
    # the check can fail: a wrong use of the API is reported
    example.write_text(readme_example() + "\nmshbm.solve(bar, '30000')\n")
    out = mypy("mypy", "--strict", "--no-incremental", str(example), cwd=tmp_path)
    assert out.returncode == 1 and "arg-type" in out.stdout, out.stdout + out.stderr
