"""Solving an LMI and reusing its compilation: the solver plumbing.

A problem is solved in one place (:func:`solve`), which turns any failure of
the solver into a status, restores the global solver options it must set,
and keeps cvxpy's accuracy warnings from users (the status says it). Every
number of the data enters a problem as a cvxpy Parameter, so a problem is
compiled once per shape and thread and reused (``CACHE_SIZE``).
"""

from __future__ import annotations

import functools
import threading
import time
import warnings
import weakref
from collections import OrderedDict
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import cvxpy as cp
from control.exception import ControlArgument

from ..exceptions import TIME_LIMIT

#: Default relative strictness margin: LMIs are imposed as ``M ≼ -ε·s·I`` with
#: ``s`` the scale of the data.
DEFAULT_MARGIN = 1e-7

#: Clarabel settings used unless the caller overrides them: tighter than the
#: 1e-8 defaults so that answers near the optimum still pass the exact checks.
CLARABEL_DEFAULTS = dict(tol_gap_abs=1e-9, tol_gap_rel=1e-9, tol_feas=1e-9,
                         max_iter=500)


@dataclass
class SolveReport:
    """What the solver said and how long it took.

    Attributes
    ----------
    status : str
        cvxpy's status (``'optimal'``, ``'optimal_inaccurate'``,
        ``'infeasible'``, …, or ``'solver_error'``).
    solver : str
    compile_time, solve_time, total_time : float
        Seconds: cvxpy's compilation, the solver call, and both together.
    iterations : int or None
    value : float or None
        Optimal objective, if any.
    message : str
        The solver's error message, if it failed.
    """

    status: str
    solver: str
    compile_time: float
    solve_time: float
    total_time: float
    iterations: int | None = None
    value: float | None = None
    message: str = ""
    options: dict = field(default_factory=dict)

    @property
    def ok(self) -> bool:
        return self.status == cp.OPTIMAL

    @property
    def infeasible(self) -> bool:
        return self.status in (cp.INFEASIBLE, cp.INFEASIBLE_INACCURATE)


@functools.lru_cache(maxsize=1)
def installed_solvers() -> tuple[str, ...]:
    """cvxpy's installed solvers, asked once: cvxpy imports every solver's
    module to answer, which cost a third of a small refinement's time when
    it was asked at every solve."""
    return tuple(cp.installed_solvers())


def check_solver(solver: str | None) -> str:
    """The cvxpy solver name to use (Clarabel by default), or a clear error."""
    name = cp.CLARABEL if solver is None else str(solver).upper()
    if name not in installed_solvers():
        raise ControlArgument(f"solver: {solver!r} is not an installed cvxpy "
                              f"solver; installed: {list(installed_solvers())}")
    return name


#: Asked once when nothing verified with the default solver (never when the
#: caller names one): CVXOPT proves infeasible what Clarabel leaves unsettled.
FALLBACK_SOLVER = "CVXOPT"


def fallback_solver(solver: str | None) -> str | None:
    """The solver to ask once when nothing verified, or None (see above)."""
    if solver is None and FALLBACK_SOLVER in installed_solvers():
        return FALLBACK_SOLVER
    return None


#: Keywords that :meth:`cvxpy.Problem.solve` itself accepts for any solver.
CVXPY_SOLVE_KEYWORDS = frozenset((
    "verbose", "warm_start", "gp", "qcp", "requires_grad", "enforce_dpp",
    "ignore_dpp", "canon_backend", "bounds"))

#: CVXOPT's options (and cvxpy's two): CVXOPT ignores unknown keys silently,
#: so a misspelt one is rejected here instead.
CVXOPT_OPTIONS = frozenset((
    "show_progress", "maxiters", "abstol", "reltol", "feastol", "refinement",
    "kktreg", "debug", "max_iters", "kktsolver"))

#: Keys cvxpy's Clarabel interface consumes itself (not Clarabel settings).
CLARABEL_CVXPY_KEYS = frozenset(("use_quad_obj", "accept_unknown"))

