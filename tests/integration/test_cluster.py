"""The workflow through a real executor plugin: every job runs on its own, from files alone.

Snakemake's cluster-generic executor (snakemake-executor-plugin-cluster-generic, pinned in
environment.txt) submits each job as a job script through a submit command, as it would with SLURM's
sbatch; here the command is tests/cluster/submit.sh, which starts the job script as a process of its
own on this machine.  Each job is then a separate Snakemake process that sees nothing but the files of
the working directory (a temporary copy of the workflow, tests/workflow_run.py).

The target is a representative chain of the quick configuration: Fig. 3 (the configuration snapshot,
its solves with full shooting, HBM and MS-HBM, its summary, its notebook).  The test checks that the
chain completes, that every job went through the submit command with the resources its rule declares,
and that the figure's numbers match the stored references of the quick workflow
(tests/reference/quick.json), as those of the local run do (tests/integration/test_workflow.py).

The declared resources are read from the run's own job records (Snakemake prints each job's rule, threads
and resources as it submits it), not from a separate dry run.  Up to 4 jobs run at once: the snapshot and
four solves are ready together, HBM's solve waits for its fallback solutions, then come the summary and the
notebook.  Each job costs about 2 s of CPU on its own (a Snakemake process that parses the workflow) besides
its script: the cluster run spends most of its time in these processes, not in the solves.
"""
import re

import pytest
from workflow_run import QUICK, ROOT, copy_workflow, reference_failures, run

SUBMIT = ROOT / "tests" / "cluster" / "submit.sh"
TARGET = ["results/quick/figures/fig3.png", "results/quick/notebooks/fig3.html"]
#: the rules of the chain
RULES = {"config_snapshot", "solve", "summary", "notebook"}


def _cluster_args():
    submit = f"sh {SUBMIT} {{rule}} {{threads}} {{resources.mem_mb}} {{resources.runtime}}"
    return ["--executor", "cluster-generic", "--cluster-generic-submit-cmd", submit, "--jobs", "4",
            "--latency-wait", "30", "--seconds-between-status-checks", "1"]


def declared_resources(log):
    """(threads, mem_mb, runtime) of each rule, as the rule files declare them (printed by Snakemake with every
    job it plans or submits)."""
    out = {}
    for block in re.split(r"^(?=rule \w+:$)", log, flags=re.M)[1:]:
        block = block.split("\n[", 1)[0].split("\n\n", 1)[0]  # up to the next job's time stamp
        m = re.match(r"rule (\w+):$", block, re.M)
        res = re.search(r"^\s+resources: (.*)$", block, re.M)
        if m and res:
            kv = dict(item.split("=", 1) for item in res.group(1).split(", "))
            threads = re.search(r"^\s+threads: (\d+)$", block, re.M)
            out[m.group(1)] = (int(threads.group(1)) if threads else 1, int(kv["mem_mb"]), int(kv["runtime"]))
    return out


@pytest.fixture(scope="module")
def cluster_run(tmp_path_factory):
    wd = copy_workflow(tmp_path_factory.mktemp("cluster"))
    proc = run(TARGET + _cluster_args() + QUICK, wd, timeout=900)
    logs = "\n".join(p.read_text()[-2000:] for p in sorted((wd / "cluster-logs").glob("*.log"))) \
        if (wd / "cluster-logs").exists() else ""
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:] + logs
    declared = declared_resources(proc.stdout + proc.stderr)
    assert set(declared) == RULES, declared
    return wd, proc.stdout + proc.stderr, declared


@pytest.mark.slow
def test_every_job_is_submitted_with_its_declared_resources(cluster_run):
    wd, out, declared = cluster_run
    ledger = [line.split("\t") for line in (wd / "cluster-ledger.tsv").read_text().splitlines()]
    rules = [row[0] for row in ledger]
    assert set(rules) == RULES, rules
    assert rules.count("notebook") == 1 and rules.count("summary") == 1 and rules.count("config_snapshot") == 1
    assert rules.count("solve") >= 4  # reference and timed full shooting, HBM, MS-HBM
    for rule, threads, mem_mb, runtime in ledger:
        assert (int(threads), int(mem_mb), int(runtime)) == declared[rule], rule
    # every job ran as its own process (one job script and one external job id each)
    submitted = re.findall(r"Submitted job \d+ with external jobid '(\d+)'", out)
    assert len(submitted) == len(ledger) and len(set(submitted)) == len(ledger), out[-3000:]
    assert len(list((wd / "cluster-logs").glob("*.log"))) == len(ledger)


@pytest.mark.slow
def test_cluster_outputs_match_the_references(cluster_run):
    wd, _, _ = cluster_run
    assert (wd / TARGET[0]).stat().st_size > 1000
    assert "<html" in (wd / TARGET[1]).read_text()[:2000].lower()
    failures = reference_failures(wd / "results" / "quick" / "summary", figures={"fig3"})
    assert not failures, "\n".join(failures)
