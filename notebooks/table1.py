# %% [markdown]
# # Table 1 — parameters of the system with friction
#
# The paper's Table 1 lists $m_i = 1$, $k_i = 1$, $c_i = 0$, $\mu = 0.8$, $\omega = \pi/5$ and
# $f_{ex,30} = 5\cos(\omega t)$.  Everything else a computation needs is left open; the column
# "used here" comes from `workflow/config.yaml` (the single source of every parameter) and each
# value we had to choose carries a footnote with the reason.  Numbers in the footnotes are
# measured by the workflow (placeholders filled from `results/summary/*.json`).

# %% tags=["parameters"]
config = "results/config.json"
summaries = []
out_md = "results/tables/table1.md"
out_csv = "results/tables/table1.csv"
TABLE = 1

# %%
from mshbm_workflow import tables
from IPython.display import Markdown, display

# %%
display(Markdown(tables.build(config, summaries, TABLE, out_md, out_csv)))
