#!/bin/bash
# Coatlab's batch renders on a real scheduler: starts a one-node Slurm cluster on
# this machine (Debian's slurm-wlm and munge), then
#  1. submits a 20-task review deck as an array job with benches/cluster/slurm-array.sh,
#     kills one task's renderer on purpose (SIGKILL) and lets Slurm requeue it
#     (RequeueExit=137), and checks the deck: every output and sidecar there, a
#     second `batch run` finds all 20 up to date, `batch report` writes the deck
#     with nothing missing;
#  2. renders one 1024-sample image as 8 array tasks of 128 samples
#     (benches/cluster/slurm-film-parts.sh, --sample-range) plus a merge job that
#     depends on them (--dependency=afterok), and checks that the merged image is
#     bit-identical to a single-process render.
# Its last line says what it checked. Not part of CI: it needs root, installs
# packages and starts daemons; it stops the daemons it started when it ends.
#
#   sudo benches/cluster/slurm-local.sh            # the build in target/ (release, else debug)
#   COATLAB=/path/to/coatlab benches/cluster/slurm-local.sh
#
# Facts it builds on (Debian 12, root, no systemd): /work/shared/docs/slurm-local.md.
# Sizes are small so that it runs in minutes on a busy 2-core machine; set
# DECK_SIZE, DECK_SPP, FILM_SIZE to change them.
set -euo pipefail

here=$(cd "$(dirname "$0")" && pwd)
repo=$(cd "$here/../.." && pwd)
DECK_SIZE=${DECK_SIZE:-160x90}
DECK_SPP=${DECK_SPP:-16}
FILM_SIZE=${FILM_SIZE:-48x27}
FILM_SPP=1024
FILM_TASKS=8
KILL_TASK=${KILL_TASK:-5}

say() { echo "slurm-local: $*"; }
die() { echo "slurm-local: FAILED: $*" >&2; exit 1; }

[ "$(id -u)" -eq 0 ] || die "run as root (it installs packages and starts slurmctld, slurmd, munged)"

if [ -z "${COATLAB:-}" ]; then
  for build in release debug; do
    if [ -x "$repo/target/$build/coatlab" ]; then COATLAB="$repo/target/$build/coatlab"; break; fi
  done
fi
[ -n "${COATLAB:-}" ] && [ -x "$COATLAB" ] || die "no coatlab binary: cargo build --release, or set COATLAB"
export COATLAB
say "coatlab: $COATLAB ($("$COATLAB" --version 2>/dev/null || echo '?'))"

if ! command -v slurmctld >/dev/null || ! command -v munged >/dev/null; then
  say "installing slurm-wlm and munge"
  DEBIAN_FRONTEND=noninteractive apt-get install -y --no-install-recommends slurm-wlm munge >/dev/null
fi

WORK=${WORK:-$(mktemp -d /tmp/coatlab-slurm.XXXXXX)}
mkdir -p "$WORK/slurm/state" "$WORK/slurm/spool" "$WORK/slurm/log" "$WORK/pids"
chmod 755 "$WORK"
say "working in $WORK"

# --- munge: reuse a running munged, else start one (and stop it at the end) ---
started_munged=""
munged_pid_file=/run/munge/munged.pid
running() { [ -f "$1" ] && kill -0 "$(cat "$1")" 2>/dev/null; }
if ! running "$munged_pid_file"; then
  mkdir -p /etc/munge /var/lib/munge /var/log/munge /run/munge
  if [ ! -s /etc/munge/munge.key ]; then
    dd if=/dev/urandom of=/etc/munge/munge.key bs=1024 count=1 status=none
  fi
  chown munge:munge /etc/munge /etc/munge/munge.key /var/lib/munge /var/log/munge /run/munge
  chmod 0400 /etc/munge/munge.key
  su -s /bin/sh munge -c /usr/sbin/munged
  started_munged=yes
  for _ in $(seq 50); do running "$munged_pid_file" && break; sleep 0.1; done
fi
munge -n | unmunge | grep -q 'STATUS: *Success' || die "munge does not work"

