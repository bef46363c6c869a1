"""Every public name documents itself in python-control's manner.

numpydoc's own validator (``numpydoc.validate``) is run on every name in
``control_ncs.__all__``; the checks below are the ones python-control's users
rely on: a summary line, every parameter documented (and no stale ones), a
Returns section for functions that return something, and an Example.
"""

from __future__ import annotations

import importlib
import inspect
import re

import pytest

import control_ncs

numpydoc_validate = pytest.importorskip("numpydoc.validate")

#: numpydoc error codes enforced (numpydoc.validate.ERROR_MSGS):
#: GL08 no docstring; SS01 no summary; PR01 a parameter not documented;
#: PR02 a documented parameter that does not exist; RT01 no Returns section;
#: EX01 no Examples section.
ENFORCED = ("GL08", "SS01", "PR01", "PR02", "RT01", "EX01")


def _public_names() -> list[str]:
    # the top-level names and those public in their submodule only
    return sorted([*control_ncs.__all__, *control_ncs._IN_SUBMODULE])


def _named(name: str):
    """A public name from where it lives (the top level or its module)."""
    return getattr(importlib.import_module(
        control_ncs._IN_SUBMODULE.get(name, "control_ncs")), name)


def _is_class(name: str) -> bool:
    return inspect.isclass(_named(name))


def _attribute_names(cls) -> set[str]:
    from numpydoc.docscrape import ClassDoc
    doc = ClassDoc(cls)
    names = set()
    for item in doc["Attributes"]:
        names.update(part.strip() for part in item.name.split(","))
    return names


def _is_dataclass(cls) -> bool:
    return "__dataclass_fields__" in vars(cls)


def _names_in(message: str) -> set[str]:
    return set(re.findall(r"'([^']+)'", message))


@pytest.mark.parametrize("name", _public_names())
def test_public_name_has_a_complete_numpydoc_docstring(name):
    obj = _named(name)
    module = obj.__module__
    report = numpydoc_validate.validate(f"{module}.{obj.__qualname__}")
    enforced = set(ENFORCED)
    if _is_class(name):
        # a class documents its constructor's parameters; it returns nothing
        enforced.discard("RT01")
        if issubclass(obj, BaseException):
            enforced -= {"PR01", "PR02", "EX01"}
    if _is_class(name):
        # result classes document their fields as Attributes (numpydoc's
        # class convention); a field listed there counts as documented
        attributes = _attribute_names(obj)
        if "__init__" not in vars(obj) and not _is_dataclass(obj):
            # the constructor is python-control's own, documented there
            attributes |= set(inspect.signature(obj).parameters)
        report["errors"] = [
            (code, msg) for code, msg in report["errors"]
            if not (code == "PR01" and _names_in(msg) <= attributes)]
    failing = sorted(
        f"{code}: {msg}" for code, msg in report["errors"] if code in enforced)
    assert not failing, f"{module}.{obj.__qualname__}:\n" + "\n".join(failing)
