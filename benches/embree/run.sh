#!/usr/bin/env bash
# Coatlab's BVH and Intel Embree 4 on the same machine, triangles and rays, in turn.
# See README.md. Usage: benches/embree/run.sh [ROUNDS]   (WORK=folder, default
# target/embree; ACCEL_MESH=substring restricts the meshes, as in the accel bench;
# SIMD_PATHS="avx2 avx512 portable" runs Coatlab's side on each of those paths in
# every round, default: the path Coatlab chooses itself; ACCEL_FILTER=Simd8/Fast adds
# Coatlab's trees without spatial splits, like Embree's `medium` and `robust` ones;
# benches/embree/ratios.py reads the output)
set -euo pipefail
cd "$(dirname "$0")/../.."
rounds="${1:-2}"
trees="${ACCEL_FILTER:-Simd8/Fast/Spatial}"
work="${WORK:-target/embree}"
mkdir -p "$work"

if [ ! -x "$work/venv/bin/python" ]; then
  python3 -m venv "$work/venv"
fi
"$work/venv/bin/pip" install --quiet --no-deps -r benches/embree/requirements.txt
site="$("$work/venv/bin/python" -c 'import sysconfig; print(sysconfig.get_paths()["purelib"])')"
libdir="$site/embreex.libs"
lib="$(ls "$libdir"/libembree4-*.so.4)"
# Embree 4.4.0's own headers, as the wheel's library (4.4.0) was built with them:
# checked against their recorded SHA-256 sums, and the library's version is checked
# against them at start-up (embree_rays.c).
(cd vendor/embree4/include && sha256sum --check --quiet SHA256SUMS)
cc -O2 -Wall -Werror -I vendor/embree4/include -o "$work/embree_rays" \
  benches/embree/embree_rays.c "$lib" -Wl,-rpath,"$libdir" -lpthread -lm

# The bench binary itself, so that the rounds below run it without cargo.
bench="$(cargo bench -p coatlab-core --bench accel --no-run --message-format=json 2>/dev/null |
  "$work/venv/bin/python" -c 'import json, sys
for line in sys.stdin:
    m = json.loads(line)
    if m.get("reason") == "compiler-artifact" and m["target"]["name"] == "accel" and m.get("executable"):
        print(m["executable"])')"
ACCEL_DUMP="$work/dump" "$bench" >/dev/null

for round in $(seq "$rounds"); do
  echo "== round $round, load $(cut -d' ' -f1-3 /proc/loadavg)"
  for simd in ${SIMD_PATHS:-default}; do
    if [ "$simd" = default ]; then
      ACCEL_SUMMARY=1 ACCEL_FILTER="$trees" "$bench" 2>/dev/null | grep -v -- "---"
    else
      echo "-- Coatlab on its $simd path (COATLAB_SIMD=$simd)"
      COATLAB_SIMD="$simd" ACCEL_SUMMARY=1 ACCEL_FILTER="$trees" "$bench" 2>/dev/null |
        grep -v -- "---"
    fi
  done
  for mesh in "$work"/dump/*.bin; do
    # Every mode available (rtcIntersect1, 8, and 16 where the CPU has AVX-512).
    for quality in medium high; do
      "$work/embree_rays" "$mesh" "$quality" fast 2
    done
    "$work/embree_rays" "$mesh" high robust 2
  done
done
echo "== load after: $(cut -d' ' -f1-3 /proc/loadavg)"