# --- slurm: a config of our own (SLURM_CONF), daemons stopped by their pid files ---
node=$(hostname -s)
mem_mb=$(awk '/MemTotal/ { print int($2 / 1024) - 512 }' /proc/meminfo)
export SLURM_CONF="$WORK/slurm/slurm.conf"
cat >"$SLURM_CONF" <<CONF
ClusterName=coatlab-local
SlurmctldHost=$node
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
StateSaveLocation=$WORK/slurm/state
SlurmdSpoolDir=$WORK/slurm/spool
SlurmctldPidFile=$WORK/slurm/slurmctld.pid
SlurmdPidFile=$WORK/slurm/slurmd.pid
SlurmctldLogFile=$WORK/slurm/log/slurmctld.log
SlurmdLogFile=$WORK/slurm/log/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
ReturnToService=2
MpiDefault=none
# A task whose script exits 137 (its renderer killed by SIGKILL) is requeued.
RequeueExit=137
# Finished jobs stay visible to scontrol for this long (no accounting database here).
MinJobAge=3600
NodeName=$node CPUs=$(nproc) RealMemory=$mem_mb State=UNKNOWN
PartitionName=local Nodes=$node Default=YES MaxTime=INFINITE State=UP
CONF

stop() {
  local status=$?
  for daemon in slurmd slurmctld; do
    local pid_file="$WORK/slurm/$daemon.pid"
    if running "$pid_file"; then kill "$(cat "$pid_file")" 2>/dev/null || true; fi
  done
  sleep 1
  if [ -n "$started_munged" ] && running "$munged_pid_file"; then
    kill "$(cat "$munged_pid_file")" 2>/dev/null || true
  fi
  [ "$status" -eq 0 ] || echo "slurm-local: logs in $WORK/slurm/log and $WORK/*.log" >&2
}
trap stop EXIT

slurmctld -f "$SLURM_CONF"
slurmd -f "$SLURM_CONF"
for _ in $(seq 60); do
  sinfo -h -o %t 2>/dev/null | grep -qE '^idle' && break
  sleep 1
done
sinfo -h -o %t | grep -qE '^idle' || die "the node did not come up idle: $(sinfo 2>&1)"
say "cluster up: $(sinfo -h -o '%P %D node, %c CPUs, %t')"

# Waits for job $1 (all its array tasks) to leave the queue, at most $2 seconds.
wait_for() {
  local job=$1 limit=$2 waited=0
  while [ -n "$(squeue -h -j "$job" 2>/dev/null)" ]; do
    [ "$waited" -lt "$limit" ] || die "job $job still queued after ${limit} s: $(squeue -j "$job")"
    sleep 2; waited=$((waited + 2))
  done
}
# The state Slurm records of job $1 (e.g. 1_5) in field $2 (JobState, Restarts, ExitCode).
job_field() { scontrol show job "$1" | tr ' ' '\n' | sed -n "s/^$2=//p" | head -1; }

# === 1. A 20-task deck as an array job, one task killed and requeued ===
deck="$WORK/deck"
mkdir -p "$deck"
for preset in signal-red deep-blue racing-green silver-grey sunflower-yellow; do
  cp "$repo/assets/presets/$preset.toml" "$deck/"
done
cp "$repo/assets/presets/signal-red.toml" "$deck/standard.toml"
cat >"$deck/review.toml" <<TOML
format = "coatlab-batch"
version = 1
output = "out"
designs = ["signal-red.toml", "deep-blue.toml", "racing-green.toml", "silver-grey.toml",
           "sunflower-yellow.toml"]
lighting = ["studio", "booth-d65", "booth-a", "booth-f11"]
spp = $DECK_SPP
wavelengths = 8
size = "$DECK_SIZE"
target = "standard.toml"
TOML
tasks=$("$COATLAB" batch plan "$deck/review.toml" --json | grep -c '"index"')
[ "$tasks" -eq 20 ] || die "the deck has $tasks tasks, not 20"

export COATLAB_TASK_PIDS="$WORK/pids"
start_s=$(date +%s.%N)
deck_job=$(sbatch --parsable --array=0-19 --cpus-per-task=1 --chdir="$WORK" \
  --output="$WORK/deck-%A_%a.log" "$here/slurm-array.sh" "$deck/review.toml")
say "deck: array job $deck_job, 20 tasks"

# Kill the renderer of task KILL_TASK on its first attempt, as soon as it runs.
first_attempt="$WORK/pids/task-$KILL_TASK.attempt-0"
# At these sizes a task lasts about a second: poll often and kill at once.
for _ in $(seq 6000); do [ -s "$first_attempt" ] && break; sleep 0.05; done
[ -s "$first_attempt" ] || die "task $KILL_TASK did not start"
victim=$(cat "$first_attempt")
if kill -0 "$victim" 2>/dev/null; then
  kill -KILL "$victim"
  say "deck: killed task $KILL_TASK's renderer (pid $victim) mid-task"
