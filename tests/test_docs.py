"""The documentation site (docs/, Sphinx; `make docs` builds it with
warnings as errors and `make test` runs it): every public name has its API
page."""

import pathlib
import re

import hairshade as hs

DOCS = pathlib.Path(__file__).resolve().parent.parent / "docs"


def test_every_public_name_has_an_api_page():
    """Each name of hairshade.__all__ (but the version string) is listed in
    docs/api.rst, whose autosummary generates its page from the docstring."""
    listed = set(re.findall(r"^\s+hairshade\.(\w+)$", (DOCS / "api.rst").read_text(), flags=re.M))
    missing = [n for n in hs.__all__ if n != "__version__" and n not in listed]
    assert not missing, missing


def test_every_topic_page_is_in_the_site():
    """Every Markdown page of docs/ is in a toctree of docs/index.md (Sphinx
    warns, and -W fails, on an orphan; this names it faster)."""
    index = (DOCS / "index.md").read_text()
    pages = [p.relative_to(DOCS).with_suffix("").as_posix() for p in DOCS.rglob("*.md")
             if "_build" not in p.parts and "_generated" not in p.parts and p.name != "index.md"]
    missing = [p for p in pages if not re.search(rf"^{re.escape(p)}$", index, flags=re.M)]
    assert not missing, missing
