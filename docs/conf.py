"""Sphinx configuration of dhkin's reference site (docs/).

Build: ``python -m sphinx -W --keep-going -b html docs docs/_build/html`` (tests/test_docs.py
runs exactly this build, warnings as errors). Pages are Markdown (MyST); the API reference
(api.rst) is generated from the docstrings by autodoc, which reads them as reStructuredText
with Sphinx's roles (:class:, :func:, ...), as they are written.
"""

from __future__ import annotations

project = "dhkin"
author = "the dhkin developers"
extensions = ["sphinx.ext.autodoc", "myst_parser"]
source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
exclude_patterns = ["_build"]
root_doc = "index"

# Markdown: heading anchors for links such as architecture.md#cold-start.
myst_heading_anchors = 3

# API reference: members in source order, signatures with their type hints.
autodoc_member_order = "bysource"
autodoc_typehints = "signature"
autodoc_default_options = {"members": True}

html_theme = "alabaster"
html_title = "dhkin"
html_static_path: list[str] = []
