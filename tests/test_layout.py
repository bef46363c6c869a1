"""The package's shape: one way down, each layer in its place.

Read from the source (every import, also those inside functions), so a
circle or a stray import shows here before it shows as a slow import or a
hidden dependency: no import circle among the package's modules, cvxpy only
in the LMI layer, matplotlib only where figures are drawn, and each module
small enough to own one idea and say which in its docstring.
"""

import ast
import pathlib

import pytest

PACKAGE = pathlib.Path(__file__).resolve().parent.parent / "control_ncs"

#: Where figures may be drawn: the figures module and the demo.
MATPLOTLIB = {"control_ncs.plots", "control_ncs.demo"}
#: A module much longer than this does more than one thing.
MAX_LINES = 1000


def _modules() -> dict[str, pathlib.Path]:
    out = {}
    for path in sorted(PACKAGE.rglob("*.py")):
        parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
        name = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
        out[name] = path
    return out


MODULES = _modules()


def _imports(name: str) -> tuple[set, set]:
    """(package modules, outside top-level packages) imported by ``name``."""
    path = MODULES[name]
    package = name if path.name == "__init__.py" else name.rsplit(".", 1)[0]
    inside, outside = set(), set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.ImportFrom) and node.level:
            base = package.split(".")[:len(package.split(".")) - node.level + 1]
            target = ".".join(base + ([node.module] if node.module else []))
            for alias in node.names:
                for candidate in (f"{target}.{alias.name}", target):
                    if candidate in MODULES and candidate != name:
                        inside.add(candidate)
                        break
        elif isinstance(node, ast.ImportFrom):
            outside.add(node.module.split(".")[0])
        elif isinstance(node, ast.Import):
            outside.update(a.name.split(".")[0] for a in node.names)
    return inside, outside


GRAPH = {name: _imports(name)[0] - {"control_ncs"} for name in MODULES
         if name != "control_ncs"}


def test_no_import_circle_among_the_packages_modules():
    state: dict = {}
    circles = []

    def visit(node, stack):
        state[node] = "open"
        stack.append(node)
        for nxt in sorted(GRAPH.get(node, ())):
            if state.get(nxt) == "open":
                circles.append(stack[stack.index(nxt):] + [nxt])
            elif nxt not in state:
                visit(nxt, stack)
        stack.pop()
        state[node] = "done"

    for node in sorted(GRAPH):
        if node not in state:
            visit(node, [])
    assert not circles, circles


@pytest.mark.parametrize("name", sorted(MODULES))
def test_cvxpy_is_imported_only_by_the_lmi_layer(name):
    if not name.startswith("control_ncs.lmi"):
        assert "cvxpy" not in _imports(name)[1]


@pytest.mark.parametrize("name", sorted(MODULES))
def test_matplotlib_is_imported_only_where_figures_are_drawn(name):
    if name not in MATPLOTLIB:
        assert "matplotlib" not in _imports(name)[1]


@pytest.mark.parametrize("name", sorted(MODULES))
def test_module_says_what_it_owns_in_a_docstring(name):
    tree = ast.parse(MODULES[name].read_text(encoding="utf-8"))
    assert ast.get_docstring(tree), f"{name} has no module docstring"


@pytest.mark.parametrize("name", sorted(MODULES))
def test_module_is_small_enough_to_own_one_idea(name):
    lines = MODULES[name].read_text(encoding="utf-8").count("\n")
    assert lines <= MAX_LINES, (name, lines)
