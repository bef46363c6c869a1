"""python-control's contract on a jump system, and no silent loss of its
randomness.

A :class:`control_ncs.JumpStateSpace` is a ``control.StateSpace`` whose
matrices are its exact mean. These tests check that python-control's
calls on it either keep the jump system (mode by mode), refuse by name,
or are recognised later: a plain copy of the mean face
(``control.ss(CL)``, ``similarity_transform``, canonical forms) is refused
by the package's analysis, whose answer for it would be the mean system's
(another mean-square radius). They also check that the system is
immutable, prints as python-control's systems do (``repr`` formats, HTML,
``str``; the loadable form rebuilds an equal system), and that
deterministic jump systems combine as the LTI systems they are, against
python-control on the same matrices.
"""

from __future__ import annotations

import re
import warnings

import control as ct
import numpy as np
import pytest
from control.exception import ControlArgument, ControlDimension
from hypothesis import given, settings, strategies as st

import control_ncs as ncs

DT = 0.1


# -- systems --------------------------------------------------------------------
def lossy_loop():
    """A scalar loop whose control is lost with probability 0.3 (random)."""
    return ncs.jss([[[1.1]], [[0.1]]], [[1.0]], [[1.0]], [[0.0]], [0.3, 0.7],
                   DT, name="CL", nominal=[1])


def mimo_loop():
    """Two states, two inputs, two outputs, three i.i.d. modes."""
    A = [[[0.9, 0.2], [0.0, 0.7]], [[1.1, 0.2], [0.1, 0.9]],
         [[0.5, 0.0], [0.3, 0.4]]]
    B = [[1.0, 0.0], [0.5, 1.0]]
    C = [[[1.0, 0.0], [0.0, 1.0]], [[1.0, 0.0], [0.0, 0.0]],
         [[1.0, 0.0], [0.0, 1.0]]]
    return ncs.jss(A, B, C, [[0.1, 0.0], [0.0, 0.2]], [0.6, 0.1, 0.3], DT,
                   name="CL2", inputs=["w1", "w2"], outputs=["z1", "z2"])


def markov_loop():
    """Bursty losses: three states, four Markov modes (face order 12)."""
    rng = np.random.default_rng(4)
    A = np.array([rng.standard_normal((3, 3)) * s for s in
                  (0.3, 0.35, 0.4, 0.5)])
    T = [[0.7, 0.1, 0.1, 0.1], [0.2, 0.6, 0.1, 0.1], [0.1, 0.1, 0.7, 0.1],
         [0.1, 0.1, 0.2, 0.6]]
    return ncs.jss(A, np.ones((3, 1)), np.eye(3)[:1], [[0.0]], dt=DT,
                   transition=T, name="bursty")


def small_markov_loop():
    """Bursts of lost control: one state, two Markov modes."""
    return ncs.jss([[[2.0]], [[0.0]]], [[1.0]], [[1.0]], [[0.0]], dt=DT,
                   transition=[[0.5, 0.5], [0.125, 0.875]], name="bursts")


def periodic_loop():
    """Period 2, two modes per phase."""
    A = [[[[0.5]], [[1.2]]], [[[0.8]], [[0.2]]]]
    return ncs.jss(A, [[1.0]], [[1.0]], [[0.0]], [[0.5, 0.5], [0.8, 0.2]], DT,
                   name="CLN")


def one_mode(sys):
    """A deterministic StateSpace as a one-mode jump system."""
    return ncs.jss(sys.A[None], sys.B[None], sys.C[None], sys.D[None], [1.0],
                   sys.dt, name=sys.name, inputs=list(sys.input_labels),
                   outputs=list(sys.output_labels),
                   states=list(sys.state_labels))


def filter_G(tf=False):
    G = ct.ss([[0.3]], [[1.0]], [[0.4]], [[0.2]], DT, name="G")
    return ct.tf(G) if tf else G


def assert_modewise(result, sys, op):
    """Every mode of ``result`` is python-control's ``op`` of that mode."""
    assert isinstance(result, ncs.JumpStateSpace)
    np.testing.assert_array_equal(result.modes.probabilities,
                                  sys.modes.probabilities)
    for k in range(sys.period):
        for i in range(sys.nmodes):
            want = op(ct.ss(*sys.mode(k, i), sys.dt_step))
            for got, X in zip(result.mode(k, i), (want.A, want.B, want.C,
                                                  want.D)):
                np.testing.assert_allclose(got, X, atol=1e-12)


