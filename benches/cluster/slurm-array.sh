#!/bin/bash
# One task of a Coatlab review deck as a Slurm array task. Submit with one array
# index per task of the manifest (their number: `coatlab batch plan MANIFEST`):
#
#   sbatch --array=0-719 benches/cluster/slurm-array.sh /shared/review/review.toml
#   sbatch --array=0-719%50 …        # at most 50 at once
#
# Slurm sets SLURM_ARRAY_TASK_ID in each task, which `coatlab batch run` reads
# (docs/batch.md). The manifest's folder and its output folder must be on a file
# system every node sees. A task whose output is already up to date is skipped,
# so a resubmitted or requeued array redoes only what is missing.
#SBATCH --job-name=coatlab-deck
#SBATCH --cpus-per-task=8
#SBATCH --requeue
#SBATCH --output=coatlab-deck-%A_%a.log
set -u
MANIFEST=${1:?usage: sbatch --array=0-N slurm-array.sh MANIFEST}
COATLAB=${COATLAB:-coatlab}

# Not `exec`: the script outlives coatlab so that a task killed by a signal
# exits with 128+signal, a status slurm.conf's RequeueExit can name (a crashed
# or killed worker is then requeued by Slurm, not lost).
"$COATLAB" batch run "$MANIFEST" &
child=$!
# COATLAB_TASK_PIDS (optional): a folder to record each attempt's process id in,
# one file per task and attempt; benches/cluster/slurm-local.sh uses it to kill
# one task on purpose.
if [ -n "${COATLAB_TASK_PIDS:-}" ]; then
  echo "$child" >"$COATLAB_TASK_PIDS/task-$SLURM_ARRAY_TASK_ID.attempt-${SLURM_RESTART_COUNT:-0}"
fi
wait "$child"
