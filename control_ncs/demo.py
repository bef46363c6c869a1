"""End-to-end demo: a two-mass magnetic-levitation stage over a lossy network.

``python -m control_ncs demo [--out DIR]`` builds the plant, designs a
passive networked controller, verifies it exactly, and writes PNG plots.

The plant (continuous time, SI units): mass 1 (1 kg) is pushed by an outside
force ``w`` and by actuator ``u1``; it is coupled by a spring-damper
(4 N/m, 0.2 N·s/m) to mass 2 (0.5 kg), which levitates in a magnetic field
with negative stiffness (1 N/m, so the open loop is unstable) and is driven
by actuator ``u2``. The performance output is the velocity of mass 1 plus a
parallel damper ``0.5·w`` -- the port the outside world sees, collocated with
``w``. Sampled with a zero-order hold at 20 Hz (:func:`control.sample_system`).
All four states are measured by four sensors on a network: the two sensors
of mass 1 send in one phase, those of mass 2 in the next, and the controller
addresses ``u1`` and ``u2`` alternately; 10 % of sensor packets and 10 % of
actuator packets are lost.
"""

from __future__ import annotations

import os
from typing import Any

import numpy as np
import control as ct

from .plant import NetworkedStateSpace, nss

__all__ = ["levitation_stage", "run_demo", "passivity_figure"]


def levitation_stage(dt: float = 0.05, **network: Any) -> NetworkedStateSpace:
    """The demo plant, sampled with period ``dt``, with a network.

    Parameters
    ----------
    dt : float
        Sampling period in seconds.
    **network
        Passed to :func:`control_ncs.nss` (schedules, losses). Defaults: the
        alternating schedule described in the module docstring, 10 % losses.

    Returns
    -------
    NetworkedStateSpace
        Inputs ``[w, u1, u2]``, outputs ``[z, q1, v1, q2, v2]``.
    """
    m1, m2, k, c, c1, kneg, damper = 1.0, 0.5, 4.0, 0.2, 0.1, 1.0, 0.5
    A = np.array([[0, 1, 0, 0],
                  [-k / m1, -(c + c1) / m1, k / m1, c / m1],
                  [0, 0, 0, 1],
                  [k / m2, c / m2, (kneg - k) / m2, -c / m2]])
    Bw = np.array([[0], [1 / m1], [0], [0]])
    Bu = np.array([[0, 0], [1 / m1, 0], [0, 0], [0, 1 / m2]])
    C = np.vstack([[0, 1, 0, 0], np.eye(4)])
    D = np.zeros((5, 3))
    D[0, 0] = damper
    cont = ct.ss(A, np.hstack([Bw, Bu]), C, D, name="levitation",
                 inputs=["w", "u1", "u2"],
                 outputs=["z", "q1", "v1", "q2", "v2"],
                 states=["q1", "v1", "q2", "v2"])
    disc = ct.sample_system(cont, dt, method="zoh", name="levitation")
    settings = dict(sensor_schedule=[[1, 1, 0, 0], [0, 0, 1, 1]],
                    actuator_schedule=[1, 2], sensor_loss=0.1,
                    actuator_loss=0.1)
    settings.update(network)
    return nss(disc, nmeas=4, ncon=2, inputs=["w", "u1", "u2"],
               outputs=["z", "q1", "v1", "q2", "v2"],
               states=["q1", "v1", "q2", "v2"], **settings)


def run_demo_command(outdir: str, *, trials: int, seed: int) -> None:
    """``python -m control_ncs demo``: the demo in a process of its own,
    drawing to files (matplotlib's Agg backend: no screen needed)."""
    import matplotlib
    matplotlib.use("Agg")
    run_demo(outdir, trials=trials, seed=seed)