#: Keys cvxpy's SCS interface consumes itself before calling ``scs.SCS``.
SCS_CVXPY_KEYS = frozenset(("use_indirect", "gpu", "eps", "linear_solver"))


def _clarabel_settings() -> frozenset:
    """The settings the installed Clarabel knows (its ``DefaultSettings``)."""
    import clarabel
    return frozenset(name for name in dir(clarabel.DefaultSettings())
                     if not name.startswith("_") and name != "default")


def _unknown_scs(options: dict) -> list:
    """Options the installed SCS rejects: asked of SCS itself, on a
    one-variable problem (SCS publishes no list of its settings)."""
    import scipy.sparse as sp
    import scs
    data = dict(A=sp.csc_matrix(np.ones((1, 1))), b=np.ones(1), c=np.ones(1))
    bad = []
    for key, value in options.items():
        try:
            scs.SCS(data, dict(l=1), **{"verbose": False, key: value})
        except TypeError:
            bad.append(key)
    return bad


def check_options(name: str, options: dict) -> None:
    """``TypeError`` for solver options the solver does not know.

    Checked here, at the boundary, for Clarabel (its ``DefaultSettings``),
    SCS (asked of the installed SCS) and CVXOPT (which would ignore an
    unknown key silently), so that a misspelt option never reaches the
    solver deep inside cvxpy. Options of other solvers pass unchecked.
    """
    if name == cp.CVXOPT:
        unknown = sorted(set(options) - CVXOPT_OPTIONS - CVXPY_SOLVE_KEYWORDS)
        known = sorted(CVXOPT_OPTIONS)
    elif name == cp.CLARABEL:
        settings = _clarabel_settings()
        unknown = sorted(set(options) - settings - CLARABEL_CVXPY_KEYS
                         - CVXPY_SOLVE_KEYWORDS)
        known = sorted(settings | CLARABEL_CVXPY_KEYS)
    elif name == cp.SCS:
        unknown = sorted(_unknown_scs(
            {k: v for k, v in options.items()
             if k not in SCS_CVXPY_KEYS | CVXPY_SOLVE_KEYWORDS}))
        known = ["the settings of scs.SCS (see SCS's documentation)"] + sorted(
            SCS_CVXPY_KEYS)
    else:
        return
    if unknown:
        raise TypeError(
            f"solver option(s) {unknown} not accepted by {name} (known: "
            f"{known}, and cvxpy's {sorted(CVXPY_SOLVE_KEYWORDS)})")


class _SolverOptionsRestored:
    """Restore ``cvxopt.solvers.options`` after a solve: cvxpy writes the
    caller's options into that global dictionary and leaves them there."""

    def __enter__(self):
        try:
            from cvxopt import solvers
        except ImportError:
            self.saved = None
        else:
            self.saved = (solvers, dict(solvers.options))
        return self

    def __exit__(self, *exc):
        if self.saved is not None:
            solvers, saved = self.saved
            solvers.options.clear()
            solvers.options.update(saved)
        return False


def _run(problem: cp.Problem, name: str, opts: dict) -> tuple[str, str]:
    """One solver call: its status, or 'solver_error' and why."""
    try:
        with _SolverOptionsRestored(), warnings.catch_warnings():
            # the status says 'optimal_inaccurate' already, and the caller's
            # exact check decides; the warning would only reach users as noise
            warnings.filterwarnings("ignore",
                                    message="Solution may be inaccurate",
                                    category=UserWarning)
            # a cvxpy without the COO backend (before 1.8, the newest on
            # Python 3.10) compiles large parametrised LMIs more slowly and
            # says so; the answer is the same, the advice is not the user's
            warnings.filterwarnings(
                "ignore", category=UserWarning,
                message="Your problem has too many parameters for efficient "
                        "DPP compilation")
            problem.solve(solver=name, **opts)
        return problem.status, ""
    except (KeyboardInterrupt, SystemExit):
        raise
    except BaseException as err:
        # Clarabel (Rust, via pyo3) turns an internal panic, e.g. a failed
        # eigendecomposition in a PSD cone step near the boundary, into
        # pyo3_runtime.PanicException, a BaseException; CVXOPT raises
        # ZeroDivisionError or ArithmeticError from its own steps near the
        # boundary. Each is a solver failure like any other.
        kind = type(err).__name__
        return "solver_error", (f"{name} panicked: {err}"
                                if kind == "PanicException"
                                else f"{name} raised {kind}: {err}")


