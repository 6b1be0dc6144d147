"""Run a workflow script that has a command line as the `script:` of a rule (rules stress, bench_*,
intermediate_demo).

These scripts are also run by hand (``python workflow/scripts/stress/stress.py --quick ...``), so their
interface is ``main(argv)``, which returns an exit code (stress.py) or the data it wrote (the
benchmarks).  Under Snakemake the rule names the script as
``input.script`` (a change of it reruns the job) and its command line as ``params.argv``; this file
imports the script as a module and calls ``main(params.argv)`` in the job's own interpreter (the one
running Snakemake, with mshbm installed: no ``{python}`` parameter, no shell).  Everything the script
and its child processes print goes to the rule's log (the scripts import their helpers from the package
``mshbm_workflow``, workflow/lib); an exception or an integer return value other
than 0 fails the job.  The rules' ``message`` is the equivalent command line (shown by ``snakemake -n``).
"""
import importlib.util
import os
import sys
from pathlib import Path


def run(script, argv, log):
    script = Path(script).resolve()
    sys.argv = [str(script), *argv]
    with open(log, "w", encoding="utf-8") as logf:
        # file descriptors, not sys.stdout: child processes (worker pools, other interpreters) log too
        sys.stdout.flush()
        sys.stderr.flush()
        os.dup2(logf.fileno(), 1)
        os.dup2(logf.fileno(), 2)
        spec = importlib.util.spec_from_file_location(script.stem, script)
        module = importlib.util.module_from_spec(spec)
        sys.modules[script.stem] = module  # picklable functions for forked worker pools
        spec.loader.exec_module(module)
        code = module.main(argv)
        sys.stdout.flush()
        sys.stderr.flush()
    if isinstance(code, int) and not isinstance(code, bool) and code != 0:
        sys.exit(f"{script.name} {' '.join(argv)} exited with code {code} (log: {log})")


run(snakemake.input.script, [str(a) for a in snakemake.params.argv], snakemake.log[0])  # noqa: F821