def run_demo(outdir: str = "demo-output", *, trials: int = 200, seed: int = 0,
             verbose: bool = True) -> dict:
    """Run the demo end to end and write its plots.

    Parameters
    ----------
    outdir : str
        Folder for the PNG files (created if missing).
    trials : int
        Monte Carlo sample paths drawn for the step-response band.
    seed : int
        Seed of the sample paths.
    verbose : bool
        Print the model, the synthesis result and its verification.

    Returns
    -------
    dict
        ``{'files': [...], 'eta': ..., 'ms_radius': ...}`` and more figures.
    """
    import matplotlib.pyplot as plt

    from .meancov import moments
    from .passivity import mean_input_ff_index
    from .responses import simulate
    from .stability import ms_radius
    from .loop import feedback
    from .synthesis import passivesyn
    from .plots import schedule_plot
    from .exceptions import SynthesisError

    say = print if verbose else (lambda *a, **k: None)
    os.makedirs(outdir, exist_ok=True)
    files = []

    def save(fig, name):
        path = os.path.join(outdir, name)
        fig.savefig(path, dpi=110, bbox_inches="tight")
        plt.close(fig)
        files.append(path)

    P = levitation_stage()
    say(P)
    open_loop = feedback(P, np.zeros((2, 4)))
    say(f"Open loop: ms_radius = {ms_radius(open_loop):.4f} (unstable plant)\n")

    K, CL, eta = passivesyn(P, decay=0.995)
    say(K.result.summary())
    say(f"Gains K_k (phase k uses the sensors it hears, drives the actuator "
        f"it addresses):\n{np.round(K.gains, 3)}")
    mean_eta = mean_input_ff_index(CL)
    say(f"Certified stochastic passivity index η = {eta:.4f}; index of the "
        f"mean system = {mean_eta:.4f} (a statement about E z only)\n")

    # 1. the schedule
    ax = schedule_plot(P, 8)
    save(ax.figure, "schedule.png")

    # 2. step response of the port: exact mean ± 2 std, sample paths, nominal
    steps = 160
    t = np.arange(steps) * P.dt
    w = np.ones((1, steps))
    mom = moments(CL, steps, w)
    nominal = moments(_periodic_nominal(CL), steps, w).outputs_mean[0]
    fig, ax = plt.subplots(figsize=(8, 4))
    mean, std = mom.outputs_mean[0], mom.outputs_std[0]
    ax.fill_between(t, mean - 2 * std, mean + 2 * std, alpha=0.25,
                    label="exact mean ± 2 std")
    paths = np.asarray(simulate(CL, steps, w, trials=trials, seed=seed).outputs)[0]
    for j, path in enumerate(paths[:5]):
        ax.plot(t, path, lw=0.6, color="0.5",
                label="sample paths" if j == 0 else None)
    # the exact mean wide and underneath, the sample mean thin on top: both
    # stay visible where they agree
    ax.plot(t, mean, color="tab:orange", lw=3.0, alpha=0.8,
            label="exact mean E z (theory: moments)")
    ax.plot(t, paths.mean(axis=0), "--", color="tab:blue", lw=1.2,
            label=f"sample mean ({trials} paths)")
    ax.plot(t, nominal, ":", color="tab:green", label="loss-free loop")
    ax.set_xlabel("time [s]")
    ax.set_ylabel("z = v1 + 0.5 w")
    ax.set_title("Response of the port to a unit force step")
    ax.legend(fontsize=8)
    save(fig, "step.png")

    # 3. passivity in frequency: the Hermitian part of the lifted mean loop
    save(passivity_figure(CL, eta, mean_eta), "passivity.png")

    # 4. certified η against actuator loss
    losses = np.linspace(0.0, 0.4, 5)
    etas = []
    for a2 in losses:
        try:
            etas.append(passivesyn(P.with_network(actuator_loss=a2),
                                   decay=0.995)[2])
        except SynthesisError:
            etas.append(np.nan)
    fig, ax = plt.subplots(figsize=(6, 4))
    ax.plot(losses, etas, "o-")
    ax.set_xlabel("actuator loss probability α2")
    ax.set_ylabel("certified η")
    ax.set_xlim(-0.02, 0.42)
    ax.set_ylim(0.0, 1.25 * np.nanmax(etas) if np.any(np.isfinite(etas))
                else 1.0)
    if np.all(np.isfinite(etas)):
        ax.text(0.98, 0.95, f"η falls {100 * (etas[0] - etas[-1]) / etas[0]:.2g}"
                f" % from no loss to α2 = {losses[-1]:g}",
                transform=ax.transAxes, ha="right", va="top", fontsize=9)
    ax.set_title("Passivity bought with the network's reliability")
    save(fig, "eta_vs_loss.png")
    say("Wrote: " + ", ".join(files))
    return dict(files=files, eta=eta, mean_eta=mean_eta,
                ms_radius=ms_radius(CL), open_loop_ms_radius=ms_radius(open_loop),
                eta_vs_loss=dict(zip(losses.tolist(), etas)), gain=K)