# -- 1. a plain copy of the mean face is refused by the package --------------------
COPIES = {
    "ct.ss": lambda CL: ct.ss(CL),
    "StateSpace": lambda CL: ct.StateSpace(CL),
    "ct.ss with new names": lambda CL: ct.ss(CL, name="copy", inputs="u"),
    "similarity_transform": lambda CL: ct.similarity_transform(CL, [[2.0]]),
    "reachable_form": lambda CL: ct.reachable_form(CL)[0],
    "observable_form": lambda CL: ct.observable_form(CL)[0],
}

ANALYSES = {
    "ms_radius": lambda S: ncs.ms_radius(S),
    "is_mss": lambda S: ncs.is_mss(S),
    "norm 2": lambda S: ncs.norm(S, 2),
    "norm inf": lambda S: ncs.norm(S, "inf"),
    "simulate": lambda S: ncs.simulate(S, 5, trials=2, seed=0),
    "moments": lambda S: ncs.moments(S, 5),
    "step_response": lambda S: ncs.step_response(S, 5, trials=2, seed=0),
    "jump_feedback": lambda S: ncs.jump_feedback(S, 0.5),
}


@pytest.mark.parametrize("copy", list(COPIES))
def test_python_control_copy_is_a_plain_state_space_of_the_mean(copy):
    CL = lossy_loop()
    S = COPIES[copy](CL)
    assert type(S) is ct.StateSpace
    assert abs(np.linalg.eigvals(S.A)[0] - 0.4) < 1e-12    # the mean, 0.4


@pytest.mark.parametrize("analysis", list(ANALYSES))
@pytest.mark.parametrize("copy", list(COPIES))
def test_package_refuses_a_copy_of_the_mean_face(copy, analysis):
    CL = lossy_loop()
    with pytest.raises(ControlArgument, match="copied from the mean face"):
        ANALYSES[analysis](COPIES[copy](CL))


def test_the_copy_would_have_answered_for_the_mean_system():
    # what the refusal prevents: the mean system's radius, 0.4² = 0.16,
    # where the jump system's is E a² = 0.3·1.21 + 0.7·0.01 = 0.37
    CL = lossy_loop()
    assert ncs.ms_radius(CL) == pytest.approx(0.37, rel=1e-12)
    assert ncs.ms_radius(CL.mean()) == pytest.approx(0.16, rel=1e-12)


def test_the_mean_system_asked_for_knowingly_is_analysed():
    CL = mimo_loop()
    M = CL.mean()
    assert ncs.ms_radius(M) == pytest.approx(
        max(abs(np.linalg.eigvals(CL.A))) ** 2, rel=1e-12)
    assert ncs.norm(M, 2) == pytest.approx(float(ct.norm(M, 2)), rel=1e-9)


def test_copy_of_a_markov_face_is_refused():
    CL = markov_loop()
    with pytest.raises(ControlArgument, match="copied from the mean face"):
        ncs.ms_radius(ct.ss(CL))


def test_copy_is_refused_as_an_operand_of_the_algebra():
    CL, other = lossy_loop(), mimo_loop()
    with pytest.raises(ControlArgument, match="copied from the mean face"):
        CL * ct.ss(CL)
    with pytest.raises(ControlArgument, match="copied from the mean face"):
        ct.feedback(other, ct.ss(other))
    with pytest.raises(ControlArgument, match="copied from the mean face"):
        ncs.interconnect([CL, ct.ss(other)])


def test_copy_of_a_deterministic_jump_system_is_an_ordinary_system():
    J = one_mode(filter_G())
    S = ct.ss(J)
    assert ncs.ms_radius(S) == pytest.approx(0.09, rel=1e-12)
    assert ncs.ms_radius(S) == ncs.ms_radius(J)


def test_control_norm_is_still_refused_and_names_ncs_norm():
    with pytest.raises(ControlArgument, match="control_ncs.norm"):
        ct.norm(lossy_loop(), 2)


# -- 2. linearize keeps the jump system ------------------------------------------
@pytest.mark.parametrize("loop", [lossy_loop, mimo_loop, markov_loop,
                                  periodic_loop])
def test_linearize_returns_the_jump_system_itself(loop):
    CL = loop()
    lin = ct.linearize(CL, np.ones(CL.nstates), np.zeros(CL.ninputs))
    assert isinstance(lin, ncs.JumpStateSpace)
    assert lin.modes == CL.modes and lin.dt_step == CL.dt_step
    assert ncs.ms_radius(lin) == ncs.ms_radius(CL)
    # python-control's generic names, as its own linearize gives them
    assert lin.name != CL.name and lin.jump_inputs[0] == "u[0]"
    named = ct.linearize(CL, 0, copy_names=True)
    assert named.name == CL.name + "$linearized"
    assert named.jump_inputs == CL.jump_inputs
    assert ct.linearize(CL, 0, name="L", inputs=len(CL.jump_inputs)).name \
        == "L"


