"""kinema for Python: planar mechanisms in absolute coordinates.

Each body i has the coordinates q_i = (x_i, y_i, phi_i): the position of its
reference point in metres and its angle in radians. A model (kinema's ``.kin``
language, or a simEngine2D ``.adm`` file) lists bodies, joints and drivers;
kinema derives the constraint equations Phi(q, t) = 0 symbolically with
their Jacobian Phi_q, the velocity right-hand side nu and the acceleration
right-hand side gamma, and solves over a time grid

* position:      Phi(q, t) = 0        (Newton-Raphson),
* velocity:      Phi_q q_dot = nu,
* acceleration:  Phi_q q_ddot = gamma,

exactly as the ``kinema`` command line does: :meth:`Model.run` returns the
numbers of ``kinema run``'s CSV, column for column, and :meth:`Model.sweep`
those of ``kinema sweep``. Times are in seconds, lengths in metres, angles in
radians, their rates per second (per second squared for ``_ddot``); a model
with inertia adds inverse dynamics: Lagrange multipliers ``lambda.*``, joint
reactions ``reaction.*`` in newtons and newton-metres, driver efforts
``driver.*``.

A model with inertia (mass m_i and polar moment J_i on every body) and free
degrees of freedom runs forward dynamics instead (:meth:`Model.run` decides as
``kinema run`` does; :meth:`Model.forward` says so explicitly): the index-3
equations of motion

* M q_ddot + Phi_q^T lambda = Q_A(q, q_dot, t),   Phi(q, t) = 0,

integrated by HHT-alpha at a fixed step or by error-controlled Dormand-Prince
5(4) on the index-1 form; :meth:`Model.equilibrium` finds the stable static
equilibrium (Phi_q^T lambda = Q_A with q_dot = q_ddot = 0).

The GIL is released while Rust computes, so threads (and Dask workers, see
:mod:`kinema.dask`) run models in parallel.
"""

from __future__ import annotations

import math
import numbers
import os
import warnings
from typing import Any, Dict, Iterable, List, Mapping, Optional, Sequence, Tuple, Union

import numpy as np

from ._kinema import AnalysisError, KinemaError, ModelError, NativeModel

__all__ = [
    "Model",
    "Results",
    "Event",
    "KinemaError",
    "ModelError",
    "AnalysisError",
    "KinemaWarning",
    "ModelWarning",
    "SingularConfigurationWarning",
    "KinkWarning",
    "PrecisionWarning",
    "RedundantConstraintsWarning",
    "EnergyBalanceWarning",
    "StabilityWarning",
    "SweepWarning",
]

__version__ = "0.1.0"


class KinemaWarning(UserWarning):
    """The base class of kinema's warnings."""


class ModelWarning(KinemaWarning):
    """A warning of the model check (the rendered diagnostic)."""


class SingularConfigurationWarning(KinemaWarning):
    """The run met a singular configuration (Phi_q rank-deficient): a
    bifurcation, a toggle (dead point), a lock-up; or output rows lie within
    the threshold of one, their q_dot and q_ddot the limits along the branch."""


class KinkWarning(KinemaWarning):
    """Output rows where a function of an equation or of a result column is
    not differentiable (atan2 at (0, 0), sqrt at 0, ...): their rates are
    not determined by the model."""


class PrecisionWarning(KinemaWarning):
    """Output rows with an equation that its own floating-point arithmetic
    does not determine (sin(1e30 * t), large numbers that cancel)."""


class RedundantConstraintsWarning(KinemaWarning):
    """Forward dynamics of a model whose equations are dependent at the start
    (redundant constraints): the motion is determined, the constraint forces
    of those equations (their lambda, reactions, driver efforts) are the
    minimum-norm values."""


class EnergyBalanceWarning(KinemaWarning):
    """Forward dynamics whose energy balance, kinetic + potential - work of
    the other forces, is off by more than 1 % of the energies: the results
    are not accurate (a smaller ``step``, or ``integrator="accurate"``)."""


class StabilityWarning(KinemaWarning):
    """The equilibrium found is not stable: a small disturbance moves the
    mechanism away."""


class SweepWarning(KinemaWarning):
    """Variants of a sweep that failed (with ``errors="warn"``) or whose
    rows were flagged."""


_Number = Union[int, float]
TableLike = Union[Mapping[str, Sequence[float]], Any]