else
  die "task $KILL_TASK finished before it could be killed; set DECK_SIZE larger"
fi

wait_for "$deck_job" 3600
end_s=$(date +%s.%N)

restarts=$(job_field "${deck_job}_$KILL_TASK" Restarts)
[ "${restarts:-0}" -ge 1 ] || die "task $KILL_TASK was not requeued (Restarts=${restarts:-?})"
[ -s "$WORK/pids/task-$KILL_TASK.attempt-1" ] || die "no second attempt of task $KILL_TASK ran"
for i in $(seq 0 19); do
  state=$(job_field "${deck_job}_$i" JobState)
  [ "$state" = COMPLETED ] || die "task $i ended $state (log: $WORK/deck-${deck_job}_$i.log)"
done
say "deck: all 20 tasks COMPLETED; task $KILL_TASK restarted $restarts time(s) by Slurm"

images=$(find "$deck/out" -maxdepth 1 -name '*.png' | wc -l)
sidecars=$(find "$deck/out" -maxdepth 1 -name '*.png.json' | wc -l)
[ "$images" -eq 20 ] && [ "$sidecars" -eq 20 ] || die "deck: $images images and $sidecars sidecars, not 20 and 20"
leftover=$(find "$deck/out" -maxdepth 1 -name '.*.tmp' | wc -l)
# Every sidecar names its own image, and that image's hash.
for sidecar in "$deck/out"/*.png.json; do
  image="${sidecar%.json}"
  want=$(sed -n 's/^  "image_sha256": "\([0-9a-f]*\)",$/\1/p' "$sidecar")
  have=$(sha256sum "$image" | cut -d' ' -f1)
  [ "$want" = "$have" ] || die "$sidecar: image_sha256 $want, but $(basename "$image") hashes to $have"
done
# And coatlab itself finds every output up to date with its inputs.
rerun=$("$COATLAB" batch run "$deck/review.toml" --jobs 1)
skipped=$(grep -c 'up to date, skipped' <<<"$rerun" || true)
[ "$skipped" -eq 20 ] || die "a second batch run did not skip all 20: $rerun"
report=$("$COATLAB" batch report "$deck/review.toml")
grep -q '20 tasks, 20 rendered, 0 missing, 0 out of date' <<<"$report" || die "batch report: $report"
[ -s "$deck/out/index.html" ] || die "no deck page"
say "deck: 20 images and sidecars consistent, a second run skipped all 20; $report"
[ "$leftover" -eq 0 ] || say "deck: $leftover temporary file(s) of the killed attempt left (hidden, never read)"

# Figures: tasks per hour through the scheduler (all 20 with the requeue, and
# the 19 never killed: Slurm holds a requeued task back for a while before it
# starts it again), the requeue's wait, and each task's own time.
wall=$(awk -v a="$start_s" -v b="$end_s" 'BEGIN { printf "%.1f", b - a }')
per_hour=$(awk -v w="$wall" 'BEGIN { printf "%.0f", 20 * 3600 / w }')
last_unkilled=$(for sidecar in "$deck/out"/*.png.json; do
    grep -q "^  \"task\": $KILL_TASK,\$" "$sidecar" && continue
    sed -n 's/^  "finished_unix_s": \([0-9]*\),$/\1/p' "$sidecar"
  done | sort -n | tail -1)
wall19=$(awk -v a="$start_s" -v b="$last_unkilled" 'BEGIN { w = b - a; printf "%.0f", w < 1 ? 1 : w }')
per_hour19=$(awk -v w="$wall19" 'BEGIN { printf "%.0f", 19 * 3600 / w }')
requeue_wait=$(( $(stat -c %Y "$WORK/pids/task-$KILL_TASK.attempt-1") - $(stat -c %Y "$first_attempt") ))
mean_task=$(cat "$deck/out"/*.png.json | sed -n 's/^  "seconds": \([0-9.e+-]*\),$/\1/p' \
  | awk '{ s += $1; n += 1 } END { printf "%.2f", s / n }')
# The fixed cost of a task (start, loading, BVH, lighting tables, writing): the
# same task at 1 spp against DECK_SPP, from the sidecars' seconds.
one="$WORK/one-spp"
mkdir -p "$one"
cp "$deck"/signal-red.toml "$deck"/deep-blue.toml "$one/"
sed -e "s/^spp = .*/spp = 1/" -e '/^target/d' \
  -e 's/^designs = .*/designs = ["signal-red.toml", "deep-blue.toml"]/' -e '/^ *"sunflower/d' \
  -e 's/^lighting = .*/lighting = ["studio"]/' "$deck/review.toml" >"$one/review.toml"
