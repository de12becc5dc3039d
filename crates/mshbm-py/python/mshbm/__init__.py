"""mshbm: periodic solutions and nonlinear frequency response diagrams of mechanical
systems with unilateral contact (Mixed Shooting–Harmonic Balance Method), from Python.

A thin layer over the Rust library that the ``mshbm`` command runs: the same
computations, defaults and messages. Frequencies are in Hz; lengths, forces and masses
in the model's units (the paper's bar: mm, N, t, s). The GIL is released while the
library computes; ``threads=`` bounds the threads a call uses.

>>> import mshbm
>>> bar = mshbm.Model.from_toml("examples/clamped_bar.toml",
...                             {"damping.first_mode_ratio": 0.01})
>>> s = mshbm.solve(bar, 30000, harmonics=3)          # doctest: +SKIP
>>> d = mshbm.frf(bar, 20000, 40000, harmonics=[1, 3])  # doctest: +SKIP
"""

from ._native import (
    ArgumentError,
    ModelError,
    MshbmError,
    NotConvergedError,
    __version__,
)
from ._model import Model
from ._results import (
    Branch,
    Floquet,
    FrequencyResponse,
    Modes,
    Simulation,
    Solution,
    SteadyState,
)
from ._api import ArgumentTypeError, frf, modes, simulate, solve, stability

__all__ = [
    "ArgumentTypeError",
    "Model",
    "solve",
    "frf",
    "modes",
    "simulate",
    "stability",
    "Solution",
    "Floquet",
    "FrequencyResponse",
    "Branch",
    "Modes",
    "Simulation",
    "SteadyState",
    "MshbmError",
    "ModelError",
    "ArgumentError",
    "NotConvergedError",
    "__version__",
]