class Event:
    """A singular configuration met during a run.

    Attributes:
        kind: ``"bifurcation"``, ``"toggle"``, ``"lock-up"`` or ``"at-end"``
            (kinematics), ``"passage"`` (forward dynamics went through it).
        t: the time in seconds.
        equations: the names of the dependent equations there.
        message: the CLI's warning text.
    """

    __slots__ = ("kind", "t", "equations", "message")

    def __init__(self, kind: str, t: float, equations: List[str], message: str) -> None:
        self.kind = kind
        self.t = t
        self.equations = equations
        self.message = message

    def __repr__(self) -> str:
        return f"Event(kind={self.kind!r}, t={self.t!r}, equations={self.equations!r})"


class Results:
    """The table of a run or sweep: ``columns`` (the CSV header's names) and
    ``values`` (a 2-D float64 numpy array, one row per output time).

    ``results["coupler.p.x"]`` is one column (a view of ``values``);
    :meth:`to_pandas` makes a DataFrame. ``events`` lists the singular
    configurations met; ``flagged``, ``kinks``, ``output_kinks`` and
    ``imprecise`` the output times the CLI warns about; ``backend`` the
    back end the run ended on (``"jit"`` or ``"tape"``). ``info`` holds
    what the CLI's summary says of a forward run or an equilibrium (the
    integrator and its counters, the consistency corrections at the start,
    the energies, the redundancy; the stability and the reduced Hessian's
    eigenvalues), empty for a kinematic run.
    """

    def __init__(
        self,
        columns: List[str],
        values: np.ndarray,
        events: Optional[List[Event]] = None,
        flagged: Optional[List[float]] = None,
        kinks: Optional[List[Tuple[float, str]]] = None,
        output_kinks: Optional[List[Tuple[float, str, str]]] = None,
        imprecise: Optional[List[Tuple[float, str, str]]] = None,
        failures: Optional[List[Tuple[int, str]]] = None,
        backend: Optional[str] = None,
        rust_seconds: Optional[float] = None,
        info: Optional[Dict[str, Any]] = None,
    ) -> None:
        self.columns: List[str] = list(columns)
        self.values: np.ndarray = values
        self.events: List[Event] = events or []
        self.flagged: List[float] = flagged or []
        self.kinks: List[Tuple[float, str]] = kinks or []
        self.output_kinks: List[Tuple[float, str, str]] = output_kinks or []
        self.imprecise: List[Tuple[float, str, str]] = imprecise or []
        self.failures: List[Tuple[int, str]] = failures or []
        self.backend = backend
        #: Seconds the run spent in Rust (the solver loop), for measuring
        #: the Python overhead around it; None for sweeps.
        self.rust_seconds = rust_seconds
        self.info: Dict[str, Any] = info or {}
        self._index = {name: k for k, name in enumerate(self.columns)}

    @property
    def shape(self) -> Tuple[int, int]:
        """(rows, columns)."""
        return self.values.shape  # type: ignore[return-value]

    def __len__(self) -> int:
        return int(self.values.shape[0])

    def __getitem__(self, name: str) -> np.ndarray:
        if not isinstance(name, str):
            raise TypeError(f"columns are selected by name (a str), not {type(name).__name__}")
        try:
            k = self._index[name]
        except KeyError:
            close = [c for c in self.columns if name.split(".")[0] in c][:8]
            hint = f"; similar: {', '.join(close)}" if close else ""
            raise KeyError(f"no column {name!r}{hint}") from None
        return self.values[:, k]

    def __contains__(self, name: object) -> bool:
        return name in self._index

    def to_pandas(self) -> Any:
        """The table as a ``pandas.DataFrame`` (pandas must be installed)."""
        try:
            import pandas as pd
        except ImportError as e:  # pragma: no cover - depends on the environment
            raise ImportError("Results.to_pandas needs pandas: pip install pandas") from e
        return pd.DataFrame(self.values, columns=self.columns, copy=False)

    def __repr__(self) -> str:
        rows, cols = self.values.shape
        return f"<kinema.Results {rows} rows x {cols} columns: {', '.join(self.columns[:6])}{', ...' if cols > 6 else ''}>"


def _check_real(name: str, value: Any) -> Optional[float]:
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise TypeError(f"{name} must be a number, found {type(value).__name__} {value!r}")
    return float(value)


def _check_int(name: str, value: Any) -> Optional[int]:
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise TypeError(f"{name} must be a whole number (int), found {type(value).__name__} {value!r}")
    return int(value)


