"""Markdown -> HTML for the paper and the notebook HTML: one parser, math as MathML, nothing online.

The syntax (CommonMark plus the extensions below) is the same in ``paper/paper.md``, in generated
tables and in notebook markdown (cells and ``display(Markdown(...))`` outputs):

* tables: GitHub pipe tables (``| a | b |`` / ``|---|---|``), also inside an HTML block such as
  ``<div class="table">`` when blank lines separate them from the tags (CommonMark rule);
* footnotes: ``text[^label]`` and, on its own paragraph, ``[^label]: the note``; collected at the
  end of the document in order of first reference;
* math: ``$...$`` inline, ``$$...$$`` display (a block on its own lines).  A ``$`` followed or
  preceded by a space, or followed by a digit, is a dollar sign, not math.  The TeX is converted to
  MathML (``latex2mathml``), which browsers draw natively; no MathJax, no fonts from the network;
* inline HTML (``<sub>``, ``&omega;``) and HTML blocks pass through; headings get ``id`` anchors.

Wide tables are wrapped in ``<div class="table-scroll">`` (CSS ``overflow-x: auto``: they scroll
instead of being clipped); see :data:`CSS`.

Packages: ``markdown-it-py``, ``mdit-py-plugins``, ``latex2mathml`` (pinned in environment.txt).
"""
from __future__ import annotations

import html
import re

from latex2mathml.converter import convert as _tex_to_mathml
from markdown_it import MarkdownIt
from mdit_py_plugins.anchors import anchors_plugin
from mdit_py_plugins.dollarmath import dollarmath_plugin
from mdit_py_plugins.footnote import footnote_plugin

#: CSS every page that embeds rendered markdown needs (tables scroll, math sized like the text)
CSS = """
div.table-scroll { overflow-x: auto; max-width: 100%; }
math { font-size: 1.05em; }
math[display="block"] { margin: 0.6em 0; }
section.footnotes { font-size: 0.9em; border-top: 1px solid #ccc; margin-top: 2em; }
"""


class MathError(ValueError):
    """TeX that cannot be converted to MathML (the build fails: no raw TeX reaches a reader)."""


def tex_to_mathml(tex: str, display: bool = False) -> str:
    """MathML of one TeX formula (``display``: a centred block)."""
    try:
        out = _tex_to_mathml(tex.strip(), display="block" if display else "inline")
    except Exception as exc:  # latex2mathml raises several exception types
        raise MathError(f"cannot convert math ${tex}$ to MathML: {type(exc).__name__}: {exc}") from exc
    # a solidus is ordinary in TeX (no space around it); MathML's operator dictionary spaces it
    out = out.replace("<mo>&#x0002F;</mo>", '<mo lspace="0" rspace="0">/</mo>')
    # the original TeX as alt text for copy/paste and screen readers
    return out.replace("<math ", f'<math alttext="{html.escape(tex.strip(), quote=True)}" ', 1)


def _math_renderer(content, options):
    return tex_to_mathml(content, bool(options.get("display_mode")))


def make_parser() -> MarkdownIt:
    md = MarkdownIt("commonmark", {"html": True, "typographer": False})
    md.enable(["table", "strikethrough"])
    md.use(footnote_plugin)
    md.use(dollarmath_plugin, allow_space=False, allow_digits=False, double_inline=True,
           renderer=_math_renderer)
    md.use(anchors_plugin, min_level=2, max_level=3)
    # tables scroll horizontally instead of being clipped by the page width
    md.add_render_rule("table_open", lambda self, tokens, idx, options, env:
                       '<div class="table-scroll">\n' + self.renderToken(tokens, idx, options, env))
    md.add_render_rule("table_close", lambda self, tokens, idx, options, env:
                       self.renderToken(tokens, idx, options, env) + "</div>\n")
    return md


_PARSER = None


def render(text: str) -> str:
    """HTML of a markdown document (see the module docstring for the syntax)."""
    global _PARSER
    if _PARSER is None:
        _PARSER = make_parser()
    return _PARSER.render(text)


def render_inline(text: str) -> str:
    """HTML of one paragraph without the enclosing ``<p>`` (captions, table cells)."""
    out = render(text).strip()
    m = re.fullmatch(r"<p>(.*)</p>", out, re.S)
    return m.group(1) if m else out


# ----------------------------------------------------------------------------- notation
#: ASCII spellings of the paper's symbols in generated text (claims, result tables) -> TeX
_SYMBOLS = [
    (r"\bn_H\b", r"n_H"), (r"\bF_N\b", r"F_N"), (r"\bk_c\b", r"k_c"), (r"\bd_c\b", r"d_c"),
    (r"\be_N\b", r"e_N"), (r"\bg_N,0\b", r"g_{N,0}"), (r"\bmu F_N\b", r"\mu F_N"), (r"\bmu\b", r"\mu"),
    (r"\bkappa\b", r"\kappa"), (r"\bomega\b", r"\omega"), (r"\btheta\b", r"\theta"),
    (r"\blambda_T\b", r"\lambda_T"), (r"(?<![\w/])pi/5\b", r"\pi/5"),
]
_SYMBOL_RE = re.compile("|".join(f"(?:{p})" for p, _ in _SYMBOLS))
_PROTECTED = re.compile(r"(`+)(?:.+?)\1|\$\$.+?\$\$|\$[^$\n]+\$|<[^>]+>", re.S)


def notation(text: str) -> str:
    """Generated text with the paper's symbols as math: ``n_H`` -> ``$n_H$``, ``kappa`` ->
    ``$\\kappa$``, ``mu F_N``, ``omega``, ``pi/5`` ... (see :data:`_SYMBOLS`).  Code spans, existing
    math and HTML tags are left alone.  For generated tables and claims only; prose in paper.md and
    notebook markdown writes its math as ``$...$`` itself."""
    text = str(text)

    def swap(segment):
        def one(m):
            s = m.group(0)
            for pat, tex in _SYMBOLS:
                if re.fullmatch(pat, s):
                    return f"${tex}$"
            return s
        return _SYMBOL_RE.sub(one, segment)

    out, pos = [], 0
    for m in _PROTECTED.finditer(text):
        out.append(swap(text[pos:m.start()]))
        out.append(m.group(0))
        pos = m.end()
    out.append(swap(text[pos:]))
    return "".join(out)
