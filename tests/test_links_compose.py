"""Links compose: every combination of the two links is one loop.

Each loop is built three ways and the figures must agree:

* the package: ``ncs.feedback(ncs.nss(..., sensor_loss=, actuator_loss=,
  sensor_delay=, actuator_delay=, sensor_schedule=, actuator_schedule=), K,
  controller=, actuator=)``;
* the independent augmented-state construction of ``reference_loops``
  (written from the event-level semantics, returned through ``ncs.jss``
  only): ``ms_radius``, ``norm(·, 2)`` and ``moments`` agree to 1e-9
  relative;
* the event-level simulator (:mod:`control_ncs.protocol`, packet by packet
  with time stamps): its stationary output power under unit white noise is
  the reference's ``norm(·, 2)²`` within 4 standard errors.

The links: none, Bernoulli, Gilbert–Elliott, random delay, random delay
with a Bernoulli loss (the thinned law) and bursty delay, on either side;
schedules of period 2 or 3 (all-or-none on a delayed link); controllers:
one static gain, a gain per age of the measurement, the predictor, the
estimator and an LTI controller; zero or hold actuators.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field

import control as ct
import numpy as np
import pytest
import scipy.linalg
from hypothesis import Phase, given, settings, strategies as st

import control_ncs as ncs
from control_ncs.protocol import simulate_protocol

import reference_loops as R

RTOL = 1e-9
#: the simulator's loops use a third of a deadbeat-like gain: their tails stay
#: light, so that sample standard errors of the output power hold
GAIN_SCALE = 0.3
KINDS = ("none", "bernoulli", "gilbert_elliott", "delay", "delay_loss",
         "bursty")
CONTROLLERS = ("static", "per_age", "predictor", "estimator", "lti")


# --------------------------------------------------------------------------
# one link, three ways
# --------------------------------------------------------------------------
@dataclass(frozen=True)
class LinkSpec:
    """One link as the package, the reference and the simulator take it."""

    kind: str
    params: dict = field(default_factory=dict)

    @property
    def delayed(self) -> bool:
        return self.kind in ("delay", "delay_loss", "bursty")

    @property
    def buffer(self) -> int:
        return self.params.get("D", 0)

    def _ge(self):
        return ncs.gilbert_elliott(fail=self.params["f"],
                                   recover=self.params["r"])

    def _delay(self):
        p = self.params
        if self.kind == "bursty":
            return ncs.bursty_delay(self._ge(), p["qb"], p["qg"],
                                    buffer=p["D"])
        return ncs.random_delay(p["q"], buffer=p["D"])

    def package(self, side: str) -> dict:
        """The keywords of ``ncs.nss`` for this link on ``side``."""
        p, kw = self.params, {}
        if self.kind in ("bernoulli", "delay_loss"):
            kw[f"{side}_loss"] = p["alpha"]
        if self.kind == "gilbert_elliott":
            kw[f"{side}_loss"] = self._ge()
        if self.delayed:
            kw[f"{side}_delay"] = self._delay()
        return kw

    def reference(self) -> R.Link:
        p = self.params
        return {"none": R.perfect,
                "bernoulli": lambda: R.bernoulli(p["alpha"]),
                "gilbert_elliott": lambda: R.gilbert_elliott(p["f"], p["r"]),
                "delay": lambda: R.delay(p["q"], p["D"]),
                "delay_loss": lambda: R.delay(p["q"], p["D"], p["alpha"]),
                "bursty": lambda: R.bursty(p["f"], p["r"], p["qb"], p["qg"],
                                           p["D"])}[self.kind]()

    def simulator(self) -> tuple:
        """``(loss, delay)`` arguments of ``simulate_protocol``."""
        loss: object = 0.0
        if self.kind in ("bernoulli", "delay_loss"):
            loss = self.params["alpha"]
        elif self.kind == "gilbert_elliott":
            loss = self._ge()
        return loss, (self._delay() if self.delayed else None)

    def __str__(self) -> str:
        return self.kind


def draw_link(kind: str, rng: np.random.Generator) -> LinkSpec:
    """A link of ``kind`` with random parameters (delays of at most 2
    steps, a bursty link of at most 1, buffers up to one step longer)."""
    if kind == "none":
        return LinkSpec(kind)
    if kind == "bernoulli":
        return LinkSpec(kind, {"alpha": rng.uniform(0.05, 0.4)})
    if kind == "gilbert_elliott":
        return LinkSpec(kind, {"f": rng.uniform(0.05, 0.5),
                               "r": rng.uniform(0.3, 0.9)})
    if kind in ("delay", "delay_loss"):
        d = int(rng.integers(1, 3))
        q = rng.dirichlet(np.ones(d + 1)) * rng.uniform(0.8, 1.0)
        q[-1] = max(q[-1], 0.05)
        params = {"q": (q / max(1.0, q.sum())).tolist(),
                  "D": d + int(rng.integers(0, 2))}
        if kind == "delay_loss":
            params["alpha"] = rng.uniform(0.05, 0.3)
        return LinkSpec(kind, params)
    bad = rng.dirichlet(np.ones(2)) * rng.uniform(0.3, 0.9)
    good = rng.dirichlet([4.0, 1.0]) * rng.uniform(0.85, 1.0)
    return LinkSpec(kind, {"f": rng.uniform(0.1, 0.4),
                           "r": rng.uniform(0.3, 0.8),
                           "qb": bad.tolist(), "qg": good.tolist(),
                           "D": 1 + int(rng.integers(0, 2))})


#: One link of each kind, for the enumeration of all pairs.
REPRESENTATIVE = {
    "none": LinkSpec("none"),
    "bernoulli": LinkSpec("bernoulli", {"alpha": 0.2}),
    "gilbert_elliott": LinkSpec("gilbert_elliott", {"f": 0.2, "r": 0.6}),
    "delay": LinkSpec("delay", {"q": [0.5, 0.3, 0.1], "D": 2}),
    "delay_loss": LinkSpec("delay_loss", {"q": [0.6, 0.3], "D": 2,
                                          "alpha": 0.15}),
    "bursty": LinkSpec("bursty", {"f": 0.2, "r": 0.5, "qb": [0.3, 0.4],
                                  "qg": [0.8, 0.15], "D": 1}),
}


# --------------------------------------------------------------------------
# one loop, three ways
# --------------------------------------------------------------------------
@dataclass
class Case:
    """A plant, its two links and schedules, and the controller."""

    A: np.ndarray
    B1: np.ndarray
    B2: np.ndarray
    C1: np.ndarray
    D11: np.ndarray
    D12: np.ndarray
    C2: np.ndarray
    D21: np.ndarray
    sensor: LinkSpec
    actuator: LinkSpec
    controller: str
    strategy: str = "zero"              # the actuator's (and LTI sensor's)
    S1: np.ndarray | None = None
    S2: np.ndarray | None = None
    K: np.ndarray | None = None
    L: np.ndarray | None = None
    lti: tuple | None = None

    def __str__(self) -> str:
        return (f"{self.sensor}-{self.actuator}-{self.controller}-"
                f"{self.strategy}")


def package_loop(case: Case):
    p2, m2 = case.C2.shape[0], case.B2.shape[1]
    D = np.block([[case.D11, case.D12],
                  [case.D21, np.zeros((p2, m2))]])
    with warnings.catch_warnings():
        # a schedule may leave a gain's column idle at some phase
        warnings.simplefilter("ignore", ncs.ScheduleWarning)
        P = ncs.nss(case.A, np.hstack([case.B1, case.B2]),
                    np.vstack([case.C1, case.C2]), D, True, nmeas=p2,
                    ncon=m2, sensor_schedule=case.S1,
                    actuator_schedule=case.S2,
                    **case.sensor.package("sensor"),
                    **case.actuator.package("actuator"))
        kw: dict = {"actuator": case.strategy}
        if case.controller == "lti":
            return ncs.feedback(P, ct.ss(*case.lti, True), sensor=case.strategy,
                                **kw)
        if case.controller == "estimator":
            kw["estimator_gain"] = case.L
        controller = "static" if case.controller == "per_age" else \
            case.controller
        K = case.K
        if case.controller == "per_age" and np.ndim(K) == 3:
            # one gain per age, as feedback reads it: blocks of columns
            K = np.concatenate(list(np.asarray(K)), axis=-1)
        return ncs.feedback(P, K, controller=controller, **kw)


def reference_plant(case: Case) -> R.Plant:
    return R.Plant(case.A, case.B1, case.B2, case.C1, case.D11, case.D12,
                   case.C2, case.D21)


def reference_loop(case: Case):
    K = case.K
    if case.controller == "per_age" and np.ndim(K) == 3:
        K = np.asarray(K)[None]                     # one phase, every age
    controller = "static" if case.controller == "per_age" else \
        case.controller
    return R.loop(reference_plant(case), case.sensor.reference(),
                  case.actuator.reference(), K, controller=controller,
                  actuator=case.strategy, sensor=case.strategy,
                  sensor_schedule=case.S1, actuator_schedule=case.S2,
                  estimator_gains=case.L, controller_system=case.lti)


def assert_figures_agree(case: Case, steps: int = 6) -> None:
    """ms_radius, moments (from 0, a deterministic and a white input) and,
    for a mean-square stable loop, the H2 norm: package = reference."""
    CL, ref = package_loop(case), reference_loop(case)
    rho = ncs.ms_radius(ref, tol=1e-13)
    assert ncs.ms_radius(CL, tol=1e-13) == pytest.approx(rho, rel=RTOL), \
        str(case)
    m1 = case.B1.shape[1]
    w = np.cos(0.7 * np.arange(steps) + np.arange(m1)[:, None])
    got = ncs.moments(CL, steps, inputs=w, noise_covariance=np.eye(m1))
    want = ncs.moments(ref, steps, inputs=w, noise_covariance=np.eye(m1))
    scale = np.abs(want.outputs_cov).max() + np.abs(want.outputs_mean).max()
    np.testing.assert_allclose(got.outputs_mean, want.outputs_mean,
                               rtol=0, atol=RTOL * scale, err_msg=str(case))
    np.testing.assert_allclose(got.outputs_cov, want.outputs_cov,
                               rtol=0, atol=RTOL * scale, err_msg=str(case))
    if rho < 0.999:
        # ‖G‖₂² solves (I - 𝒯) q = F over one period: rounding is amplified
        # by about 1/(1 - ρ^N), the distance of the period's monodromy from
        # singular (a loop at ρ = 0.9916, N = 2 differs by 2e-8 between two
        # exact constructions)
        amplification = 1.0 / (1.0 - rho ** CL.period)
        assert ncs.norm(CL, 2, tol=1e-13) == pytest.approx(
            ncs.norm(ref, 2, tol=1e-13), rel=RTOL * amplification), str(case)


def _schedule(rng, period: int, width: int, delayed: bool) -> np.ndarray:
    """Phase 0 lets every node send (the loop closes); other phases at
    random, all-or-none on a delayed link."""
    S = np.ones((period, width), dtype=int)
    for k in range(1, period):
        S[k] = (rng.random() < 0.5) if delayed else rng.random(width) < 0.5
    return S


def _estimator_gain(A, C2):
    """The steady Kalman filter gain of ``x̂ += L (y - C2 x̂)``."""
    n, p2 = A.shape[0], C2.shape[0]
    P = scipy.linalg.solve_discrete_are(A.T, C2.T, np.eye(n), np.eye(p2))
    return P @ C2.T @ np.linalg.inv(C2 @ P @ C2.T + np.eye(p2))


def make_case(rng, sensor: LinkSpec, actuator: LinkSpec, controller: str,
              strategy: str, periods=(1, 1), n: int = 2) -> Case:
    """A random plant (spectral radius 0.8 to 1.1) and gains from its LQR
    design, scaled so that most loops are mean-square stable."""
    A = rng.standard_normal((n, n))
    A *= rng.uniform(0.8, 1.1) / max(abs(np.linalg.eigvals(A)))
    B1, B2 = rng.standard_normal((n, 1)), rng.standard_normal((n, 1))
    C1, D11 = rng.standard_normal((1, n)), 0.3 * rng.standard_normal((1, 1))
    D12 = 0.3 * rng.standard_normal((1, 1))
    Klqr = -0.8 * ct.dlqr(A, B2, np.eye(n), np.eye(1))[0]
    p2 = n if controller == "predictor" else int(rng.integers(1, n + 1))
    C2 = np.eye(n) if controller == "predictor" else \
        rng.standard_normal((p2, n))
    D21 = np.zeros((p2, 1)) if controller == "predictor" else \
        0.3 * rng.standard_normal((p2, 1))
    case = Case(A, B1, B2, C1, D11, D12, C2, D21, sensor, actuator,
                controller, strategy)
    if periods[0] > 1:
        case.S1 = _schedule(rng, periods[0], p2, sensor.delayed)
    if periods[1] > 1:
        case.S2 = _schedule(rng, periods[1], 1, actuator.delayed)
    Ky = Klqr @ np.linalg.pinv(C2)                 # u = K y ≈ the LQR's
    if controller == "static":
        case.K = Ky
    elif controller == "per_age":
        ages = sensor.buffer + 1
        case.K = np.stack([Ky * 0.8 ** a for a in range(ages)])
    elif controller == "lti":
        case.lti = (rng.uniform(-0.5, 0.5, (1, 1)),
                    0.5 * rng.standard_normal((1, p2)),
                    0.5 * rng.standard_normal((1, 1)), Ky)
    else:
        case.K = Klqr if strategy == "zero" else \
            np.hstack([Klqr, 0.2 * rng.standard_normal((1, 1))])
        if controller == "estimator":
            case.L = _estimator_gain(A, C2)
    return case


# --------------------------------------------------------------------------
# a loss, a schedule or a design beside a delayed link is kept
# --------------------------------------------------------------------------
def scalar_plant(a, **network):
    """``x⁺ = a x + w + u``, ``z = x``, ``y = x``."""
    return ncs.nss([[a]], [[1.0, 1.0]], [[1.0], [1.0]],
                   [[0.0, 0.0], [0.0, 0.0]], True, nmeas=1, ncon=1,
                   **network)


def scalar_reference(a, sensor, actuator, K, **kw):
    one = np.ones((1, 1))
    plant = R.Plant(a * one, one, one, one, 0 * one, 0 * one, one, 0 * one)
    return R.loop(plant, sensor, actuator, K, **kw)


def test_an_actuator_loss_survives_a_sensor_delay():
    """``x⁺ = 1.1x + w + u``, ``u = -0.9x`` arriving with probability 0.5:
    E a² = 0.5·0.2² + 0.5·1.1² = 0.625, whether or not the sensor link is
    a delay law that always delivers at once."""
    truth = 0.5 * 0.2 ** 2 + 0.5 * 1.1 ** 2
    ref = scalar_reference(1.1, R.delay([1.0]), R.bernoulli(0.5), [[-0.9]])
    assert ncs.ms_radius(ref) == pytest.approx(truth, rel=1e-12)
    CL = ncs.feedback(scalar_plant(1.1, actuator_loss=0.5,
                                   sensor_delay=[1.0]), [[-0.9]])
    assert ncs.ms_radius(CL) == pytest.approx(truth, rel=1e-12)


def test_a_sensor_loss_survives_an_actuator_delay():
    """``x⁺ = 1.5x + w + u`` with the deadbeat ``u = -1.5x``, the
    measurement lost with probability 0.3: 0.3·1.5² = 0.675."""
    truth = 0.3 * 1.5 ** 2
    ref = scalar_reference(1.5, R.bernoulli(0.3), R.delay([1.0]), [[-1.5]])
    assert ncs.ms_radius(ref) == pytest.approx(truth, rel=1e-12)
    CL = ncs.feedback(scalar_plant(1.5, sensor_loss=0.3,
                                   actuator_delay=ncs.random_delay([1.0])),
                      [[-1.5]])
    assert ncs.ms_radius(CL) == pytest.approx(truth, rel=1e-12)


def test_a_schedule_on_the_undelayed_link_survives_a_sensor_delay():
    """The actuator addressed every other step: over one period ``x`` is
    multiplied by ``(1.5 - 1)·1.5``, a per-step rate of 0.75."""
    truth = abs(1.5 - 1.0) * 1.5
    ref = scalar_reference(1.5, R.delay([1.0]), R.perfect(), [[-1.0]],
                           actuator_schedule=[[1], [0]])
    assert ncs.ms_radius(ref) == pytest.approx(truth, rel=1e-12)
    CL = ncs.feedback(scalar_plant(1.5, actuator_schedule=[1, 0],
                                   sensor_delay=[1.0]), [[-1.0]])
    assert ncs.ms_radius(CL) == pytest.approx(truth, rel=1e-12)


def test_h2syn_reports_the_norm_of_its_loop_beside_an_actuator_delay():
    """h2syn over a lossy sensor link and a delayed actuator link: the
    norm it reports is the norm of the loop its gain closes
    (``1/√(1 - 0.3·1.5²) ≈ 1.754`` for the deadbeat gain)."""
    P = scalar_plant(1.5, sensor_loss=0.3,
                     actuator_delay=ncs.random_delay([1.0]))
    K, CL, value = ncs.h2syn(P)
    gains = np.asarray(K.gains)[:, None]          # (N, one age, m2, p2)
    ref = scalar_reference(1.5, R.bernoulli(0.3), R.delay([1.0]), gains)
    truth = ncs.norm(ref)
    assert truth >= 1.0 / math.sqrt(1.0 - 0.3 * 1.5 ** 2) * (1 - 1e-6)
    assert value == pytest.approx(truth, rel=1e-6)
    assert ncs.norm(CL) == pytest.approx(truth, rel=RTOL)


def test_critical_loss_sees_the_actuator_loss_beside_a_sensor_delay():
    """``u = -0.9x`` on ``x⁺ = 1.1x + u``: mean-square stable while
    ``α·1.1² + (1 - α)·0.2² < 1``, i.e. ``α < 0.96/1.17``; the reference
    loop crosses 1 there."""
    truth = 0.96 / 1.17
    for alpha, side in ((truth - 1e-4, -1), (truth + 1e-4, 1)):
        rho = ncs.ms_radius(scalar_reference(1.1, R.delay([1.0]),
                                             R.bernoulli(alpha), [[-0.9]]))
        assert np.sign(rho - 1.0) == side
    P = scalar_plant(1.1, sensor_delay=[1.0])
    assert ncs.critical_loss(P, [[-0.9]]) == pytest.approx(truth, abs=1e-5)


# --------------------------------------------------------------------------
# the reference against closed forms and the theory page
# --------------------------------------------------------------------------
def test_the_delay_chain_has_the_rows_of_the_worked_example():
    chain = R.link_chain(R.delay([0.5, 0.3, 0.1], buffer=3), [True])
    expected = [[.5, .5, 0, 0, 0], [.5, .3, .2, 0, 0], [.5, .3, .1, .1, 0],
                [.5, .3, .1, 0, .1], [.5, .3, .1, 0, .1]]
    np.testing.assert_allclose(chain.T[0], expected, atol=1e-15)


def test_a_bursty_link_with_one_law_in_both_states_is_the_delay_link():
    """The hazard counts the law's loss as a delay of ∞: with equal lossy
    laws the channel state is irrelevant and the ages are the delay
    chain's (the semantics' hazard ``q_c / Σ_{c'≥c} q_c'`` would deliver
    every packet)."""
    q = [0.4, 0.3]
    bursty = R.link_chain(R.bursty(0.2, 0.5, q, q, buffer=2), [True])
    plain = R.link_chain(R.delay(q, buffer=2), [True])
    ages = np.kron(np.ones((1, 2)), np.eye(4))            # (g, a) -> a
    for g in range(2):
        rows = bursty.T[0, 4 * g:4 * g + 4] @ ages.T
        np.testing.assert_allclose(rows, plain.T[0], atol=1e-15)


def test_the_predictor_over_a_lossy_delayed_sensor_link_costs_the_loss():
    """Scalar ``x⁺ = a x + u``, deadbeat predictor, delays ≤ 2 and loss ℓ
    on the sensor link: the second-moment rate is ℓ a², whatever the
    delay law (theory: random delays)."""
    for q, a in (([0.5, 0.3, 0.1], 1.5), ([0.2, 0.2, 0.4], 2.0)):
        ref = scalar_reference(a, R.delay(q, buffer=3), R.perfect(),
                               [[-a]], controller="predictor")
        assert ncs.ms_radius(ref) == pytest.approx((1 - sum(q)) * a * a,
                                                   rel=1e-9)


def test_sub_sample_input_delays_give_the_kushner_tobias_radii():
    """``P(s) = 6/((s+1)(s+2))``, ``u = -y``, ``h = 1.42``, ``τ`` uniform
    on ``{0, δ, …, jδ}``, ``δ = h/50`` (theory: sub-sample delays)."""
    G = ct.ss(ct.tf([6.0], [1.0, 3.0, 2.0]))
    one, zero = np.ones((1, 1)), np.zeros((1, 1))
    for j, radius in ((0, 0.978055), (23, 0.981160), (24, 1.006315)):
        taus = np.arange(j + 1) * 1.42 / 50
        Phi, B1d, B2d, g0, g1 = R.sample_input_delay(G.A, G.B, G.B, 1.42,
                                                     taus)
        plant = R.Plant(Phi, B1d, B2d, G.C, zero, zero, G.C, zero, g0, g1,
                        np.full(j + 1, 1.0 / (j + 1)))
        ref = R.loop(plant, R.perfect(), R.perfect(), -one)
        assert ncs.ms_radius(ref) == pytest.approx(radius, abs=5e-7)


def test_the_simulators_ages_follow_the_reference_chain_of_a_bursty_link():
    """Packets of a bursty link, scheduled at phases 0 and 1 of 3: the
    transitions of (age) seen by the simulator are the reference chain's
    marginal ones, within 5 binomial standard errors."""
    spec = LinkSpec("bursty", {"f": 0.2, "r": 0.4, "qb": [0.1, 0.5],
                               "qg": [0.7, 0.2], "D": 2})
    sent = [True, True, False]
    out = simulate_protocol(
        [[0.5]], [[0.0]], [[1.0]], [[1.0]], [[0.0]], [[0.0]],
        [[int(s)] for s in sent], [[1]] * 3, 0.0, 0.0,
        np.zeros((3, 1, 1)), 3000, sensor_delay=spec.simulator()[1],
        trials=40, rng=np.random.default_rng(3))
    ages = out["age1"][:, 30:]
    chain = R.link_chain(spec.reference(), sent)
    G, S = 2, spec.buffer + 2
    counts = np.zeros((3, S, S))
    t = np.arange(30, 30 + ages.shape[1] - 1)
    for row in ages:
        np.add.at(counts, (t % 3, row[:-1], row[1:]), 1.0)
    # the reference's law of (age_t, age_t+1) from its joint chain
    law = chain.initial.copy()
    for k in range(3):
        joint = (law[:, None] * chain.T[k]).reshape(G, S, G, S).sum((0, 2))
        visits = counts[k].sum(axis=1, keepdims=True)
        expected = joint / np.maximum(joint.sum(axis=1, keepdims=True), 1e-300)
        freq = counts[k] / np.maximum(visits, 1.0)
        sigma = np.sqrt(expected * (1 - expected) / np.maximum(visits, 1.0))
        assert np.all(np.abs(freq - expected) <= 5 * sigma + 1e-12), k
        assert np.all(counts[k][expected == 0] == 0)
        law = law @ chain.T[k]


# --------------------------------------------------------------------------
# every pair of links: the package against the reference
# --------------------------------------------------------------------------
PAIRS = [(s, a) for s in KINDS for a in KINDS]


def _representative(i: int, sensor: str, actuator: str) -> Case:
    controller = CONTROLLERS[i % len(CONTROLLERS)]
    strategy = ("zero", "hold")[(i // len(CONTROLLERS)) % 2]
    periods = ((1, 1), (2, 1), (1, 3))[i % 3]
    return make_case(np.random.default_rng(100 + i), REPRESENTATIVE[sensor],
                     REPRESENTATIVE[actuator], controller, strategy, periods)


@pytest.mark.parametrize(
    "case", [_representative(i, s, a) for i, (s, a) in enumerate(PAIRS)],
    ids=str)
def test_every_pair_of_links_equals_the_reference(case):
    assert_figures_agree(case)


@pytest.mark.parametrize("controller", CONTROLLERS)
@pytest.mark.parametrize("strategy", ["zero", "hold"])
@pytest.mark.parametrize("sensor, actuator", [("delay_loss", "bursty"),
                                              ("bursty", "delay")])
def test_every_controller_over_two_delayed_links_equals_the_reference(
        sensor, actuator, controller, strategy):
    """Both links delayed, the sensor's all-or-none schedule of period 2."""
    case = make_case(np.random.default_rng(7), REPRESENTATIVE[sensor],
                     REPRESENTATIVE[actuator], controller, strategy, (2, 1))
    assert_figures_agree(case)


