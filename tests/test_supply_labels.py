"""A supply the loop cannot meet is said to be infeasible, with its proof
(theory: performance, quadratic supplies)."""

import numpy as np

import control_ncs as ncs
from control_ncs._farkas import supply_dual_check


def sector_loop():
    """``x⁺ = a x + w``, ``z = x + w``, ``a = 0.5`` or ``0.9``."""
    return ncs.jss([[[0.5]], [[0.9]]], [[1.0]], [[1.0]], [[1.0]], [0.5, 0.5])


def test_a_proven_infeasible_supply_is_labelled_infeasible():
    sys = sector_loop()
    res = ncs.dissipativity(sys, -1.0, 1.25, -1.0)
    assert res.status == "infeasible" and not res.success
    assert res.proof["value"] >= 0 and res.proof["Y_min"] > 0
    assert supply_dual_check(sys, res.proof["Z"], -1.0, 1.25, -1.0)[0]
    assert "proven" in res.message


def test_the_sector_supply_indeed_fails_on_a_constant_input():
    # exact moments of x under w = 1 from rest (independent of the LMI):
    # m⁺ = E a m + 1, q⁺ = E a² q + 2 E a m + 1; s = -z² + 2.5 z w - w²
    Ea, Ea2 = 0.7, 0.53
    m = q = 0.0
    total = 0.0
    for _ in range(200):
        Ez, Ez2 = m + 1, q + 2 * m + 1
        total += -Ez2 + 2.5 * Ez - 1
        m, q = Ea * m + 1, Ea2 * q + 2 * Ea * m + 1
    assert total < 0                  # E Σ s < 0: no storage can exist


def test_multipliers_that_prove_nothing_are_not_called_a_proof():
    sys = sector_loop()
    # passivity with dissipation 0.2 holds, so no multipliers refute it
    ok, value, _ = supply_dual_check(sys, np.eye(2)[None, None], 0.0, 1.0,
                                     -0.4)
    assert not ok and value < 0


def test_a_certified_supply_is_still_certified():
    res = ncs.dissipativity(sector_loop(), 0.0, 1.0, -0.4)
    assert res.status == "certified" and res.proof is None
