"""Write the validated, merged configuration (without results_dir) as JSON for notebooks and the paper."""
import math

from mshbm_workflow.wfcore import write_json

smk = snakemake  # noqa: F821
with open(smk.log[0], "w") as log:
    cfg = dict(smk.params.config)
    cfg["omega"] = float(cfg["omega_over_pi"]) * math.pi
    write_json(smk.output[0], cfg)
    print(f"wrote {smk.output[0]}", file=log)