def _columns_spec(columns: Any) -> Optional[str]:
    if columns is None:
        return None
    if isinstance(columns, str):
        return columns
    if isinstance(columns, Iterable):
        items = list(columns)
        for c in items:
            if not isinstance(c, str):
                raise TypeError(f"columns must be names (str), found {type(c).__name__} {c!r}")
        return ",".join(items)
    raise TypeError(f"columns must be a str or a list of str, found {type(columns).__name__}")


def _times(times: Any) -> List[float]:
    try:
        a = np.asarray(times, dtype=np.float64)
    except (TypeError, ValueError) as e:
        raise TypeError(f"times must be an array of numbers: {e}") from None
    if a.ndim != 1:
        raise ValueError(f"times must be one-dimensional, found shape {a.shape}")
    return a.tolist()


def _table(table: TableLike) -> Tuple[List[str], np.ndarray]:
    """Parameter names and a (variants x names) float64 array from a dict of
    arrays or a pandas DataFrame."""
    if hasattr(table, "columns") and hasattr(table, "to_numpy"):
        names = [str(c) for c in table.columns]
        columns = [np.asarray(table[c].to_numpy(), dtype=np.float64) for c in table.columns]
    elif isinstance(table, Mapping):
        names = []
        columns = []
        for k, v in table.items():
            if not isinstance(k, str):
                raise TypeError(f"parameter names must be str, found {type(k).__name__} {k!r}")
            names.append(k)
            try:
                columns.append(np.asarray(v, dtype=np.float64).reshape(-1))
            except (TypeError, ValueError) as e:
                raise TypeError(f"parameter {k!r}: values must be numbers: {e}") from None
    else:
        raise TypeError(
            f"a sweep table is a dict of arrays or a pandas DataFrame, found {type(table).__name__}"
        )
    if not names:
        raise ValueError("the sweep table has no parameters")
    lengths = {len(c) for c in columns}
    if len(lengths) != 1:
        raise ValueError(
            "the sweep table's columns differ in length: "
            + ", ".join(f"{n}: {len(c)}" for n, c in zip(names, columns))
        )
    return names, np.ascontiguousarray(np.column_stack(columns), dtype=np.float64)


def _warn_run(out: Mapping[str, Any], stacklevel: int) -> None:
    """The CLI's run warnings, through :mod:`warnings`."""
    events = out["events"]
    limit = out["max_event_warnings"]
    for e in events[:limit]:
        warnings.warn(e["message"], SingularConfigurationWarning, stacklevel=stacklevel)
    if len(events) > limit:
        warnings.warn(
            f"... and {len(events) - limit} more singular configurations, up to t = {events[-1]['t']}",
            SingularConfigurationWarning,
            stacklevel=stacklevel,
        )
    flagged = out["flagged"]
    if flagged:
        warnings.warn(
            f"{len(flagged)} row(s) at t = {flagged[0]} ... {flagged[-1]} lie within the threshold "
            "of a singular configuration: their q_dot and q_ddot are the limits along the branch, "
            "not solves",
            SingularConfigurationWarning,
            stacklevel=stacklevel,
        )
    if out["kinks"]:
        t, what = out["kinks"][0]
        warnings.warn(
            f"{len(out['kinks'])} row(s) from t = {t}: {what} is not differentiable there; "
            "q_dot and q_ddot are not determined by the model (q is a solution)",
            KinkWarning,
            stacklevel=stacklevel,
        )
    if out["output_kinks"]:
        t, name, function = out["output_kinks"][0]
        warnings.warn(
            f"{len(out['output_kinks'])} row(s) from t = {t}: result `{name}` has {function} "
            f"where it is not differentiable: `{name}_dot` and `{name}_ddot` are not determined",
            KinkWarning,
            stacklevel=stacklevel,
        )
    if out["imprecise"]:
        worst = out["imprecise"][0]
        warnings.warn(
            f"{len(out['imprecise'])} row(s) from t = {worst[0]}: {worst[2]}",
            PrecisionWarning,
            stacklevel=stacklevel,
        )


def _results_of_run(out: Mapping[str, Any]) -> Results:
    return Results(
        out["columns"],
        out["values"],
        events=[Event(e["kind"], e["t"], list(e["equations"]), e["message"]) for e in out["events"]],
        flagged=list(out["flagged"]),
        kinks=list(out["kinks"]),
        output_kinks=list(out["output_kinks"]),
        imprecise=list(out["imprecise"]),
        backend=out["backend"],
        rust_seconds=out["rust_seconds"],
    )


