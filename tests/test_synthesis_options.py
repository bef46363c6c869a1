"""The designs take the solver's knobs in one ``options=`` mapping.

``passivesyn``, ``h2syn`` and ``hinfsyn`` group ``solver``, ``margin``,
``time_limit``, ``form``, ``structure`` and the solver's own settings the
way ``scipy.optimize.minimize(..., options=...)`` does. The old keywords
still work, with one DeprecationWarning that points at the caller's line,
and give the same design.
"""

import warnings

import numpy as np
import pytest

import control_ncs as ncs


def passive_plant():
    """``x⁺ = 2x + w + θu``, ``z = x + w``, 10 % of the commands lost."""
    return ncs.nss([[2.0]], [[1.0, 1.0]], [[1.0], [1.0]],
                   [[1.0, 0.0], [0.0, 0.0]], nmeas=1, ncon=1,
                   actuator_loss=0.1)


def lq_plant(loss=0.5):
    """``x⁺ = 1.2x + w + θu``, ``z = [x; θu]``."""
    return ncs.nss([[1.2]], [[1.0, 1.0]], [[1.0], [0.0], [1.0]],
                   [[0.0, 0.0], [0.0, 1.0], [0.0, 0.0]], True, nmeas=1,
                   ncon=1, actuator_loss=loss)


#: each design, a plant for it, and knobs that change what is solved
CASES = {
    "passivesyn": (ncs.passivesyn, passive_plant, dict(decay=0.9),
                   dict(solver="CLARABEL", margin=1e-6, form="paper"),
                   dict(tol_gap_abs=1e-9)),
    "h2syn": (ncs.h2syn, lq_plant, {}, dict(solver="CLARABEL", margin=1e-6),
              dict(tol_gap_abs=1e-9)),
    "hinfsyn": (ncs.hinfsyn, lq_plant, {}, dict(margin=1e-6,
                                                time_limit=30.0),
                dict(tol_feas=1e-9)),
}


def ours(record):
    """The DeprecationWarnings of a record that name the options."""
    return [w for w in record if issubclass(w.category, DeprecationWarning)
            and "options" in str(w.message)]


@pytest.mark.parametrize("name", sorted(CASES))
def test_options_give_the_design_of_the_old_keywords(name):
    design, plant, kw, knobs, settings = CASES[name]
    with pytest.warns(DeprecationWarning):
        K_old, _, value_old = design(plant(), **kw, **knobs, **settings)
    K_new, _, value_new = design(plant(), **kw, options=dict(
        knobs, solver_options=settings))
    np.testing.assert_allclose(K_new.gains, K_old.gains, rtol=1e-8,
                               atol=1e-12)
    assert value_new == pytest.approx(value_old, rel=1e-8)
    assert K_new.result.options == K_old.result.options


@pytest.mark.parametrize("name", sorted(CASES))
def test_the_result_keeps_the_options_filled_with_their_defaults(name):
    design, plant, kw, knobs, settings = CASES[name]
    K, _, _ = design(plant(), **kw, options=dict(
        knobs, solver_options=settings))
    used = K.result.options
    assert {k: used[k] for k in knobs} == knobs
    assert used["solver_options"] == settings
    default, _, _ = design(plant(), **kw)
    assert set(default.result.options) == set(used)
    assert default.result.options["solver_options"] == {}
    assert default.result.options["time_limit"] == (
        120.0 if name == "passivesyn" else 60.0)


def test_an_option_changes_the_route_as_the_keyword_did():
    K, _, _ = ncs.passivesyn(passive_plant(), decay=0.9,
                             options={"solver": "riccati"})
    assert K.result.report.solver == "RICCATI"
    with pytest.warns(DeprecationWarning):
        K, _, _ = ncs.passivesyn(passive_plant(), decay=0.9,
                                 solver="riccati")
    assert K.result.report.solver == "RICCATI"


@pytest.mark.parametrize("design, key", [
    (ncs.passivesyn, "bogus"), (ncs.h2syn, "form"),
    (ncs.hinfsyn, "structure")])
def test_unknown_option_raises_type_error_listing_the_accepted_keys(design,
                                                                   key):
    P = passive_plant() if design is ncs.passivesyn else lq_plant()
    with pytest.raises(TypeError, match=rf"\['{key}'\].*accepted keys: "
                                        r"solver, margin, time_limit"):
        design(P, options={key: 1})


@pytest.mark.parametrize("design", [ncs.passivesyn, ncs.h2syn,
                                    ncs.hinfsyn])
def test_an_unknown_keyword_is_a_type_error_without_a_deprecation(design):
    """A keyword that is neither the design's nor an option of its solver
    is refused at once as an unknown keyword; no deprecation warning of
    the solver-option spelling comes first."""
    P = passive_plant() if design is ncs.passivesyn else lq_plant()
    with warnings.catch_warnings():
        warnings.simplefilter("error", DeprecationWarning)
        with pytest.raises(TypeError, match=rf"{design.__name__}\(\) got "
                                            r"unexpected keyword.*'bogus_kw'"):
            design(P, bogus_kw=1)


def test_options_must_be_a_mapping_with_a_mapping_of_solver_options():
    with pytest.raises(TypeError, match="options must be a mapping"):
        ncs.h2syn(lq_plant(), options=[("margin", 1e-6)])
    with pytest.raises(TypeError, match=r"options\['solver_options'\]"):
        ncs.h2syn(lq_plant(), options={"solver_options": "tol_gap_abs"})


