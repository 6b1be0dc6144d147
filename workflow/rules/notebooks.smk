# One notebook per figure/table: notebooks/<name>.ipynb -> rule <name> -> results/figures/<name>.png/.pdf
# (tables: results/tables/<name>.md/.csv).  Executed with papermill (scripts/run_notebook.py);
# the executed notebook and its HTML rendering are kept under results/notebooks/.
# Named inputs become notebook parameters (except `nb` and `helpers`); `npz_*` inputs are passed
# together as the dict `npz`.


rule table1:
    input:
        nb="notebooks/table1.ipynb",
        helpers=NB_HELPERS,
        config=f"{R}/config.json",
        summaries=expand(f"{R}/summary/{{fig}}.json", fig=SUMMARIZED),
    output:
        **notebook_outputs("table1"),
    log:
        f"{R}/logs/notebooks/table1.log",
    threads: 1
    resources:
        mem_mb=1000,
        runtime=10,
    script:
        "../scripts/run_notebook.py"


rule table2:
    input:
        nb="notebooks/table2.ipynb",
        helpers=NB_HELPERS,
        config=f"{R}/config.json",
        summaries=expand(f"{R}/summary/{{fig}}.json", fig=SUMMARIZED),
    output:
        **notebook_outputs("table2"),
    log:
        f"{R}/logs/notebooks/table2.log",
    threads: 1
    resources:
        mem_mb=1000,
        runtime=10,
    script:
        "../scripts/run_notebook.py"


rule fig1:
    input:
        nb="notebooks/fig1.ipynb",
        helpers=NB_HELPERS,
        config=f"{R}/config.json",
    output:
        **notebook_outputs("fig1"),
    log:
        f"{R}/logs/notebooks/fig1.log",
    threads: 1
    resources:
        mem_mb=1000,
        runtime=10,
    script:
        "../scripts/run_notebook.py"


rule fig2:
    input:
        nb="notebooks/fig2.ipynb",
        helpers=NB_HELPERS,
        config=f"{R}/config.json",
    output:
        **notebook_outputs("fig2"),
    log:
        f"{R}/logs/notebooks/fig2.log",
    threads: 1
    resources:
        mem_mb=1000,
        runtime=10,
    script:
        "../scripts/run_notebook.py"


rule fig3:
    input:
        nb="notebooks/fig3.ipynb",
        helpers=NB_HELPERS,
        config=f"{R}/config.json",
        summary=f"{R}/summary/fig3.json",
        **npz_inputs("fig3"),
    output:
        **notebook_outputs("fig3"),
    log:
        f"{R}/logs/notebooks/fig3.log",
    threads: 1
    resources:
        mem_mb=1000,
        runtime=10,
    script:
        "../scripts/run_notebook.py"


rule fig4:
    input:
        nb="notebooks/fig4.ipynb",
        helpers=NB_HELPERS,
        config=f"{R}/config.json",
        summary=f"{R}/summary/fig4.json",
    output:
        **notebook_outputs("fig4"),
    log:
        f"{R}/logs/notebooks/fig4.log",
    threads: 1
    resources:
        mem_mb=1000,
        runtime=10,
    script:
        "../scripts/run_notebook.py"


rule fig5:
    input:
        nb="notebooks/fig5.ipynb",
        helpers=NB_HELPERS,
        config=f"{R}/config.json",
        summary=f"{R}/summary/fig5.json",
        **npz_inputs("fig5"),
    output:
        **notebook_outputs("fig5"),
    log:
        f"{R}/logs/notebooks/fig5.log",
    threads: 1
    resources:
        mem_mb=1000,
        runtime=10,
    script:
        "../scripts/run_notebook.py"


rule fig6:
    input:
        nb="notebooks/fig6.ipynb",
        helpers=NB_HELPERS,
        config=f"{R}/config.json",
        summary=f"{R}/summary/fig6.json",
        **npz_inputs("fig6"),
        npz_longrun=longrun_file(config["figures"]["fig6"]["system"], "npz"),
    output:
        **notebook_outputs("fig6"),
    log:
        f"{R}/logs/notebooks/fig6.log",
    threads: 1
    resources:
        mem_mb=1000,
        runtime=10,
    script:
        "../scripts/run_notebook.py"


rule fig7:
    input:
        nb="notebooks/fig7.ipynb",
        helpers=NB_HELPERS,
        config=f"{R}/config.json",
        summary=f"{R}/summary/fig7.json",
        **npz_inputs("fig7"),
        npz_longrun=longrun_file(config["figures"]["fig7"]["system"], "npz"),
    output:
        **notebook_outputs("fig7"),
    log:
        f"{R}/logs/notebooks/fig7.log",
    threads: 1
    resources:
        mem_mb=1000,
        runtime=10,
    script:
        "../scripts/run_notebook.py"


rule fig8:
    input:
        nb="notebooks/fig8.ipynb",
        helpers=NB_HELPERS,
        config=f"{R}/config.json",
        summary=f"{R}/summary/fig8.json",
    output:
        **notebook_outputs("fig8"),
    log:
        f"{R}/logs/notebooks/fig8.log",
    threads: 1
    resources:
        mem_mb=1000,
        runtime=10,
    script:
        "../scripts/run_notebook.py"
