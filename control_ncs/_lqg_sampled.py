"""LQG of a sampled continuous plant with continuous weights, as
Jitterbug's ``lqgdesign`` (:ref:`theory-lqg-continuous`).

The weights ``Q, R`` of ``J = lim (1/T) E ∫ (xᵀQx + uᵀRu) dt`` and the
intensity ``QN`` of the continuous process noise on ``B1`` become the
sampled loss ``x_kᵀQ1x_k + 2x_kᵀQ12u_k + u_kᵀQ2u_k`` and the sampled
noise covariance ``R1d`` by van Loan's integrals over the period
(:mod:`control_ncs.intersample`); with a constant input delay ``τ`` the
state is ``[x_k; u_{k-1}]`` and the loss the blocks of ``W(τ)``. The
measurement's covariance ``RN`` is already a sampled one. Separation
holds: the (modified) Kalman filter on the sampled model, the LQ gain of
the Riccati equation with its cross term, and the cost

    J = (tr(S_c R_a) + c(h) + tr(P̃ Lᵀ(Q2 + ΓᵀS_cΓ) L)) / h.
"""

from __future__ import annotations

from typing import Any, NamedTuple

import control as ct
import numpy as np

from ._lqg_loops import sqrt_psd
from .intersample import delay_augmented_loss, sampled_noise
from .plant import NetworkedStateSpace, nss

__all__: list[str] = []


class Sampled(NamedTuple):
    """The sampled problem (augmented by ``u_{k-1}`` with a delay)."""

    h: float
    tau: float | None     #: the constant input delay, None without one
    Phi: np.ndarray       #: the plant's ``Φ``
    Phi_a: np.ndarray     #: ``Φ`` or ``[[Φ, Γ1], [0, 0]]``
    Gam_a: np.ndarray     #: ``Γ`` or ``[Γ0; I]``
    Q1: np.ndarray
    Q12: np.ndarray
    Q2: np.ndarray
    R1d: np.ndarray       #: the process noise over one period (on x)
    c: float              #: the noise's own cost inside the period
    A: np.ndarray         #: the continuous plant: A, B1, B2, C2
    B1: np.ndarray
    B2: np.ndarray
    C2: np.ndarray


def sample(P: NetworkedStateSpace, Q: np.ndarray, R: np.ndarray,
           QN: np.ndarray, tau: float | None) -> Sampled:
    """Van Loan's integrals of the continuous weights and noise."""
    sys: Any = P.continuous
    A, B = np.asarray(sys.A, float), np.asarray(sys.B, float)
    m1 = B.shape[1] - P.ncon
    B1, B2 = B[:, :m1], B[:, m1:]
    n, m = B2.shape
    h = float(P.dt)
    C1 = np.vstack([sqrt_psd(Q), np.zeros((m, n))])
    D12 = np.vstack([np.zeros((n, m)), sqrt_psd(R)])
    Phi_a, Gam_a, Q1, Q12, Q2 = delay_augmented_loss(
        A, B2, C1, D12, h, 0.0 if tau is None else tau)
    if tau is None:                  # no u_{k-1} in the state
        Phi_a, Gam_a = Phi_a[:n, :n], Gam_a[:n]
        Q1, Q12 = Q1[:n, :n], Q12[:n]
    R1d, c = sampled_noise(A, B1 @ sqrt_psd(QN), C1, h)
    return Sampled(h, tau, Phi_a[:n, :n], Phi_a, Gam_a, Q1, Q12, Q2, R1d, c,
                   A, B1, B2, np.asarray(P.C2, float))


def control(s: Sampled, dlqr: Any) -> tuple:
    """The LQ gain ``u = L ξ`` of the sampled loss with its cross term:
    the package's ``dlqr`` on the problem without it (``u = ũ - Q2⁻¹
    Q12ᵀ ξ``, ``Q̃ = Q1 - Q12 Q2⁻¹ Q12ᵀ ⪰ 0``); returns ``(L, S_c,
    solution)``."""
    F = np.linalg.solve(s.Q2, s.Q12.T)
    At = s.Phi_a - s.Gam_a @ F
    Qt = s.Q1 - s.Q12 @ F
    Kt, Sc, _, solution = dlqr(At, s.Gam_a, 0.5 * (Qt + Qt.T), s.Q2,
                               full_output=True)
    return -(Kt + F), Sc, solution