# no shrinking: a failure is reported as drawn (the enumeration above names
# the link pair), and a failing run stays as cheap as a passing one
@settings(max_examples=20, deadline=None,
          phases=(Phase.explicit, Phase.reuse, Phase.generate))
@given(seed=st.integers(0, 2 ** 32 - 1), sensor=st.sampled_from(KINDS),
       actuator=st.sampled_from(KINDS),
       controller=st.sampled_from(CONTROLLERS),
       strategy=st.sampled_from(["zero", "hold"]),
       periods=st.tuples(st.sampled_from([1, 2, 3]),
                         st.sampled_from([1, 2, 3])),
       n=st.integers(1, 2))
def test_any_combination_of_links_equals_the_reference(
        seed, sensor, actuator, controller, strategy, periods, n):
    rng = np.random.default_rng(seed)
    case = make_case(rng, draw_link(sensor, rng), draw_link(actuator, rng),
                     controller, strategy, periods, n)
    assert_figures_agree(case)


TAUS, TAU_PROBABILITIES = np.array([0.0, 0.3, 0.6]), np.array([0.5, 0.3, 0.2])


def _input_delay_plant():
    """A continuous oscillator sampled every 0.7 s, its input applied 0,
    0.3 or 0.6 s after the sample: the continuous system and the
    reference's sampled plant."""
    Ac = np.array([[0.0, 1.0], [-2.0, -0.5]])
    Bw, Bu = np.array([[0.0], [1.0]]), np.array([[0.2], [1.0]])
    C1 = np.array([[1.0, 0.0]])
    sys_c = ct.ss(Ac, np.hstack([Bw, Bu]), np.vstack([C1, np.eye(2)]),
                  np.zeros((3, 2)))
    Phi, B1d, B2d, g0, g1 = R.sample_input_delay(Ac, Bw, Bu, 0.7, TAUS)
    zero = np.zeros((1, 1))
    return sys_c, R.Plant(Phi, B1d, B2d, C1, zero, zero, np.eye(2),
                          np.zeros((2, 1)), g0, g1, TAU_PROBABILITIES)


