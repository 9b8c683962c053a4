#!/bin/bash
# One long render split by sample index over a Slurm array: task i of COUNT
# renders sample indices [i·SPP/COUNT, (i+1)·SPP/COUNT) into PARTS/part-i.film;
# a merge job that depends on the array adds them (docs/batch.md, "film parts"):
#
#   job=$(sbatch --parsable --array=0-7 slurm-film-parts.sh parts 1024 8 \
#           --design paint.toml --size 960x540)
#   sbatch --dependency=afterok:$job --wrap "coatlab merge parts/part-*.film --out final.exr"
#
# The merged image is bit-identical to one process rendering all SPP samples with
# the same seed and flags.
#SBATCH --job-name=coatlab-film
#SBATCH --cpus-per-task=8
#SBATCH --requeue
#SBATCH --output=coatlab-film-%A_%a.log
set -eu
PARTS=${1:?usage: slurm-film-parts.sh PARTS SPP COUNT RENDER-FLAGS…}
SPP=${2:?samples per pixel of the whole image}
COUNT=${3:?how many array tasks (give sbatch --array=0-(COUNT-1))}
shift 3
COATLAB=${COATLAB:-coatlab}
i=${SLURM_ARRAY_TASK_ID:?run as a Slurm array task}
first=$(( i * SPP / COUNT ))
end=$(( (i + 1) * SPP / COUNT ))
mkdir -p "$PARTS"
exec "$COATLAB" render "$@" --spp "$SPP" --sample-range "$first..$end" --out "$PARTS/part-$i.film"
