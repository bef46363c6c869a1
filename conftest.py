"""Shared pytest set-up: headless plotting and what doctests see.

A docstring example runs as a user would type it: with ``np``, ``ct`` and
``ncs`` imported, and nothing else.
"""

import matplotlib

matplotlib.use("Agg")

import numpy as np  # noqa: E402
import pytest  # noqa: E402
import control as ct  # noqa: E402

import control_ncs  # noqa: E402


@pytest.fixture(autouse=True)
def _doctest_names(doctest_namespace):
    doctest_namespace["np"] = np
    doctest_namespace["ct"] = ct
    doctest_namespace["ncs"] = control_ncs


def pytest_runtest_setup(item):
    """A docstring example sees only what a user has typed (numpy as np,
    control as ct, control_ncs as ncs), not its module's own globals."""
    from _pytest.doctest import DoctestItem
    if isinstance(item, DoctestItem):
        item.dtest.globs.clear()
