"""The package under test is the one `pip install ./crates/mshbm-py` installed (not the
source tree), with its compiled extension."""

from pathlib import Path

import mshbm
import mshbm._native
from conftest import ROOT


def test_the_installed_package_is_imported():
    package = Path(mshbm.__file__).resolve().parent
    assert "site-packages" in package.parts, package
    assert not package.is_relative_to(ROOT / "crates" / "mshbm-py" / "python")
    assert Path(mshbm._native.__file__).resolve().parent == package
    assert mshbm.__version__ == "0.1.0"
    assert issubclass(mshbm.ModelError, mshbm.MshbmError) and issubclass(mshbm.NotConvergedError, mshbm.MshbmError)
