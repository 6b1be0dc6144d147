#!/bin/sh
# A local stand-in for a batch scheduler's submit command, for Snakemake's cluster-generic executor
# (tests/integration/test_cluster.py):
#
#   submit.sh RULE THREADS MEM_MB RUNTIME_MIN JOBSCRIPT
#
# Like sbatch it refuses a job without declared resources, records the submission in
# cluster-ledger.tsv (rule, threads, mem_mb, runtime), starts the job script as a process of its own
# (in the background, its output in cluster-logs/, the declared runtime as a hard limit) and prints a job
# id.  The job script runs Snakemake for that one job, from the files in the working directory only.
set -eu
rule=$1 threads=$2 mem_mb=$3 runtime=$4 jobscript=$5
for value in "$threads" "$mem_mb" "$runtime"; do
    case $value in
        '' | *[!0-9]* | 0) echo "submit.sh: job of rule $rule: resource '$value' is not a positive integer" >&2; exit 1 ;;
    esac
done
mkdir -p cluster-logs
printf '%s\t%s\t%s\t%s\n' "$rule" "$threads" "$mem_mb" "$runtime" >> cluster-ledger.tsv
log="cluster-logs/$(basename "$jobscript").log"
nohup timeout "${runtime}m" sh "$jobscript" > "$log" 2>&1 < /dev/null &
echo "$!"
