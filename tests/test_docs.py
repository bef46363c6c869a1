"""The documentation site (docs/) is complete and its links resolve.

The Sphinx build itself runs in ``.ci/run`` with warnings as errors; these
checks are the fast ones that need no build: every public name has an API
entry, every theory anchor that code, notebooks or README point to exists,
and every test the docs name as evidence exists.
"""

from __future__ import annotations

import ast
import json
import re
from pathlib import Path

import pytest

import control_ncs

ROOT = Path(__file__).resolve().parent.parent
DOCS = ROOT / "docs"
THEORY = DOCS / "theory.md"

# a cross-reference (docstrings, .rst, MyST) to a label of the docs
REF = re.compile(r"(?::ref:|\{ref\})`(?:[^`<]*<)?([a-z0-9-]+)>?`")
# a Markdown link to a section of the theory page
THEORY_LINK = re.compile(r"\]\((?:\.\./)?(?:docs/)?theory\.md#([a-z0-9-]+)\)")
# a Markdown link from the README to a page (and section) of the guide
GUIDE_LINK = re.compile(r"\]\(docs/guide/(\w+\.md)(?:#([a-z0-9-]+))?\)")


def _pages() -> list[Path]:
    """The site's hand-written pages: top level and the user guide."""
    return (sorted(DOCS.glob("*.md")) + sorted(DOCS.glob("*.rst"))
            + sorted((DOCS / "guide").glob("*.md")))


def _labels() -> set[str]:
    labels = set()
    for page in _pages():
        text = page.read_text(encoding="utf-8")
        labels |= set(re.findall(r"^\(([a-z0-9-]+)\)=\s*$", text, re.M))
        labels |= set(re.findall(r"^\.\. _([a-z0-9-]+):\s*$", text, re.M))
    return labels


def _slug(title: str) -> str:
    """MyST's heading anchors (myst_heading_anchors), GitHub's slugs."""
    return re.sub(r"[^\w\- ]", "", title.strip().lower()).replace(" ", "-")


def _heading_slugs(page: Path) -> set[str]:
    text = page.read_text(encoding="utf-8")
    return {_slug(t) for t in re.findall(r"^#{1,3} (.+)$", text, re.M)}


def _theory_slugs() -> set[str]:
    return _heading_slugs(THEORY)


def _notebook_markdown() -> dict[str, str]:
    out = {}
    for path in sorted((ROOT / "notebooks").glob("*.ipynb")):
        cells = json.loads(path.read_text(encoding="utf-8"))["cells"]
        out[path.name] = "\n".join("".join(c["source"]) for c in cells
                                   if c["cell_type"] == "markdown")
    return out


def _sources() -> dict[str, str]:
    """Every text that may point into the docs, by name."""
    texts = {p.relative_to(ROOT).as_posix(): p.read_text(encoding="utf-8")
             for p in sorted((ROOT / "control_ncs").glob("*.py"))}
    texts.update({f"notebooks/{k}": v for k, v in _notebook_markdown().items()})
    texts["README.md"] = (ROOT / "README.md").read_text(encoding="utf-8")
    for page in _pages():
        texts[page.relative_to(ROOT).as_posix()] = page.read_text(
            encoding="utf-8")
    return texts


def _api_names(module: str = "control_ncs") -> set[str]:
    """The names the API reference lists under ``currentmodule`` module."""
    text = (DOCS / "api.rst").read_text(encoding="utf-8")
    names = set()
    for part in re.split(r"^\.\. currentmodule:: ", text, flags=re.M)[1:]:
        current, _, body = part.partition("\n")
        if current.strip() != module:
            continue
        for block in re.findall(r"\.\. autosummary::\n((?:\n|   .*\n)+)",
                                body):
            names |= {line.strip() for line in block.splitlines()
                      if line.strip() and not line.strip().startswith(":")}
    return names


def test_theory_page_has_one_label_per_section():
    text = THEORY.read_text(encoding="utf-8")
    headings = re.findall(r"^(?:\(([a-z0-9-]+)\)=\n)?#{2,3} (.+)$", text, re.M)
    unlabelled = [title for label, title in headings
                  if not label and title != "References"]
    assert not unlabelled
    assert len({label for label, _ in headings if label}) >= 12


def test_every_label_referenced_exists():
    labels = _labels()
    missing = {f"{name}: {ref}" for name, text in _sources().items()
               for ref in REF.findall(text) if ref not in labels}
    assert not missing, sorted(missing)


def test_every_theory_link_points_to_a_heading():
    slugs = _theory_slugs()
    missing = {f"{name}: #{slug}" for name, text in _sources().items()
               for slug in THEORY_LINK.findall(text) if slug not in slugs}
    assert not missing, sorted(missing)


def test_api_reference_lists_exactly_the_public_names():
    listed = _api_names()
    assert listed >= set(control_ncs.__all__), \
        sorted(set(control_ncs.__all__) - listed)
    assert listed <= set(control_ncs.__all__), \
        sorted(listed - set(control_ncs.__all__))


