"""Performance of jump systems beyond passivity: the H2 norm and the top
Lyapunov exponent (:ref:`theory-performance`).

* :func:`norm` mirrors :func:`control.norm`: for a jump system the H2 norm
  is the stationary output power under unit white noise, exact, from the
  linear fixed point of :func:`control_ncs.stability_covariances`; it is
  not the mean system's H2 norm (which ``ct.norm(CL, 2)`` would compute on
  the StateSpace face).
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
from control.exception import ControlArgument

from ._checks import choice, no_extra_kwargs, positive_int, positive_real
from ._results import Result
from ._lti import is_jump
from .jump import as_jump
from .montecarlo import root_entropy
from .stability import ms_radius, output_power

__all__ = ["norm", "lyapunov_exponent", "LyapunovResult"]


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
        The norm (default 2). ``'inf'`` (or ``numpy.inf``) is delegated to
        :func:`control.norm` for a deterministic system; for a jump system
        it raises ``NotImplementedError``.
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
    NotImplementedError
        ``p='inf'`` for a jump system.
    ControlArgument
        Unknown ``p`` or ``method``.

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
    tol = positive_real(tol, "tol")
    choice(method, "method", ("auto", "dense", "matrix-free"))
    if isinstance(p, str) or p == np.inf:
        choice(p if isinstance(p, str) else "inf", "p", ("inf",))
        if is_jump(sys):
            raise NotImplementedError(
                "norm(sys, 'inf') of a jump system: the certified l2-gain "
                "bound is not available yet; ncs.norm(sys, 2), ncs.ms_radius "
                "and the supply-rate certificates are")
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