def solve(problem: cp.Problem, solver: str | None = None, *,
          time_limit: float | None = None, **options: Any) -> SolveReport:
    """Solve ``problem`` and report; any failure of the solver is a status.

    ``time_limit`` (seconds) is passed to solvers that support one
    (Clarabel); others run to their own end. Any exception raised by the
    solver call (cvxpy's ``SolverError``, CVXOPT's ``ZeroDivisionError``
    or ``ArithmeticError``, Clarabel's Rust panic, ...) becomes the status
    ``'solver_error'`` with its message; only ``KeyboardInterrupt`` and
    ``SystemExit`` pass. Global solver options are restored afterwards.
    """
    name = check_solver(solver)
    check_options(name, options)
    opts: dict[str, Any] = {}
    if name == cp.CLARABEL:
        # warm_start=False: with True, cvxpy reuses the Clarabel solver of
        # the previous solve of this (cached) problem and keeps every
        # setting not given again (a time limit, tolerances of a retry)
        opts.update(CLARABEL_DEFAULTS, warm_start=False)
        if time_limit is not None:
            opts["time_limit"] = max(float(time_limit), 1e-3)
    opts.update(_cache.compile_options.get(problem, {}))
    opts.update(options)
    start = time.perf_counter()
    status, message = _run(problem, name, opts)
    if (status == cp.OPTIMAL_INACCURATE and name == cp.CLARABEL
            and "accept_unknown" not in options
            and not any(key.startswith(("tol_", "reduced_tol_"))
                        for key in options)):
        # CLARABEL_DEFAULTS ask for 1e-9; Clarabel sometimes stalls just
        # above it (measured: gap 1.19e-9, then a zero step) and reports
        # AlmostSolved. Asked again at its own default tolerances (1e-8)
        # it says 'Solved' when the answer has that accuracy; otherwise the
        # first answer is restored (the solver is deterministic).
        relaxed = {key: value for key, value in opts.items()
                   if key not in CLARABEL_DEFAULTS or key == "max_iter"}
        status2, message2 = _run(problem, name, relaxed)
        if status2 == cp.OPTIMAL:
            status, message, opts = status2, message2, relaxed
        else:
            status, message = _run(problem, name, opts)
    total = time.perf_counter() - start
    if status == cp.USER_LIMIT and time_limit is not None \
            and total >= 0.9 * time_limit:
        status, message = TIME_LIMIT, f"{name} reached its time limit"
    template = _cache.templates.get(problem)
    if template is not None:
        template.solved = template.owner
    compile_time = float(getattr(problem, "compilation_time", None) or 0.0)
    stats = problem.solver_stats
    solve_time = getattr(problem, "_solve_time", None)
    if solve_time is None:
        solve_time = max(total - compile_time, 0.0)
    value = problem.value if status in (cp.OPTIMAL, cp.OPTIMAL_INACCURATE) \
        else None
    return SolveReport(status, name, compile_time, float(solve_time), total,
                       getattr(stats, "num_iters", None) if stats else None,
                       None if value is None else float(value), message, opts)


def data_scale(*mats: np.ndarray) -> float:
    """A scale for the margins: the largest spectral norm among the data."""
    norms = [float(np.linalg.norm(M.reshape(-1, M.shape[-1]), 2))
             for M in mats if M.size]
    return max([1.0] + norms)