def test_api_reference_lists_the_checks_in_their_modules():
    """Names public in their submodule only are documented there, and
    the old top-level spelling still resolves to the same object, with a
    DeprecationWarning naming the module."""
    by_module: dict[str, set[str]] = {}
    for name, module in control_ncs._IN_SUBMODULE.items():
        by_module.setdefault(module, set()).add(name)
        assert name not in control_ncs.__all__
        assert name not in dir(control_ncs)
        with pytest.warns(DeprecationWarning, match=f"{module}.{name}"):
            assert getattr(control_ncs, name) is getattr(
                __import__(module, fromlist=[name]), name)
    for module, names in by_module.items():
        assert _api_names(module) == names, module


def _named_tests() -> set[tuple[str, str]]:
    found = set()
    for page in sorted(DOCS.glob("*.md")):
        found |= set(re.findall(r"(tests/test_\w+\.py)::(test_\w+)",
                                page.read_text(encoding="utf-8")))
    return found


def test_the_docs_name_tests_as_evidence():
    assert len(_named_tests()) >= 10


@pytest.mark.parametrize("path, name", sorted(_named_tests()))
def test_every_test_named_in_the_docs_exists(path, name):
    tree = ast.parse((ROOT / path).read_text(encoding="utf-8"))
    assert name in {node.name for node in ast.walk(tree)
                    if isinstance(node, ast.FunctionDef)}


BUILD = "python -m sphinx -W --keep-going -b html docs docs/_build/html"


def test_ci_builds_the_site_with_warnings_as_errors():
    assert BUILD in (ROOT / ".ci" / "run").read_text(encoding="utf-8")


def test_readme_gives_the_one_local_build_command():
    assert BUILD in (ROOT / "README.md").read_text(encoding="utf-8")


def test_no_math_section_reference_is_left():
    """Users never receive MATH.md: code, notebooks, README and the site
    point to the theory page instead."""
    left = {name for name, text in _sources().items()
            if re.search(r"MATH\s*(#\s*)?§|MATH\.md", text)}
    assert not left, sorted(left)


def test_the_product_speaks_of_itself_not_of_how_it_was_made():
    """No tracker or work-session numbers in what users read or run."""
    pattern = re.compile(r"\b(issue|session)s?\s*#?\d", re.IGNORECASE)
    left = {name: pattern.search(text).group(0)
            for name, text in _sources().items() if pattern.search(text)}
    assert not left, left


def test_the_site_ships_its_math_renderer():
    """Formulas must render without internet: MathJax comes with the build
    (sphinx-mathjax-offline), and the docs extra installs it."""
    conf = (DOCS / "conf.py").read_text(encoding="utf-8")
    assert '"sphinx-mathjax-offline"' in conf
    pyproject = (ROOT / "pyproject.toml").read_text(encoding="utf-8")
    assert "sphinx-mathjax-offline" in pyproject


README = ROOT / "README.md"
TEST_COMMAND = 'python -m pip install -e ".[test]" && python -m pytest -n auto'
DEMO_COMMAND = "python -m pip install -e . && python -m control_ncs demo"


def test_readme_is_a_front_door():
    """Short, with the two commands that work on a fresh machine; the
    test command is the one CI runs."""
    text = README.read_text(encoding="utf-8")
    assert len(text.splitlines()) < 150
    assert TEST_COMMAND in text and DEMO_COMMAND in text
    assert TEST_COMMAND in (ROOT / ".ci" / "run").read_text(encoding="utf-8")


def test_readme_figure_exists():
    images = re.findall(r"!\[[^\]]*\]\(([^)]+)\)",
                        README.read_text(encoding="utf-8"))
    assert images
    assert all((ROOT / image).is_file() for image in images)


def test_readme_tasks_link_to_guide_sections_that_exist():
    links = GUIDE_LINK.findall(README.read_text(encoding="utf-8"))
    assert len({page for page, _ in links}) >= 8
    broken = [f"{page}#{slug}" for page, slug in links
              if not (DOCS / "guide" / page).is_file()
              or (slug and slug not in _heading_slugs(DOCS / "guide" / page))]
    assert not broken


def test_every_guide_page_is_in_the_guide_toctree():
    index = (DOCS / "guide" / "index.md").read_text(encoding="utf-8")
    toctree = re.search(r"```\{toctree\}\n(.*?)```", index, re.S).group(1)
    listed = {line.strip() for line in toctree.splitlines()
              if line.strip() and not line.startswith(":")}
    pages = {page.stem for page in (DOCS / "guide").glob("*.md")} - {"index"}
    assert listed == pages
    assert "guide/index" in (DOCS / "index.md").read_text(encoding="utf-8")


def test_the_sign_convention_is_stated_once_and_linked():
    defined = [name for name, text in _sources().items()
               if re.search(r"^\(guide-sign\)=$", text, re.M)]
    assert defined == ["docs/guide/model.md"]
    readme = README.read_text(encoding="utf-8")
    assert "docs/guide/model.md#sign-convention" in readme
    assert "sign-convention" in _heading_slugs(DOCS / "guide" / "model.md")
