"""Docstring summaries fit python-control's rule: one line, 64 characters.

python-control's ``docstrings_test.py`` asks the same of its own functions;
a summary is what ``help()``, autosummary tables and IDE tooltips show.
"""

import importlib
import inspect

import pytest

import control_ncs as ncs

LIMIT = 64


def _documented():
    out = {}
    for name in [*ncs.__all__, *ncs._IN_SUBMODULE]:
        obj = getattr(importlib.import_module(
            ncs._IN_SUBMODULE.get(name, "control_ncs")), name)
        out[name] = obj
        if inspect.isclass(obj):
            for member, value in vars(obj).items():
                func = value.fget if isinstance(value, property) else value
                if member.startswith("_") or not callable(func) or \
                        not getattr(func, "__qualname__", "").startswith(
                            obj.__name__ + "."):
                    continue
                out[f"{name}.{member}"] = func
    return out


DOCUMENTED = _documented()


@pytest.mark.parametrize("name", sorted(DOCUMENTED))
def test_summary_is_one_line_of_at_most_64_characters(name):
    doc = inspect.getdoc(DOCUMENTED[name])
    assert doc, f"{name} has no docstring"
    summary, _, rest = doc.partition("\n")
    assert len(summary) <= LIMIT, (len(summary), summary)
    assert rest == "" or rest.startswith("\n"), \
        f"{name}: the summary runs onto a second line"
