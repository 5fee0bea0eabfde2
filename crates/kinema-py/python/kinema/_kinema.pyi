"""Type stubs of the native module kinema._kinema (crates/kinema-py/src/lib.rs)."""

from typing import Any, Dict, List, Optional, Tuple

import numpy as np
import numpy.typing as npt

MAX_TIMES: int

class KinemaError(Exception):
    """The base class of kinema's errors."""

class ModelError(KinemaError):
    """A model that cannot be read, checked or derived; the message is the
    rendered diagnostics (file:line:column)."""

    diagnostics: List[Dict[str, Any]]

class AnalysisError(KinemaError):
    """An analysis that failed part-way."""

    results: Any

class NativeModel:
    @staticmethod
    def from_text(text: str, file: str) -> NativeModel: ...
    @staticmethod
    def from_file(path: str, acf: Optional[str] = None) -> NativeModel: ...
    @property
    def file(self) -> str: ...
    @property
    def name(self) -> str: ...
    @property
    def is_adm(self) -> bool: ...
    @property
    def motion(self) -> str:
        """"kinematic", "forward" or "prescribed", as `kinema run` decides."""
    @property
    def default_step(self) -> float:
        """Forward dynamics' step when none is given (s): a Dynamics ACF's
        stepSize, 1e-3 for a .kin model."""
    def param_names(self) -> List[str]: ...
    def param_values(self) -> List[float]: ...
    def warnings(self) -> List[str]: ...
    def with_params(self, values: List[Tuple[str, float]]) -> NativeModel: ...
    def check(self) -> Dict[str, Any]: ...
    def grid(self, t_end: Optional[float] = None, steps: Optional[int] = None) -> Tuple[List[float], List[bool]]: ...
    def columns(self, columns: Optional[str] = None, positions_only: bool = False) -> List[str]: ...
    def run(
        self,
        times: Optional[List[float]],
        outputs: Optional[List[bool]] = None,
        columns: Optional[str] = None,
        positions_only: bool = False,
        stop_at_singular: bool = False,
        backend: str = "jit",
        t_end: Optional[float] = None,
        steps: Optional[int] = None,
    ) -> Dict[str, Any]: ...
    def sweep(
        self,
        names: List[str],
        table: npt.NDArray[np.float64],
        times: List[float],
        first: int = 0,
        positions_only: bool = False,
        stop_at_singular: bool = False,
        backend: str = "jit",
        threads: Optional[int] = None,
    ) -> Dict[str, Any]: ...
    def forward(
        self,
        times: List[float],
        columns: Optional[str] = None,
        integrator: str = "hht",
        step: Optional[float] = None,
        rtol: Optional[float] = None,
        project_velocity: bool = False,
        energy: bool = False,
        backend: str = "jit",
    ) -> Dict[str, Any]:
        """Forward dynamics through `times` (s): columns, values, passages,
        redundancy, consistency, integrator, energies (J), imprecise, error,
        motion, backend, rust_seconds."""
    def equilibrium(self, columns: Optional[str] = None, backend: str = "jit") -> Dict[str, Any]:
        """The stable static equilibrium at t = 0: columns, values (one row),
        stability, stable, eigenvalues, residual, gradient, iterations."""