def test_python_controls_numerical_linearization_would_give_the_mean():
    CL = lossy_loop()
    pc = ct.NonlinearIOSystem.linearize(CL, [0.0], [0.0])
    assert type(pc) is ct.StateSpace and pc.A[0, 0] == pytest.approx(0.4)
    assert ct.linearize(CL, [0.0], [0.0]).modes.A[0, :, 0, 0].tolist() == [
        1.1, 0.1]


def test_linearize_checks_the_operating_point_size():
    with pytest.raises(ControlDimension, match="x0"):
        ct.linearize(mimo_loop(), np.zeros(3))


# -- 3. TransferFunction on the left: refused by name -----------------------------
TF_LEFT = {
    "G * CL": lambda G, CL: G * CL,
    "G + CL": lambda G, CL: G + CL,
    "G - CL": lambda G, CL: G - CL,
    "series(CL, G)": lambda G, CL: ct.series(CL, G),
    "parallel(G, CL)": lambda G, CL: ct.parallel(G, CL),
    "G / CL": lambda G, CL: G / CL,
}


@pytest.mark.parametrize("op", list(TF_LEFT))
def test_transfer_function_on_the_left_is_refused_naming_ct_ss(op):
    CL = lossy_loop()
    with pytest.raises(ControlArgument, match=r"control\.ss\(G\)"):
        TF_LEFT[op](filter_G(tf=True), CL)


@pytest.mark.parametrize("op", ["G * CL", "G + CL", "G - CL",
                                "series(CL, G)", "parallel(G, CL)"])
def test_the_named_alternative_keeps_the_modes(op):
    CL, G = lossy_loop(), filter_G(tf=True)
    result = TF_LEFT[op](ct.ss(G), CL)
    assert_modewise(result, CL, lambda S: TF_LEFT[op](ct.ss(G), S))


def test_tf_of_a_jump_system_is_refused_naming_the_mean():
    with pytest.raises(ControlArgument, match=r"control\.tf\(sys\.mean\(\)\)"):
        ct.tf(lossy_loop())
    assert ct.tf(lossy_loop().mean()).den[0][0][-1] == pytest.approx(-0.4)


def test_transfer_function_with_a_deterministic_jump_system_is_allowed():
    J, G = one_mode(filter_G()), filter_G(tf=True)
    assert isinstance(G * J, ct.TransferFunction)
    assert isinstance(ct.tf(J), ct.TransferFunction)


def test_python_controls_other_reads_of_the_face_still_give_the_mean():
    CL = lossy_loop()
    np.testing.assert_allclose(ct.poles(CL), [0.4])     # the mean's
    np.testing.assert_equal(ct.stability_margins(CL),
                            ct.stability_margins(CL.mean()))


# -- 4. immutable ---------------------------------------------------------------
@pytest.mark.parametrize("attr", ["A", "B", "C", "D", "dt", "modes"])
def test_assigning_a_matrix_or_the_modes_is_refused(attr):
    CL = mimo_loop()
    before = str(CL)
    with pytest.raises(AttributeError, match="cannot be changed"):
        setattr(CL, attr, getattr(CL, attr))
    assert str(CL) == before


@pytest.mark.parametrize("X", ["A", "B", "C", "D"])
def test_writing_into_the_face_or_the_modes_is_refused(X):
    CL = mimo_loop()
    with pytest.raises(ValueError, match="read-only"):
        getattr(CL, X)[0, 0] = 5.0
    with pytest.raises(ValueError, match="read-only"):
        getattr(CL.modes, X)[0, 0, 0, 0] = 5.0


def test_face_and_modes_stay_consistent():
    CL = mimo_loop()
    for attempt in (lambda: setattr(CL, "A", np.eye(2)),
                    lambda: CL.A.__setitem__((0, 0), 5.0)):
        with pytest.raises((AttributeError, ValueError)):
            attempt()
    np.testing.assert_allclose(CL.A, CL.modes.mean()[0][0], atol=0)