# -- compiled problems, reused: one per shape ---------------------------------
# cvxpy's compilation of these LMIs costs more than Clarabel's solve up to
# n ≈ 8 (docs/benchmarks.md §1: 53-74 % of passivesyn's time at n = 4). Every
# number of the data therefore enters a problem as a cvxpy Parameter (DPP), and
# a problem is built and compiled once per *shape*: retries, η sweeps and other
# plants of the same sizes only load new parameter values, and cvxpy re-applies
# them to its cached compilation (a few ms) instead of recompiling.

#: Compiled problems kept per thread (LRU): enough for the shapes of one
#: synthesis plus one analysis; each holds ~n⁴ parametrised data.
CACHE_SIZE = 6

#: From this many parameter entries on, cvxpy's COO backend compiles faster
#: than its C++ one (cvxpy itself switches at 1000).
COO_FROM = 500

#: cvxpy's COO canonicalisation backend, where the installed cvxpy has one
#: (older releases compile with their default backend: slower, same answer).
COO_BACKEND = getattr(cp.settings, "COO_CANON_BACKEND", None)


class _Cache(threading.local):
    """Per-thread LRU cache: threads never share (or solve) one Problem."""

    def __init__(self) -> None:
        self.entries: OrderedDict = OrderedDict()
        self.hits = 0
        self.misses = 0
        # compile options of the cached problems, read by solve()
        self.compile_options: weakref.WeakKeyDictionary[cp.Problem, dict] = \
            weakref.WeakKeyDictionary()
        # problem -> its template, so that solve() can record whose data
        # were solved
        self.templates: weakref.WeakKeyDictionary[cp.Problem, _Template] = \
            weakref.WeakKeyDictionary()


_cache = _Cache()


def cache_info() -> dict:
    """This thread's cache: ``hits``, ``misses``, ``size``, ``maxsize``."""
    return dict(hits=_cache.hits, misses=_cache.misses,
                size=len(_cache.entries), maxsize=CACHE_SIZE)


def cache_clear() -> None:
    """Empty this thread's cache and reset its statistics."""
    _cache.entries.clear()
    _cache.hits = _cache.misses = 0


class _Template:
    """A problem of one shape whose data are all Parameters (DPP).

    ``owner`` is the model whose data the parameters hold; a model loads
    its own values before its problem is handed out, so two models of one
    shape never solve each other's data. ``solved`` is the model whose data
    were last solved (set by :func:`solve`); variables are read only when
    both are the reader (``_Model.check_current``), and loading other data
    clears the variables' values.
    """

    def __init__(self, problem: cp.Problem, params: dict, **parts: Any):
        self.problem, self.params, self.parts = problem, params, parts
        self.owner = self.solved = None
        if COO_BACKEND is not None and sum(
                param.size for param in params.values()) >= COO_FROM:
            _cache.compile_options[problem] = dict(canon_backend=COO_BACKEND)
        _cache.templates[problem] = self

    def load(self, owner: Any, values: dict) -> None:
        if self.owner is not owner:
            for key, value in values.items():
                self.params[key].value = value
            for variable in self.problem.variables():
                variable.value = None      # another model's solution
            self.owner, self.solved = owner, None


def _template(key: tuple, build) -> _Template:
    entries = _cache.entries
    template = entries.get(key)
    if template is None:
        _cache.misses += 1
        template = entries[key] = build()
        while len(entries) > CACHE_SIZE:
            entries.popitem(last=False)
    else:
        _cache.hits += 1
        entries.move_to_end(key)
    return template


class _Model:
    """A view of a cached problem loaded with one set of data.

    ``problem`` is shared by every model of the same shape (in one thread):
    solve it and read the variables' values before building the next model
    of that shape, as :func:`solve` then :func:`read_gains` do.
    """

    def __init__(self, template: _Template, values: dict):
        self._template, self._values = template, values
        template.load(self, values)

    @property
    def problem(self) -> cp.Problem:
        """The cvxpy problem, holding this model's data."""
        self._template.load(self, self._values)
        return self._template.problem

    def check_current(self) -> None:
        """Raise unless the variables hold the solution of this model's
        data (its problem solved since it was last loaded)."""
        if self._template.owner is not self or self._template.solved is not self:
            raise RuntimeError(
                "this model's problem was not solved with its data since it "
                "was loaded (models of one shape share a compiled problem, "
                "lmi.CACHE_SIZE); solve(model.problem) before reading it")