@pytest.mark.parametrize("sensor, actuator", [
    ("none", "none"), ("bernoulli", "none"), ("none", "gilbert_elliott"),
    ("delay", "none"), ("delay_loss", "bernoulli")])
@pytest.mark.parametrize("controller", ["static", "predictor"])
def test_sub_sample_input_delays_compose_with_the_links(
        controller, sensor, actuator):
    sensor, actuator = REPRESENTATIVE[sensor], REPRESENTATIVE[actuator]
    sys_c, plant = _input_delay_plant()
    P = ncs.nss(sys_c, nmeas=2, ncon=1, dt=0.7,
                input_delay=(TAUS, TAU_PROBABILITIES),
                **sensor.package("sensor"), **actuator.package("actuator"))
    K = np.array([[-1.0, -0.8]])
    CL = ncs.feedback(P, K, controller=controller)
    ref = R.loop(plant, sensor.reference(), actuator.reference(), K,
                 controller=controller, dt=0.7)
    assert ncs.ms_radius(CL) == pytest.approx(ncs.ms_radius(ref), rel=RTOL)
    assert ncs.norm(CL) == pytest.approx(ncs.norm(ref), rel=RTOL)


# --------------------------------------------------------------------------
# the event-level simulator against the reference
# --------------------------------------------------------------------------
def _stable_case(controller, strategy, sensor, actuator, periods=(1, 1),
                 sensor_schedule=None):
    """A well-damped two-state plant (spectral radius 0.96) whose loops
    have light tails, so that sample errors of the output power hold."""
    A = np.array([[0.85, 0.4], [-0.3, 0.95]])
    B1, B2 = np.array([[1.0], [0.5]]), np.array([[0.5], [1.0]])
    C1, D11, D12 = np.array([[1.0, -0.5]]), [[0.3]], [[0.2]]
    C2 = np.eye(2)
    D21 = np.zeros((2, 1)) if controller == "predictor" else \
        np.array([[0.2], [-0.1]])
    if controller == "estimator":
        C2, D21 = np.array([[1.0, 0.5]]), np.array([[0.2]])
    case = Case(A, B1, B2, C1, np.array(D11), np.array(D12), C2, D21,
                REPRESENTATIVE[sensor], REPRESENTATIVE[actuator], controller,
                strategy)
    rng = np.random.default_rng(1)
    if periods[0] > 1:
        case.S1 = _schedule(rng, periods[0], C2.shape[0], case.sensor.delayed)
    if periods[1] > 1:
        case.S2 = _schedule(rng, periods[1], 1, case.actuator.delayed)
    if sensor_schedule is not None:
        case.S1 = np.asarray(sensor_schedule)
    Kx = GAIN_SCALE * np.array([[-0.55, -0.9]])
    if controller == "static":
        case.K = Kx
    elif controller == "per_age":
        case.K = np.stack([Kx * 0.8 ** a for a in range(case.sensor.buffer
                                                        + 1)])
    elif controller == "lti":
        case.lti = (np.array([[0.3]]), np.array([[0.2, 0.1]]),
                    np.array([[-0.2]]), Kx)
    else:
        case.K = Kx if strategy == "zero" else np.hstack([Kx, [[0.1]]])
    if controller == "estimator":
        case.L = np.array([[0.5], [0.3]])
    return case