def test_renaming_is_still_allowed():
    CL = markov_loop()
    CL.update_names(name="renamed", states=["a", "b", "c"])
    assert CL.name == "renamed" and CL.jump_states == ["a", "b", "c"]
    assert CL.state_labels[:4] == ["a#0", "b#0", "c#0", "a#1"]
    with pytest.raises(ControlArgument, match="copied from the mean face"):
        ncs.ms_radius(ct.ss(CL))       # renamed states are marked too


# -- 5. the face's order is not the loop's state dimension --------------------------
def test_initial_state_of_the_face_order_names_jump_states():
    CL = markov_loop()
    assert CL.nstates == 12 and len(CL.jump_states) == 3
    for call in (lambda x0: ncs.simulate(CL, 5, initial_state=x0, trials=2,
                                         seed=0),
                 lambda x0: ncs.initial_response(CL, 5, x0, trials=2,
                                                 seed=0)):
        with pytest.raises(ControlDimension,
                           match=r"expected 3 entries.*jump_states.*got 12"
                                 r".*nstates = 12"):
            call(np.ones(CL.nstates))
        assert call(np.ones(3)).time.size == 5


def test_a_wrong_initial_state_size_names_jump_states():
    with pytest.raises(ControlDimension, match=r"expected 2 entries.*"
                                               r"jump_states.*got 5"):
        ncs.simulate(mimo_loop(), 5, initial_state=np.ones(5), trials=2)


# -- 6. step_response of a periodic face warns -----------------------------------
def test_control_step_response_of_a_periodic_loop_warns_naming_ncs():
    CL = periodic_loop()
    with pytest.warns(UserWarning, match=r"control_ncs\.step_response") as rec:
        ct.step_response(CL)
    assert len(rec) == 1 and rec[0].filename == __file__
    with pytest.warns(UserWarning, match="lifted face"):
        ct.step_info(CL)


def test_control_step_response_of_a_one_phase_loop_does_not_warn():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        r = ct.step_response(lossy_loop(), np.arange(10) * DT)
    # exact E z of a unit step, x⁺ = 0.4 x + w: Σ_{j<t} 0.4^j
    want = np.r_[0.0, np.cumsum(0.4 ** np.arange(9))]
    np.testing.assert_allclose(r.outputs, want, atol=1e-12)


# -- 7. interconnect without external inputs ----------------------------------------
def test_interconnect_with_no_input_is_the_autonomous_loop():
    CL = ncs.jss([[[0.5]], [[0.9]]], [[1.0]], [[1.0]], [[0.0]], [0.3, 0.7],
                 DT, name="CL", inputs="w", outputs="z")
    W = ct.ss([[0.8]], [[1.0]], [[0.2]], [[0.0]], DT, name="W",
              inputs="d", outputs="w")
    driven = ncs.interconnect([W, CL], inplist="d", outlist="z")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")        # python-control: unused input
        free = ncs.interconnect([W, CL], inplist=[], outlist="z")
        silent = ncs.interconnect([W, CL], inplist=[], outlist=[])
    assert free.jump_inputs == ["unused"] and not free.modes.B.any()
    assert not free.modes.D.any() and free.jump_outputs == ["y[0]"]
    assert silent.jump_outputs == ["unused"] and not silent.modes.C.any()
    np.testing.assert_array_equal(free.modes.A, driven.modes.A)
    np.testing.assert_array_equal(free.modes.C, driven.modes.C)
    assert ncs.ms_radius(free) == ncs.ms_radius(driven) == pytest.approx(
        0.3 * 0.25 + 0.7 * 0.81)
    # the autonomous response is the driven loop's from the same state
    x0 = [1.0, -0.5]
    np.testing.assert_allclose(ncs.moments(free, 6, initial_state=x0)
                               .outputs_mean,
                               ncs.moments(driven, 6, initial_state=x0)
                               .outputs_mean, atol=1e-14)


# -- 8. printing as python-control's systems do ---------------------------------------
def _pc_and_jump(dt=DT, **names):
    rng = np.random.default_rng(7)
    S = ct.ss(rng.standard_normal((3, 3)).round(3),
              rng.standard_normal((3, 2)).round(3),
              rng.standard_normal((2, 3)).round(3),
              rng.standard_normal((2, 2)).round(3), dt, **names)
    return S, one_mode(S)


@pytest.mark.parametrize("dt", [DT, True])
@pytest.mark.parametrize("names", [{}, dict(name="plant", inputs=["a", "b"])])
def test_info_repr_is_python_controls(dt, names):
    S, J = _pc_and_jump(dt, **names)
    S.repr_format = J.repr_format = "info"
    assert repr(J) == repr(S).replace("<StateSpace", "<JumpStateSpace")


