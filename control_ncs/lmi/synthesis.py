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


# -- H2 and H∞: theory: performance ------------------------------------------------
class _ClassModel:
    """A program whose variables are per phase ``k`` and class ``c`` of
    previous modes ``ℓ = σ_{k-1}`` with equal rows ``T_{k-1}[ℓ]``
    (:func:`mode_classes`; i.i.d. modes: one class per phase), with the
    gain ``K_{k,c} = Y_{k,c} X_{k,c}⁻¹``.

    Attributes
    ----------
    problem : cvxpy.Problem
    X, Y : list of list of cvxpy.Variable
        Per phase and class: the matrix the gain is read against (a
        covariance bound ``Q`` or an inverse storage ``X = P⁻¹``) and ``Y``.
    labels : list of ndarray
        Per phase, the class of each previous mode ``ℓ``.
    markov : bool
    """

    def __init__(self, problem: cp.Problem, X: list, Y: list,
                 labels: list, markov: bool):
        self.problem, self.X, self.Y = problem, X, Y
        self.labels, self.markov = labels, markov

    def gains(self) -> np.ndarray:
        """``K_k`` (i.i.d. modes), shape (N, nu, nx); ``K_{k,ℓ}`` per
        previous mode (Markov modes), shape (N, M, nu, nx)."""
        per_class = [[np.linalg.solve(np.asarray(X.value, float).T,
                                      np.asarray(Y.value, float).T).T
                      for X, Y in zip(Xk, Yk)]
                     for Xk, Yk in zip(self.X, self.Y)]
        if not self.markov:
            return np.array([Ks[0] for Ks in per_class])
        return np.array([[per_class[k][c] for c in self.labels[k]]
                         for k in range(len(per_class))])


class H2Model(_ClassModel):
    """Costa–do Val–Geromel's convex H2 program over one period
    (:func:`h2_model`); ``X`` are the covariance bounds ``Q_{k,c}``."""

    @property
    def Q(self) -> list:
        """Per phase and class, the covariance bound ``Q_{k,c}``."""
        return self.X


class HinfModel(_ClassModel):
    """The bounded real lemma in the synthesis variables ``X = P⁻¹``,
    ``Y = K X`` (:func:`hinf_model`); ``gamma2`` is minimised."""

    def __init__(self, problem: cp.Problem, gamma2: Any, X: list, Y: list,
                 labels: list, markov: bool):
        super().__init__(problem, X, Y, labels, markov)
        self.gamma2 = gamma2


def _classes(plant: JumpPlant) -> tuple[np.ndarray, list, list]:
    """``T``, and per phase the class of each previous mode and the rows
    ``t_c = T_{k-1}[ℓ]`` of its classes."""
    T = plant.transitions()
    N = T.shape[0]
    labels, rows = [], []
    for k in range(N):
        lab, reps = mode_classes(T[k - 1])
        labels.append(lab)
        rows.append([T[k - 1][r] for r in reps])
    return T, labels, rows


def _psd_schur(lhs: Any, rows: list, inner: list) -> Any:
    """``lhs - Σ_j rows_j inner_j⁻¹ rows_jᵀ ⪰ 0`` as one LMI (Schur)."""
    L = len(rows)
    block = [[lhs] + rows]
    for j in range(L):
        block.append([rows[j].T] + [
            inner[j] if jj == j else np.zeros((inner[j].shape[0],
                                               inner[jj].shape[0]))
            for jj in range(L)])
    Mx = cp.bmat(block)
    return 0.5 * (Mx + Mx.T) >> 0


