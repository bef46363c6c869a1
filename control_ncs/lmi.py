"""The one place that talks to cvxpy: LMIs of :ref:`theory-passivity` and
:ref:`theory-synthesis`, solved.

Models are built as functions of the data (cvxpy's idiom: build, then solve
in one place). Strictness margins are relative to the scale of the data, so
that a problem and its rescaled copy are treated alike
(:ref:`theory-synthesis`). Nothing here decides whether a result is *true*:
``verify.py`` does that exactly.

Every number of the data enters a problem as a cvxpy Parameter, so a problem
is compiled once per shape and thread and reused (see ``CACHE_SIZE``).
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

from .exceptions import TIME_LIMIT
from .jump import JumpStateSpace
from .modes import mode_classes
from .openloop import JumpPlant
from .verify import supply_rows

__all__: list[str] = []

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


# -- analysis: theory: passivity ----------------------------------------------
class AnalysisModel(_Model):
    """The analysis LMI: ``Θ_k(P, η) ≼ -ε diag(P_k, I)``, ``P_k ≽ ε I``.

    Attributes
    ----------
    problem : cvxpy.Problem
    P : list of cvxpy.Variable
        ``P_k`` per phase.
    eta : cvxpy.Variable or float
        ``η`` when maximised, else the given value.
    margin : cvxpy.Variable or float
        The absolute margin ``ε`` (relative margin times the data's scale),
        or the variable ``t`` when the margin is maximised.
    """

    def __init__(self, template, values, eta, margin):
        super().__init__(template, values)
        self.P = template.parts["P"]
        self.eta, self.margin = eta, margin

    def values(self) -> np.ndarray:
        """The solved certificate ``P_k``, shape (N, n, n)."""
        return np.array([Pk.value for Pk in self.P])

    def theta_duals(self) -> list[np.ndarray]:
        """The dual variables of the ``Θ_k`` constraints, one per phase
        (the template adds ``Θ_k ≼ …`` then ``P_k ≽ …`` for each phase)."""
        return [np.asarray(c.dual_value, float)
                for c in self.problem.constraints[0::2]]


def analysis_model(sys: JumpStateSpace, eta: float | None,
                   margin: float | None, decay: float = 1.0) -> AnalysisModel:
    """Build the LMI of :ref:`theory-passivity` (maximise ``η`` when ``eta`` is
    None).

    ``margin=None`` (with a given ``eta``) maximises the strictness margin
    ``t`` itself: ``Θ_k ≼ -t I``, ``P_k ≽ t I``. Its answer is the most
    interior certificate, the one most likely to pass the exact check when
    ``η`` lies within a fixed margin of the index; ``t ≤ 0`` at the optimum
    means no strict certificate exists.

    The problem is compiled once per shape (period, sizes, which of ``η``
    and the margin is maximised) and reused in this thread.
    """
    A, B, p = sys.modes.A, sys.modes.B, sys.modes.probabilities
    _, _, Cbar, Dbar = sys.modes.mean()
    N, n, m = sys.period, A.shape[-1], B.shape[-1]
    if margin is None and eta is None:
        raise ValueError("analysis_model: margin=None needs a given eta")
    key = ("analysis", N, n, m, Cbar.shape[-2], eta is None, margin is None)
    template = _template(key, lambda: _analysis_template(*key[1:]))
    values: dict[Any, Any] = {"decay2": float(decay) ** 2}
    if eta is not None:
        values["eta"] = float(eta)
    if margin is not None:
        eps = margin * data_scale(A, B, sys.modes.C, sys.modes.D)
        values["margin"] = eps
    for k in range(N):
        G = np.concatenate([A[k], B[k]], axis=-1)
        values[("quad", k)] = _quad_map(
            [(p[k, i], G[i]) for i in np.flatnonzero(p[k] > 0)], n, m)
        values[("C", k)] = Cbar[k]
        values[("Dsym", k)] = Dbar[k] + Dbar[k].T
    return AnalysisModel(
        template, values,
        template.parts["eta"] if eta is None else float(eta),
        template.parts["margin"] if margin is None else eps)


def _analysis_template(N, n, m, nz, maximise_eta, maximise_margin):
    params: dict = {}
    d2 = _param(params, "decay2")
    e = cp.Variable(name="eta") if maximise_eta else _param(params, "eta")
    t = (cp.Variable(name="margin") if maximise_margin
         else _param(params, "margin"))
    P = [cp.Variable((n, n), symmetric=True, name=f"P{k}") for k in range(N)]
    cons = []
    lower_n, lower_nm = _lower(n), _lower(n + m)
    scatter = _symmetric_scatter(n + m)
    for k in range(N):
        Pn = P[(k + 1) % N]
        quad = cp.reshape(
            scatter @ (_param(params, ("quad", k),
                              (lower_nm.size, lower_n.size))
                       @ cp.vec(Pn, order="F")[lower_n]),
            (n + m, n + m), order="F")
        C = _param(params, ("C", k), (nz, n))
        supply = cp.bmat([
            [-d2 * P[k], -C.T],
            [-C, 2 * e * np.eye(m) - _param(params, ("Dsym", k), (m, m))]])
        # The (1,1) block is homogeneous in P, so its margin is relative to
        # P_k (a decay margin 1 - ε). An absolute ε·I there forces
        # ‖P‖ ≳ ε / (1 - ms_radius) and, through the supply coupling, costs η:
        # measured on a loop from passivesyn with ms_radius = 1 - 1e-6, the
        # absolute margin certified η = -4.7e5 where the synthesis P proves
        # 1.5285 (tests/test_passivity.py).
        slack = (np.eye(n + m) if maximise_margin else
                 cp.bmat([[P[k], np.zeros((n, m))],
                          [np.zeros((m, n)), np.eye(m)]]))
        # symmetric by construction (see _symmetric_scatter)
        cons += [quad + supply << -t * slack, P[k] >> t * np.eye(n)]
    objective = (cp.Maximize(t) if maximise_margin else
                 cp.Maximize(e) if maximise_eta else cp.Minimize(0))
    return _Template(cp.Problem(objective, cons), params, P=P, eta=e, margin=t)


# -- synthesis: theory: synthesis, predictor, jump system ---------------------
class SynthesisModel(_Model):
    """The synthesis LMI ``Ψ_{k,c} ≼ -ε I`` and how to read a gain from it.

    The blocks are indexed by phase ``k`` and class ``c`` of previous modes
    ``ℓ = σ_{k-1}`` with equal transition rows ``T_{k-1}[ℓ]``
    (:ref:`theory-markov`); i.i.d. modes have one class per phase
    (:ref:`theory-synthesis`).

    Attributes
    ----------
    problem : cvxpy.Problem
    X, Z, Y : list
        Per phase, of its first class (the only one for i.i.d. modes):
        ``X_k``; ``X_k`` (block/full) or the slack ``G_k`` (extended, or
        phase-only gains over several classes); ``Y_k`` on (active inputs
        × known coordinates), or None.
    blocks : list
        Per phase, of its first class: (known coordinates, active inputs,
        variable ``Z_s`` on the known coordinates) for reading gains.
    X_classes, Z_classes, Y_classes, blocks_classes : list of list
        The same per phase and class.
    classes : list of ndarray
        Per phase, the class of each previous mode ``ℓ``.
    eta : cvxpy.Variable or float
        ``η`` when maximised, else the given value.
    margin : float
        Absolute margin ``ε`` (relative margin times the data's scale).
    structure, form : str
    gain : {'mode', 'phase'}
        Gains ``K_{k,ℓ}`` or ``K_k`` (as asked; with one class per phase
        the LMI is the same).
    markov : bool
        Whether the plant's modes are a Markov chain.
    width : int
        Side of the largest block ``Ψ_{k,c}``.
    """

    def __init__(self, template, values, eta, margin, structure, form,
                 gain="mode", classes=None, markov=False):
        super().__init__(template, values)
        parts = template.parts
        self.X_classes, self.Z_classes = parts["X"], parts["Z"]
        self.Y_classes, self.blocks_classes = parts["Y"], parts["blocks"]
        self.X, self.Z, self.Y, self.blocks = (
            [v[0] for v in parts[f]] for f in ("X", "Z", "Y", "blocks"))
        self.width = parts["width"]
        self.eta, self.margin = eta, margin
        self.structure, self.form = structure, form
        self.gain, self.classes, self.markov = gain, classes, markov


def _selector(idx: np.ndarray, size: int) -> np.ndarray:
    S = np.zeros((idx.size, size))
    S[np.arange(idx.size), idx] = 1.0
    return S


#: Kinds of gain the synthesis LMI designs: ``K_{k,ℓ}`` (exact with
#: ``structure='full'``) or ``K_k`` (sufficient on Markov modes).
GAINS = ("mode", "phase")


def gain_kinds(plant: JumpPlant, gain: str) -> tuple[str, ...]:
    """Per phase, whether the gain may use the previous mode (``'mode'``).

    A gain ``K_{k,ℓ}`` may differ only between previous modes ``ℓ`` that the
    controller can tell apart. Acknowledgements and arrivals reveal a
    link's state only at steps where it carries a message: a link idle the
    step before hides its bit of ``ℓ`` (:ref:`theory-markov`). A builder
    records what is observed as ``plant.info['observed']``, shape (N, M):
    the observation class of each ``ℓ`` per phase (no entry: all of ``ℓ``
    is known). A phase keeps ``'mode'`` when every observation class lies
    in one class of equal rows ``T_{k-1}[ℓ]`` (:func:`mode_classes`: there
    the optimal gain is a function of what is observed); otherwise it
    takes one gain for every ``ℓ`` (``'phase'``, sufficient).

    Parameters
    ----------
    plant : JumpPlant
    gain : {'mode', 'phase'}
        What the caller asked for.

    Returns
    -------
    tuple of str
        ``'mode'`` or ``'phase'`` per phase.
    """
    N = plant.period
    if gain == "phase":
        return ("phase",) * N
    observed = plant.info.get("observed")
    if plant.transition is None or observed is None:
        return ("mode",) * N
    T = plant.transitions()
    kinds = []
    for k in range(N):
        rows, _ = mode_classes(T[k - 1])
        obs = np.asarray(observed[k])
        fine = all(np.unique(rows[obs == o]).size == 1
                   for o in np.unique(obs))
        kinds.append("mode" if fine else "phase")
    return tuple(kinds)


def synthesis_model(plant: JumpPlant, eta: float | None, decay: float,
                    margin: float, structure: str, form: str,
                    gain: str = "mode") -> SynthesisModel:
    """Build ``Ψ_{k,c}`` of :ref:`theory-synthesis` / :ref:`theory-markov` for
    the generic plant of :ref:`theory-jump-system`.

    ``structure``: ``'full'`` (``E_k = I``: exact), ``'block'`` (``X_k``
    block-diagonal on known/unknown coordinates, ``Y_k`` zero on the
    unknown: sufficient), ``'extended'`` (``X_k`` full, slack ``G_k``
    block-diagonal carries the structure: sufficient, never more
    conservative than ``'block'``). ``form``: ``'merged'`` (rows of modes
    with equal matrices and the same next class merged,
    :ref:`theory-synthesis`) or ``'paper'`` (one row per network mode, eq. 15).

    Markov modes (:ref:`theory-markov`): per phase ``k`` the previous modes
    ``ℓ`` fall into classes of equal rows ``t = T_{k-1}[ℓ]``
    (:func:`mode_classes`; i.i.d. modes: one class, the LMI of
    :ref:`theory-synthesis`); class ``c`` has ``X_{k,c}``, ``Y_{k,c}``, rows
    ``√t_i (A_{k,i} X_{k,c} + B_{k,i} Y_{k,c})`` and ``√t_i G_{k,i}`` against
    ``-X_{k+1,c'(i)}`` (``c'(i)``: the class of ``i`` at phase ``k+1``), supply
    row ``-Σ t_i (C X + D Y)``. ``gain='phase'`` asks for ``K_k`` common to the
    classes: a common ``X_k`` (``structure='block'``) or a common slack ``G_k``
    with ``Y_k = K_k G_k`` (sufficient); with one class it is ``'mode'``.

    The problem is compiled once per shape (sizes, period, known
    coordinates, active inputs, classes and rows of each phase, form,
    structure, gain kind, whether ``η`` is maximised) and reused in this
    thread.
    """
    if form == "merged":
        plant = plant.merged()
    s = plant.shape
    N, nx, nu, nw, nz = plant.period, s["nx"], s["nu"], s["nw"], s["nz"]
    T = plant.transitions()
    classes = [mode_classes(T[k - 1]) for k in range(N)]
    phases, rows = [], []
    for k in range(N):
        known, active = plant.known_coordinates(k), plant.active_inputs(k)
        if structure == "full" and known.size not in (0, nx):
            raise ValueError("structure='full' needs E_k = I at every phase")
        labels_next = classes[(k + 1) % N][0]
        rows_k, spec = [], []
        for rep in classes[k][1]:
            t = T[k - 1][rep]
            merged: dict = {}
            for i in np.flatnonzero(t > 0):
                key = ((int(labels_next[i]),) + tuple(
                    getattr(plant, f)[k, i].tobytes()
                    for f in JumpPlant._FIELDS) if form == "merged" else i)
                if key in merged:
                    merged[key][0] += t[i]
                else:
                    merged[key] = [t[i], i, int(labels_next[i])]
            rows_k.append((t, list(merged.values())))
            spec.append(tuple(r[2] for r in merged.values()))
        rows.append(rows_k)
        phases.append((tuple(known), tuple(active), tuple(spec)))
    kinds = tuple(k if len(c[1]) > 1 else "mode"
                  for k, c in zip(gain_kinds(plant, gain), classes))
    key = ("synthesis", form, structure, kinds, N, nx, nu, nw, nz,
           eta is None, tuple(phases))
    template = _template(key, lambda: _synthesis_template(
        N, nx, nu, nw, nz, phases, eta is None, structure, kinds))
    eps = margin * data_scale(plant.A, plant.Bu, plant.Bw, plant.Cz,
                              plant.Du, plant.Dw)
    values: dict[Any, Any] = {"margin": eps, "decay2": float(decay) ** 2}
    if eta is not None:
        values["eta"] = float(eta)
    for k, (known_k, active_k, _) in enumerate(phases):
        cols = list(active_k)
        has_y = bool(known_k) and bool(cols)
        for c, (t, rows_kc) in enumerate(rows[k]):
            # the supply is linear in z: its expectation takes the means
            Dwbar = np.einsum("m,mij->ij", t, plant.Dw[k])
            values[("Cz", k, c)] = np.einsum("m,mij->ij", t, plant.Cz[k])
            values[("Dsym", k, c)] = Dwbar + Dwbar.T
            if has_y:
                values[("Du", k, c)] = np.einsum(
                    "m,mij->ij", t, plant.Du[k])[:, cols]
            # √t_i times the data, as one parameter: √t × A × X is not DPP
            for a, (weight, i, _) in enumerate(rows_kc):
                root = np.sqrt(weight)
                values[("A", k, c, a)] = root * plant.A[k, i]
                values[("Bw", k, c, a)] = root * plant.Bw[k, i]
                if has_y:
                    values[("Bu", k, c, a)] = root * plant.Bu[k, i][:, cols]
    return SynthesisModel(
        template, values,
        template.parts["eta"] if eta is None else float(eta), eps,
        structure, form, gain, [c[0] for c in classes],
        plant.transition is not None)


def _gain_variables(nx, known, active, structure, k, tag):
    """``X``, ``Z`` (``X`` or the slack ``G``), ``Z_s`` and ``Y`` of one
    block, with the structure of :ref:`theory-synthesis`."""
    rest = np.setdiff1d(np.arange(nx), known)
    Es, Er = _selector(known, nx), _selector(rest, nx)
    split = structure != "full" and rest.size > 0 and known.size > 0
    if structure == "extended" and split:
        Xk = cp.Variable((nx, nx), symmetric=True, name=f"X{k}{tag}")
        Gs = cp.Variable((known.size, known.size), name=f"Gs{k}{tag}")
        Gr = cp.Variable((rest.size, rest.size), name=f"Gr{k}{tag}")
        Zk, Zs = Es.T @ Gs @ Es + Er.T @ Gr @ Er, Gs
    elif split:
        Xs = cp.Variable((known.size, known.size), symmetric=True,
                         name=f"Xs{k}{tag}")
        Xr = cp.Variable((rest.size, rest.size), symmetric=True,
                         name=f"Xr{k}{tag}")
        Xk = Es.T @ Xs @ Es + Er.T @ Xr @ Er
        Zk, Zs = Xk, Xs
    else:
        Xk = cp.Variable((nx, nx), symmetric=True, name=f"X{k}{tag}")
        Zk, Zs = Xk, Xk
    # Y_k is zero on unknown coordinates and unaddressed inputs, exactly.
    Yv = (cp.Variable((active.size, known.size), name=f"Y{k}{tag}")
          if known.size and active.size else None)
    return Xk, Zk, Zs, Yv


def _shared_slack(nx, known, k):
    """Slack ``G_k`` common to the classes of a phase (phase-only gains):
    block-diagonal on (known, rest) so that ``Y_k G_k⁻¹`` keeps the zeros."""
    rest = np.setdiff1d(np.arange(nx), known)
    if rest.size == 0 or known.size == 0:
        G = cp.Variable((nx, nx), name=f"G{k}")
        return G, G
    Es, Er = _selector(known, nx), _selector(rest, nx)
    Gs = cp.Variable((known.size, known.size), name=f"Gs{k}")
    Gr = cp.Variable((rest.size, rest.size), name=f"Gr{k}")
    return Es.T @ Gs @ Es + Er.T @ Gr @ Er, Gs


def _synthesis_template(N, nx, nu, nw, nz, phases, maximise_eta, structure,
                        kinds):
    params: dict = {}
    eps = _param(params, "margin")
    d2 = _param(params, "decay2")
    e = cp.Variable(name="eta") if maximise_eta else _param(params, "eta")
    X, Z, Y, blocks = [], [], [], []
    for k, (known, active, spec) in enumerate(phases):
        known, active = np.array(known, int), np.array(active, int)
        if kinds[k] == "phase" and len(spec) > 1:
            # K_k for every ℓ (theory: Markov losses): non-convex; sufficient
            # with a common X_k ('block') or a common slack G_k, Y_k = K_k G_k
            Xk, Zk, Zs, Yv = _gain_variables(nx, known, active, structure, k,
                                             "")
            if structure != "block":
                Zk, Zs = _shared_slack(nx, known, k)
                Xs = [Xk] + [cp.Variable((nx, nx), symmetric=True,
                                         name=f"X{k}_{c}")
                             for c in range(1, len(spec))]
            else:
                Xs = [Xk] * len(spec)
            X.append(Xs)
            Z.append([Zk] * len(spec))
            Y.append([Yv] * len(spec))
            blocks.append([(known, active, Zs)] * len(spec))
            continue
        parts = [_gain_variables(nx, known, active, structure, k,
                                 "" if len(spec) == 1 else f"_{c}")
                 for c in range(len(spec))]
        X.append([p[0] for p in parts])
        Z.append([p[1] for p in parts])
        Y.append([p[3] for p in parts])
        blocks.append([(known, active, p[2]) for p in parts])
    width = 0
    cons = []
    for k, (_known, active, spec) in enumerate(phases):
        Sk = _selector(blocks[k][0][0], nx)
        for c, nexts in enumerate(spec):
            Zk, Xk, Yv = Z[k][c], X[k][c], Y[k][c]
            # extended form: -Gᵀ X⁻¹ G ≼ X - G - Gᵀ replaces -X
            # (de Oliveira et al.)
            top = (-d2 * Xk if Zk is Xk else d2 * (Xk - Zk - Zk.T))
            L21 = -(_param(params, ("Cz", k, c), (nz, nx)) @ Zk)
            if Yv is not None:
                # Du Y, Y = S_activeᵀ Yv S_known: (Du S_activeᵀ) Yv S_known
                L21 = L21 - _param(params, ("Du", k, c),
                                   (nz, len(active))) @ Yv @ Sk
            L22 = 2 * e * np.eye(nw) - _param(params, ("Dsym", k, c),
                                              (nw, nw))
            rows1, rows2 = [], []
            for a in range(len(nexts)):
                row = _param(params, ("A", k, c, a), (nx, nx)) @ Zk
                if Yv is not None:
                    row = row + _param(params, ("Bu", k, c, a),
                                       (nx, len(active))) @ Yv @ Sk
                rows1.append(row)
                rows2.append(_param(params, ("Bw", k, c, a), (nx, nw)))
            R = len(nexts)
            grid = [[top, L21.T] + [r.T for r in rows1],
                    [L21, L22] + [r.T for r in rows2]]
            for a in range(R):
                Xn = X[(k + 1) % N][nexts[a]]
                grid.append([rows1[a], rows2[a]] + [
                    -Xn if b == a else np.zeros((nx, nx)) for b in range(R)])
            side = nx + nw + R * nx
            width = max(width, side)
            # symmetric by construction (see _symmetric_scatter)
            cons.append(cp.bmat(grid) << -eps * np.eye(side))
            if c == 0 or Xk is not X[k][0]:
                cons.append(Xk >> eps * np.eye(nx))
    objective = cp.Maximize(e) if maximise_eta else cp.Minimize(0)
    return _Template(cp.Problem(objective, cons), params, X=X, Z=Z, Y=Y,
                     blocks=blocks, eta=e, width=width)


def read_gains(model: SynthesisModel, plant: JumpPlant
               ) -> tuple[np.ndarray, np.ndarray]:
    """Gains and certificates ``P = X⁻¹`` of a solved model.

    ``K E = Y Z⁻¹`` is computed block-wise, so the zero pattern that the
    structure imposes (silent sensors, unaddressed actuators) is exact.
    Returns gains of shape ``(N, nu, nk)`` (i.i.d. modes, or
    ``gain='phase'``) or ``(N, M, nu, nk)`` (``K_{k,ℓ}``, Markov modes),
    and certificates of shape ``(N, nx, nx)`` (i.i.d.) or
    ``(N, M, nx, nx)`` (``P_{k,ℓ}``, indexed by the previous mode).
    """
    model.check_current()
    s = plant.shape
    N, nx, nu = plant.period, s["nx"], s["nu"]
    per_class_K, per_class_P = [], []
    for k in range(N):
        Ks, Ps = [], []
        for c, Xv in enumerate(model.X_classes[k]):
            Xk = np.asarray(Xv.value, float)
            Pk = np.linalg.inv(0.5 * (Xk + Xk.T))
            Ps.append(0.5 * (Pk + Pk.T))
            known, active, Zs = model.blocks_classes[k][c]
            Yv = model.Y_classes[k][c]
            gain = np.zeros((nu, s["nk"]))
            if Yv is not None:
                Zs_val = np.asarray(Zs.value, float)
                Kv = np.linalg.solve(Zs_val.T, np.asarray(Yv.value).T).T
                Kfull = np.zeros((nu, nx))
                Kfull[np.ix_(active, known)] = Kv
                gain = Kfull @ plant.E[k].T
            Ks.append(gain)
        per_class_K.append(Ks)
        per_class_P.append(Ps)
    if not model.markov:
        return (np.array([Ks[0] for Ks in per_class_K]),
                np.array([Ps[0] for Ps in per_class_P]))
    labels = model.classes
    P = np.array([[per_class_P[k][c] for c in labels[k]] for k in range(N)])
    if model.gain == "phase":
        return np.array([Ks[0] for Ks in per_class_K]), P
    gains = np.array([[per_class_K[k][c] for c in labels[k]]
                      for k in range(N)])
    return gains, P


# -- analysis with an output-feedback term (theory: passivity, supply 2wᵀz -
# 2ρzᵀz - 2ηwᵀw)
class SupplyModel:
    """The analysis LMI with ``ρ`` or Markov modes: ``Θ ≼ -ε diag(P, I)``.

    A plain (uncached) cvxpy problem: the ``ρ`` term and Markov modes are
    rare next to the i.i.d. input-feedforward index of
    :func:`analysis_model`.

    Attributes
    ----------
    problem : cvxpy.Problem
    P : list of list of cvxpy.Variable
        ``P[k][ℓ]``: ``P_k`` (``ℓ = 0`` only) for i.i.d. modes, ``P_{k,ℓ}``
        per previous mode for Markov modes (:ref:`theory-markov`).
    eta, rho, margin : cvxpy.Variable or float
        The maximised one is a Variable, the others the given values.
    """

    def __init__(self, problem: cp.Problem, P: list, eta: Any, rho: Any,
                 margin: Any, markov: bool = False):
        self.problem, self.P = problem, P
        self.eta, self.rho, self.margin = eta, rho, margin
        self.markov = markov

    def check_current(self) -> None:
        """Nothing to check: the problem is this model's own."""

    def values(self) -> np.ndarray:
        """The solved certificate: (N, n, n), or (N, M, n, n) if Markov."""
        P = np.array([[v.value for v in Pk] for Pk in self.P])
        return P if self.markov else P[:, 0]


def supply_model(sys: JumpStateSpace, eta: float | None, rho: float | None,
                 margin: float | None, decay: float = 1.0) -> SupplyModel:
    """Build the LMI of :ref:`theory-passivity` / :ref:`theory-markov` with the
    supply ``2wᵀz - 2ρzᵀz - 2ηwᵀw``.

    ``Θ`` gains ``2ρ Σ_i t_i [C_i D_i]ᵀ[C_i D_i]`` (``zᵀz`` is quadratic:
    its expectation takes each mode's output matrices, not their mean; see
    :func:`control_ncs.verify.dissipation_blocks`), linear in ``P``, ``η``
    and ``ρ``. One inequality per phase and supply row
    (:func:`control_ncs.verify.supply_rows`): for Markov modes ``Θ_{k,ℓ}``
    with ``P_{k,ℓ}`` and ``P_{k+1,i}`` per next mode. Exactly one of
    ``eta``, ``rho``, ``margin`` may be None: that one is maximised
    (``margin=None``: the most interior certificate, as in
    :func:`analysis_model`).
    """
    if [eta, rho, margin].count(None) > 1:
        raise ValueError("supply_model: at most one of eta, rho, margin may "
                         "be None")
    A, B, C, D = sys.modes.A, sys.modes.B, sys.modes.C, sys.modes.D
    rows = supply_rows(sys.modes)
    markov = not sys.modes.is_iid
    N, L, n, m = sys.period, rows.shape[1], A.shape[-1], B.shape[-1]
    e = cp.Variable(name="eta") if eta is None else float(eta)
    r = cp.Variable(name="rho") if rho is None else float(rho)
    t = (cp.Variable(name="margin") if margin is None
         else margin * data_scale(A, B, C, D))
    P = [[cp.Variable((n, n), symmetric=True, name=f"P{k}_{l}")
          for l in range(L)] for k in range(N)]
    cons = []
    for k in range(N):
        Pn = P[(k + 1) % N]
        for l, p in enumerate(rows[k]):
            live = np.flatnonzero(p > 0)
            F = {i: np.concatenate([A[k, i], B[k, i]], axis=1) for i in live}
            H = {i: np.concatenate([C[k, i], D[k, i]], axis=1) for i in live}
            # i.i.d.: one P_{k+1}; Markov: P_{k+1,i} for next mode i
            quad = sum(p[i] * (F[i].T @ Pn[i if markov else 0] @ F[i])
                       for i in live)
            W = sum(p[i] * (H[i].T @ H[i]) for i in live)
            Cbar = np.tensordot(p, C[k], axes=1)
            Dbar = np.tensordot(p, D[k], axes=1)
            Pk = P[k][l]
            supply = cp.bmat([[-float(decay) ** 2 * Pk, -Cbar.T],
                              [-Cbar, 2 * e * np.eye(m) - Dbar - Dbar.T]])
            M = quad + supply + 2 * r * W
            slack = (np.eye(n + m) if margin is None else
                     cp.bmat([[Pk, np.zeros((n, m))],
                              [np.zeros((m, n)), np.eye(m)]]))
            cons += [0.5 * (M + M.T) << -t * slack, Pk >> t * np.eye(n)]
    objective = (cp.Maximize(t) if margin is None else
                 cp.Maximize(e) if eta is None else
                 cp.Maximize(r) if rho is None else cp.Minimize(0))
    return SupplyModel(cp.Problem(objective, cons), P, e, r, t, markov)


# -- estimator gain (theory: output feedback) ---------------------------------
@dataclass
class EstimatorModel:
    """The estimator LMI of :ref:`theory-output-feedback` over one period,
    before its solve.

    Attributes
    ----------
    problem : cvxpy.Problem
    P, Z : list of cvxpy.Variable
        ``P_k`` (n × n, symmetric) and ``Z_k = P_k L_k`` (n × p2), per phase.
    """

    problem: cp.Problem
    P: list
    Z: list


def estimator_model(A: np.ndarray, C2: np.ndarray, S1: np.ndarray,
                    loss: float, decay: float = 1.0,
                    margin: float = 1e-6) -> EstimatorModel:
    """Mean-square detectability LMI of the lossy, scheduled sensor link.

    For every phase ``k`` (``j = k + 1 mod N``), with ``Mθ = (I - θ L_j Σ1,j
    C2) A`` and ``Z_j = P_j L_j``, ``Σ_θ p_θ Mθᵀ P_j Mθ ≺ r² P_k`` is, by a
    Schur complement, ``[[r² P_k, *, *], [√α1 P_j A, P_j, 0],
    [√(1-α1) (P_j - Z_j Σ1,j C2) A, 0, P_j]] ≻ 0``
    (:ref:`theory-output-feedback`). The LMI is homogeneous in ``(P, Z)``: it
    is normalised by ``P_k ⪰ I`` and imposed with the margin ``margin · s``
    (``s`` the scale of ``A``); the objective ``t ⪰ P_k`` keeps the certificate
    well conditioned.

    Parameters
    ----------
    A : ndarray, shape (n, n)
    C2 : ndarray, shape (p2, n)
    S1 : ndarray, shape (N, p2, p2)
        Sensor selections ``Σ1,k`` per phase.
    loss : float
        ``α1``, the sensor link's loss probability (Bernoulli).
    decay : float
        ``r`` in ``(0, 1]``.
    margin : float
        Relative strictness margin.

    Returns
    -------
    EstimatorModel
    """
    n, N = A.shape[0], S1.shape[0]
    p2 = C2.shape[0]
    P = [cp.Variable((n, n), symmetric=True) for _ in range(N)]
    Z = [cp.Variable((n, p2)) for _ in range(N)]
    t = cp.Variable()
    eps = margin * max(1.0, float(np.linalg.norm(A, 2)) ** 2)
    cons = []
    for k in range(N):
        j = (k + 1) % N
        rows = []
        if loss > 0:
            rows.append(np.sqrt(loss) * (P[j] @ A))
        if loss < 1:
            rows.append(np.sqrt(1 - loss) * ((P[j] - Z[j] @ S1[j] @ C2) @ A))
        size = len(rows)
        blocks = [[decay ** 2 * P[k]] + [r.T for r in rows]]
        for i, r in enumerate(rows):
            blocks.append([r] + [P[j] if i == c else np.zeros((n, n))
                                 for c in range(size)])
        M = cp.bmat(blocks)
        # cvxpy needs the symmetry said out loud
        cons.append(0.5 * (M + M.T) >> eps * np.eye(n * (size + 1)))
        cons += [P[k] >> np.eye(n), P[k] << t * np.eye(n)]
    return EstimatorModel(cp.Problem(cp.Minimize(t), cons), P, Z)


def markov_estimator_model(A: np.ndarray, C2: np.ndarray, S1: np.ndarray,
                           transition: np.ndarray, decay: float = 1.0,
                           margin: float = 1e-6) -> EstimatorModel:
    """The estimator LMI over a bursty (Markov) sensor link; exact.

    The error loop ``e_{k+1} = (I - θ_{k+1} L_{k+1} Σ1,k+1 C2) A e_k`` is a
    Markov jump system whose mode at step ``k`` is ``i = θ_{k+1}`` (the link
    moves at every step, scheduled or not: :ref:`theory-markov`). It is
    mean-square stable (within ``r²``) iff storages ``P_{k,i} ≻ 0`` exist
    with ``M_iᵀ E_{k,i} M_i ≺ r² P_{k,i}``, ``E_{k,i} = Σ_j T[i, j]
    P_{k+1,j}``, ``M_0 = A`` and ``M_1 = (I - L_{k+1} Σ C2) A``. The gain
    enters the arrived mode only, so ``Z_k = E_{k,1} L_{k+1}`` makes the
    condition an LMI without loss (:ref:`theory-output-feedback`): one gain
    per phase is optimal. Normalised by ``P ⪰ I`` with the margin
    ``margin · s``, as :func:`estimator_model`.

    Parameters
    ----------
    A, C2, S1, decay, margin
        As for :func:`estimator_model`.
    transition : ndarray, shape (2, 2)
        The sensor link's ``T[a, b] = P(θ⁺ = b | θ = a)``, order (lost,
        arrived).

    Returns
    -------
    EstimatorModel
        ``P[k]`` is the pair ``[P_{k,0}, P_{k,1}]``; ``Z[k]`` gives
        ``L_{k+1} = E_{k,1}⁻¹ Z_k``.
    """
    n, N = A.shape[0], S1.shape[0]
    p2 = C2.shape[0]
    T = np.asarray(transition, float)
    P = [[cp.Variable((n, n), symmetric=True) for _ in range(2)]
         for _ in range(N)]
    Z = [cp.Variable((n, p2)) for _ in range(N)]
    t = cp.Variable()
    eps = margin * max(1.0, float(np.linalg.norm(A, 2)) ** 2)
    cons = []
    for k in range(N):
        j = (k + 1) % N
        E = [T[i, 0] * P[j][0] + T[i, 1] * P[j][1] for i in range(2)]
        lost = decay ** 2 * P[k][0] - A.T @ E[0] @ A
        cons.append(0.5 * (lost + lost.T) >> eps * np.eye(n))
        M = (E[1] - Z[k] @ S1[j] @ C2) @ A
        block = cp.bmat([[decay ** 2 * P[k][1], M.T], [M, E[1]]])
        cons.append(0.5 * (block + block.T) >> eps * np.eye(2 * n))
        for i in range(2):
            cons += [P[k][i] >> np.eye(n), P[k][i] << t * np.eye(n)]
    return EstimatorModel(cp.Problem(cp.Minimize(t), cons), P, Z)


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
