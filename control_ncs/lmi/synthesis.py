"""The synthesis LMIs: a gain and its certificate together.

:ref:`theory-synthesis` (full information, exact), its structured forms
(``'block'``, ``'extended'``, sufficient), the predictor and the gains on the
previous mode of :ref:`theory-markov`, all over one period.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import cvxpy as cp

from ..modes import mode_classes
from ..openloop import JumpPlant
from ._core import (data_scale, _Model, _param, _template, _Template)


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
    records what is observed as ``plant.observed``, shape (N, M):
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
    observed = plant.observed
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


# -- H2: theory: performance -------------------------------------------------------
class H2Model:
    """Costa–do Val–Geromel's convex H2 program over one period.

    Attributes
    ----------
    problem : cvxpy.Problem
    Q, Y : list of cvxpy.Variable
        Per phase: the covariance bound ``Q_k`` and ``Y_k = K_k Q_k``.
    """

    def __init__(self, problem: cp.Problem, Q: list, Y: list):
        self.problem, self.Q, self.Y = problem, Q, Y

    def gains(self) -> np.ndarray:
        """``K_k = Y_k Q_k⁻¹`` per phase, shape (N, nu, nx)."""
        return np.array([np.linalg.solve(np.asarray(Q.value, float).T,
                                         np.asarray(Y.value, float).T).T
                         for Q, Y in zip(self.Q, self.Y)])


def h2_model(plant: JumpPlant, margin: float) -> H2Model:
    """``min (1/N) Σ_k tr W_k`` over ``Q_k ≻ 0``, ``Y_k``, ``W_k`` with

    ``Q_{k+1} ⪰ Σ_i p_ki (A_ki Q_k + Bu_ki Y_k) Q_k⁻¹ (·)ᵀ + Σ_i p_ki Bw Bwᵀ``
    and ``W_k ⪰ Σ_i p_ki (Cz Q_k + Du Y_k) Q_k⁻¹ (·)ᵀ + Σ_i p_ki Dw Dwᵀ``
    (Schur complements), for a plant whose controller sees the whole state
    (``E_k = I``) and i.i.d. modes: any feasible point bounds the periodic
    stationary covariance of the loop ``u = K_k x`` with ``K_k = Y_k
    Q_k⁻¹``, and the loop's own covariances are feasible, so the optimum is
    the optimal H2 cost (:ref:`theory-performance`)."""
    N, M = plant.probabilities.shape
    nx, nu = plant.A.shape[-1], plant.Bu.shape[-1]
    nz = plant.Cz.shape[-2]
    eps = margin * data_scale(plant.A, plant.Bu, plant.Bw, plant.Cz)
    Q = [cp.Variable((nx, nx), symmetric=True) for _ in range(N)]
    Y = [cp.Variable((nu, nx)) for _ in range(N)]
    W = [cp.Variable((nz, nz), symmetric=True) for _ in range(N)]
    cons = []
    for k in range(N):
        live = np.flatnonzero(plant.probabilities[k] > 0)
        p = plant.probabilities[k]
        BB = sum(p[i] * plant.Bw[k, i] @ plant.Bw[k, i].T for i in live)
        DD = sum(p[i] * plant.Dw[k, i] @ plant.Dw[k, i].T for i in live)
        for lhs, rows in (
                (Q[(k + 1) % N] - BB,
                 [np.sqrt(p[i]) * (plant.A[k, i] @ Q[k] + plant.Bu[k, i] @ Y[k])
                  for i in live]),
                (W[k] - DD,
                 [np.sqrt(p[i]) * (plant.Cz[k, i] @ Q[k]
                                   + plant.Du[k, i] @ Y[k]) for i in live])):
            L = len(rows)
            block = [[lhs] + rows]
            for j in range(L):
                row = [rows[j].T] + [Q[k] if jj == j else np.zeros((nx, nx))
                                     for jj in range(L)]
                block.append(row)
            Mx = cp.bmat(block)
            cons.append(0.5 * (Mx + Mx.T) >> 0)
        cons.append(Q[k] >> eps * np.eye(nx))
    objective = cp.Minimize(sum(cp.trace(Wk) for Wk in W) / N)
    return H2Model(cp.Problem(objective, cons), Q, Y)


# -- H∞: theory: performance -------------------------------------------------------
class HinfModel:
    """The bounded real lemma in the synthesis variables ``X_k = P_k⁻¹``,
    ``Y_k = K_k X_k``: minimise ``γ²``.

    Attributes
    ----------
    problem : cvxpy.Problem
    gamma2 : cvxpy.Variable
    X, Y : list of cvxpy.Variable
    """

    def __init__(self, problem: cp.Problem, gamma2: Any, X: list, Y: list):
        self.problem, self.gamma2, self.X, self.Y = problem, gamma2, X, Y

    def gains(self) -> np.ndarray:
        """``K_k = Y_k X_k⁻¹`` per phase, shape (N, nu, nx)."""
        return np.array([np.linalg.solve(np.asarray(X.value, float).T,
                                         np.asarray(Y.value, float).T).T
                         for X, Y in zip(self.X, self.Y)])


def hinf_model(plant: JumpPlant, margin: float) -> HinfModel:
    """``min γ²`` over ``X_k ≻ 0``, ``Y_k`` with, per phase ``k``, the
    Schur form of the bounded real lemma of the loop ``u = K_k x``
    (congruence by ``diag(X_k, I)``)::

        [ -X_k    0       √p_i (A_i X_k + Bu_i Y_k)ᵀ   √p_i (Cz_i X_k + Du_i Y_k)ᵀ ]
        [  0    -γ² I     √p_i Bw_iᵀ                   √p_i Dw_iᵀ                 ]  ≺ 0
        [  ·      ·       -X_{k+1} (per mode i)         0                          ]
        [  ·      ·        0                            -I (per mode i)            ]

    exact for a controller that sees the whole state and i.i.d. modes
    (the storage ``P_k`` cannot depend on a mode not yet drawn)."""
    N, M = plant.probabilities.shape
    nx, nu = plant.A.shape[-1], plant.Bu.shape[-1]
    nw, nz = plant.Bw.shape[-1], plant.Cz.shape[-2]
    eps = margin * data_scale(plant.A, plant.Bu, plant.Bw, plant.Cz)
    X = [cp.Variable((nx, nx), symmetric=True) for _ in range(N)]
    Y = [cp.Variable((nu, nx)) for _ in range(N)]
    gamma2 = cp.Variable(nonneg=True)
    cons = []
    for k in range(N):
        p = plant.probabilities[k]
        live = np.flatnonzero(p > 0)
        Xn = X[(k + 1) % N]
        left = [[-X[k], np.zeros((nx, nw))],
                [np.zeros((nw, nx)), -gamma2 * np.eye(nw)]]
        cols = []       # the off-diagonal blocks, one pair per live mode
        for i in live:
            r = np.sqrt(p[i])
            cols.append((r * (plant.A[k, i] @ X[k] + plant.Bu[k, i] @ Y[k]),
                         r * plant.Bw[k, i], Xn, nx))
            cols.append((r * (plant.Cz[k, i] @ X[k] + plant.Du[k, i] @ Y[k]),
                         r * plant.Dw[k, i], np.eye(nz), nz))
        size = len(cols)
        rows = [[left[0][0], left[0][1]] + [c[0].T for c in cols],
                [left[1][0], left[1][1]] + [c[1].T for c in cols]]
        for a, (Fx, Fw, W, dim) in enumerate(cols):
            row = [Fx, Fw]
            for b in range(size):
                if a == b:
                    row.append(-W)
                else:
                    row.append(np.zeros((dim, cols[b][3])))
            rows.append(row)
        Mx = cp.bmat(rows)
        total = nx + nw + sum(c[3] for c in cols)
        cons.append(0.5 * (Mx + Mx.T) << -eps * np.eye(total))
        cons.append(X[k] >> eps * np.eye(nx))
    return HinfModel(cp.Problem(cp.Minimize(gamma2), cons), gamma2, X, Y)
