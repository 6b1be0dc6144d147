"""Check rendered HTML (the paper, the notebooks) for what a reader must never see.

Parses each page with an HTML parser (BeautifulSoup, ``html.parser``) and inspects the *visible*
text, i.e. without ``<script>``, ``<style>``, ``<head>`` and MathML (a formula is drawn, its TeX
source only sits in an attribute).  *Prose* is the visible text outside ``<pre>`` and ``<code>``
(notebook code cells, their printed output and inline code).

Defects (one line each, with a snippet):

* ``raw heading`` -- a line of prose starting with ``#``..``######`` and a space (markdown that
  was never parsed);
* ``raw table`` -- a pipe-table row or separator (``| a | b |``, ``|---|``) in prose;
* ``raw markup`` -- ``**bold**`` or ``[^note]`` left in prose;
* ``placeholder`` -- ``{{...}}`` anywhere in the visible text;
* ``missing value`` -- ``n/a``, ``None``, ``nan`` (whole words) in prose or in printed output;
* ``machine path`` -- ``/root``, ``/home``, ``/tmp``, ``/work``, ``site-packages`` in any
  visible text (code, output, prose) or in a link/image address;
* ``ASCII symbol`` -- the paper's symbols spelt in ASCII in prose (``mu``, ``kappa``, ``omega``,
  ``theta``, ``pi/5``, ``n_H``, ``F_N``, ``k_c``, ``d_c``, ``e_N``): write them as math;
* ``raw TeX`` -- ``$...$``, ``\\frac``, ``\\mu`` and other backslash commands in prose;
* ``network`` -- anything the page would load from elsewhere: ``src``/``srcset``/``data``/``poster``
  of any element and ``href`` of ``<link>`` pointing to ``http(s)://`` or ``//``, ``url(http...)``
  or ``@import`` in CSS, an ``http(s)://`` address inside a ``<script>``.  Plain links
  (``<a href="https://...">``) load nothing and are allowed.

Usage::

    python workflow/scripts/paper/check_render.py results/paper/paper.html results/notebooks/*.html
    python workflow/scripts/paper/check_render.py --screenshot results/paper/paper.html   # also Chromium

Exit status 1 when a defect was found.  :func:`screenshot` takes a headless-Chromium screenshot
(Debian package ``chromium``) and :func:`screenshot_stats` measures it (non-blank, page height).
"""
from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile

from bs4 import BeautifulSoup, Comment, Doctype, ProcessingInstruction

INVISIBLE = {"script", "style", "head", "title", "template", "noscript", "math"}
CODE = {"pre", "code"}

RAW_HEADING = re.compile(r"(?:^|\n)[ \t]*#{1,6}[ \t]+\S")
RAW_TABLE = re.compile(r"(?:^|\n)[ \t]*\|.*\|.*\|[ \t]*(?:\n|$)|\|[ \t]*:?-{3,}:?[ \t]*\|")
RAW_MARKUP = re.compile(r"\*\*[^*\s][^*]*\*\*|\[\^[^\]]+\]")
PLACEHOLDER = re.compile(r"\{\{.*?\}\}", re.S)
MISSING = re.compile(r"(?<![\w/])(?:n/a|N/A|None|nan|NaN)(?![\w/])")
MACHINE_PATH = re.compile(r"(?:(?<![\w.])/(?:root|home|tmp|work)(?=/|\b)|site-packages)")
RAW_TEX = re.compile(r"\$[^$\s][^$\n]*?\$|\\(?:frac|mu|kappa|omega|pi|lambda|hat|dot|ddot|sum|int|cdot|le|ge|"
                     r"theta|mathrm|mathbf|left|right|begin|end|[a-zA-Z]+\{)")
ASCII_SYMBOL = re.compile(r"\b(?:mu|kappa|omega|theta|lambda_T|n_H|F_N|k_c|d_c|e_N|g_N,0)\b|(?<![\w/])pi/5\b")
NETWORK_URL = re.compile(r"^\s*(?:https?:)?//", re.I)
CSS_NETWORK = re.compile(r"url\(\s*['\"]?\s*(?:https?:)?//|@import", re.I)
SCRIPT_NETWORK = re.compile(r"https?://", re.I)


def _texts(soup):
    """(visible text, prose text) of a parsed page."""
    visible, prose = [], []
    body = soup.body or soup
    for node in body.find_all(string=True):
        if isinstance(node, (Comment, Doctype, ProcessingInstruction)):
            continue
        parents = {p.name for p in node.parents}
        if parents & INVISIBLE:
            continue
        visible.append(str(node))
        if not parents & CODE:
            prose.append(str(node))
    return "".join(visible), "".join(prose)


def visible_text(page: str) -> str:
    """The text a reader sees (without scripts, styles and the TeX source of formulas)."""
    return _texts(BeautifulSoup(page, "html.parser"))[0]


