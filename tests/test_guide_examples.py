"""Every Python example of the README and the user guide runs as written.

The ```` ```python ```` blocks of one page run in order in one namespace
(a reader types them one after the other), in a temporary working folder,
with matplotlib's non-interactive backend; one test per page. A block that
raises fails its page's test and names the block.
"""

from __future__ import annotations

import re
from pathlib import Path

import matplotlib
import pytest

ROOT = Path(__file__).resolve().parent.parent
PAGES = ([ROOT / "README.md", ROOT / "docs" / "index.md"]
         + sorted((ROOT / "docs" / "guide").glob("*.md")))
BLOCK = re.compile(r"^```python\n(.*?)^```", re.M | re.S)


def python_blocks(page: Path) -> list[str]:
    """The ```` ```python ```` blocks of a Markdown page, in order."""
    return BLOCK.findall(page.read_text(encoding="utf-8"))


def test_the_guide_has_one_page_per_task():
    names = {page.stem for page in PAGES}
    assert {"index", "model", "stability", "performance", "design",
            "estimation", "simulate", "sweeps", "python_control"} <= names


def test_every_task_page_has_an_example():
    empty = [page.name for page in PAGES
             if page.stem != "index" and not python_blocks(page)]
    assert not empty


@pytest.mark.parametrize("page", PAGES,
                         ids=[page.relative_to(ROOT).as_posix()
                              for page in PAGES])
def test_the_examples_of_a_page_run(page, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    backend = matplotlib.get_backend()
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    namespace: dict = {"__name__": "__guide__"}
    try:
        for number, block in enumerate(python_blocks(page), 1):
            code = compile(block, f"{page.name}, block {number}", "exec")
            exec(code, namespace)
    finally:
        plt.close("all")
        matplotlib.use(backend)
