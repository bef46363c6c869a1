"""Shared pytest set-up: headless plotting and the doctest namespace."""

import matplotlib

matplotlib.use("Agg")

import numpy as np  # noqa: E402
import pytest  # noqa: E402
import control as ct  # noqa: E402

import control_ncs  # noqa: E402


@pytest.fixture(autouse=True)
def _doctest_names(doctest_namespace):
    doctest_namespace.update({name: getattr(control_ncs, name)
                              for name in control_ncs.__all__})
    doctest_namespace["np"] = np
    doctest_namespace["ct"] = ct
    doctest_namespace["ncs"] = control_ncs