def passivity_figure(CL: Any, eta: float, mean_eta: float) -> Any:
    """The closed loop's passivity in frequency, and the certificate's gap.

    The loop's mean system, lifted over the period, is an LTI port ``G``;
    it is passive with index ``ν`` when every eigenvalue of the Hermitian
    part ``(G + Gᴴ)/2`` is at least ``ν`` at every frequency
    (:ref:`theory-passivity`). The left panel draws those eigenvalues from
    zero, with the certified index ``η``; the right panel draws the margin
    ``λmin − η`` on its own scale, where the mean system's index (the
    minimum of ``λmin``, a statement about ``E z`` only) and the certified
    stochastic index (every sample path, in mean square) are told apart.

    Parameters
    ----------
    CL : JumpStateSpace
        The closed loop, with square ``w`` and ``z``.
    eta : float
        The certified stochastic index (from the design).
    mean_eta : float
        The mean system's index (:func:`control_ncs.mean_input_ff_index`).

    Returns
    -------
    matplotlib.figure.Figure
        Two axes: the eigenvalues, and the margin above ``eta``.
    """
    import matplotlib.pyplot as plt
    from .plots import plain_ticks

    lifted = CL.mean()
    nyquist = np.pi / lifted.dt
    omega = np.minimum(np.logspace(-3, np.log10(nyquist), 400), nyquist)
    G = np.moveaxis(lifted.frequency_response(omega).complex, -1, 0)
    lam = np.array([np.linalg.eigvalsh(0.5 * (g + g.conj().T)) for g in G])
    fig, (ax, bx) = plt.subplots(1, 2, figsize=(11, 4), layout="constrained")
    last = lam.shape[1] - 1
    for i in range(lam.shape[1]):
        label = ("λmin of (G + Gᴴ)/2" if i == 0 else "λmax" if i == last
                 else "other eigenvalues" if i == 1 else None)
        ax.semilogx(omega, lam[:, i], color="tab:blue" if i == 0 else
                    "tab:purple", lw=1.8 if i == 0 else 1.0, label=label)
    ax.axhline(eta, ls=":", color="tab:red",
               label=f"certified index η = {eta:.4f}")
    ax.set_ylim(0.0, 1.1 * lam.max())
    ax.set_xlabel("ω [rad/s] (lifted, per period)")
    ax.set_ylabel("passivity level")
    ax.set_title("Every eigenvalue stays above η at every frequency",
                 fontsize="medium")
    ax.legend(fontsize=8, loc="lower left")
    ax.text(0.98, 0.95, "λmin hugs η: its margin is drawn on the right",
            transform=ax.transAxes, ha="right", va="top", fontsize=8)
    # the smallest eigenvalue is set by the port's feedthrough (the parallel
    # damper, less the coupling within a period): it moves by a fraction of
    # a percent, so its margin above η needs its own scale
    margin = lam[:, 0] - eta
    bx.semilogx(omega, margin, color="tab:blue", lw=1.8,
                label="λmin − η, lifted mean system")
    bx.axhline(mean_eta - eta, ls="--", color="tab:green",
               label=f"mean-system index − η = {mean_eta - eta:.2e}")
    bx.axhline(0.0, ls=":", color="tab:red", label="certified η (every path)")
    top = max(margin.max(), mean_eta - eta)
    bx.set_ylim(-0.1 * top, 1.15 * top)
    bx.yaxis.set_major_formatter(plain_ticks())
    bx.set_xlabel("ω [rad/s] (lifted, per period)")
    bx.set_ylabel("margin above the certified η")
    bx.set_title(f"η is {100 * (mean_eta - eta) / mean_eta:.2g} % below the "
                 f"mean system's index {mean_eta:.4f}", fontsize="medium")
    bx.legend(fontsize=8, loc="lower right")
    fig.suptitle("Passivity of the closed loop in frequency")
    return fig


def _periodic_nominal(CL):
    """The loss-free loop as a one-mode (deterministic) periodic system."""
    from .jump import JumpStateSpace
    k = np.arange(CL.period)
    mats = [M[k, CL.nominal_mode][:, None] for M in (
        CL.modes.A, CL.modes.B, CL.modes.C, CL.modes.D)]
    return JumpStateSpace(*mats, np.ones((CL.period, 1)), CL.dt_step)
