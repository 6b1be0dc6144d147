"""The README's table "Where each figure comes from", rendered from workflow/manifest.yaml.

    python workflow/scripts/paper/manifest_table.py           # print the table
    python workflow/scripts/paper/manifest_table.py --write   # replace the table in README.md
    python workflow/scripts/paper/manifest_table.py --check   # exit 1 if README.md shows another table

The table sits between the markers ``<!-- manifest:begin -->`` and ``<!-- manifest:end -->`` of
README.md; tests/integration/test_manifest.py runs the check.
"""
import sys
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[3]
MANIFEST = ROOT / "workflow" / "manifest.yaml"
README = ROOT / "README.md"
BEGIN, END = "<!-- manifest:begin -->", "<!-- manifest:end -->"


def load(path=MANIFEST):
    with open(path, encoding="utf-8") as fh:
        return yaml.safe_load(fh)


def module_path(module):
    """Source file of an mshbm module, relative to the repository (a module or a package)."""
    rel = Path("src", *module.split("."))
    return rel / "__init__.py" if (ROOT / rel).is_dir() else rel.with_suffix(".py")


def table(manifest):
    rows = ["| Output | In the paper | Rules: data → notebook | Notebook | Method modules |",
            "|---|---|---|---|---|"]
    for name, entry in manifest.items():
        kind = "figures" if name.startswith("fig") else "tables"
        ext = "png" if kind == "figures" else "md"
        rule = "notebook" if kind == "figures" else "notebook_table"
        rules = ", ".join(f"`{r}`" for r in entry["rules"]) + f" → `{rule}`"
        modules = ", ".join(f"[`{m}`]({module_path(m).as_posix()})" for m in entry["methods"])
        rows.append(f"| `results/{kind}/{name}.{ext}` | {entry['paper']}: {entry['title']} | {rules} "
                    f"| [`notebooks/{name}.py`](notebooks/{name}.py) | {modules} |")
    return "\n".join(rows)


def readme_table(text):
    """The table between the markers of README.md (None without markers)."""
    if BEGIN not in text or END not in text:
        return None
    return text.split(BEGIN, 1)[1].split(END, 1)[0].strip()


def main(argv):
    want = table(load())
    if "--write" in argv or "--check" in argv:
        text = README.read_text(encoding="utf-8")
        have = readme_table(text)
        if have is None:
            print(f"README.md has no {BEGIN} ... {END} section", file=sys.stderr)
            return 1
        if "--check" in argv:
            if have != want:
                print("README.md's table differs from workflow/manifest.yaml "
                      "(python workflow/scripts/paper/manifest_table.py --write)", file=sys.stderr)
                return 1
            return 0
        head, rest = text.split(BEGIN, 1)
        README.write_text(f"{head}{BEGIN}\n{want}\n{END}{rest.split(END, 1)[1]}", encoding="utf-8")
        return 0
    print(want)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
