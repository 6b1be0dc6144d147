"""Build the literate manuscript paper/paper.md into ONE self-contained HTML file.

* ``{{fig8.key|fmt}}`` / ``{{config.dotted.key|fmt}}``: numbers from results/summary/<fig>.json
  (``numbers``) and the configuration (see :func:`wfcore.fill_placeholders`); an unknown key fails
  the build.
* ``{{include:table1}}``: the generated table results/tables/table1.md, wrapped in
  ``<div class="table" id="table1">``.
* ``{{include:claims-fig3}}``: the paper's claims of a figure next to our numbers and the verdict
  (``claims`` of results/summary/fig3.json).
* ``{{include:choices}}``: every value the paper leaves open and our choice (config ``choices``).
* ``{{include:benchmarks}}``: the Performance section written by bench_report.py
  (results/benchmarks/summary.md; its figures ``benchmarks/*.png`` are embedded like the others);
  its numbers (``numbers`` of summary.json) are placeholders ``{{benchmarks.key}}`` and available to
  checks as ``benchmarks``.
* ``{{include:accuracy}}``: the per-method table of the accuracy suite (results/accuracy[-quick]/summary.md,
  config ``accuracy_profile``); its ``numbers`` are placeholders ``{{accuracy.key}}``.
* ``<!-- if: EXPR -->text<!-- else -->other text<!-- endif -->`` (``else`` optional, also inside a
  paragraph): text that exists only where a result exists, e.g. a sentence about a benchmark that
  the quick configuration does not run (``benchmarks["pyharm_available"]``).  EXPR as for checks.
* ``<!-- check: EXPR ## statement -->``: a qualitative statement of the text that depends on the
  results, as a Python expression over the figure numbers (``fig8["hbm_failed"] > 0``).  When a
  result changes and the expression turns false, the document opens with a warning box listing
  the stale statements (and the build log says so), instead of silently printing outdated text.
* ``![caption](figures/fig3.png)`` on its own line: the figure, embedded as a base64 data URI in
  ``<figure id="fig3">`` with the caption.

Markdown syntax (CommonMark with tables, footnotes ``[^note]``, math ``$...$`` / ``$$...$$`` as
MathML): see mdrender.py.  A placeholder whose value is missing (None) prints ``n/a`` and is listed
in the build log as ``MISSING VALUE``; the rendering test fails on it, so text about results a
configuration may lack belongs inside ``<!-- if: ... -->``.

Run by the rule ``paper`` or stand-alone::

    python workflow/scripts/paper/build_paper.py [results_dir]
"""
import base64
import html
import os
import re
import sys

from mshbm_workflow import mdrender  # noqa: E402
from mshbm_workflow.wfcore import fill_placeholders, get_key, load_json, md_table  # noqa: E402

CSS = """
body { font-family: Georgia, 'Times New Roman', serif; max-width: 52em; margin: 2em auto; padding: 0 1em;
       line-height: 1.45; color: #222; }
h1, h2, h3 { font-family: Helvetica, Arial, sans-serif; line-height: 1.2; }
h1 { font-size: 1.6em; } h2 { font-size: 1.25em; margin-top: 2em; border-bottom: 1px solid #ccc; }
figure { margin: 1.5em 0; text-align: center; }
figure img { max-width: 100%; }
figcaption { font-size: 0.9em; text-align: left; margin-top: 0.4em; }
table { border-collapse: collapse; font-size: 0.82em; margin: 1em 0; }
th, td { border: 1px solid #bbb; padding: 0.25em 0.5em; vertical-align: top; }
th { background: #f0f0f0; }
div.table { overflow-x: auto; }
code { font-size: 0.9em; background: #f5f5f5; padding: 0 0.2em; }
pre { background: #f5f5f5; padding: 0.6em; overflow-x: auto; }
.verdict { font-weight: bold; }
div.stale { border: 2px solid #c00; background: #fee; padding: 0.5em 1em; }
"""

FIGURE = re.compile(r"^!\[(?P<cap>[^\]]*)\]\((?P<path>(?:figures|benchmarks(?:-full)?)/(?P<name>[A-Za-z0-9_]+)\.png)\)[ \t]*$",
                    re.M)
CHECK = re.compile(r"<!--\s*check:\s*(?P<expr>.+?)\s*##\s*(?P<text>.+?)\s*-->", re.S)
CONDITION = re.compile(r"<!--\s*if:\s*(?P<expr>.+?)\s*-->(?P<yes>.*?)"
                       r"(?:<!--\s*else\s*-->(?P<no>.*?))?<!--\s*endif\s*-->", re.S)