def _simulated_power(case, trials=1500, steps=240, burn=48, seed=0):
    """Mean over trials of the time-averaged ‖z‖² (after a burn-in of
    whole periods) and its standard error, from the event-level simulator
    with unit white noise."""
    p2 = case.C2.shape[0]
    S1 = np.ones((1, p2)) if case.S1 is None else np.asarray(case.S1)
    S2 = np.ones((1, 1)) if case.S2 is None else np.asarray(case.S2)
    N = math.lcm(S1.shape[0], S2.shape[0])
    S1, S2 = np.tile(S1, (N // S1.shape[0], 1)), np.tile(S2, (N // S2.shape[0], 1))
    controller = "static" if case.controller == "per_age" else case.controller
    gains = None
    if case.controller == "per_age":
        gains = case.K
    elif case.controller == "static" and case.sensor.delayed:
        gains = np.tile(case.K, (case.sensor.buffer + 1, 1, 1))
    elif case.controller != "lti":
        gains = np.tile(case.K, (N, 1, 1))
    (l1, d1), (l2, d2) = case.sensor.simulator(), case.actuator.simulator()
    rng = np.random.default_rng(seed)
    out = simulate_protocol(
        case.A, case.B1, case.B2, case.C1, case.D11, case.D12, S1, S2, l1,
        l2, gains, steps, controller=controller, actuator=case.strategy,
        sensor=case.strategy if controller == "lti" else "zero", C2=case.C2,
        D21=case.D21, controller_system=case.lti,
        estimator_gains=None if case.L is None else case.L[None],
        sensor_delay=d1, actuator_delay=d2, trials=trials, rng=rng,
        inputs=rng.standard_normal((trials, 1, steps)), warmup=12)
    power = (out["z"][:, :, burn:] ** 2).sum(axis=1).mean(axis=1)
    return power.mean(), power.std(ddof=1) / math.sqrt(trials)


@pytest.mark.parametrize("case", [
    _stable_case("static", "hold", "bernoulli", "delay_loss", (2, 1)),
    _stable_case("static", "zero", "gilbert_elliott", "delay", (1, 2)),
    _stable_case("per_age", "zero", "delay_loss", "gilbert_elliott"),
    _stable_case("per_age", "hold", "delay", "bernoulli", (2, 1)),
    _stable_case("predictor", "hold", "bursty", "bernoulli"),
    _stable_case("predictor", "zero", "delay", "delay", (1, 2)),
    _stable_case("estimator", "zero", "delay", "bursty"),
    _stable_case("estimator", "hold", "gilbert_elliott", "delay_loss"),
    _stable_case("lti", "zero", "bernoulli", "bursty"),
    _stable_case("lti", "hold", "gilbert_elliott", "delay"),
    _stable_case("lti", "hold", "bernoulli", "delay_loss",
                 sensor_schedule=[[1, 1], [0, 1]]),
], ids=str)
def test_the_protocol_simulator_has_the_reference_output_power(case):
    ref = reference_loop(case)
    exact = ncs.norm(ref) ** 2
    mean, se = _simulated_power(case)
    assert abs(mean - exact) < 4 * se, (mean, se, exact)


def test_gains_per_phase_and_age_have_the_reference_output_power():
    """A gain per phase (of the actuator's period-2 schedule) and per age
    of the measurement, ``(N, Ds + 1, m2, p2)``."""
    case = _stable_case("per_age", "zero", "delay", "bernoulli")
    case.S2 = np.ones((2, 1), dtype=int)
    case.K = np.stack([case.K, 0.4 * case.K])
    one_gain = _stable_case("per_age", "zero", "delay", "bernoulli")
    assert ncs.norm(reference_loop(one_gain)) ** 2 < 0.9 * ncs.norm(
        reference_loop(case)) ** 2                   # the phases matter
    exact = ncs.norm(reference_loop(case)) ** 2
    mean, se = _simulated_power(case)
    assert abs(mean - exact) < 4 * se, (mean, se, exact)


def test_the_protocol_simulator_has_the_reference_moments_from_rest():
    """From rest with the links warmed up to their stationary law, a sine
    input: the simulator's mean and variance of z(t) over 12 steps are
    the reference's moments, within 4 standard errors each."""
    case = _stable_case("estimator", "hold", "bursty", "delay_loss")
    steps, trials = 12, 20000
    w = np.sin(0.9 * np.arange(steps))[None]
    want = ncs.moments(reference_loop(case), steps, inputs=w)
    (l1, d1), (l2, d2) = case.sensor.simulator(), case.actuator.simulator()
    out = simulate_protocol(
        case.A, case.B1, case.B2, case.C1, case.D11, case.D12, [[1]], [[1]],
        l1, l2, case.K[None], steps, controller="estimator",
        actuator="hold", C2=case.C2, D21=case.D21,
        estimator_gains=case.L[None], sensor_delay=d1, actuator_delay=d2,
        inputs=w, trials=trials, rng=np.random.default_rng(4), warmup=40)
    z = out["z"][:, 0]
    se_mean = z.std(axis=0, ddof=1) / math.sqrt(trials)
    assert np.all(np.abs(z.mean(axis=0) - want.outputs_mean[0])
                  <= 4 * se_mean + 1e-12)
    centred = (z - want.outputs_mean[0]) ** 2
    se_var = centred.std(axis=0, ddof=1) / math.sqrt(trials)
    assert np.all(np.abs(centred.mean(axis=0) - want.outputs_cov[0, 0])
                  <= 4 * se_var + 1e-12)
    assert want.outputs_cov[0, 0, -1] > 0.1      # the links do spread z


@pytest.mark.parametrize("controller", ["static", "predictor"])
def test_the_protocol_simulator_has_the_reference_power_with_input_delays(
        controller):
    """The sampled oscillator with sub-sample input delays over a lossy
    delayed sensor link and a lossy actuator link."""
    sensor, actuator = REPRESENTATIVE["delay_loss"], REPRESENTATIVE["bernoulli"]
    _, plant = _input_delay_plant()
    K = np.array([[-1.0, -0.8]])
    ref = R.loop(plant, sensor.reference(), actuator.reference(), K,
                 controller=controller, dt=0.7)
    exact = ncs.norm(ref) ** 2
    gains = np.tile(K, (sensor.buffer + 1 if controller == "static" else 1,
                        1, 1))
    (l1, d1), (l2, d2) = sensor.simulator(), actuator.simulator()
    trials, steps, burn = 1500, 240, 48
    rng = np.random.default_rng(2)
    out = simulate_protocol(
        plant.A, plant.B1, plant.B2, plant.C1, plant.D11, plant.D12,
        [[1, 1]], [[1]], l1, l2, gains, steps, controller=controller,
        sensor_delay=d1, actuator_delay=d2, warmup=12, trials=trials,
        input_delay=(plant.gamma0, plant.gamma1, TAU_PROBABILITIES),
        inputs=rng.standard_normal((trials, 1, steps)), rng=rng)
    power = (out["z"][:, :, burn:] ** 2).sum(axis=1).mean(axis=1)
    se = power.std(ddof=1) / math.sqrt(trials)
    assert abs(power.mean() - exact) < 4 * se, (power.mean(), se, exact)


def test_an_estimator_next_to_the_stability_edge_gets_its_h2_norm():
    # a Gilbert–Elliott sensor, a bursty actuator, the estimator with held
    # commands, ρ = 0.9916: GMRES stalls on the stationary second moment at
    # tol 1e-13 (864 unknowns); the route the package chose is solved dense
    rng = np.random.default_rng(1122)
    case = make_case(rng, draw_link("gilbert_elliott", rng),
                     draw_link("bursty", rng), "estimator", "hold", (2, 2), 2)
    CL = package_loop(case)
    rho = ncs.ms_radius(CL)
    assert 0.99 < rho < 0.999
    with pytest.raises(ValueError, match="GMRES"):
        ncs.norm(CL, 2, tol=1e-13, method="matrix-free")
    # the same dense system, its rounding amplified by 1/(1 - ρ^N)
    assert ncs.norm(CL, 2, tol=1e-13) == pytest.approx(
        ncs.norm(CL, 2, tol=1e-13, method="dense"),
        rel=RTOL / (1.0 - rho ** CL.period))
    assert_figures_agree(case)