@pytest.mark.parametrize("repr_type", ["partitioned", "separate"])
def test_html_repr_is_python_controls_under_the_jump_systems_name(repr_type):
    S, J = _pc_and_jump(name="plant")
    with ct.config.defaults({"statesp.latex_repr_type": repr_type}):
        assert J._repr_html_() == S._repr_html_().replace(
            "&lt;StateSpace", "&lt;JumpStateSpace")


def test_html_of_a_random_system_names_its_modes():
    html = mimo_loop()._repr_html_()
    assert html.startswith("&lt;JumpStateSpace CL2: ['w1', 'w2'] -&gt; "
                           "['z1', 'z2'], dt=0.1, 3 i.i.d. modes&gt;")


def test_str_is_python_controls_layout_with_the_mode_law():
    S, J = _pc_and_jump(name="plant")
    ours, theirs = str(J).splitlines(), str(S).splitlines()
    assert ours[0] == "<JumpStateSpace>: plant" and theirs[0] == \
        "<StateSpace>: plant"
    assert ours[1:5] == theirs[1:5]                      # signals, dt
    assert "\n".join(ours[-12:]) == "\n".join(theirs[-12:])   # A, B, C, D
    assert "1 i.i.d. mode per step" in str(J)
    text = str(markov_loop())
    assert "4 Markov modes" in text and "Transition" in text


def test_eval_repr_matches_python_controls_label_format():
    S, J = _pc_and_jump()
    text = repr(J)
    assert text.startswith("JumpStateSpace(\narray(")
    assert text.endswith("dt=0.1,\nstates=3, outputs=2, inputs=2)")
    assert repr(S).endswith("dt=0.1,\nstates=3, outputs=2, inputs=2)")


def assert_rebuilt(back, J):
    """``back`` is ``J`` up to numpy's print precision of the matrices (as
    python-control's repr); the mode law, step and names exactly."""
    for X in "ABCD":
        np.testing.assert_allclose(getattr(back.modes, X),
                                   getattr(J.modes, X), rtol=1e-7, atol=1e-8)
    assert back.mode_law()[0].tolist() == J.mode_law()[0].tolist()
    assert (back.modes.transition is None) == (J.modes.transition is None)
    if J.modes.transition is not None:
        np.testing.assert_array_equal(back.modes.transition,
                                      J.modes.transition)
    assert back.dt_step == J.dt_step
    if not re.match(r"sys\[\d+\]$", J.name):   # a generic name is not shown
        assert back.name == J.name
    assert (back.jump_inputs, back.jump_outputs, back.jump_states) == (
        J.jump_inputs, J.jump_outputs, J.jump_states)
    assert (back.nominal_mode is None) == (J.nominal_mode is None)


@pytest.mark.parametrize("loop", [lossy_loop, mimo_loop, small_markov_loop,
                                  periodic_loop])
def test_eval_repr_rebuilds_an_equal_system(loop):
    CL = loop()
    back = eval(repr(CL), {"JumpStateSpace": ncs.JumpStateSpace,
                           "array": np.array})
    assert back.equals(CL)        # short decimals print exactly
    assert_rebuilt(back, CL)


@settings(max_examples=25, deadline=None)
@given(n=st.integers(1, 3), m=st.integers(1, 2), p=st.integers(1, 2),
       M=st.integers(1, 3), N=st.integers(1, 2), markov=st.booleans(),
       seed=st.integers(0, 2 ** 16), named=st.booleans())
def test_eval_repr_round_trip_over_random_systems(n, m, p, M, N, markov,
                                                  seed, named):
    rng = np.random.default_rng(seed)
    mats = [rng.standard_normal((N, M) + shape) for shape in
            ((n, n), (n, m), (p, n), (p, m))]
    probs = rng.dirichlet(np.ones(M), size=N)
    kw = dict(name="loop", inputs=[f"in{i}" for i in range(m)]) if named \
        else {}
    if markov:
        T = rng.dirichlet(np.ones(M), size=(N, M))
        J = ncs.jss(*mats, dt=DT, transition=T, **kw)
    else:
        J = ncs.jss(*mats, probs, DT, nominal=[0] * N, **kw)
    text = repr(J)
    if text.startswith("<"):            # too large for a screen: 'info'
        assert n * M * N * max(m, p) > 2    # the smallest always fit
        assert len(text.splitlines()) == 1 and "JumpStateSpace" in text
        return
    back = eval(text, {"JumpStateSpace": ncs.JumpStateSpace,
                       "array": np.array})
    assert_rebuilt(back, J)