def h2_model(plant: JumpPlant, margin: float) -> H2Model:
    """``min (1/N) Σ_k (Σ_c tr W_{k,c} + Σ_i π_{k,i} tr Dw Dwᵀ)`` over
    ``Q_{k,c} ≻ 0``, ``Y_{k,c}``, ``W_{k,c}`` with (Schur complements)

    ``Q_{k+1,c'} ⪰ Σ_{i ∈ c'} Σ_c t_c[i] (A_ki Q_kc + Bu_ki Y_kc) Q_kc⁻¹ (·)ᵀ
    + Σ_{i ∈ c'} π_ki Bw Bwᵀ`` and
    ``W_{k,c} ⪰ Σ_i t_c[i] (Cz_ki Q_kc + Du_ki Y_kc) Q_kc⁻¹ (·)ᵀ``,

    ``c`` the classes of previous modes at phase ``k`` (rows ``t_c``),
    ``c'`` those at phase ``k + 1`` (the class of ``i = σ_k``), ``π`` the
    stationary law; for a plant whose controller sees the whole state
    (``E_k = I``). ``Q_{k,c}`` bounds ``Σ_{ℓ∈c} E[ξ_k ξ_kᵀ 1{σ_{k-1}=ℓ}]``
    for the loop ``u = K_{k,c} x`` with ``K_{k,c} = Y_{k,c} Q_{k,c}⁻¹``
    (gains on the previous mode, known from acknowledgements), and the
    loop's own moments are feasible, so the optimum is the optimal H2 cost
    (:ref:`theory-performance`, :ref:`theory-markov`). i.i.d. modes: one
    class per phase, the program of Costa, do Val and Geromel."""
    N, M = plant.probabilities.shape
    nx, nu = plant.A.shape[-1], plant.Bu.shape[-1]
    nz = plant.Cz.shape[-2]
    eps = margin * data_scale(plant.A, plant.Bu, plant.Bw, plant.Cz)
    _, labels, rows = _classes(plant)
    Q = [[cp.Variable((nx, nx), symmetric=True) for _ in r] for r in rows]
    Y = [[cp.Variable((nu, nx)) for _ in r] for r in rows]
    W = [[cp.Variable((nz, nz), symmetric=True) for _ in r] for r in rows]
    cons, constant = [], 0.0
    for k in range(N):
        pi = plant.probabilities[k]
        nxt = labels[(k + 1) % N]
        for c2, Qn in enumerate(Q[(k + 1) % N]):
            members = [i for i in range(M) if nxt[i] == c2 and pi[i] > 0]
            BB = sum((pi[i] * plant.Bw[k, i] @ plant.Bw[k, i].T
                      for i in members), np.zeros((nx, nx)))
            terms = [(np.sqrt(t[i]) * (plant.A[k, i] @ Q[k][c]
                                       + plant.Bu[k, i] @ Y[k][c]), Q[k][c])
                     for c, t in enumerate(rows[k]) for i in members
                     if t[i] > 0]
            cons.append(_psd_schur(Qn - BB, [r for r, _ in terms],
                                   [q for _, q in terms]))
        for c, t in enumerate(rows[k]):
            live = np.flatnonzero(t > 0)
            cons.append(_psd_schur(
                W[k][c], [np.sqrt(t[i]) * (plant.Cz[k, i] @ Q[k][c]
                                           + plant.Du[k, i] @ Y[k][c])
                          for i in live], [Q[k][c]] * live.size))
            cons.append(Q[k][c] >> eps * np.eye(nx))
        constant += float(sum(pi[i] * np.trace(plant.Dw[k, i]
                                               @ plant.Dw[k, i].T)
                              for i in range(M)))
    objective = cp.Minimize((sum(cp.trace(Wkc) for Wk in W for Wkc in Wk)
                             + constant) / N)
    return H2Model(cp.Problem(objective, cons), Q, Y, labels,
                   plant.transition is not None)


def hinf_model(plant: JumpPlant, margin: float) -> HinfModel:
    """``min γ²`` over ``X_{k,c} ≻ 0``, ``Y_{k,c}`` with, per phase ``k``
    and class ``c`` of previous modes (rows ``t = t_c``), the Schur form of
    the bounded real lemma of the loop ``u = K_{k,c} x`` (congruence by
    ``diag(X_{k,c}, I)``)::

        [ -X_kc   0      √t_i (A_i X_kc + Bu_i Y_kc)ᵀ   √t_i (Cz_i X_kc + Du_i Y_kc)ᵀ ]
        [  0    -γ² I    √t_i Bw_iᵀ                     √t_i Dw_iᵀ                   ]  ≺ 0
        [  ·      ·      -X_{k+1,c'(i)} (per mode i)     0                            ]
        [  ·      ·       0                              -I (per mode i)              ]

    ``c'(i)`` the class of ``i = σ_k`` at phase ``k + 1``. The storage may
    depend on what the controller knows (the previous mode) but not on a
    mode not yet drawn, so the lemma is exact for a controller that sees
    the whole state with gains on the previous mode (i.i.d. modes: one
    class per phase)."""
    N, M = plant.probabilities.shape
    nx, nu = plant.A.shape[-1], plant.Bu.shape[-1]
    nw, nz = plant.Bw.shape[-1], plant.Cz.shape[-2]
    eps = margin * data_scale(plant.A, plant.Bu, plant.Bw, plant.Cz)
    _, labels, rows = _classes(plant)
    X = [[cp.Variable((nx, nx), symmetric=True) for _ in r] for r in rows]
    Y = [[cp.Variable((nu, nx)) for _ in r] for r in rows]
    gamma2 = cp.Variable(nonneg=True)
    cons = []
    for k in range(N):
        nxt = labels[(k + 1) % N]
        for c, t in enumerate(rows[k]):
            Xk, Yk = X[k][c], Y[k][c]
            left = [[-Xk, np.zeros((nx, nw))],
                    [np.zeros((nw, nx)), -gamma2 * np.eye(nw)]]
            cols = []       # the off-diagonal blocks, one pair per live mode
            for i in np.flatnonzero(t > 0):
                r = np.sqrt(t[i])
                cols.append((r * (plant.A[k, i] @ Xk + plant.Bu[k, i] @ Yk),
                             r * plant.Bw[k, i], X[(k + 1) % N][nxt[i]], nx))
                cols.append((r * (plant.Cz[k, i] @ Xk + plant.Du[k, i] @ Yk),
                             r * plant.Dw[k, i], np.eye(nz), nz))
            size = len(cols)
            block = [[left[0][0], left[0][1]] + [col[0].T for col in cols],
                     [left[1][0], left[1][1]] + [col[1].T for col in cols]]
            for a, (Fx, Fw, Wd, dim) in enumerate(cols):
                row = [Fx, Fw]
                for b in range(size):
                    row.append(-Wd if a == b else
                               np.zeros((dim, cols[b][3])))
                block.append(row)
            Mx = cp.bmat(block)
            total = nx + nw + sum(col[3] for col in cols)
            cons.append(0.5 * (Mx + Mx.T) << -eps * np.eye(total))
            cons.append(Xk >> eps * np.eye(nx))
    return HinfModel(cp.Problem(cp.Minimize(gamma2), cons), gamma2, X, Y,
                     labels, plant.transition is not None)
