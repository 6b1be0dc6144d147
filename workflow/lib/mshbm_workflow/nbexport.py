"""Executed notebook -> one self-contained HTML page that loads nothing from the network.

nbconvert's ``lab`` template, with two changes (template ``workflow/templates/offline``):

* markdown (markdown cells and ``text/markdown`` outputs such as ``display(Markdown(table))``) is
  rendered by :mod:`mdrender` -- the paper's parser: pipe tables, footnotes, ``$...$`` math as
  MathML -- instead of nbconvert's mistune + MathJax;
* no ``<script src>`` (require.js, MathJax, mermaid.js, widget manager); wide tables and outputs
  scroll horizontally.

Figures are PNG outputs, which nbconvert embeds as ``data:`` URIs already.
"""
from __future__ import annotations

import os

from nbconvert import HTMLExporter

try:  # the decorator nbconvert itself uses for its markdown filter
    from jinja2 import pass_context
except ImportError:  # pragma: no cover - old jinja2
    from jinja2 import contextfilter as pass_context

from mshbm_workflow import mdrender

TEMPLATES = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "templates"))


class OfflineHTMLExporter(HTMLExporter):
    """HTMLExporter with :func:`mdrender.render` for markdown and the ``offline`` template."""

    @pass_context
    def markdown2html(self, context, source):
        return mdrender.render(source)


def export_html(nb, name: str) -> str:
    """HTML page of the notebook node ``nb`` (``name``: the page title)."""
    exporter = OfflineHTMLExporter(template_name="offline", extra_template_basedirs=[TEMPLATES])
    body, _ = exporter.from_notebook_node(nb, resources={"metadata": {"name": name},
                                                         "mdrender_css": mdrender.CSS})
    return body