def test_repr_of_a_large_system_is_the_info_line():
    rng = np.random.default_rng(1)
    J = ncs.jss(rng.standard_normal((4, 6, 6)), np.ones((6, 1)),
                np.ones((1, 6)), [[0.0]], [0.25] * 4, DT, name="big")
    assert repr(J) == ("<JumpStateSpace big: ['w[0]'] -> ['z[0]'], dt=0.1, "
                       "4 i.i.d. modes>")


def test_signal_counts_give_python_controls_generic_names():
    J = ncs.jss([[[0.5]]], [[1.0, 2.0]], [[1.0]], [[0.0, 0.0]], [1.0],
                inputs=2, outputs=1, states=1)
    assert J.jump_inputs == ["u[0]", "u[1]"] and J.jump_outputs == ["y[0]"]
    with pytest.raises(ControlDimension, match="inputs: expected 2"):
        ncs.jss([[[0.5]]], [[1.0, 2.0]], [[1.0]], [[0.0, 0.0]], [1.0],
                inputs=3)


# -- 9. deterministic jump systems combine as the LTI systems they are --------------
def _det_pair():
    rng = np.random.default_rng(3)
    G1 = ct.ss(rng.standard_normal((2, 2)) * 0.4, rng.standard_normal((2, 1)),
               rng.standard_normal((1, 2)), [[0.3]], DT)
    G2 = ct.ss([[0.5]], [[1.0]], [[0.7]], [[0.1]], DT)
    return G1, G2


ALGEBRA = {
    "+": lambda a, b: a + b,
    "-": lambda a, b: a - b,
    "*": lambda a, b: a * b,
    "feedback": lambda a, b: ct.feedback(a, b),
    "feedback +": lambda a, b: ct.feedback(a, b, sign=1),
    "append": lambda a, b: ct.append(a, b),
    "series": lambda a, b: ct.series(a, b),
    "parallel": lambda a, b: ct.parallel(a, b),
}


@pytest.mark.parametrize("op", list(ALGEBRA))
def test_two_deterministic_jump_systems_combine_as_python_control(op):
    G1, G2 = _det_pair()
    got = ALGEBRA[op](one_mode(G1), one_mode(G2))
    want = ALGEBRA[op](G1, G2)
    assert isinstance(got, ncs.JumpStateSpace) and got.nmodes == 1
    for X in "ABCD":
        np.testing.assert_allclose(getattr(got, X), getattr(want, X),
                                   atol=1e-12)


@pytest.mark.parametrize("op", list(ALGEBRA))
def test_a_deterministic_jump_system_with_a_random_one_is_mode_by_mode(op):
    CL = lossy_loop()
    G = ct.ss([[0.5]], [[1.0]], [[0.7]], [[0.1]], DT)
    J = one_mode(G)
    assert_modewise(ALGEBRA[op](J, CL), CL, lambda S: ALGEBRA[op](G, S))
    assert_modewise(ALGEBRA[op](CL, J), CL, lambda S: ALGEBRA[op](S, G))


def test_deterministic_jump_system_in_interconnect_is_an_lti_block():
    CL = ncs.jss([[[0.5]], [[0.9]]], [[1.0]], [[1.0]], [[0.0]], [0.3, 0.7],
                 DT, name="CL", inputs="w", outputs="z")
    W = ct.ss([[0.8]], [[1.0]], [[0.2]], [[0.0]], DT, name="W", inputs="d",
              outputs="w")
    a = ncs.interconnect([W, CL], inplist="d", outlist="z")
    b = ncs.interconnect([one_mode(W), CL], inplist="d", outlist="z")
    assert a.modes == b.modes


def test_two_random_jump_systems_are_still_refused():
    with pytest.raises(ControlArgument, match="independent"):
        lossy_loop() * lossy_loop()
    with pytest.raises(ControlArgument, match="independent"):
        ct.feedback(lossy_loop(), lossy_loop())


@pytest.mark.parametrize("dt", [0, 0.2])
def test_another_timebase_is_refused_in_python_controls_words(dt):
    CL, G = lossy_loop(), ct.ss([[0.5]], [[1.0]], [[1.0]], [[0.0]], dt)
    for op in (lambda: CL * G, lambda: ct.feedback(CL, G),
               lambda: ct.parallel(G, CL), lambda: ncs.jump_feedback(CL, G)):
        with pytest.raises(ValueError, match="incompatible timebases"):
            op()
