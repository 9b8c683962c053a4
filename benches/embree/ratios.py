#!/usr/bin/env python3
"""Coatlab ÷ Embree, round by round, from the output of run.sh.

Usage: benches/embree/run.sh 2 > run.log; benches/embree/ratios.py run.log

For each round, mesh and ray set (incoherent rays, image-order bounces), Embree's
best mode of each scene setting (`medium`, `high`, `robust`: the best of its
single and packet modes) and of `medium` and `high` together (its best mode, which
is never `robust`), and each Coatlab row of that round (SIMD path × tree) divided
by each of them: through the batch, and for the bounces one by one as well.
Embree's `robust` scene is its watertight mode; whatever quality it is asked for,
Embree builds it the tree of `medium` (no spatial splits), so Coatlab's tree without
spatial splits (`ACCEL_FILTER=Simd8/Fast` in run.sh) is the like-for-like one there.
"""

import re
import sys

COATLAB_PATH = re.compile(r"-- Coatlab on its (\w+) path")
EMBREE_ROW = re.compile(
    r".*/(?P<mesh>[^/]+)\.bin \| \d+ triangles \| embree (?P<quality>\w+) "
    r"(?P<robust>robust )?(?P<mode>\w+) \| \d+ threads \| build (?P<build>[\d.]+) ms \| "
    r"incoherent (?P<incoherent>[\d.]+) M/s .*\| image-order bounce (?P<bounce>[\d.]+) M/s"
)
# The dump's file names for the summary's mesh names.
MESH_NAMES = {"default-car": "default car"}
# The summary's columns (0-based, after the leading `|`).
COLUMN = {"build": 4, "incoherent": 9, "bounce": 12, "bounce one by one": 13}


def read(lines):
    """The rounds: for each, Coatlab's rows by (path, tree, mesh) and Embree's
    rates by (mesh, scene setting, mode)."""
    rounds = []
    path = "default"
    for line in lines:
        if line.startswith("== round"):
            rounds.append({"coatlab": {}, "embree": {}})
            path = "default"
            continue
        if not rounds:
            continue
        found = COATLAB_PATH.match(line)
        if found:
            path = found.group(1)
            continue
        if line.startswith("| ") and "Simd8" in line:
            cells = [c.strip() for c in line.strip().strip("|").split("|")]
            tree = cells[2].removesuffix(" (default)")
            rates = {name: float(cells[i]) for name, i in COLUMN.items()}
            rounds[-1]["coatlab"][(path, tree, cells[0])] = rates
            continue
        found = EMBREE_ROW.match(line)
        if found:
            mesh = MESH_NAMES.get(found["mesh"], found["mesh"])
            setting = "robust" if found["robust"] else found["quality"]
            rates = {k: float(found[k]) for k in ("build", "incoherent", "bounce")}
            rounds[-1]["embree"][(mesh, setting, found["mode"])] = rates
    return rounds


def best(embree, mesh, settings, key):
    """Embree's best rate of `key` on `mesh` over `settings` and every mode."""
    rates = [
        (rates[key], f"{setting} {mode}")
        for (m, setting, mode), rates in embree.items()
        if m == mesh and setting in settings
    ]
    return max(rates) if rates else None


def main(path):
    with open(path, encoding="utf-8") as log:
        rounds = read(log)
    if not rounds:
        sys.exit(f"{path}: no '== round' line: not the output of benches/embree/run.sh")
    bars = [
        ("best", {"medium", "high"}),
        ("medium", {"medium"}),
        ("high", {"high"}),
        ("robust", {"robust"}),
    ]
    for number, found in enumerate(rounds, 1):
        print(f"round {number}")
        meshes = dict.fromkeys(mesh for (_, _, mesh) in found["coatlab"])
        for mesh in meshes:
            for key in ("incoherent", "bounce"):
                references = {name: best(found["embree"], mesh, s, key) for name, s in bars}
                shown = ", ".join(
                    f"{name} {r[0]:.2f} ({r[1]})" for name, r in references.items() if r
                )
                print(f"  {mesh}, {key}: Embree {shown}")
                for (simd, tree, m), rates in found["coatlab"].items():
                    if m != mesh:
                        continue
                    columns = [key] + (["bounce one by one"] if key == "bounce" else [])
                    for column in columns:
                        ratios = " ".join(
                            f"÷{name} {rates[column] / r[0]:.2f}"
                            for name, r in references.items()
                            if r
                        )
                        print(f"    {simd} {tree} {column}: {rates[column]:.2f}  {ratios}")
            builds = {
                f"{simd} {tree}": rates["build"]
                for (simd, tree, m), rates in found["coatlab"].items()
                if m == mesh
            }
            embree_builds = {
                setting: rates["build"]
                for (m, setting, _), rates in found["embree"].items()
                if m == mesh
            }
            print(f"  {mesh}, build on 2 threads (ms): Coatlab {builds}, Embree {embree_builds}")


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit("usage: ratios.py RUN_LOG (the output of benches/embree/run.sh)")
    main(sys.argv[1])
