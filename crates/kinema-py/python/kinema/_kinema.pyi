"""Type stubs of the native module kinema._kinema (crates/kinema-py/src/lib.rs)."""

from typing import Any, Dict, List, Optional, Tuple, TypedDict

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

# The arguments of the native analyses, one dict each (src/request.rs);
# a key left out takes its default, an unknown key is a TypeError.

class _RunRequired(TypedDict):
    times: Optional[List[float]]

class RunRequest(_RunRequired, total=False):
    outputs: Optional[List[bool]]  # default None: every time an output
    columns: Optional[str]  # default None: every column
    positions_only: bool  # default False
    stop_at_singular: bool  # default False
    backend: str  # default "jit"
    t_end: Optional[float]  # the grid's, when times is None
    steps: Optional[int]  # the grid's, when times is None

class _ForwardRequired(TypedDict):
    times: List[float]

class ForwardRequest(_ForwardRequired, total=False):
    columns: Optional[str]  # default None: every column
    integrator: str  # default "hht"
    step: Optional[float]  # default None: the model's default step
    rtol: Optional[float]  # default None: 1e-8
    project_velocity: bool  # default False
    energy: bool  # default False
    backend: str  # default "jit"

class _SweepRequired(TypedDict):
    names: List[str]
    table: npt.NDArray[np.float64]
    times: List[float]

class SweepRequest(_SweepRequired, total=False):
    first: int  # default 0
    positions_only: bool  # default False
    stop_at_singular: bool  # default False
    backend: str  # default "jit"
    threads: Optional[int]  # default None: all cores

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
    def run(self, request: RunRequest) -> Dict[str, Any]:
        """Kinematic analysis: columns, values, events, flagged, kinks,
        output_kinks, imprecise, error, backend, rust_seconds."""
    def sweep(self, request: SweepRequest) -> Dict[str, Any]:
        """A sweep: columns, values, failures, flagged."""
    def forward(self, request: ForwardRequest) -> Dict[str, Any]:
        """Forward dynamics through `times` (s): columns, values, passages,
        redundancy, consistency, integrator, energies (J), imprecise, error,
        motion, backend, rust_seconds."""
    def equilibrium(self, columns: Optional[str] = None, backend: str = "jit") -> Dict[str, Any]:
        """The stable static equilibrium at t = 0: columns, values (one row),
        stability, stable, eigenvalues, residual, gradient, iterations."""