def _analysis_error(message: str, results: Results) -> AnalysisError:
    err = AnalysisError(message)
    err.results = results  # type: ignore[attr-defined]
    return err


def _raise_if_failed(out: Mapping[str, Any], results: Results) -> Results:
    if out["error"] is not None:
        n = len(results)
        rows = "no row was" if n == 0 else ("1 row was" if n == 1 else f"{n} rows were")
        raise _analysis_error(
            f"{out['error']}\n  = note: {rows} computed before the failure (in .results)",
            results,
        )
    return results


def _warn_forward(out: Mapping[str, Any], integrator: str, stacklevel: int) -> None:
    """The CLI's forward-dynamics warnings, through :mod:`warnings`."""
    if out["redundancy"] is not None:
        warnings.warn(out["redundancy"][0], RedundantConstraintsWarning, stacklevel=stacklevel)
    passages = out["passages"]
    limit = out["max_event_warnings"]
    for p in passages[:limit]:
        warnings.warn(p["message"], SingularConfigurationWarning, stacklevel=stacklevel)
    if len(passages) > limit:
        warnings.warn(
            f"... and {len(passages) - limit} more singular configurations passed, up to "
            f"t = {passages[-1]['t']} (not listed one by one)",
            SingularConfigurationWarning,
            stacklevel=stacklevel,
        )
    if out["imprecise"]:
        worst = out["imprecise"][0]
        warnings.warn(
            f"{len(out['imprecise'])} row(s) from t = {worst[0]}: {worst[2]}",
            PrecisionWarning,
            stacklevel=stacklevel,
        )
    if out["error"] is None:
        e = out["energies"]
        balance = e["balance"]
        scale = max(abs(e[k]) for k in ("kinetic", "potential", "kinetic0", "potential0", "work"))
        if math.isnan(balance) or abs(balance) > 1e-2 * scale:
            hint = "try a smaller step or integrator=\"accurate\"" if integrator == "hht" else "try a smaller rtol"
            warnings.warn(
                f"the energy balance is off by {balance:.3e} "
                f"({100 * abs(balance) / max(scale, 5e-324):.1f}% of the energies): the results "
                f"are not accurate; {hint}",
                EnergyBalanceWarning,
                stacklevel=stacklevel,
            )


def _results_of_forward(out: Mapping[str, Any]) -> Results:
    info = {
        "motion": out["motion"],
        "integrator": out["integrator"],
        "consistency": dict(out["consistency"]),
        "energies": dict(out["energies"]),
        "redundant": list(out["redundancy"][1]) if out["redundancy"] is not None else [],
    }
    events = [Event(p["kind"], p["t"], list(p["equations"]), p["message"]) for p in out["passages"]]
    return Results(
        out["columns"],
        out["values"],
        events=events,
        imprecise=list(out["imprecise"]),
        backend=out["backend"],
        rust_seconds=out["rust_seconds"],
        info=info,
    )


