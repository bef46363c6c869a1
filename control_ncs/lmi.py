"""The one place that talks to cvxpy: LMIs of MATH §6 and §8, solved.

Models are built as functions of the data (cvxpy's idiom: build, then solve
in one place). Strictness margins are relative to the scale of the data, so
that a problem and its rescaled copy are treated alike (MATH §8). Nothing
here decides whether a result is *true*: ``verify.py`` does that exactly.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import cvxpy as cp
from control.exception import ControlArgument

from .jump import JumpPlant, JumpStateSpace

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


def check_solver(solver: str | None) -> str:
    """The cvxpy solver name to use (Clarabel by default), or a clear error."""
    name = cp.CLARABEL if solver is None else str(solver).upper()
    if name not in cp.installed_solvers():
        raise ControlArgument(f"solver: {solver!r} is not an installed cvxpy "
                              f"solver; installed: {cp.installed_solvers()}")
    return name


#: When nothing verifies with the default solver (Clarabel), synthesis and
#: analysis ask this solver once, if installed (never when the caller names a
#: solver). Measured (tests/test_synthesis.py, tests/test_passivity.py): on
#: 54 seeded plants with sensor schedules (n = 2..5, N = 2, 3), 26 admit no
#: structured gain and Clarabel stops with InsufficientProgress as η runs off
#: to -∞ (or once claims 'optimal' at η = -2.8e14 with X indefinite); CVXOPT
#: proves 25 of them infeasible in 0.1-0.3 s each. Re-certifying a given η
#: within ~1e-8 of the index, Clarabel ends 'optimal_inaccurate' with
#: λmax(Θ) ≈ +1e-8 where CVXOPT's answer passes the exact check.
FALLBACK_SOLVER = "CVXOPT"


def fallback_solver(solver: str | None) -> str | None:
    """The solver to ask once when nothing verified, or None (see above)."""
    if solver is None and FALLBACK_SOLVER in cp.installed_solvers():
        return FALLBACK_SOLVER
    return None


#: Keywords that :meth:`cvxpy.Problem.solve` itself accepts for any solver.
CVXPY_SOLVE_KEYWORDS = frozenset((
    "verbose", "warm_start", "gp", "qcp", "requires_grad", "enforce_dpp",
    "ignore_dpp", "canon_backend", "bounds"))

#: CVXOPT's cone-programming options (cvxopt.solvers.options) and the two
#: cvxpy adds. CVXOPT ignores any other key silently, so a misspelt option
#: would change nothing and say nothing: it is rejected here instead.
CVXOPT_OPTIONS = frozenset((
    "show_progress", "maxiters", "abstol", "reltol", "feastol", "refinement",
    "kktreg", "debug", "max_iters", "kktsolver"))


def check_options(name: str, options: dict) -> None:
    """``TypeError`` for solver options the solver would silently ignore.

    Clarabel and SCS reject unknown settings themselves (``TypeError``);
    CVXOPT does not, so its keys are checked against the known ones.
    """
    if name == cp.CVXOPT:
        unknown = set(options) - CVXOPT_OPTIONS - CVXPY_SOLVE_KEYWORDS
        if unknown:
            raise TypeError(
                f"solver option(s) {sorted(unknown)} not accepted by CVXOPT "
                f"(known: {sorted(CVXOPT_OPTIONS)}, and cvxpy's "
                f"{sorted(CVXPY_SOLVE_KEYWORDS)})")


def solve(problem: cp.Problem, solver: str | None = None,
          **options: Any) -> SolveReport:
    """Solve ``problem`` and report; solver failures become a status."""
    name = check_solver(solver)
    check_options(name, options)
    opts = dict(CLARABEL_DEFAULTS) if name == cp.CLARABEL else {}
    opts.update(options)
    start = time.perf_counter()
    message = ""
    try:
        problem.solve(solver=name, **opts)
        status = problem.status
    except cp.error.SolverError as err:
        status, message = "solver_error", str(err)
    except BaseException as err:
        # Clarabel (Rust, via pyo3) turns an internal panic, e.g. a failed
        # eigendecomposition in a PSD cone step near the boundary, into
        # pyo3_runtime.PanicException, a BaseException that no `except
        # Exception` catches. It is a solver failure like any other.
        if type(err).__name__ != "PanicException":
            raise
        status, message = "solver_error", f"{name} panicked: {err}"
    total = time.perf_counter() - start
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


def _sym(M: cp.Expression) -> cp.Expression:
    return 0.5 * (M + M.T)


def data_scale(*mats: np.ndarray) -> float:
    """A scale for the margins: the largest spectral norm among the data."""
    norms = [np.linalg.norm(M.reshape(-1, M.shape[-1]), 2) for M in mats
             if M.size]
    return max([1.0] + norms)


# -- analysis: MATH §6 ---------------------------------------------------------
@dataclass
class AnalysisModel:
    """The analysis LMI: ``Θ_k(P, η) ≼ -ε diag(P_k, I)``, ``P_k ≽ ε I``."""

    problem: cp.Problem
    P: list
    eta: Any
    margin: Any          # ε, or the variable t when the margin is maximised


def analysis_model(sys: JumpStateSpace, eta: float | None,
                   margin: float | None, decay: float = 1.0) -> AnalysisModel:
    """Build the LMI of MATH §6 (maximise ``η`` when ``eta`` is None).

    ``margin=None`` (with a given ``eta``) maximises the strictness margin
    ``t`` itself: ``Θ_k ≼ -t I``, ``P_k ≽ t I``. Its answer is the most
    interior certificate, the one most likely to pass the exact check when
    ``η`` lies within a fixed margin of the index; ``t ≤ 0`` at the optimum
    means no strict certificate exists.
    """
    A, B, p = sys.modes.A, sys.modes.B, sys.modes.probabilities
    _, _, Cbar, Dbar = sys.modes.mean()
    N, n, m = sys.period, A.shape[-1], B.shape[-1]
    if margin is None:
        if eta is None:
            raise ValueError("analysis_model: margin=None needs a given eta")
        t = cp.Variable(name="margin")
    else:
        t = margin * data_scale(A, B, sys.modes.C, sys.modes.D)
    P = [cp.Variable((n, n), symmetric=True, name=f"P{k}") for k in range(N)]
    e = cp.Variable(name="eta") if eta is None else float(eta)
    cons = []
    for k in range(N):
        Pn = P[(k + 1) % N]
        live = np.flatnonzero(p[k] > 0)
        quad = sum(p[k, i] * (np.hstack([A[k, i], B[k, i]]).T @ Pn
                              @ np.hstack([A[k, i], B[k, i]])) for i in live)
        supply = cp.bmat([
            [-decay ** 2 * P[k], -Cbar[k].T],
            [-Cbar[k], 2 * e * np.eye(m) - Dbar[k] - Dbar[k].T]])
        # The (1,1) block is homogeneous in P, so its margin is relative to
        # P_k (a decay margin 1 - ε). An absolute ε·I there forces
        # ‖P‖ ≳ ε / (1 - ms_radius) and, through the supply coupling, costs η:
        # measured on a loop from passivesyn with ms_radius = 1 - 1e-6, the
        # absolute margin certified η = -4.7e5 where the synthesis P proves
        # 1.5285 (tests/test_passivity.py).
        slack = (np.eye(n + m) if margin is None else
                 cp.bmat([[P[k], np.zeros((n, m))],
                          [np.zeros((m, n)), np.eye(m)]]))
        cons += [_sym(quad + supply) << -t * slack,
                 P[k] >> t * np.eye(n)]
    objective = (cp.Maximize(t) if margin is None else
                 cp.Maximize(e) if eta is None else cp.Minimize(0))
    return AnalysisModel(cp.Problem(objective, cons), P, e, t)


# -- synthesis: MATH §8, §8b, §10 ----------------------------------------------
@dataclass
class SynthesisModel:
    """The synthesis LMI ``Ψ_k ≼ -ε I`` and how to read a gain from it."""

    problem: cp.Problem
    X: list
    Z: list              # X_k (block/full) or the slack G_k (extended)
    Y: list
    blocks: list         # per phase: (known, active, Zs variable) for gains
    eta: Any
    margin: float
    structure: str
    form: str
    width: int           # side of each Ψ_k


def _selector(idx: np.ndarray, size: int) -> np.ndarray:
    S = np.zeros((idx.size, size))
    S[np.arange(idx.size), idx] = 1.0
    return S


def synthesis_model(plant: JumpPlant, eta: float | None, decay: float,
                    margin: float, structure: str, form: str
                    ) -> SynthesisModel:
    """Build ``Ψ_k`` of MATH §8 for the generic plant of §10.

    ``structure``: ``'full'`` (``E_k = I``: exact), ``'block'`` (``X_k``
    block-diagonal on known/unknown coordinates, ``Y_k`` zero on the
    unknown: sufficient), ``'extended'`` (``X_k`` full, slack ``G_k``
    block-diagonal carries the structure: sufficient, never more
    conservative than ``'block'``). ``form``: ``'merged'`` (coinciding modes
    merged, MATH §8) or ``'paper'`` (one row per network mode, eq. 15).
    """
    if form == "merged":
        plant = plant.merged()
    s = plant.shape
    N, nx, nu, nw = plant.period, s["nx"], s["nu"], s["nw"]
    p = plant.probabilities
    Czbar = np.einsum("km,kmij->kij", p, plant.Cz)
    Dubar = np.einsum("km,kmij->kij", p, plant.Du)
    Dwbar = np.einsum("km,kmij->kij", p, plant.Dw)
    eps = margin * data_scale(plant.A, plant.Bu, plant.Bw, plant.Cz,
                              plant.Du, plant.Dw)
    X, Z, Y, blocks, cons = [], [], [], [], []
    for k in range(N):
        known = plant.known_coordinates(k)
        rest = np.setdiff1d(np.arange(nx), known)
        active = plant.active_inputs(k)
        Es, Er = _selector(known, nx), _selector(rest, nx)
        split = structure != "full" and rest.size > 0 and known.size > 0
        if structure == "extended" and split:
            Xk = cp.Variable((nx, nx), symmetric=True, name=f"X{k}")
            Gs = cp.Variable((known.size, known.size), name=f"Gs{k}")
            Gr = cp.Variable((rest.size, rest.size), name=f"Gr{k}")
            Zk, Zs = Es.T @ Gs @ Es + Er.T @ Gr @ Er, Gs
        elif split:
            Xs = cp.Variable((known.size, known.size), symmetric=True,
                             name=f"Xs{k}")
            Xr = cp.Variable((rest.size, rest.size), symmetric=True,
                             name=f"Xr{k}")
            Xk = Es.T @ Xs @ Es + Er.T @ Xr @ Er
            Zk, Zs = Xk, Xs
        else:
            if structure == "full" and rest.size and known.size:
                raise ValueError("structure='full' needs E_k = I at every phase")
            Xk = cp.Variable((nx, nx), symmetric=True, name=f"X{k}")
            Zk, Zs = Xk, Xk
        # Y_k is zero on unknown coordinates and unaddressed inputs, exactly.
        Yv = (cp.Variable((active.size, known.size), name=f"Y{k}")
              if known.size and active.size else None)
        X.append(Xk)
        Z.append(Zk)
        Y.append(Yv)
        blocks.append((known, active, Zs))
    e = cp.Variable(name="eta") if eta is None else float(eta)
    width = 0
    for k in range(N):
        Xn = X[(k + 1) % N]
        Zk, Xk = Z[k], X[k]
        Yk = _y_full(Y[k], blocks[k], nu, nx)
        # extended form: -Gᵀ X⁻¹ G ≼ X - G - Gᵀ replaces -X (de Oliveira et al.)
        top = (-decay ** 2 * Xk if Zk is Xk
               else decay ** 2 * (Xk - Zk - Zk.T))
        L21 = -(Czbar[k] @ Zk + Dubar[k] @ Yk)
        L22 = 2 * e * np.eye(nw) - Dwbar[k] - Dwbar[k].T
        live = np.flatnonzero(p[k] > 0)
        rows1 = [np.sqrt(p[k, i]) * (plant.A[k, i] @ Zk + plant.Bu[k, i] @ Yk)
                 for i in live]
        rows2 = [np.sqrt(p[k, i]) * plant.Bw[k, i] for i in live]
        M = len(live)
        grid = [[top, L21.T] + [r.T for r in rows1],
                [L21, L22] + [r.T for r in rows2]]
        for a in range(M):
            grid.append([rows1[a], rows2[a]] + [
                -Xn if b == a else np.zeros((nx, nx)) for b in range(M)])
        Psi = cp.bmat(grid)
        width = nx + nw + M * nx
        cons += [_sym(Psi) << -eps * np.eye(width), Xk >> eps * np.eye(nx)]
    objective = cp.Maximize(e) if eta is None else cp.Minimize(0)
    return SynthesisModel(cp.Problem(objective, cons), X, Z, Y, blocks, e, eps,
                          structure, form, width)


def _y_full(Yv, block, nu, nx):
    known, active, _ = block
    if Yv is None:
        return np.zeros((nu, nx))
    return _selector(active, nu).T @ Yv @ _selector(known, nx)


def read_gains(model: SynthesisModel, plant: JumpPlant
               ) -> tuple[np.ndarray, np.ndarray]:
    """Gains ``K_k`` (shape (N, nu, nk)) and certificates ``P_k = X_k⁻¹``.

    ``K_k E_k = Y_k Z_k⁻¹`` is computed block-wise, so the zero pattern that
    the structure imposes (silent sensors, unaddressed actuators) is exact.
    """
    s = plant.shape
    N, nx, nu = plant.period, s["nx"], s["nu"]
    gains = np.zeros((N, nu, s["nk"]))
    P = np.zeros((N, nx, nx))
    for k in range(N):
        Xk = np.asarray(model.X[k].value, float)
        P[k] = np.linalg.inv(0.5 * (Xk + Xk.T))
        P[k] = 0.5 * (P[k] + P[k].T)
        known, active, Zs = model.blocks[k]
        if model.Y[k] is None:
            continue
        Zs_val = np.asarray(Zs.value, float)
        Kv = np.linalg.solve(Zs_val.T, np.asarray(model.Y[k].value).T).T
        Kfull = np.zeros((nu, nx))
        Kfull[np.ix_(active, known)] = Kv
        gains[k] = Kfull @ plant.E[k].T
    return gains, P
