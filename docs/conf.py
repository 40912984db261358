"""Sphinx configuration of hairshade's documentation site: the topic pages
(the Markdown files of docs/, most of them written by the scripts that
measure what they report) and an API page per public Python name, from its
docstring. Built by `make docs` (warnings are errors; `make test` builds it)."""

import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "python"))

project = "hairshade"
author = "the hairshade authors"
extensions = ["myst_parser", "sphinx.ext.autodoc", "sphinx.ext.autosummary", "sphinx.ext.napoleon"]
source_suffix = {".md": "markdown", ".rst": "restructuredtext"}
root_doc = "index"
exclude_patterns = ["_build", "*.csv", "*.json"]
autosummary_generate = True
autodoc_default_options = {"members": True, "undoc-members": False, "show-inheritance": True}
autodoc_typehints = "description"
myst_heading_anchors = 3
html_theme = "alabaster"
html_title = "hairshade"


def _cli_page() -> None:
    """docs/_generated/cli.md: the help of every command, from the parser."""
    import argparse

    from hairshade.cli import build_parser

    parser = build_parser()
    parts = ["# The command line", "", "`hairshade COMMAND --help` prints the same.", "",
             "```text", parser.format_help().rstrip(), "```"]
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                parts += ["", f"## hairshade {name}", "", "```text", sub.format_help().rstrip(), "```"]
    out = os.path.join(os.path.dirname(__file__), "_generated")
    os.makedirs(out, exist_ok=True)
    with open(os.path.join(out, "cli.md"), "w") as f:
        f.write("\n".join(parts) + "\n")


_cli_page()
