"""Types of the compiled core `mshbm._native` (crates/mshbm-py/src), written by hand from
its `#[pyo3(signature …)]`s; the public API is the pure-Python package around it."""

from collections.abc import Callable, Sequence
from os import PathLike
from typing import Any, final

import numpy as np
import numpy.typing as npt

__all__ = [
    "MshbmError",
    "ModelError",
    "ArgumentError",
    "NotConvergedError",
    "NativeModel",
    "solve",
    "frf",
    "modes",
    "simulate",
    "__version__",
]

__version__: str

class MshbmError(Exception): ...
class ModelError(MshbmError, ValueError): ...
class ArgumentError(MshbmError, ValueError):
    #: the keyword at fault (None when the message names it otherwise)
    argument: str | None

class NotConvergedError(MshbmError, RuntimeError):
    #: the partial result, when one exists
    result: Any


#: a sparse matrix as the extension reads it: (shape, data, indices, indptr) of CSC
_Csc = tuple[tuple[int, int], npt.NDArray[np.float64], npt.NDArray[Any], npt.NDArray[Any]]

@final
class NativeModel:
    @staticmethod
    def from_toml(
        path: str | PathLike[str],
        overrides: Sequence[str] = ...,
        max_memory_gib: float | None = None,
        allow_outside_paths: bool = False,
    ) -> NativeModel: ...
    @staticmethod
    def from_toml_text(
        text: str,
        path: str | PathLike[str],
        overrides: Sequence[str] = ...,
        max_memory_gib: float | None = None,
        allow_outside_paths: bool = False,
    ) -> NativeModel: ...
    @staticmethod
    def from_arrays(
        *,
        mass: _Csc,
        stiffness: _Csc,
        coordinates: npt.NDArray[np.float64],
        dofs_per_node: int,
        dirichlet: Sequence[int],
        contacts: Sequence[tuple[Sequence[int], Sequence[float], float]],
        harmonic_load: npt.NDArray[np.float64],
        constant_load: npt.NDArray[np.float64],
        damping_matrix: _Csc | None = None,
        alpha: float = 0.0,
        beta: float = 0.0,
        beta_linear: float = 0.0,
        beta_condensed: float = 0.0,
        first_mode_ratio: float | None = None,
        name: str | None = None,
        acceleration: Sequence[float] | None = None,
        max_memory_gib: float | None = None,
    ) -> NativeModel: ...
    @property
    def name(self) -> str: ...
    @property
    def n_dofs(self) -> int: ...
    @property
    def source(self) -> str: ...
    @property
    def contact_dofs(self) -> list[list[int]]: ...
    def recipe(self) -> Any: ...
    def arrays(self) -> dict[str, Any]: ...

def solve(
    model: NativeModel,
    frequency: float,
    harmonics: int | None = None,
    *,
    method: str | None = None,
    samples: int | None = None,
    quadrature: str | None = None,
    mass: str | None = None,
    penalty: Sequence[str] = ...,
    tangential_penalty: str | None = None,
    tolerance: float | None = None,
    max_iterations: int | None = None,
    dof: int | None = None,
    stability_modes: int | None = None,
    receptance: str | None = None,
    receptance_modes: int | None = None,
    jacobian: str | None = None,
    stability: bool | None = None,
    start: str | None = None,
    start_solution: str | None = None,
    sweep_from: float | None = None,
    sweep_to: float | None = None,
    field: bool = False,
    threads: int | None = None,
) -> dict[str, Any]: ...
def frf(
    model: NativeModel,
    from_hz: float,
    to_hz: float,
    harmonics: Sequence[int] | None = None,
    *,
    method: str | None = None,
    samples: int | None = None,
    quadrature: str | None = None,
    mass: str | None = None,
    penalty: Sequence[str] = ...,
    tangential_penalty: str | None = None,
    tolerance: float | None = None,
    max_iterations: int | None = None,
    dof: int | None = None,
    stability_modes: int | None = None,
    receptance: str | None = None,
    receptance_modes: int | None = None,
    jacobian: str | None = None,
    step: float | None = None,
    max_step: float | None = None,
    min_step: float | None = None,
    max_turn: float | None = None,
    stability: bool | None = None,
    overlay_mshbm: bool | None = None,
    max_points: int | None = None,
    callback: Callable[[dict[str, Any]], object] | None = None,
    threads: int | None = None,
) -> dict[str, Any]: ...
def modes(model: NativeModel, count: int = 30, *, threads: int | None = None) -> dict[str, Any]: ...
def simulate(
    model: NativeModel,
    frequency: float | None = None,
    *,
    periods: float | None = None,
    duration: float | None = None,
    steps_per_period: int | None = None,
    dt: float | None = None,
    scheme: str | None = None,
    restitution: float | None = None,
    theta: float | None = None,
    steady_state: bool = False,
    periodicity: str | None = None,
    tolerance: float | None = None,
    harmonics: int | None = None,
    dof: int | None = None,
    start_solution: str | None = None,
    record: bool = True,
    threads: int | None = None,
) -> dict[str, Any]: ...
