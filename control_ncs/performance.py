"""Performance of jump systems beyond passivity: the H2 norm, the ℓ2 gain
and the top Lyapunov exponent (:ref:`theory-performance`).

* :func:`norm` mirrors :func:`control.norm`: for a jump system the H2 norm
  is the stationary output power under unit white noise, exact, from the
  linear fixed point of :func:`control_ncs.stationary_covariances`; it is
  not the mean system's H2 norm (the StateSpace face's, which
  ``ct.norm(CL, 2)`` would compute: it refuses a jump system and names this
  function).
* :func:`l2_gain` brackets the ℓ2 gain (H∞ norm) to within 1 %: a
  certified upper bound from the bounded real lemma (its Riccati equation
  bisected, the storage checked exactly) and the exact gain of a worst
  input below it (:mod:`control_ncs._gain`).
* :func:`lyapunov_exponent` estimates the almost-sure growth rate
  ``lim (1/t) log ‖ξ_t‖`` from renormalised products along sample paths,
  with a confidence interval; exact in the scalar case. It can lie far
  below ``½ log ms_radius`` (Jensen's bound): a system can be almost surely
  stable and not mean-square stable.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass
from typing import Any, ClassVar

import control as ct
import numpy as np
from control.exception import ControlArgument, ControlDimension

from ._checks import (choice, decay_bound, no_extra_kwargs,
                      positive_int, positive_real, real_array)
from .exceptions import (CERTIFIED, INFEASIBLE, NOT_MSS, NOT_VERIFIED,
                         SOLVER_FAILED, CertificationError)
from .lmi import (DEFAULT_MARGIN, check_options, check_solver,
                  quadratic_supply_model, solve)
from ._results import CertifiedResult, Result
from ._face import refuse_mean_copy
from ._lti import is_jump
from .jump import as_jump
from .montecarlo import root_entropy
from ._blas import serial_blas
from ._gain import RICCATI_MAX_SIZE, gain_bracket, gain_bracket_size
from .stability import ms_radius
from .stationary import output_power
from ._farkas import supply_dual_check
from .verify import gain_certificate_check, supply_certificate_check

__all__ = ["norm", "l2_gain", "GainResult", "lyapunov_exponent",
           "LyapunovResult", "dissipativity", "SupplyResult"]


def norm(sys: Any, p: Any = 2, *, tol: float = 1e-10, method: str = "auto",
         print_warning: bool = True, **kwargs: Any) -> float:
    """The H2 norm of a jump system (python-control's ``norm``).

    For a jump system (:class:`~control_ncs.jump.JumpStateSpace`) with unit
    white noise ``w``, ``‖G‖₂²`` is the stationary mean power of ``z``
    averaged over the period, ``lim (1/T) E Σ_t ‖z_t‖²``, computed exactly
    from the periodic stationary covariances
    (:func:`control_ncs.stationary_covariances`, matrix-free for large
    systems). For a deterministic system it equals :func:`control.norm`.

    Parameters
    ----------
    sys : JumpStateSpace, StateSpace or TransferFunction
    p : 2 or 'inf', optional
        The norm (default 2). ``'inf'`` (or ``numpy.inf``): for a jump
        system the certified upper bound on its ℓ2 gain
        (:func:`l2_gain`, whose result also gives the lower end of the
        bracket); for a deterministic system :func:`control.norm`.
    tol : float, optional
        Relative residual of the matrix-free solve; for a deterministic
        continuous-time system, python-control's ``tol``.
    method : {'auto', 'dense', 'matrix-free'}, optional
        As for :func:`control_ncs.stationary_covariances`.
    print_warning : bool, optional
        Warn (``UserWarning``) when the system is not mean-square stable
        and the norm is infinite, as python-control does.
    **kwargs
        Reserved: any keyword raises ``TypeError``.

    Returns
    -------
    float
        ``inf`` if ``sys`` is not mean-square stable.

    Raises
    ------
    ControlArgument
        Unknown ``p`` or ``method``.
    CertificationError
        ``p='inf'``: no certificate passed the exact check (see
        :func:`l2_gain`).

    See Also
    --------
    control.norm, control_ncs.ms_radius

    Examples
    --------
    ``x⁺ = 1.1 x + θ u + w``, ``u = -x``, ``z = x``, the control lost with
    probability 0.3: ``‖G‖₂² = 1/(1 - E a²) = 1/(1 - 0.37)``, while the
    mean system (``a = 0.4``) would give ``1/(1 - 0.16)``.

    >>> import control as ct
    >>> import control_ncs as ncs
    >>> CL = ncs.jss([[[1.1]], [[0.1]]], [[1.0]], [[1.0]], [[0.0]], [0.3, 0.7])
    >>> round(ncs.norm(CL, 2), 5), round(float(ct.norm(CL.mean(), 2)), 5)
    (1.25988, 1.09109)
    """
    no_extra_kwargs("norm", kwargs)
    refuse_mean_copy(sys, "sys")    # python-control's copy of a jump system
    tol = positive_real(tol, "tol")
    choice(method, "method", ("auto", "dense", "matrix-free"))
    if isinstance(p, str) or p == np.inf:
        choice(p if isinstance(p, str) else "inf", "p", ("inf",))
        if is_jump(sys):
            radius = ms_radius(sys, bracket=True)
            if radius.stable is not True:
                if print_warning:
                    warnings.warn(f"norm: sys is not proven mean-square "
                                  f"stable ({radius.message}): its l2 gain "
                                  "is taken as infinite", UserWarning,
                                  stacklevel=2)
                return float("inf")
            return l2_gain(sys).gamma
        return float(ct.norm(sys, "inf", print_warning=print_warning))
    if p != 2:
        raise ControlArgument(f"p: expected 2 or 'inf', got {p!r}")
    if not is_jump(sys) and isinstance(sys, ct.LTI) and \
            ct.isctime(sys, strict=True):
        return float(ct.norm(sys, 2, tol=tol, print_warning=print_warning))
    power = output_power(as_jump(sys), method=method, tol=tol)
    if power == math.inf and print_warning:
        warnings.warn("norm: sys is not mean-square stable (ms_radius >= 1): "
                      "its H2 norm is infinite", UserWarning, stacklevel=2)
    return math.sqrt(max(power, 0.0))


#: Relative back-offs above the solver's γ² tried by the exact check (the
#: LMI route, for loops too large for the Riccati route).
GAIN_BACKOFFS = (1e-7, 1e-6, 1e-5, 1e-4, 1e-3, 1e-2)

#: The bracket ``[lower, gamma]`` counts as tight when ``gamma`` exceeds
#: ``lower`` by at most this much (relative).
GAIN_TIGHT = 0.01


@dataclass(repr=False)
class GainResult(CertifiedResult):
    """A certified ℓ2-gain bracket of a jump system.

    Attributes
    ----------
    gamma : float
        Certified upper bound: ``E Σ zᵀz ≤ γ² E Σ wᵀw`` from rest, for every
        input adapted to the past, proven by ``P`` (exact check).
    lower : float
        A lower bound: the gain of a worst input found (``method
        'riccati'``: the maximising policy of the Riccati equation, pushed
        to the edge of mean-square stability, its energies computed
        exactly), or of the mean system (the map from deterministic ``w``
        to ``E z``) on a frequency grid, whichever is larger.
    P : ndarray
        The certificate, (N, n, n) or (N, M, n, n) (Markov modes).
    theta_max, P_min : ndarray
        ``λmax`` of every bounded-real matrix ``Θ`` and ``λmin`` of every
        ``P``, as checked.
    gamma_solver : float
        The SDP solver's optimum (never the certified number); nan on the
        Riccati route.
    report : SolveReport or None
        The SDP solve (None on the Riccati route).
    method : str
        ``'riccati'`` (the bounded real lemma's Riccati equation, bisected
        on ``γ``) or ``'lmi'`` (the SDP, for loops too large for the dense
        Riccati route).
    note : str
        Why the bracket is not tight, when it is not (empty otherwise).

    Examples
    --------
    >>> import control_ncs as ncs
    >>> sys = ncs.jss([[[0.5]], [[0.9]]], [[1.0]], [[1.0]], [[0.0]], [0.5, 0.5])
    >>> res = ncs.l2_gain(sys)
    >>> res.status, bool(res.lower <= res.gamma), res.tight
    ('certified', True, True)
    """

    gamma: float
    lower: float
    P: np.ndarray
    theta_max: np.ndarray
    P_min: np.ndarray
    gamma_solver: float
    report: Any
    method: str = "riccati"
    note: str = ""

    _repr_fields: ClassVar[tuple[str, ...]] = ("gamma", "lower")

    @property
    def tight(self) -> bool:
        """``gamma ≤ (1 + GAIN_TIGHT)·lower``: within 1 % of the gain."""
        return bool(self.gamma <= (1 + GAIN_TIGHT) * self.lower)

    @property
    def message(self) -> str:
        """The bracket in words."""
        text = (f"the l2 gain lies in [{self.lower:.6g}, {self.gamma:.6g}] "
                f"(upper end certified)")
        return text if self.tight else f"{text}; not tight: {self.note}"

    def _details(self) -> list[str]:
        how = ("Riccati equation, bisected" if self.method == "riccati"
               else f"SDP (solver {self.gamma_solver:.8g})")
        return [f"certified gamma {self.gamma:.8g} ({how}), lower bound "
                f"{self.lower:.8g} (relative width "
                f"{self.gamma / self.lower - 1 if self.lower else math.inf:.1e})",
                f"max λmax(Θ) = {self.theta_max.max():.3e}, "
                f"min λmin(P) = {self.P_min.min():.3e}"]


def _mean_gain_lower(sys: Any) -> float:
    """``max_θ σmax(Ḡ(e^{jθ}))`` of the mean face on a grid: a lower bound on
    the ℓ2 gain (deterministic inputs, ``‖E z‖ ≤ (E ‖z‖²)^{1/2}``)."""
    face = sys.mean() if hasattr(sys, "mean") else sys
    A, B, C, D = (np.asarray(X, float) for X in (face.A, face.B, face.C,
                                                  face.D))
    best = float(np.linalg.norm(D, 2)) if D.size else 0.0
    n = A.shape[0]
    if not n or not B.size or not C.size:
        return best
    z = np.exp(1j * np.linspace(0.0, np.pi, 2000))
    # σmax² as the largest eigenvalue of the Gram matrix ``GᴴG = DᴴD +
    # DᴴC X + (DᴴC X)ᴴ + Xᴴ CᴴC X``, ``X = (zI - A)⁻¹ B``, from the
    # products of the data computed once, over blocks of frequencies (the
    # whole grid at once held 1.2 GB); a Hermitian eigenvalue problem
    # instead of an SVD, and only where it can raise the maximum (a loop
    # lifted over 8 phases, 144 × 128: 9.1 s became 2.4 s, the same figure
    # to rounding)
    DD, DC, CC = D.T @ D, D.T @ C, C.T @ C

    def grams(w: np.ndarray) -> np.ndarray:
        X = np.linalg.solve(w[:, None, None] * np.eye(n) - A, B)
        cross = DC @ X
        return DD + cross + cross.conj().swapaxes(-1, -2) + \
            X.conj().swapaxes(-1, -2) @ (CC @ X)

    # λmax ≤ the largest absolute row sum (Gershgorin): the frequencies
    # are solved in the order of that bound, until it is below the best
    # found (those left cannot raise it)
    bound = np.concatenate([np.abs(grams(z[lo:lo + 200])).sum(axis=-1).max(
        axis=-1) for lo in range(0, z.size, 200)])
    order = np.argsort(-bound, kind="stable")
    top = 0.0
    for lo in range(0, order.size, 16):
        idx = order[lo:lo + 16]
        idx = idx[bound[idx] > top]
        if not idx.size:
            break
        top = max(top, float(np.linalg.eigvalsh(grams(z[idx]))[:, -1].max()))
    return max(best, math.sqrt(max(top, 0.0)))


def l2_gain(sys: Any, *, solver: str | None = None,
            margin: float = DEFAULT_MARGIN, **solver_options: Any
            ) -> GainResult:
    """Certified bracket of the ℓ2 gain (H∞ norm) of a jump system.

    The bounded real lemma (:ref:`theory-performance`): storages ``P_k``
    (Markov modes: ``P_{k,ℓ}`` per previous mode) with
    ``Θ_{k,ℓ}(P, γ²) ≺ 0`` prove ``E Σ zᵀz < γ² E Σ wᵀw`` from rest for
    every input adapted to the past; for a fixed loop the lemma is exact.
    Its boundary is a Riccati equation, solved by policy iteration and
    bisected on ``γ``: the returned ``gamma`` is the lowest level whose
    storage (the Riccati solution with a strictness term relative to its
    size) passes the exact check, a relative ``1e-8`` to ``1e-6`` above
    the level where the equation stops having a solution. The lower end is
    the gain of an input built from the maximising policy there (exact
    energies), so the bracket is tight (within 1 %, ``res.tight``) for
    any mean-square stable loop the dense Riccati route can hold
    (``L·n² ≤ 1600`` unknowns); larger loops fall back on the LMI (solved
    by cvxpy, the solver's ``γ²`` raised by ``GAIN_BACKOFFS`` until the
    exact check passes) with the mean system's gain as the lower end, and
    ``res.note`` says so.

    Parameters
    ----------
    sys : JumpStateSpace or discrete-time StateSpace
    solver : str, optional
        Any installed cvxpy solver (default Clarabel), for the LMI route.
    margin : float, optional
        Relative strictness margin of the LMI route.
    **solver_options
        Passed to the solver.

    Returns
    -------
    GainResult

    Raises
    ------
    CertificationError
        ``'not_mss'`` (no finite gain: proven by the certified radius),
        ``'not_verified'`` (stability undecided: the radius' bracket
        contains 1; or no level passes the exact check), ``'solver_failed'``
        (LMI route).

    Examples
    --------
    ``x⁺ = a x + w``, ``z = x``, ``a = 0.5`` or ``0.9`` (probabilities 0.5):
    the scalar bounded real lemma gives ``γ² = min_P P + (0.7P)²/(0.47P -
    1) = 12.7737``; the mean system's gain is only ``1/(1 - 0.7)``.

    >>> import control_ncs as ncs
    >>> sys = ncs.jss([[[0.5]], [[0.9]]], [[1.0]], [[1.0]], [[0.0]], [0.5, 0.5])
    >>> res = ncs.l2_gain(sys)
    >>> round(res.lower, 4), round(res.gamma, 4)
    (3.574, 3.574)
    """
    J = as_jump(sys)
    name = check_solver(solver)
    check_options(name, solver_options)
    margin = positive_real(margin, "margin")
    radius = ms_radius(J, bracket=True)
    if radius.stable is not True:
        undecided = radius.stable is None
        raise CertificationError(
            f"l2_gain: {radius.message}: "
            + ("stability is undecided, so no gain is certified"
               if undecided else "the l2 gain is infinite"),
            NOT_VERIFIED if undecided else NOT_MSS,
            dict(ms_radius=radius.radius, lower=radius.lower,
                 upper=radius.upper))
    # the Riccati route's products act on n² × n² matrices: one BLAS
    # thread (threaded, the n = 16 loop of a sensor schedule took 262 s on
    # the loaded 2-core machine against about 10 s)
    with serial_blas(J.modes.A.shape[-1] ** 2):
        mean = _mean_gain_lower(J)
        found = gain_bracket(J, mean)
    if found is not None and found.level is not None:
        level = found.level
        P = level.P if not J.modes.is_iid else level.P[:, 0]
        note = "" if found.upper <= (1 + GAIN_TIGHT) * found.lower else (
            f"the worst input found reaches {found.lower:.6g}; the "
            "maximising policy could not be pushed to the edge of "
            "mean-square stability")
        return GainResult(found.upper, found.lower, P, level.theta_max,
                          level.P_min, math.nan, None, method="riccati",
                          note=note)
    return _lmi_gain(J, mean, name, margin, solver_options)


def _lmi_gain(J: Any, mean: float, name: str, margin: float,
              solver_options: dict[str, Any]) -> GainResult:
    """The LMI route of :func:`l2_gain` (the Riccati route declined)."""
    model = quadratic_supply_model(J, -1.0, 0.0, None, margin)
    report = solve(model.problem, name, **solver_options)
    if report.status not in ("optimal", "optimal_inaccurate") or \
            model.level.value is None:
        raise CertificationError(
            f"l2_gain: the solver gave no certificate (status "
            f"{report.status!r})", SOLVER_FAILED, dict(status=report.status))
    g2 = float(model.level.value)
    P = model.certificate()
    if J.modes.is_iid:
        P = P[:, 0]                                 # one storage per phase
    scale = max(g2, 1e-12)
    n = J.modes.A.shape[-1]
    why = ("the loop is too large for the dense Riccati route "
           f"({n} states): the lower end is the mean system's gain"
           if gain_bracket_size(J) > RICCATI_MAX_SIZE else
           "no Riccati level passed the exact check: the lower end is the "
           "mean system's gain")
    for backoff in GAIN_BACKOFFS:
        gamma = math.sqrt(g2 + backoff * scale)
        ok, theta_max, P_min = gain_certificate_check(J, P, gamma)
        if ok:
            return GainResult(gamma, min(mean, gamma), P, theta_max, P_min,
                              math.sqrt(g2), report, method="lmi", note=why)
    raise CertificationError(
        f"l2_gain: the solver's gamma = {math.sqrt(g2):.6g} could not be "
        f"certified exactly with back-offs up to {GAIN_BACKOFFS[-1]:g}",
        NOT_VERIFIED, dict(gamma_solver=math.sqrt(g2)))


@dataclass(repr=False)
class LyapunovResult(Result):
    """The top Lyapunov exponent of a jump system, estimated or exact.

    Attributes
    ----------
    exponent : float
        ``λ = lim (1/t) log ‖ξ_t‖`` per step (almost surely).
    confidence_interval : tuple of float
        95 % interval of the estimate (zero width when ``exact``).
    stderr : float
        Standard error over the trials (0 when ``exact``).
    ms_bound : float
        ``½ log ms_radius``, Jensen's upper bound on ``λ``.
    exact : bool
        True for a scalar system (``λ = Σ p log |a|``, averaged over the
        period).
    steps, trials : int
        The sample paths used (0 when ``exact``).

    Examples
    --------
    >>> import control_ncs as ncs
    >>> sys = ncs.jss([[[2.0]], [[0.25]]], [[1.0]], [[1.0]], [[0.0]], [0.5, 0.5])
    >>> res = ncs.lyapunov_exponent(sys)
    >>> res.status, res.message
    ('exact', 'almost surely stable; not mean-square stable')
    """

    exponent: float
    confidence_interval: tuple[float, float]
    stderr: float
    ms_bound: float
    exact: bool
    steps: int
    trials: int

    _repr_fields: ClassVar[tuple[str, ...]] = ("exponent", "ms_bound",
                                               "exact")

    @property
    def success(self) -> bool:
        """True: an estimate always exists."""
        return True

    @property
    def status(self) -> str:
        """``'exact'`` or ``'estimated'``."""
        return "exact" if self.exact else "estimated"

    @property
    def message(self) -> str:
        """One sentence: almost-sure and mean-square stability."""
        sure = ("almost surely stable" if self.confidence_interval[1] < 0
                else "not almost surely stable"
                if self.confidence_interval[0] > 0
                else "undecided at this sample size")
        mss = "mean-square stable" if self.ms_bound < 0 else \
            "not mean-square stable"
        return f"{sure}; {mss}"

    def _details(self) -> list[str]:
        lo, hi = self.confidence_interval
        how = ("exact (scalar)" if self.exact else
               f"{self.trials} paths of {self.steps} steps, 95 % interval "
               f"[{lo:.6g}, {hi:.6g}]")
        return [f"Lyapunov exponent {self.exponent:.6g} per step, {how}",
                f"Jensen's bound ½ log ms_radius = {self.ms_bound:.6g}"]


def lyapunov_exponent(sys: Any, *, steps: int = 5000, trials: int = 20,
                      seed: Any = None, **kwargs: Any) -> LyapunovResult:
    """The top Lyapunov exponent: the almost-sure growth rate.

    ``λ = lim (1/t) log ‖ξ_t‖`` of ``ξ⁺ = A_σ ξ`` (the seed's Definition
    1.4: almost surely stable when ``λ < 0``). Estimated from ``trials``
    independent sample paths of the mode chain, each ``steps`` steps long,
    by products renormalised at every step; the interval is the mean ± 1.96
    standard errors over the paths. For a scalar system it is exact,
    ``λ = (1/N) Σ_k Σ_i p_ki log |a_ki|`` (Markov modes: the stationary
    marginals). Always ``λ ≤ ½ log ms_radius`` (Jensen).

    Parameters
    ----------
    sys : JumpStateSpace or discrete-time StateSpace
    steps : int, optional
        Length of each path (rounded up to whole periods).
    trials : int, optional
        Number of independent paths (at least 2).
    seed : None, int, SeedSequence, BitGenerator or Generator, optional
        The random numbers (never NumPy's global state).
    **kwargs
        Reserved: any keyword raises ``TypeError``.

    Returns
    -------
    LyapunovResult

    Examples
    --------
    ``a = 2`` or ``0.25``, equally likely: ``λ = ½ ln 0.5 < 0`` (almost
    surely stable) while ``E a² = 2.03 > 1`` (not mean-square stable).

    >>> import control_ncs as ncs
    >>> sys = ncs.jss([[[2.0]], [[0.25]]], [[1.0]], [[1.0]], [[0.0]], [0.5, 0.5])
    >>> res = ncs.lyapunov_exponent(sys)
    >>> round(res.exponent, 5), res.exact, res.ms_bound > 0
    (-0.34657, True, True)
    """
    no_extra_kwargs("lyapunov_exponent", kwargs)
    steps = positive_int(steps, "steps")
    trials = positive_int(trials, "trials")
    if trials < 2:
        raise ValueError(f"trials: expected at least 2 paths (for the "
                         f"interval), got {trials}")
    J = as_jump(sys)
    m = J.modes
    n, N = m.A.shape[-1], J.period
    rho = ms_radius(J)
    bound = 0.5 * math.log(rho) if rho > 0 else -math.inf
    if n == 1:
        a = np.abs(m.A[..., 0, 0])
        p = m.probabilities
        with np.errstate(divide="ignore"):
            logs = np.where(p > 0, np.log(np.where(a > 0, a, 1.0)), 0.0)
        dead = np.any((p > 0) & (a == 0))
        lam = -math.inf if dead else float((p * logs).sum() / N)
        return LyapunovResult(lam, (lam, lam), 0.0, bound, True, 0, 0)
    periods = -(-steps // N)
    rng = np.random.default_rng(root_entropy(seed))
    T = m.transitions()
    mode = rng.choice(m.count, size=trials, p=m.start())
    x = rng.standard_normal((trials, n))
    x /= np.linalg.norm(x, axis=1, keepdims=True)
    total = np.zeros(trials)
    for _ in range(periods):
        for k in range(N):
            x = np.einsum("tab,tb->ta", m.A[k, mode], x)
            size = np.linalg.norm(x, axis=1)
            with np.errstate(divide="ignore"):
                total += np.log(size)
            x /= np.where(size > 0, size, 1.0)[:, None]
            # next mode from the row of the current one
            u = rng.random(trials)
            cdf = np.cumsum(T[k][mode], axis=1)
            mode = np.minimum((u[:, None] > cdf).sum(axis=1), m.count - 1)
    per = total / (periods * N)
    lam = float(per.mean())
    se = float(per.std(ddof=1) / math.sqrt(trials)) if np.all(
        np.isfinite(per)) else 0.0
    return LyapunovResult(lam, (lam - 1.96 * se, lam + 1.96 * se), se, bound,
                          False, periods * N, trials)


@dataclass(repr=False)
class SupplyResult(Result):
    """A certificate of dissipativity for a quadratic supply, checked.

    Attributes
    ----------
    dissipative : bool
        True only when the storage passed the exact check: then
        ``E Σ s(w, z) > 0`` from rest for every input adapted to the past
        (strictly, with a margin), and the loop is mean-square stable.
    P : ndarray or None
        The storage, (N, n, n) or (N, M, n, n) (Markov modes).
    theta_max, P_min : ndarray or None
        As checked.
    reason : str
        ``'certified'``; ``'infeasible'``, a proof that no storage exists
        (the solver's Farkas certificate passed
        :func:`control_ncs._farkas.supply_dual_check`: for a fixed loop the
        lemma is exact, so the loop is not strictly dissipative for this
        supply); or, proving nothing, the solver's failure
        (``'solver_failed'``) or ``'not_verified'`` (a candidate that failed
        the exact check).
    report : SolveReport or None
    proof : dict or None
        With ``'infeasible'``: the multipliers ``Z``, ``value``
        (``Σ <Θ⁰, Z> ≥ 0``) and ``Y_min`` (``≥ 0``), as checked.

    Examples
    --------
    >>> import control_ncs as ncs
    >>> sys = ncs.jss([[[0.5]], [[0.9]]], [[1.0]], [[1.0]], [[1.0]], [0.5, 0.5])
    >>> res = ncs.dissipativity(sys, 0.0, 1.0, -0.4)
    >>> res.status, bool(res.theta_max.max() < 0)
    ('certified', True)
    """

    dissipative: bool
    P: np.ndarray | None
    theta_max: np.ndarray | None
    P_min: np.ndarray | None
    reason: str
    report: Any
    proof: dict[str, Any] | None = None

    _repr_fields: ClassVar[tuple[str, ...]] = ("dissipative", "reason")

    @property
    def success(self) -> bool:
        """True when certified."""
        return self.dissipative

    @property
    def status(self) -> str:
        """``reason``."""
        return self.reason

    @property
    def message(self) -> str:
        """One sentence."""
        if self.dissipative:
            return "dissipative for this supply (storage checked exactly)"
        if self.reason == INFEASIBLE:
            return ("proven: no storage exists for this supply (the "
                    "solver's Farkas certificate passed the exact check)")
        status = getattr(self.report, "status", None)
        return ("no certificate: not a proof that the supply fails "
                f"({self.reason}, solver status {status!r})")

    def _details(self) -> list[str]:
        if self.proof is not None:
            return [f"Σ <Θ⁰, Z> = {self.proof['value']:.3e} ≥ 0, "
                    f"min λmin(Y) = {self.proof['Y_min']:.3e} ≥ 0"]
        if self.theta_max is None or self.P_min is None:
            return []
        return [f"max λmax(Θ) = {self.theta_max.max():.3e}, "
                f"min λmin(P) = {self.P_min.min():.3e}"]


def _supply_weights(Q: Any, S: Any, R: Any, nz: int, nw: int
                    ) -> tuple[Any, Any, Any]:
    out: list[Any] = []
    for name, X, shape in (("Q", Q, (nz, nz)), ("S", S, (nz, nw)),
                           ("R", R, (nw, nw))):
        arr = real_array(X, name, ndim=(0, 2))
        if arr.ndim == 0:
            if shape[0] != shape[1]:
                raise ControlDimension(
                    f"{name}: a number stands for a multiple of I, but the "
                    f"loop has {nz} outputs and {nw} inputs; give a "
                    f"{shape[0]}x{shape[1]} matrix")
            out.append(float(arr))
        elif arr.shape != shape:
            raise ControlDimension(f"{name}: expected shape {shape}, got "
                                   f"{arr.shape}")
        else:
            out.append(arr)
    Qm: np.ndarray = (out[0] * np.eye(nz) if np.ndim(out[0]) == 0
                      else out[0])
    if not np.allclose(Qm, Qm.T) or np.linalg.eigvalsh(
            0.5 * (Qm + Qm.T)).max() > 1e-12 * max(1.0, np.abs(Qm).max()):
        raise ValueError("Q: expected a symmetric negative semidefinite "
                         "weight (Q ⪯ 0)")
    return out[0], out[1], out[2]


def dissipativity(sys: Any, Q: Any, S: Any, R: Any, *, decay: float = 1.0,
                  solver: str | None = None, margin: float = DEFAULT_MARGIN,
                  **solver_options: Any) -> SupplyResult:
    """Certify a jump system dissipative for a quadratic supply.

    The supply ``s(w, z) = zᵀQz + 2 zᵀSw + wᵀRw`` with ``Q ⪯ 0``
    (:ref:`theory-performance`): passivity (``Q = 0, S = I, R = -2ηI``),
    the passivity indices, the ℓ2 gain (``Q = -I, S = 0, R = γ²I``), sector
    bounds and mixed specifications are its cases. A storage ``P_k``
    (Markov modes: ``P_{k,ℓ}``) is found by the LMI (cvxpy) and then
    checked exactly (:func:`control_ncs.verify.supply_certificate_check`);
    only a storage that passes makes the result ``dissipative``.

    Parameters
    ----------
    sys : JumpStateSpace or discrete-time StateSpace
    Q, S, R : float or array_like
        The supply's weights, shapes (p, p), (p, m), (m, m); a number stands
        for that multiple of ``I``.
    decay : float, optional
        Also certify ``E V`` decaying like ``r^(2t)`` (``r`` in (0, 1]).
    solver : str, optional
        Any installed cvxpy solver (default Clarabel).
    margin : float, optional
        Relative strictness margin of the LMI.
    **solver_options
        Passed to the solver.

    Returns
    -------
    SupplyResult

    Raises
    ------
    ValueError
        ``Q`` is not negative semidefinite, or ``decay`` not in (0, 1].
    ControlDimension
        A weight of the wrong shape.

    Examples
    --------
    ``x⁺ = a x + w``, ``z = x + w``, ``a = 0.5`` or ``0.9``: passive with
    dissipation 0.2 (``Q = 0, S = 1, R = -0.4``); for the sector bound
    ``(z - 0.5w)(2w - z) ≥ 0`` (``Q = -1, S = 1.25, R = -1``) no storage
    exists, and the solver's infeasibility certificate proves it.

    >>> import control_ncs as ncs
    >>> sys = ncs.jss([[[0.5]], [[0.9]]], [[1.0]], [[1.0]], [[1.0]], [0.5, 0.5])
    >>> ncs.dissipativity(sys, 0.0, 1.0, -0.4).dissipative
    True
    >>> res = ncs.dissipativity(sys, -1.0, 1.25, -1.0)
    >>> res.dissipative, res.status
    (False, 'infeasible')
    """
    J = as_jump(sys)
    nz, nw = J.modes.C.shape[-2], J.modes.B.shape[-1]
    Q, S, R = _supply_weights(Q, S, R, nz, nw)
    decay = decay_bound(decay)
    name = check_solver(solver)
    check_options(name, solver_options)
    margin = positive_real(margin, "margin")
    model = quadratic_supply_model(J, Q, S, R, margin, decay=decay)
    report = solve(model.problem, name, **solver_options)
    if report.status in ("infeasible", "infeasible_inaccurate"):
        # the solver's Farkas certificate, checked exactly: a proof
        Z = model.theta_duals()
        if Z is not None:
            proven, value, Y_min = supply_dual_check(J, Z, Q, S, R,
                                                     decay=decay)
            if proven:
                return SupplyResult(False, None, None, None, INFEASIBLE,
                                    report, dict(value=value, Y_min=Y_min,
                                                 Z=Z))
    if report.status not in ("optimal", "optimal_inaccurate"):
        return SupplyResult(False, None, None, None, SOLVER_FAILED, report)
    try:
        P = model.certificate()
    except (TypeError, ValueError):
        return SupplyResult(False, None, None, None, SOLVER_FAILED, report)
    if J.modes.is_iid:
        P = P[:, 0]
    ok, theta_max, P_min = supply_certificate_check(J, P, Q, S, R,
                                                    decay=decay)
    return SupplyResult(ok, P, theta_max, P_min,
                        CERTIFIED if ok else NOT_VERIFIED, report)