class Model:
    """A mechanism read, checked and derived.

    ``Model(text)`` reads kinema's model language; :meth:`from_file` reads a
    ``.kin`` file or a simEngine2D ``.adm`` model (with its ``.acf``
    analysis). Errors in the model raise :class:`ModelError`, whose message
    is the rendered diagnostics (``file:line:column``, the source line and
    carets) and whose ``diagnostics`` are the same as dicts (severity,
    message, file, line, column, label, help). The model check's warnings
    are issued as :class:`ModelWarning`.
    """

    __slots__ = ("_native",)

    def __init__(self, text: str, file: str = "<text>") -> None:
        if not isinstance(text, str):
            raise TypeError(f"Model(text): text must be a str, found {type(text).__name__}")
        if not isinstance(file, str):
            raise TypeError(f"Model(text, file): file must be a str, found {type(file).__name__}")
        self._native = NativeModel.from_text(text, file)
        self._warn_model(stacklevel=3)

    @classmethod
    def _wrap(cls, native: NativeModel) -> "Model":
        m = cls.__new__(cls)
        m._native = native
        return m

    def _warn_model(self, stacklevel: int) -> None:
        for w in self._native.warnings():
            warnings.warn(w.rstrip(), ModelWarning, stacklevel=stacklevel)

    @classmethod
    def from_file(cls, path: Union[str, "os.PathLike[str]"], acf: Union[str, "os.PathLike[str]", None] = None) -> "Model":
        """Reads a model file: ``.kin`` text, or a simEngine2D ``.adm`` model
        run under the analysis ``acf`` (the engine's kinematics.acf, tend 5 s,
        stepSize 0.01 s, 500 output steps, when None).

        Raises:
            FileNotFoundError: no such file.
            ModelError: the model has errors (message with line:column).
            TypeError: ``path`` is not a str or path.
        """
        if not isinstance(path, (str, os.PathLike)):
            raise TypeError(f"path must be a str or os.PathLike, found {type(path).__name__}")
        if acf is not None and not isinstance(acf, (str, os.PathLike)):
            raise TypeError(f"acf must be a str or os.PathLike, found {type(acf).__name__}")
        native = NativeModel.from_file(os.fspath(path), None if acf is None else os.fspath(acf))
        m = cls._wrap(native)
        m._warn_model(stacklevel=3)
        return m

    @property
    def name(self) -> str:
        """The mechanism's name."""
        return self._native.name

    @property
    def file(self) -> str:
        """The file it was read from (or the name given to the text)."""
        return self._native.file

    @property
    def params(self) -> Dict[str, float]:
        """The parameters and their values, in declaration order."""
        return dict(zip(self._native.param_names(), self._native.param_values()))

    @property
    def warnings(self) -> List[str]:
        """The model check's warnings, rendered."""
        return list(self._native.warnings())

    def with_params(self, **values: float) -> "Model":
        """The same model with some parameters set: ``model.with_params(l=0.3)``.

        Raises:
            ValueError: a name that is not a parameter, or a value that is not finite.
            TypeError: a value that is not a number.
        """
        pairs = []
        for k, v in values.items():
            f = _check_real(f"parameter {k!r}", v)
            pairs.append((k, f))
        return Model._wrap(self._native.with_params(pairs))

    def check(self) -> Dict[str, Any]:
        """The degrees-of-freedom report as data: bodies, coordinates (nc),
        equations (their names, the order of Phi's rows), kinematic and driving
        equation counts, ``kdof`` = nc - m_K, ``dof`` = nc - m_K - m_D (0 for
        kinematic analysis), result columns, parameters, whether the model has
        inertia, the warnings, and ``motion`` (:attr:`motion`: how
        :meth:`run` moves it)."""
        report = dict(self._native.check())
        report["motion"] = self.motion
        return report

    def columns(self, columns: Union[str, Sequence[str], None] = None, positions_only: bool = False) -> List[str]:
        """The column names :meth:`run` gives for these options."""
        return list(self._native.columns(_columns_spec(columns), bool(positions_only)))

    def _grid(self, t_end: Any, steps: Any, times: Any) -> Tuple[List[float], Optional[List[bool]]]:
        t_end = _check_real("t_end", t_end)
        steps = _check_int("steps", steps)
        if times is not None:
            if t_end is not None or steps is not None:
                raise TypeError("give either times= or t_end=/steps=, not both")
            return _times(times), None
        return self._native.grid(t_end, steps)

    def run(
        self,
        t_end: Optional[float] = None,
        steps: Optional[int] = None,
        *,
        times: Optional[Sequence[float]] = None,
        columns: Union[str, Sequence[str], None] = None,
        positions_only: bool = False,
        stop_at_singular: bool = False,
        backend: str = "jit",
        integrator: str = "hht",
        step: Optional[float] = None,
        rtol: Optional[float] = None,
        project_velocity: bool = False,
        energy: bool = False,
    ) -> Results:
        """The model's motion, as ``kinema run``: q (m, rad), q_dot (m/s,
        rad/s), q_ddot (m/s^2, rad/s^2) of every coordinate, then the named
        points and outputs with their rates, then for a model with inertia
        the Lagrange multipliers ``lambda.<equation>``, the joints' reactions
        ``reaction.<joint>.<body>.Fx/Fy`` (N) and ``.T`` (N m, about the
        body's frame) and the drivers' efforts ``driver.<equation>`` (N or
        N m).

        Which motion: kinematic analysis (Newton-Raphson on Phi(q, t) = 0,
        then Phi_q q_dot = nu, Phi_q q_ddot = gamma) when the model is
        fully driven; forward dynamics (see :meth:`forward`, whose options
        ``integrator``, ``step``, ``rtol``, ``project_velocity`` and
        ``energy`` apply) for a model with inertia and free degrees of
        freedom or a simEngine2D Dynamics analysis; :attr:`motion` says
        which.

        Args:
            t_end: final time in seconds (1 s by default; an ``.adm`` model's
                analysis ``tend`` otherwise).
            steps: number of equal steps from 0 to ``t_end`` (N + 1 rows; 100
                by default, an ``.adm`` model's ``outputSteps``).
            times: the output times instead (strictly increasing, seconds).
            columns: ``kinema run --columns``: ``"bodies"``, ``"points"``,
                ``"outputs"``, ``"all"``, a body, a point, an output or one
                column by name, as a comma-separated str or a list.
            positions_only: values only, no ``_dot``/``_ddot`` columns (and
                no velocity or acceleration solves).
            stop_at_singular: stop at the first singular configuration.
            backend: ``"jit"`` (native code, the default) or ``"tape"``.
            integrator, step, rtol, project_velocity, energy: forward
                dynamics only (:meth:`forward`); refused for a kinematic run.

        Returns:
            :class:`Results`. Singular configurations and doubtful rows are
            also issued as warnings (:class:`SingularConfigurationWarning`,
            :class:`KinkWarning`, :class:`PrecisionWarning`).

        Raises:
            AnalysisError: a step failed; ``.results`` holds the rows before it.
            ValueError / TypeError: bad arguments.
        """
        if self.motion != "kinematic":
            if positions_only:
                raise ValueError(
                    "positions_only cannot be used with forward dynamics: its positions are "
                    "integrated from the accelerations, which it must solve"
                )
            if stop_at_singular:
                raise ValueError(
                    "stop_at_singular is for kinematic runs: forward dynamics stops at a step "
                    "that fails"
                )
            return self._forward(
                t_end, steps, times, columns, backend, integrator, step, rtol,
                project_velocity, energy, stacklevel=4,
            )
        if rtol is not None or integrator != "hht" or energy or project_velocity:
            raise ValueError(
                "integrator, rtol, project_velocity and energy are for forward dynamics (a model "
                "with inertia and free degrees of freedom, or a Dynamics ACF)"
            )
        if step is not None:
            raise ValueError(
                "step is for forward dynamics (a model with inertia and free degrees of freedom, "
                "or a Dynamics ACF); a kinematic run takes t_end and steps"
            )
        if not isinstance(backend, str):
            raise TypeError(f"backend must be a str, found {type(backend).__name__}")
        t_end = _check_real("t_end", t_end)
        steps = _check_int("steps", steps)
        if times is not None:
            if t_end is not None or steps is not None:
                raise TypeError("give either times= or t_end=/steps=, not both")
            grid: Optional[List[float]] = _times(times)
        else:
            grid = None  # the grid of t_end and steps, made in Rust
        out = self._native.run(
            {
                "times": grid,
                "columns": _columns_spec(columns),
                "positions_only": bool(positions_only),
                "stop_at_singular": bool(stop_at_singular),
                "backend": backend,
                "t_end": t_end,
                "steps": steps,
            }
        )
        _warn_run(out, stacklevel=3)
        return _raise_if_failed(out, _results_of_run(out))

    @property
    def motion(self) -> str:
        """How :meth:`run` moves the model, as ``kinema run`` decides:
        ``"kinematic"`` (fully driven: kinematics, and inverse dynamics with
        inertia), ``"forward"`` (inertia and free degrees of freedom, or a
        simEngine2D Dynamics analysis: forward dynamics) or ``"prescribed"``
        (inertia, fully driven with redundant rows: minimum-norm solves of
        the prescribed motion and its multipliers)."""
        return self._native.motion

    def forward(
        self,
        t_end: Optional[float] = None,
        steps: Optional[int] = None,
        *,
        times: Optional[Sequence[float]] = None,
        columns: Union[str, Sequence[str], None] = None,
        integrator: str = "hht",
        step: Optional[float] = None,
        rtol: Optional[float] = None,
        project_velocity: bool = False,
        energy: bool = False,
        backend: str = "jit",
    ) -> Results:
        """Forward dynamics, as ``kinema run`` of a model with inertia and
        free degrees of freedom: from the declared configuration q0 (the
        guesses) and velocities q_dot0 (``velocity`` items, an ``.adm``
        body's ``qd0``), made consistent with Phi = 0 and Phi_q q_dot = nu
        by minimum-norm projections (``info["consistency"]``), the equations
        of motion M q_ddot + Phi_q^T lambda = Q_A, Phi(q, t) = 0 are
        integrated and a row written at each output time: q, q_dot, q_ddot,
        points and outputs, ``lambda.*``, ``reaction.*`` (N, N m),
        ``driver.*`` (N or N m), and with ``energy`` the kinetic energy
        ``energy.kinetic`` = 1/2 q_dot^T M q_dot, the gravity potential
        ``energy.potential`` and the work of the other forces and drivers
        since the start ``energy.work`` (J); kinetic + potential - work is
        constant when the integration is exact. A model fully driven with
        redundant rows runs its prescribed motion by minimum-norm solves.

        Args:
            t_end: final time in seconds (1 s; an ``.adm`` model's ``tend``).
            steps: output intervals from 0 to ``t_end`` (100; ``outputSteps``).
            times: the output times instead (strictly increasing, s; the
                motion starts at ``times[0]``).
            columns: as :meth:`run` (the dynamics columns always follow).
            integrator: ``"hht"`` (HHT-alpha, alpha = -0.1, at a fixed step,
                index-3, second order) or ``"accurate"`` (Dormand-Prince
                5(4), error-controlled to ``rtol``, index-1 with projection).
            step: HHT's largest step in seconds (1e-3; an ``.adm`` model's
                ``stepSize``), shortened to land on every output time.
            rtol: the accurate integrator's relative and absolute tolerance
                (1e-8; in (1e-14, 1)).
            project_velocity: HHT: report q_dot projected onto
                Phi_q q_dot = nu at every step.
            energy: three more columns, the energies (J).
            backend: ``"jit"`` or ``"tape"`` for the points, outputs and
                reactions (the integrator runs on tapes, as the CLI's).

        Returns:
            :class:`Results`; ``events`` lists the singular configurations
            passed (kind ``"passage"``), ``info`` the integrator's counters,
            the consistency corrections, the energies and their balance, the
            redundant equations.

        Warns:
            SingularConfigurationWarning: a singular configuration passed.
            RedundantConstraintsWarning: dependent equations at the start.
            EnergyBalanceWarning: the balance is off by more than 1 %.

        Raises:
            AnalysisError: a step failed (an equation undefined ahead, no
                convergence); ``.results`` holds the rows before it.
            KinemaError: the model has no inertia, or is fully driven
                (use :meth:`run`).
            ValueError / TypeError: bad arguments.
        """
        if self.motion == "kinematic":
            check = self._native.check()
            why = (
                "it has no inertia (`mass` and `inertia` on every body)"
                if not check["inertia"]
                else "it is fully driven (NDOF = 0): its motion is kinematic, with inverse dynamics"
            )
            raise KinemaError(f"{self.name} does not run forward dynamics: {why}; use Model.run")
        return self._forward(
            t_end, steps, times, columns, backend, integrator, step, rtol, project_velocity, energy,
            stacklevel=4,
        )

    def _forward(
        self,
        t_end: Any,
        steps: Any,
        times: Any,
        columns: Any,
        backend: Any,
        integrator: Any,
        step: Any,
        rtol: Any,
        project_velocity: Any,
        energy: Any,
        stacklevel: int,
    ) -> Results:
        grid, _ = self._grid(t_end, steps, times)
        for name, value in (("backend", backend), ("integrator", integrator)):
            if not isinstance(value, str):
                raise TypeError(f"{name} must be a str, found {type(value).__name__}")
        out = self._native.forward(
            {
                "times": grid,
                "columns": _columns_spec(columns),
                "integrator": integrator,
                "step": _check_real("step", step),
                "rtol": _check_real("rtol", rtol),
                "project_velocity": bool(project_velocity),
                "energy": bool(energy),
                "backend": backend,
            }
        )
        _warn_forward(out, integrator, stacklevel=stacklevel)
        return _raise_if_failed(out, _results_of_forward(out))

    def equilibrium(
        self,
        *,
        columns: Union[str, Sequence[str], None] = None,
        backend: str = "jit",
    ) -> Results:
        """The stable static equilibrium at t = 0, as ``kinema run
        --equilibrium``: from the guess, descending the potential to q with
        Phi(q, 0) = 0 and Phi_q^T lambda = Q_A (q_dot = q_ddot = 0). One row
        with the columns of a dynamics run (q in m and rad, rates 0, points
        and outputs at rest, ``lambda.*``, ``reaction.*`` in N and N m,
        ``driver.*``); ``info`` has ``stability`` (``"stable"``, ...), the
        reduced Hessian's ``eigenvalues`` (ascending), ``residual``
        (max |Phi|), ``gradient`` (max |N^T Q_A|) and ``iterations``.

        Warns:
            StabilityWarning: the equilibrium found is not stable.

        Raises:
            KinemaError: the model has no inertia, gravity or forces.
            AnalysisError: no equilibrium found.
        """
        if not isinstance(backend, str):
            raise TypeError(f"backend must be a str, found {type(backend).__name__}")
        out = self._native.equilibrium(_columns_spec(columns), backend)
        info = {k: out[k] for k in ("stability", "eigenvalues", "residual", "gradient", "iterations")}
        if not out["stable"]:
            warnings.warn(
                f"the equilibrium found is {out['stability']}: a small disturbance moves the "
                "mechanism away",
                StabilityWarning,
                stacklevel=2,
            )
        return Results(out["columns"], out["values"], info=info)

    def sweep(
        self,
        table: TableLike,
        *,
        t_end: Optional[float] = None,
        steps: Optional[int] = None,
        times: Optional[Sequence[float]] = None,
        positions_only: bool = False,
        stop_at_singular: bool = False,
        backend: str = "jit",
        threads: Optional[int] = None,
        errors: str = "raise",
    ) -> Results:
        """Runs the model once per row of ``table`` (a dict of arrays or a
        DataFrame; its keys are parameter names), as ``kinema sweep``: one
        long table with the columns ``row`` (the variant, from 1), the
        parameters, ``t``, every coordinate's q, q_dot, q_ddot and every
        result's value and rates. Variants run in parallel on ``threads``
        threads (all cores by default) with the GIL released.

        ``errors="raise"`` (default): if any variant failed, raise
        :class:`AnalysisError` whose ``.results`` hold every row computed
        (a failed variant's rows up to its failure); ``"warn"``: issue a
        :class:`SweepWarning` per failed variant and return the table.
        ``Results.failures`` lists (variant index from 0, message).
        """
        grid = self._sweep_grid(t_end, steps, times)
        names, array = _table(table)
        threads = _check_int("threads", threads)
        if threads is not None and threads < 1:
            raise ValueError(f"threads must be at least 1, found {threads}")
        out = self._native.sweep(
            {
                "names": names,
                "table": array,
                "times": grid,
                "positions_only": bool(positions_only),
                "stop_at_singular": bool(stop_at_singular),
                "backend": backend,
                "threads": threads,
            }
        )
        return _finish_sweep(out["columns"], out["values"], out["failures"], out["flagged"], names, array, errors, stacklevel=3)

    def _sweep_grid(self, t_end: Any, steps: Any, times: Any) -> List[float]:
        if self._native.is_adm:
            raise KinemaError(
                "a sweep takes .kin models: a simEngine2D model has no parameters "
                "(`kinema import` it and declare the values to sweep as params)"
            )
        grid, outputs = self._grid(t_end, steps, times)
        return grid

    def __repr__(self) -> str:
        return f"<kinema.Model {self.name} ({self.file})>"


