# Reproduction of Schreyer & Leine (2016): every figure, table, rendered notebook and the paper.
#
#   snakemake --cores 2                                         # full run -> results/
#   snakemake --cores 2 --configfile workflow/config-quick.yaml  # quick run -> results/quick/
#   snakemake --cores 2 reproduction                            # the paper's outputs only
#
# This file is an index only: configuration, its validation, the rule files, the target.
# Rules live in workflow/rules/*.smk (all included, in sorted order: drop a new file there).
from pathlib import Path

from snakemake.utils import min_version, validate

min_version("9.0")


configfile: "workflow/config.yaml"


validate(config, "workflow/schemas/config.schema.yaml")


for _rules in sorted(Path(workflow.basedir, "workflow", "rules").glob("*.smk")):

    include: str(_rules)


rule all:
    default_target: True
    input:
        all_targets(),


# The reproduction of the paper only (without targets other rule files add to EXTRA_TARGETS).
rule reproduction:
    input:
        reproduction_targets(),
