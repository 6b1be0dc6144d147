# The reproduction workflow of this repository: every figure and table, the executed notebooks, the
# paper, the stress suite, the benchmarks and the finite-element example.  Its index is workflow/Snakefile
# (the Snakemake workflow template's layout: workflow/rules, workflow/scripts/<stage>, workflow/lib,
# workflow/schemas, workflow/envs); it lists the targets.
#
#   snakemake --cores 2                                         # everything the paper shows -> results/
#   snakemake --cores 2 --configfile workflow/config-quick.yaml  # quick run -> results/quick/
#   snakemake -n                                                # what would run


include: "workflow/Snakefile"


# `snakemake` without a target: rule `all` of workflow/Snakefile (the default target of an included file
# does not carry over to the file that includes it)
rule default:
    default_target: True
    input:
        rules.all.input,
