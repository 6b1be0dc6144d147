# One notebook per figure/table, one rule for all of them: notebooks/<name>.py (jupytext percent
# format, the only source) -> job of rule `notebook` with name=<name> -> results/figures/<name>.png/.pdf.
# The tables' jobs (rule `notebook_table`, the same rule with the table's outputs
# results/tables/<name>.md/.csv instead of a PNG and a PDF) work alike.  scripts/paper/run_notebook.py converts
# the source with jupytext, executes it with papermill and renders it; the executed notebook and its
# HTML are kept under results/notebooks/.  Editing notebooks/fig3.py reruns the fig3 job and the paper.
#
# What each notebook reads is declared in workflow/manifest.yaml (`data`); notebook_inputs() in
# common.smk turns it into named inputs.  Named inputs become notebook parameters (except `nb` and
# `helpers`); `npz_*` inputs are passed together as the dict `npz`; named outputs other than `nb` and
# `html` become the parameters `out_<name>`.


rule notebook:
    input:
        unpack(lambda w: notebook_inputs(w.name)),
        nb="notebooks/{name}.py",
        helpers=NB_HELPERS,
        config=f"{R}/config.json",
    output:
        nb=f"{R}/notebooks/{{name}}.ipynb",
        html=f"{R}/notebooks/{{name}}.html",
        png=f"{R}/figures/{{name}}.png",
        pdf=f"{R}/figures/{{name}}.pdf",
    log:
        f"{R}/logs/notebooks/{{name}}.log",
    wildcard_constraints:
        name="|".join(FIGURES),
    threads: 1
    resources:
        mem_mb=1000,
        runtime=10,
    script:
        "../scripts/paper/run_notebook.py"


use rule notebook as notebook_table with:
    output:
        nb=f"{R}/notebooks/{{name}}.ipynb",
        html=f"{R}/notebooks/{{name}}.html",
        md=f"{R}/tables/{{name}}.md",
        csv=f"{R}/tables/{{name}}.csv",
    wildcard_constraints:
        name="|".join(TABLES),