def _param(params: dict, key: Any, shape: tuple = ()) -> cp.Parameter:
    name = "_".join(str(part) for part in
                    (key if isinstance(key, tuple) else (key,)))
    params[key] = cp.Parameter(shape, name=name)
    return params[key]


def _lower(n: int) -> np.ndarray:
    """Column-major positions in ``vec(M)`` of the lower triangle of M."""
    i, j = np.tril_indices(n)
    order = np.lexsort((i, j))
    return (i + n * j)[order]


def _quad_map(terms: list, n: int, m: int) -> np.ndarray:
    """``Σ p_i G_iᵀ P G_i`` as a matrix acting on the lower triangle of P.

    Returns ``Q`` with ``Q @ vec(P)[lower(n)]`` the lower triangle of the
    sum (column-major) for symmetric ``P``, ``G_i`` of shape (n, n+m).
    ``parameter × P × parameter`` is not DPP; this linear map of ``P`` is,
    and the triangles make it a quarter of ``Σ p_i G_iᵀ ⊗ G_iᵀ``
    (:ref:`theory-passivity`).
    """
    # vec(Gᵀ P G) = (Gᵀ ⊗ Gᵀ) vec(P), column-major
    K = sum(w * np.kron(G.T, G.T) for w, G in terms)
    lower_n, lower_nm = _lower(n), _lower(n + m)
    i, j = lower_n % n, lower_n // n
    # P_ij (i > j) stands at (i, j) and at (j, i) of vec(P)
    Q = K[:, lower_n] + np.where(i != j, 1.0, 0.0) * K[:, j + n * i]
    return Q[lower_nm]


def _symmetric_scatter(n: int) -> np.ndarray:
    """``S`` with ``S @ v`` = vec of the symmetric M whose lower triangle
    is ``v`` (column-major).

    cvxpy constrains the symmetric part ``(M + Mᵀ)/2`` of a semidefinite
    argument, but solvers that read whole matrices (CVXOPT) need ``M``
    itself symmetric. The LMIs here are symmetric by construction, with
    each coefficient at ``(i, j)`` and ``(j, i)``, and never symmetrised
    explicitly: that would double the work of cvxpy's parametrised
    compilation, which grows with the parameter entries multiplying
    variables.
    """
    lower = _lower(n)
    i, j = lower % n, lower // n
    S = np.zeros((n * n, lower.size))
    S[lower, np.arange(lower.size)] = 1.0
    S[j + n * i, np.arange(lower.size)] = 1.0
    return S


def balancing_scale(A: np.ndarray, b: np.ndarray, c: np.ndarray,
                    spread: float) -> np.ndarray | None:
    """Diagonal state scaling ``t`` (powers of two) for an LMI, or None.

    Balances the weights ``A`` (``n × n``, e.g. ``Σ |A_ki|``) together with
    one extra node standing for every input (``b``, weight per state) and
    output (``c``) like :func:`scipy.linalg.matrix_balance`. A similarity by
    powers of two is exact in floating point and keeps every zero pattern,
    so the LMI can be solved in ``x = diag(t) x̃`` and its answer mapped back
    exactly. None when the data are not finite or ``t`` spreads by less than
    ``spread`` (then the data are taken as they are).
    """
    from scipy.linalg import matrix_balance
    n = A.shape[0]
    S = np.zeros((n + 1, n + 1))
    S[:n, :n], S[:n, n], S[n, :n] = A, b, c
    if not np.all(np.isfinite(S)) or not np.any(S):
        return None
    _, (scale, _) = matrix_balance(S, permute=False, separate=True)
    t = scale[:n] / scale[n]
    if not t.max() / t.min() >= spread:
        return None
    return t