def _snip(text, m, width=60):
    a, b = max(m.start() - width, 0), min(m.end() + width, len(text))
    return " ".join(text[a:b].split())


def defects(page: str, name: str = "page") -> list[str]:
    """Every defect of one HTML page (empty: clean)."""
    soup = BeautifulSoup(page, "html.parser")
    visible, prose = _texts(soup)
    out = []

    def scan(kind, pattern, text):
        for m in pattern.finditer(text):
            out.append(f"{name}: {kind}: ...{_snip(text, m)}...")

    scan("raw heading", RAW_HEADING, prose)
    scan("raw table", RAW_TABLE, prose)
    scan("raw markup", RAW_MARKUP, prose)
    scan("placeholder", PLACEHOLDER, visible)
    # printed output (<pre> of notebook outputs) counts; code input cells are not scanned for words
    outputs = "".join(str(n) for el in soup.select(".jp-OutputArea-output pre") for n in el.find_all(string=True))
    scan("missing value", MISSING, prose + "\n" + outputs)
    scan("machine path", MACHINE_PATH, visible)
    scan("raw TeX", RAW_TEX, prose)
    scan("ASCII symbol", ASCII_SYMBOL, prose)
    for el in soup.find_all(True):
        for attr in ("src", "srcset", "data", "poster"):
            val = el.get(attr)
            if isinstance(val, str) and NETWORK_URL.match(val):
                out.append(f"{name}: network: <{el.name} {attr}={val[:80]!r}>")
        if el.name == "link" and NETWORK_URL.match(el.get("href") or ""):
            out.append(f"{name}: network: <link href={el['href'][:80]!r}>")
        for attr in ("href", "src"):
            val = el.get(attr)
            if isinstance(val, str) and not val.startswith("data:") and MACHINE_PATH.search(val):
                out.append(f"{name}: machine path: <{el.name} {attr}={val[:80]!r}>")
        if el.name == "style" or el.get("style"):
            css = el.get_text() if el.name == "style" else el["style"]
            for m in CSS_NETWORK.finditer(css):
                out.append(f"{name}: network: CSS ...{_snip(css, m, 40)}...")
        if el.name == "script":
            for m in SCRIPT_NETWORK.finditer(el.get_text()):
                out.append(f"{name}: network: script ...{_snip(el.get_text(), m, 40)}...")
    return out


# ----------------------------------------------------------------------------- Chromium
def chromium() -> str | None:
    """Path of a headless-capable Chromium (Debian package ``chromium``), or None."""
    for exe in ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable"):
        path = shutil.which(exe)
        if path:
            return path
    return None


def screenshot(html_path: str, png_path: str, width: int = 1000, height: int = 30000, timeout: float = 120) -> str:
    """Headless-Chromium screenshot of a local HTML file (network disabled by a bogus proxy, so a
    page that needs the network shows it)."""
    exe = chromium()
    if exe is None:
        raise FileNotFoundError("no chromium on PATH (Debian: apt-get install chromium)")
    with tempfile.TemporaryDirectory() as profile:
        cmd = [exe, "--headless", "--no-sandbox", "--disable-gpu", "--hide-scrollbars", "--mute-audio",
               "--no-first-run", "--disable-extensions", f"--user-data-dir={profile}",
               "--proxy-server=127.0.0.1:9", "--proxy-bypass-list=<-loopback>",
               f"--window-size={width},{height}", f"--screenshot={os.path.abspath(png_path)}",
               "file://" + os.path.abspath(html_path)]
        proc = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)
    if not os.path.exists(png_path):
        raise RuntimeError(f"chromium wrote no screenshot: {proc.stderr[-2000:]}")
    return png_path


def screenshot_stats(png_path: str) -> dict:
    """``height``: rows from the top to the last row with content (the page height as drawn, capped
    by the window); ``ink``: fraction of non-white pixels; ``window_height``."""
    import numpy as np
    from PIL import Image

    Image.MAX_IMAGE_PIXELS = None
    gray = np.asarray(Image.open(png_path).convert("L"))
    rows = np.flatnonzero((gray < 245).any(axis=1))
    return {"height": int(rows.max() + 1) if rows.size else 0, "ink": float((gray < 245).mean()),
            "window_height": int(gray.shape[0]), "width": int(gray.shape[1])}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("pages", nargs="+")
    ap.add_argument("--screenshot", action="store_true", help="also take and measure a Chromium screenshot")
    args = ap.parse_args(argv)
    found = []
    for path in args.pages:
        with open(path, encoding="utf-8") as fh:
            found += defects(fh.read(), os.path.basename(path))
        if args.screenshot:
            png = os.path.splitext(path)[0] + ".screenshot.png"
            print(path, screenshot_stats(screenshot(path, png)), png)
    for line in found:
        print(line)
    print(f"{len(found)} defect(s) in {len(args.pages)} page(s)")
    return 1 if found else 0


if __name__ == "__main__":
    sys.exit(main())