PLACEHOLDER = re.compile(r"\{\{\s*([A-Za-z0-9_]+)\.([A-Za-z0-9_.\-]+?)\s*(?:\|\s*[a-z0-9]+\s*)?\}\}")
SAFE_BUILTINS = {"min": min, "max": max, "abs": abs, "len": len, "all": all, "any": any}
INCLUDE = re.compile(r"\{\{\s*include:(?P<name>[A-Za-z0-9_\-]+)\s*\}\}")


def build(md_path, results_dir, out_html, out_md=None, stress_md=None, bench_md=None, accuracy_md=None):
    text = open(md_path, encoding="utf-8").read()
    config = load_json(os.path.join(results_dir, "config.json"))
    context, summaries = {"config": config}, {}
    sdir = os.path.join(results_dir, "summary")
    for fn in sorted(os.listdir(sdir)):
        if fn.endswith(".json"):
            summaries[fn[:-5]] = load_json(os.path.join(sdir, fn))
            context[fn[:-5]] = summaries[fn[:-5]]["numbers"]
    if bench_md is None:  # stand-alone use; "" (the rule without a `benchmarks` config): none
        bench_md = os.path.join(results_dir, "benchmarks", "summary.md")
    if bench_md and os.path.exists(bench_md):
        context["benchmarks"] = load_json(os.path.splitext(bench_md)[0] + ".json")["numbers"]
    if accuracy_md and os.path.exists(accuracy_md):  # the accuracy suite (rule accuracy / accuracy_quick)
        context["accuracy"] = load_json(os.path.splitext(accuracy_md)[0] + ".json")["numbers"]

    def include(m):
        name = m.group("name")
        if name.startswith("claims-"):
            claims = summaries[name[len("claims-"):]]["claims"]
            return md_table(["the paper says", "we measure", "verdict"],
                            [(mdrender.notation(c["paper"]), mdrender.notation(c["ours"]), f"**{c['verdict']}**")
                             for c in claims])
        if name == "stress":
            path = stress_md or os.path.join(results_dir, "stress", "summary.md")
            data = load_json(os.path.splitext(path)[0] + ".json")
            counts = {}
            for r in data["rows"]:
                c = counts.setdefault((r["category"], r["method"]), {"converged": 0, "failed-with-diagnosis": 0,
                                                                     "truncation-warned": 0, "WRONG": 0})
                c[r["outcome"]] = c.get(r["outcome"], 0) + 1
            rows = [(cat, meth, c["converged"], c["failed-with-diagnosis"], c["truncation-warned"], c["WRONG"])
                    for (cat, meth), c in sorted(counts.items())]
            total = {k: sum(c.get(k, 0) for c in counts.values())
                     for k in ("converged", "failed-with-diagnosis", "truncation-warned", "WRONG")}
            head = (f"Profile `{data['profile']}`: {len(data['rows'])} solves in {data['wall_time_s']:.0f} s; "
                    f"converged {total['converged']}, failed with a diagnosis {total['failed-with-diagnosis']}, "
                    f"truncation-warned {total['truncation-warned']}, "
                    f"WRONG {total['WRONG']}.  Every row, with its reference or message: "
                    f"`{os.path.relpath(path, results_dir)}`.")
            table = md_table(["category", "method", "converged", "failed with diagnosis", "truncation-warned", "WRONG"],
                             rows)
            return f'<div class="table" id="stress">\n\n{head}\n\n{table}\n\n</div>'
        if name == "accuracy":  # the per-method table of the accuracy suite's summary.md
            table = open(accuracy_md, encoding="utf-8").read().split("\n\n")
            return '<div class="table" id="accuracy">\n\n' + "\n\n".join(table[1:3]).strip() + "\n\n</div>"
        if name == "benchmarks":
            if not (bench_md and os.path.exists(bench_md)):
                return ("*The benchmarks are not part of this configuration (no `benchmarks` section in the "
                        "config).*")
            return mdrender.notation(open(bench_md, encoding="utf-8").read().strip())
        if name == "choices":
            lines = []
            for c in config["choices"]:
                value = get_key(config, c["key"])
                shown = "" if isinstance(value, str) and len(value) > 40 else f": {plain(value)}"
                what = c["what"][:1].upper() + c["what"][1:]
                lines.append(f"- **{what}**{shown}.  {' '.join(c['why'].split())}")
            return "\n".join(lines)
        table = open(os.path.join(results_dir, "tables", f"{name}.md"), encoding="utf-8").read()
        return f'<div class="table" id="{name}">\n\n{table.strip()}\n\n</div>'

    scope = {k: v for k, v in context.items() if k != "config"}

    def evaluate(expr):
        # the names as globals: generator expressions in a check see them too
        return bool(eval(expr, dict(scope, __builtins__=SAFE_BUILTINS)))

    def condition(m):
        try:
            ok = evaluate(m.group("expr"))
        except NameError:  # a whole kind of result absent from this configuration (no `benchmarks`)
            ok = False
        except (KeyError, TypeError) as exc:  # a typo must not silently drop text
            raise ValueError(f"condition <!-- if: {m.group('expr')} --> cannot be evaluated: "
                             f"{type(exc).__name__}: {exc}") from exc
        return m.group("yes") if ok else (m.group("no") or "")

    text = CONDITION.sub(condition, text)
    left_over = re.findall(r"<!-- (?:if:[^>]*|else|endif) -->", text)
    if left_over:  # one pass, no nesting: an <!-- if --> inside another leaves its markers in the text
        raise ValueError(f"conditional markers left after filling (nested <!-- if --> blocks are not supported; "
                         f"repeat the outer condition instead): {left_over[:3]}")
    stale = []
    for m in CHECK.finditer(text):
        try:
            ok = evaluate(m.group("expr"))
        except (KeyError, TypeError, NameError) as exc:
            ok, note = False, f" ({type(exc).__name__}: {exc})"
        else:
            note = ""
        if not ok:
            stale.append((m.group("text"), f"{m.group('expr')}{note}"))
    text = CHECK.sub("", text)
    if stale:
        # the failed expression as code: a note to the authors, not prose
        items = "\n".join(f"<li>{html.escape(t)} <small>(check <code>{html.escape(e)}</code> failed)</small></li>"
                          for t, e in stale)
        banner = ('<div class="stale"><strong>Stale text:</strong> these statements of the manuscript no longer '
                  f"match the regenerated results; update paper/paper.md.<ul>{items}</ul></div>\n\n")
        text = re.sub(r"^(# .*\n)", lambda mm: mm.group(1) + "\n" + banner, text, count=1, flags=re.M)
    text = INCLUDE.sub(include, text)
    missing = [m.group(0) for m in PLACEHOLDER.finditer(text)
               if m.group(1) in context and m.group(1) != "config" and context[m.group(1)].get(m.group(2), 0) is None]
    text = fill_placeholders(text, context)
    left = re.findall(r"\{\{[^}]*\}\}", text)
    if left:
        raise ValueError(f"unfilled placeholders: {left}")
    if out_md:
        with open(out_md, "w", encoding="utf-8") as fh:
            fh.write(text)

    def figure(m):
        path = os.path.join(results_dir, m.group("path"))
        with open(path, "rb") as fh:
            data = base64.b64encode(fh.read()).decode("ascii")
        cap_html = mdrender.render_inline(m.group("cap"))
        alt = html.escape(re.sub(r"<[^>]+>|[*_`$\\]", "", m.group("cap")), quote=True)
        return (f'<figure id="{m.group("name")}"><img alt="{alt}" src="data:image/png;base64,{data}"/>'
                f"<figcaption>{cap_html}</figcaption></figure>")

    text = FIGURE.sub(figure, text)
    body = mdrender.render(text)
    title = re.search(r"^# (.+)$", text, re.M)
    title = html.escape(re.sub(r"<[^>]+>", "", title.group(1))) if title else "paper"
    page = (f'<!DOCTYPE html>\n<html lang="en">\n<head>\n<meta charset="utf-8"/>\n'
            f'<meta name="viewport" content="width=device-width, initial-scale=1"/>\n<title>{title}</title>\n'
            f"<style>{CSS}{mdrender.CSS}</style>\n</head>\n<body>\n{body}\n</body>\n</html>\n")
    os.makedirs(os.path.dirname(out_html) or ".", exist_ok=True)
    with open(out_html, "w", encoding="utf-8") as fh:
        fh.write(page)
    return page, [f"{t} [check `{e}` failed]" for t, e in stale] + [f"MISSING VALUE {x}" for x in missing]


def plain(value):
    """A config value for a reader (5.0 -> 5)."""
    if isinstance(value, float) and value.is_integer():
        return str(int(value))
    return str(value)


if "snakemake" in globals():
    smk = snakemake  # noqa: F821
    with open(smk.log[0], "w") as log:
        results = os.path.dirname(smk.input.config)
        bench = [p for p in smk.input.benchmarks if p.endswith("summary.md")]
        _, stale = build(smk.input.md, results, smk.output.html, smk.output.md, smk.input.stress,
                         bench[0] if bench else "", smk.input.accuracy)
        for x in stale:
            print(x if x.startswith("MISSING VALUE") else f"STALE TEXT: {x}", file=log)
        print(f"wrote {smk.output.html}", file=log)
elif __name__ == "__main__":
    results = sys.argv[1] if len(sys.argv) > 1 else "results"
    _, stale = build("paper/paper.md", results, os.path.join(results, "paper", "paper.html"),
                     os.path.join(results, "paper", "paper.filled.md"),
                     accuracy_md=os.path.join(results, "accuracy", "summary.md"))
    for x in stale:
        print(x if x.startswith("MISSING VALUE") else f"STALE TEXT: {x}")