def _finish_sweep(
    columns: List[str],
    values: np.ndarray,
    failures: List[Tuple[int, str]],
    flagged: List[Tuple[int, str]],
    names: List[str],
    array: np.ndarray,
    errors: str,
    stacklevel: int,
) -> Results:
    if errors not in ("raise", "warn"):
        raise ValueError(f'errors must be "raise" or "warn", found {errors!r}')

    def describe(k: int) -> str:
        return ", ".join(f"{n} = {array[k, j]:g}" for j, n in enumerate(names))

    results = Results(columns, values, failures=list(failures))
    for k, note in flagged[:20]:
        warnings.warn(f"variant {k + 1} ({describe(k)}): {note}", SweepWarning, stacklevel=stacklevel)
    if len(flagged) > 20:
        warnings.warn(f"... and {len(flagged) - 20} more variants with flagged rows", SweepWarning, stacklevel=stacklevel)
    if failures:
        lines = [f"variant {k + 1} ({describe(k)}): {m}" for k, m in failures[:20]]
        if errors == "warn":
            for line in lines:
                warnings.warn(line, SweepWarning, stacklevel=stacklevel)
        else:
            more = f"\n  ... and {len(failures) - 20} more" if len(failures) > 20 else ""
            raise _analysis_error(
                f"{len(failures)} of {len(array)} variants failed (their rows up to the failure "
                f"are in .results):\n  " + "\n  ".join(lines) + more,
                results,
            )
    return results