@pytest.mark.parametrize("keywords, options, named", [
    (dict(margin=1e-6), dict(margin=1e-6), "margin"),
    (dict(time_limit=5.0), dict(time_limit=10.0), "time_limit"),
    (dict(tol_gap_abs=1e-9), dict(solver_options={"max_iter": 50}),
     "solver_options")])
def test_a_knob_given_both_ways_raises_type_error(keywords, options, named):
    with warnings.catch_warnings():
        warnings.simplefilter("error", DeprecationWarning)
        with pytest.raises(TypeError, match=f"got {named} both"):
            ncs.passivesyn(passive_plant(), **keywords, options=options)


def test_solver_options_is_no_keyword():
    with pytest.raises(TypeError, match="options=.*'solver_options'"):
        ncs.hinfsyn(lq_plant(), solver_options={"max_iter": 50})


def test_old_keywords_warn_once_saying_what_to_write():
    with warnings.catch_warnings(record=True) as record:
        warnings.simplefilter("always")
        ncs.passivesyn(passive_plant(), decay=0.9, margin=1e-6,
                       tol_gap_abs=1e-9)
    [w] = ours(record)
    text = str(w.message)
    assert text.startswith("passivesyn(): passing the solver options "
                           "margin=, tol_gap_abs= as keywords is deprecated")
    assert text.endswith("options={'margin': 1e-06, 'solver_options': "
                         "{'tol_gap_abs': 1e-09}}")


@pytest.mark.parametrize("design, kw", [
    (ncs.passivesyn, dict(decay=0.9, margin=1e-6)),
    (ncs.h2syn, dict(time_limit=30.0)),
    (ncs.hinfsyn, dict(solver="CLARABEL"))])
def test_the_warning_points_at_the_callers_line(design, kw):
    P = passive_plant() if design is ncs.passivesyn else lq_plant()
    with pytest.warns(DeprecationWarning, match="pass them in options") as rec:
        design(P, **kw)
    [w] = ours(rec)
    assert w.filename == __file__


def test_a_bad_value_raises_as_the_keyword_did():
    for spelled in (dict(options={"margin": -1.0}), dict(margin=-1.0)):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", DeprecationWarning)
            with pytest.raises(ValueError, match="^margin: "):
                ncs.passivesyn(passive_plant(), **spelled)
    with pytest.raises(ValueError, match="^time_limit: "):
        ncs.h2syn(lq_plant(), actuator="hold", options={"time_limit": 0.0})


def test_critical_loss_moves_old_keywords_into_options_with_one_warning():
    P = ncs.nss([[2.0]], [[1.0, 1.0]], [[1.0], [1.0]],
                [[0.0, 0.0], [0.0, 0.0]], True, nmeas=1, ncon=1)
    new = ncs.critical_loss(P, h2=2.0, tol=1e-3, options={"margin": 1e-6})
    with warnings.catch_warnings(record=True) as record:
        warnings.simplefilter("always")
        old = ncs.critical_loss(P, h2=2.0, tol=1e-3, margin=1e-6)
    [w] = ours(record)
    assert w.filename == __file__ and "critical_loss()" in str(w.message)
    # x⁺ = 2x + w + θu with the deadbeat gain: ‖G‖₂ = 1/√(1 - 4α) = 2
    assert old == new == pytest.approx(3 / 16, abs=1e-3)


def test_design_map_passes_its_options_to_every_cell():
    # one Clarabel iteration: the exact H2 program ends without a gain
    one_step = {"solver_options": {"max_iter": 1}}
    with pytest.raises(ncs.SynthesisError) as info:
        ncs.h2syn(lq_plant(0.3), options=one_step)
    dm = ncs.design_map(lq_plant(0.0), [0.0], [0.0, 0.3], objective="h2",
                        progress=False, options=one_step)
    assert dm.reason.tolist() == [[info.value.reason] * 2]
    assert not dm.feasible.any()
    # no time at all: every passive cell stops before its first solve
    dm = ncs.design_map(passive_plant(), [0.0], [0.0, 0.1], decay=0.9,
                        progress=False, options={"time_limit": 1e-9})
    assert dm.reason.tolist() == [["time_limit"] * 2]
    res = ncs.schedule_search(passive_plant(), 1, decay=0.9, progress=False,
                              options={"time_limit": 1e-9})
    assert set(res.reason[~res.pruned]) == {"time_limit"}


@pytest.mark.parametrize("objective, key", [("eta", "bogus"), ("h2", "form")])
def test_sweeps_refuse_an_unknown_option_before_any_cell(objective, key,
                                                         monkeypatch):
    import control_ncs._sweep_cells as cells

    def never(*args, **kwargs):
        raise AssertionError("a cell ran")
    monkeypatch.setattr(cells, "in_own_thread", never)
    P = passive_plant() if objective == "eta" else lq_plant()
    with pytest.raises(TypeError, match=f"'{key}'"):
        ncs.design_map(P, [0.0], [0.1], objective=objective,
                       progress=False, options={key: 1})
    with pytest.raises(TypeError, match=f"'{key}'"):
        ncs.schedule_search(P, 1, objective=objective, progress=False,
                            options={key: 1})
