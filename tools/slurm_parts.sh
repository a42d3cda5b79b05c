#!/usr/bin/env bash
# One task of a Slurm array job that splits a `dualhair render` or `dualhair converge` run into
# parts (`--part K/N`, K = the task's index); `dualhair merge` then adds the parts up, bit for bit
# the run one machine would make. docs/usage.md, "Interrupting, resuming and splitting a render".
#
#   JOB=$(sbatch --parsable --array=1-8 tools/slurm_parts.sh render parts scenes/default.json --spp 4096)
#   sbatch --dependency=afterok:$JOB --wrap "dualhair merge parts/part-*-of-8.exr -o render.exr"
#
#   JOB=$(sbatch --parsable --array=1-8 tools/slurm_parts.sh converge runs scenes/brown.json --methods dual-importance,path-importance)
#   sbatch --dependency=afterok:$JOB --wrap "dualhair merge runs/part-*-of-8 -o converge-out"
#
# Arguments: COMMAND (render or converge), OUTDIR (shared by the tasks), then the command's own
# arguments (scene and flags, the same for every task). Each task writes OUTDIR/part-K-of-N.exr
# (render) or the folder OUTDIR/part-K-of-N (converge). Renders run with --resume: a task that is
# requeued after preemption or a time limit (Slurm sends SIGTERM first, and the render then writes
# its finished passes) continues where it stopped. DUALHAIR names the program (default: dualhair
# on PATH). Outside Slurm, set SLURM_ARRAY_TASK_ID and SLURM_ARRAY_TASK_COUNT yourself.
#SBATCH --job-name=dualhair-parts
#SBATCH --cpus-per-task=16
#SBATCH --requeue
#SBATCH --output=dualhair-parts-%A_%a.log
set -euo pipefail
if [ $# -lt 2 ]; then
    echo "usage: sbatch --array=1-N $0 render|converge OUTDIR SCENE [FLAGS...]" >&2
    exit 2
fi
command=$1
outdir=$2
shift 2
k=${SLURM_ARRAY_TASK_ID:?not an array task: submit with sbatch --array=1-N}
n=${SLURM_ARRAY_TASK_COUNT:-${SLURM_ARRAY_TASK_MAX:?cannot tell the number of tasks}}
threads=${SLURM_CPUS_PER_TASK:-0}
program=${DUALHAIR:-dualhair}
mkdir -p "$outdir"
case $command in
render)
    exec "$program" render "$@" --part "$k/$n" --threads "$threads" --resume -q -o "$outdir/part-$k-of-$n.exr"
    ;;
converge)
    exec "$program" converge "$@" --part "$k/$n" --threads "$threads" -q -o "$outdir/part-$k-of-$n"
    ;;
*)
    echo "$0: COMMAND must be render or converge, not '$command'" >&2
    exit 2
    ;;
esac