"$COATLAB" batch run "$one/review.toml" --jobs 1 >/dev/null
t1=$(cat "$one/out"/*.png.json | sed -n 's/^  "seconds": \([0-9.e+-]*\),$/\1/p' \
  | awk '{ s += $1; n += 1 } END { print s / n }')
tn=$(grep -h '^  "seconds"' "$deck/out"/signal-red--*--studio--paint.png.json \
  "$deck/out"/deep-blue--*--studio--paint.png.json \
  | sed -n 's/^  "seconds": \([0-9.e+-]*\),$/\1/p' | awk '{ s += $1; n += 1 } END { print s / n }')
fixed=$(awk -v a="$t1" -v b="$tn" -v n="$DECK_SPP" 'BEGIN { f = (n * a - b) / (n - 1); printf "%.2f", f < 0 ? 0 : f }')
load=$(cut -d' ' -f1-3 /proc/loadavg)
say "deck figures: 20 tasks ($DECK_SIZE, $DECK_SPP spp, 8 wavelengths) in $wall s through Slurm on $(nproc) cores = $per_hour tasks/hour, of which task $KILL_TASK's requeue waited ${requeue_wait} s; the 19 never killed in ${wall19} s = $per_hour19 tasks/hour; mean task ${mean_task} s; fixed cost of a task ≈ ${fixed} s (1 spp ${t1} s vs $DECK_SPP spp ${tn} s); load average $load"

# === 2. One 1024-sample image as 8 array tasks plus a merge job ===
film="$WORK/film"
mkdir -p "$film"
cp "$repo/assets/presets/deep-blue.toml" "$film/"
flags=(--design "$film/deep-blue.toml" --size "$FILM_SIZE" --wavelengths 8 --seed 7)
parts_job=$(sbatch --parsable --array=0-$((FILM_TASKS - 1)) --cpus-per-task=1 --chdir="$film" \
  --output="$WORK/film-%A_%a.log" "$here/slurm-film-parts.sh" "$film/parts" "$FILM_SPP" "$FILM_TASKS" "${flags[@]}")
merge_job=$(sbatch --parsable --dependency=afterok:"$parts_job" --chdir="$film" \
  --output="$WORK/merge-%j.log" \
  --wrap "$(printf '%q ' "$COATLAB" merge) $film/parts/part-*.film --out $film/merged.exr")
say "film: $FILM_TASKS part tasks (job $parts_job), merge job $merge_job after them"
# Meanwhile, the reference: one process, all 1024 samples (outside Slurm).
"$COATLAB" render "${flags[@]}" --spp "$FILM_SPP" --out "$film/single.exr" >"$WORK/single.log" 2>&1
wait_for "$parts_job" 3600
wait_for "$merge_job" 600
[ "$(job_field "$merge_job" JobState)" = COMPLETED ] || die "the merge job ended $(job_field "$merge_job" JobState): $(cat "$WORK/merge-$merge_job.log")"
parts=$(find "$film/parts" -name 'part-*.film' | wc -l)
[ "$parts" -eq "$FILM_TASKS" ] || die "film: $parts parts, not $FILM_TASKS"
cmp "$film/merged.exr" "$film/single.exr" || die "film: the merged image differs from the single render"
say "film: merged.exr = single.exr, bit for bit ($(stat -c %s "$film/merged.exr") bytes)"

say "checked: a one-node Slurm cluster ran a 20-task deck as an array (task $KILL_TASK killed and requeued by Slurm, 20 outputs with consistent sidecars, all up to date on a rerun, report written with 0 missing) and a $FILM_SPP-spp $FILM_SIZE render as $FILM_TASKS array tasks merged after them (afterok) bit-identical to one process; $per_hour19 tasks/hour at $DECK_SIZE/$DECK_SPP spp without the requeue, load $load"