def closed_form(s: Sampled, L: np.ndarray, Sc: np.ndarray,
                P_post: np.ndarray) -> float:
    """``J = (tr(S_c R_a) + c + tr(P̃_a Lᵀ(Q2 + ΓᵀS_cΓ)L)) / h``, the
    estimation error on ``x`` only (``u_{k-1}`` is known)."""
    n = s.Phi.shape[0]
    d = s.Phi_a.shape[0]
    Ra, Pa = np.zeros((d, d)), np.zeros((d, d))
    Ra[:n, :n], Pa[:n, :n] = s.R1d, P_post
    G = s.Q2 + s.Gam_a.T @ Sc @ s.Gam_a
    return float((np.trace(Sc @ Ra) + s.c + np.trace(Pa @ L.T @ G @ L))
                 / s.h)


def delay_controller(s: Sampled, L: np.ndarray, Lf: np.ndarray
                     ) -> ct.StateSpace:
    """The LQG controller with a constant input delay as an LTI system on
    ``[x̂⁻_k; u_{k-1}]``: ``x̂_{k|k} = x̂⁻ + L_f (y - C2 x̂⁻)``, ``u_k = Lx
    x̂_{k|k} + Lu u_{k-1}``, ``x̂⁻_{k+1} = Φ x̂_{k|k} + Γ1 u_{k-1} + Γ0
    u_k``."""
    n = s.Phi.shape[0]
    Lx, Lu = L[:, :n], L[:, n:]
    G1, G0 = s.Phi_a[:n, n:], s.Gam_a[:n]
    Hc = np.eye(n) - Lf @ s.C2
    Ac = np.block([[(s.Phi + G0 @ Lx) @ Hc, G1 + G0 @ Lu], [Lx @ Hc, Lu]])
    Bc = np.vstack([(s.Phi + G0 @ Lx) @ Lf, Lx @ Lf])
    Cc = np.hstack([Lx @ Hc, Lu])
    return ct.ss(Ac, Bc, Cc, Lx @ Lf, s.h, name="lqg")


def cost_plant(P: NetworkedStateSpace, s: Sampled, Q: np.ndarray,
               R: np.ndarray, QN: np.ndarray, RN: np.ndarray
               ) -> NetworkedStateSpace:
    """``P``'s continuous plant with ``w = [process; measurement]`` (unit
    intensity and unit variance), ``z = [Q^½ x; R^½ u]``, sampled again
    with ``P``'s links and timing: ``ncs.cost`` of its loop is ``J``."""
    n, m = s.B2.shape
    g, p = s.B1.shape[1], s.C2.shape[0]
    B = np.hstack([s.B1 @ sqrt_psd(QN), np.zeros((n, p)), s.B2])
    C = np.vstack([sqrt_psd(Q), np.zeros((m, n)), s.C2])
    D = np.zeros((n + m + p, g + p + m))
    D[n:n + m, g + p:] = sqrt_psd(R)
    D[n + m:, g:g + p] = sqrt_psd(RN)
    G = ct.ss(s.A, B, C, D,
              inputs=[f"w[{i}]" for i in range(g)]
              + [f"v[{i}]" for i in range(p)] + list(P.input_labels[-m:]),
              outputs=[f"zx[{i}]" for i in range(n)]
              + [f"zu[{i}]" for i in range(m)] + list(P.output_labels[-p:]),
              states=list(P.state_labels), name=f"{P.name} (LQG cost)")
    delay = {} if s.tau is None else dict(input_delay=([s.tau], [1.0]))
    return nss(G, nmeas=p, ncon=m, dt=s.h, sensor_loss=P.sensor_link,
               actuator_loss=P.actuator_link, **delay)
