"""Execute a figure's or a table's notebook with papermill and render it to HTML (rule notebook).

The notebook's only source is ``notebooks/<name>.py`` in jupytext's percent format (``# %%`` code
cells, ``# %% [markdown]`` cells, ``# %% tags=["parameters"]`` the papermill parameters); it is
converted here, at run time, so that editing the source reruns the job.

The HTML is self-contained and offline (nbexport.py: markdown and math through mdrender.py, math as
MathML, no scripts from the network).

Named inputs other than ``nb`` and ``helpers`` become notebook parameters of the same name; inputs named
``npz_<key>`` are passed together as the dict ``npz``; named outputs other than ``nb`` and
``html`` become parameters ``out_<name>``.
"""
import logging
import os

os.environ.setdefault("MPLBACKEND", "Agg")

import jupytext  # noqa: E402
import nbformat  # noqa: E402
import papermill as pm  # noqa: E402
from mshbm_workflow.nbexport import export_html  # noqa: E402


def as_param(value):
    return str(value) if isinstance(value, str) else [str(v) for v in value]


def read_source(path):
    """The notebook of a percent-format source, with the kernel set and stable cell ids (reproducible files)."""
    nb = jupytext.read(path, fmt="py:percent")
    nb.metadata.pop("jupytext", None)
    nb.metadata["kernelspec"] = {"name": "python3", "display_name": "Python 3", "language": "python"}
    nb.metadata["language_info"] = {"name": "python"}
    stem = os.path.splitext(os.path.basename(path))[0]
    for i, cell in enumerate(nb.cells):
        cell["id"] = f"{stem}-{i}"
    return nb


#: kernel starts per notebook: a kernel that dies before its first reply (seen once, in a fresh-clone test run: two
#: notebooks starting in the same second on a loaded machine: a race for the kernel's ports) is started again
KERNEL_STARTS = 3


def main(smk):
    inputs = dict(smk.input.items())
    nb_in = inputs.pop("nb")
    inputs.pop("helpers", None)
    params = {}
    npz = {k[len("npz_"):]: str(v) for k, v in inputs.items() if k.startswith("npz_")}
    if npz:
        params["npz"] = npz
    params.update({k: as_param(v) for k, v in inputs.items() if not k.startswith("npz_")})
    outputs = dict(smk.output.items())
    params.update({f"out_{k}": str(v) for k, v in outputs.items() if k not in ("nb", "html")})
    for path in outputs.values():
        os.makedirs(os.path.dirname(path) or ".", exist_ok=True)
    logging.basicConfig(filename=smk.log[0], filemode="w", level=logging.INFO,
                        format="%(asctime)s %(name)s %(message)s")
    logging.info("parameters: %s", params)
    for attempt in range(1, KERNEL_STARTS + 1):
        try:
            pm.execute_notebook(read_source(nb_in), outputs["nb"], parameters=params, kernel_name="python3",
                                progress_bar=False, log_output=True, cwd=os.getcwd())
            break
        except RuntimeError as exc:  # the kernel's start, not a cell (a cell's error is PapermillExecutionError)
            if "Kernel died before replying to kernel_info" not in str(exc) or attempt == KERNEL_STARTS:
                raise
            logging.warning("kernel start %d of %d failed (%s); starting a new kernel", attempt, KERNEL_STARTS, exc)
    nb = nbformat.read(outputs["nb"], as_version=4)
    body = export_html(nb, os.path.splitext(os.path.basename(nb_in))[0])
    with open(outputs["html"], "w", encoding="utf-8") as fh:
        fh.write(body)
    logging.info("wrote %s and %s", outputs["nb"], outputs["html"])


main(snakemake)  # noqa: F821
