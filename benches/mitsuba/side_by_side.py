#!/usr/bin/env python3
"""Coatlab and Mitsuba 3 side by side: error against time on the same scene.

Issue 5, item 5. Both renderers get the same scene, exported by the Rust example
`export_mitsuba_scene` (crates/coatlab-core/examples): the default car's painted
body (PLY for Mitsuba, GLB for Coatlab), the default camera, the studio baked to a
lat-long EXR map (both read that file), the image map's grey floor (ρ = 0.25) and
the paint model's special case k = 0, n = 1.5, mirror gloss, signal-red ρ(λ)
(Mitsuba: `plastic` with `nonlinear = true`, inside `twosided` because every
Coatlab surface is two-sided).

Each renderer is measured against its OWN converged reference, so the error is
convergence, not the difference between the models; that difference (fitted F_dr
against the exact coat integral, the two RGB up-samplings of the map, bilinear
against nearest-texel map look-ups) is the ΔE between the two references,
reported apart.

Error: per-pixel CIEDE2000 of the displayed colour, as Coatlab's film computes it
(render/film.rs): linear sRGB → extended Reinhard on luminance, white 4 → clamp
to [0, 1] → XYZ → CIELAB (D65, display white L* = 100). Mean and 95th percentile
over all pixels. The implementation is checked against Sharma's 34 pairs on start.

Time: wall time of each render process, and inside it the rendering alone
(Coatlab: samples ÷ the samples/s it prints; Mitsuba: the `mi.render` calls).
Runs are interleaved (for each sample count: Coatlab, then Mitsuba) so machine
load hits both alike.

Usage (from the repository root; not part of `cargo test`):

    python3.11 -m venv /tmp/mitsuba-venv
    /tmp/mitsuba-venv/bin/pip install -r benches/mitsuba/requirements.txt
    cargo build --release -p coatlab-app
    cargo run --release -p coatlab-core --example export_mitsuba_scene -- OUT/scene 320x180
    /tmp/mitsuba-venv/bin/python benches/mitsuba/side_by_side.py --work OUT \\
        --coatlab target/release/coatlab

Writes OUT/results.json, OUT/results.md (the tables for docs/tradeoff.md) and
OUT/error_vs_time.svg. `... side_by_side.py mitsuba-render ...` is the child
process that renders one Mitsuba image (run by the driver).
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import os
import re
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
SHARMA = Path("/work/shared/data/ciede2000_sharma.csv")

# ---------------------------------------------------------------------------
# Colour: CIEDE2000 of displayed colours, as coatlab_core::render::film does it.

# IEC 61966-2-1 linear sRGB → XYZ (white Y = 1) and the D65 white of sRGB.
SRGB_TO_XYZ = np.array(
    [
        [0.4124, 0.3576, 0.1805],
        [0.2126, 0.7152, 0.0722],
        [0.0193, 0.1192, 0.9505],
    ]
)
WHITE = SRGB_TO_XYZ.sum(axis=1)
LUMINANCE = np.array([0.2126, 0.7152, 0.0722])
REINHARD_WHITE = 4.0


def displayed_lab(rgb: np.ndarray) -> np.ndarray:
    """CIELAB of the colour a linear-sRGB image is shown in (Coatlab's display)."""
    rgb = rgb.astype(np.float64)
    lum = rgb @ LUMINANCE
    ok = lum > 0
    ratio = np.where(ok, (1.0 + lum / REINHARD_WHITE**2) / (1.0 + np.where(ok, lum, 1.0)), 0.0)
    shown = rgb * ratio[..., None]
    peak = shown.max(axis=-1, keepdims=True)
    shown = np.where(peak > 1.0, shown / np.maximum(peak, 1e-30), shown)
    shown = np.clip(shown, 0.0, 1.0)
    xyz = shown @ SRGB_TO_XYZ.T
    t = xyz / WHITE
    eps = (6.0 / 29.0) ** 3
    f = np.where(t > eps, np.cbrt(t), t / (3 * (6.0 / 29.0) ** 2) + 4.0 / 29.0)
    L = 116.0 * f[..., 1] - 16.0
    a = 500.0 * (f[..., 0] - f[..., 1])
    b = 200.0 * (f[..., 1] - f[..., 2])
    return np.stack([L, a, b], axis=-1)


def ciede2000(lab1: np.ndarray, lab2: np.ndarray) -> np.ndarray:
    """CIEDE2000 (kL = kC = kH = 1), Sharma, Wu & Dalal (2005), vectorised."""
    L1, a1, b1 = np.moveaxis(np.asarray(lab1, dtype=np.float64), -1, 0)
    L2, a2, b2 = np.moveaxis(np.asarray(lab2, dtype=np.float64), -1, 0)
    C1 = np.hypot(a1, b1)
    C2 = np.hypot(a2, b2)
    Cm = 0.5 * (C1 + C2)
    G = 0.5 * (1.0 - np.sqrt(Cm**7 / (Cm**7 + 25.0**7)))
    a1p, a2p = (1.0 + G) * a1, (1.0 + G) * a2
    C1p, C2p = np.hypot(a1p, b1), np.hypot(a2p, b2)
    h1p = np.where((a1p == 0) & (b1 == 0), 0.0, np.degrees(np.arctan2(b1, a1p)) % 360.0)
    h2p = np.where((a2p == 0) & (b2 == 0), 0.0, np.degrees(np.arctan2(b2, a2p)) % 360.0)
    dLp = L2 - L1
    dCp = C2p - C1p
    zero = C1p * C2p == 0
    dh = h2p - h1p
    dh = np.where(dh > 180.0, dh - 360.0, np.where(dh < -180.0, dh + 360.0, dh))
    dh = np.where(zero, 0.0, dh)
    dHp = 2.0 * np.sqrt(C1p * C2p) * np.sin(np.radians(dh) / 2.0)
    Lmp = 0.5 * (L1 + L2)
    Cmp = 0.5 * (C1p + C2p)
    hsum = h1p + h2p
    hmp = np.where(
        zero,
        hsum,
        np.where(
            np.abs(h1p - h2p) <= 180.0,
            0.5 * hsum,
            np.where(hsum < 360.0, 0.5 * (hsum + 360.0), 0.5 * (hsum - 360.0)),
        ),
    )
    T = (
        1.0
        - 0.17 * np.cos(np.radians(hmp - 30.0))
        + 0.24 * np.cos(np.radians(2.0 * hmp))
        + 0.32 * np.cos(np.radians(3.0 * hmp + 6.0))
        - 0.20 * np.cos(np.radians(4.0 * hmp - 63.0))
    )
    d_theta = 30.0 * np.exp(-(((hmp - 275.0) / 25.0) ** 2))
    Rc = 2.0 * np.sqrt(Cmp**7 / (Cmp**7 + 25.0**7))
    Sl = 1.0 + 0.015 * (Lmp - 50.0) ** 2 / np.sqrt(20.0 + (Lmp - 50.0) ** 2)
    Sc = 1.0 + 0.045 * Cmp
    Sh = 1.0 + 0.015 * Cmp * T
    Rt = -np.sin(np.radians(2.0 * d_theta)) * Rc
    return np.sqrt(
        (dLp / Sl) ** 2 + (dCp / Sc) ** 2 + (dHp / Sh) ** 2 + Rt * (dCp / Sc) * (dHp / Sh)
    )


def check_ciede2000(path: Path = SHARMA) -> float:
    """Worst error over Sharma's 34 pairs; refuses to go on above 1e-4."""
    with path.open() as f:
        rows = list(csv.DictReader(f))
    lab1 = np.array([[float(r["L1"]), float(r["a1"]), float(r["b1"])] for r in rows])
    lab2 = np.array([[float(r["L2"]), float(r["a2"]), float(r["b2"])] for r in rows])
    expected = np.array([float(r["dE00_published"]) for r in rows])
    got = ciede2000(lab1, lab2)
    # The published values have 4 decimals.
    worst = float(np.max(np.abs(got - expected)))
    symmetric = float(np.max(np.abs(ciede2000(lab2, lab1) - got)))
    if len(rows) != 34 or worst > 1e-4 or symmetric > 1e-9:
        raise SystemExit(f"CIEDE2000 check failed: {len(rows)} pairs, worst {worst}, asym {symmetric}")
    return worst


def image_error(image: np.ndarray, reference: np.ndarray) -> dict:
    de = ciede2000(displayed_lab(image), displayed_lab(reference)).ravel()
    return {"mean": float(de.mean()), "p95": float(np.percentile(de, 95))}


# ---------------------------------------------------------------------------
# Images


def read_exr(path: Path) -> np.ndarray:
    import mitsuba as mi

    if mi.variant() is None:
        mi.set_variant("scalar_rgb")
    bitmap = mi.Bitmap(str(path))
    array = np.array(bitmap, dtype=np.float64)
    return array[..., :3]


def write_exr(path: Path, rgb: np.ndarray) -> None:
    import mitsuba as mi

    if mi.variant() is None:
        mi.set_variant("scalar_rgb")
    mi.Bitmap(rgb.astype(np.float32), mi.Bitmap.PixelFormat.RGB).write(str(path))


# ---------------------------------------------------------------------------
# Mitsuba: the scene and the child process that renders it.

MITSUBA_PASS_SPP = 64  # wavefront size cap: 64 spp × 320×180 lanes per mi.render call


def mitsuba_scene_dict(scene_dir: Path, cfg: dict, mi, sampler: str = "independent") -> dict:
    T = mi.ScalarTransform4f
    cam = cfg["camera"]
    wavelengths = cfg["albedo"]["wavelength_nm"]
    values = cfg["albedo"]["value"]
    albedo = {"type": "spectrum", "value": list(zip(map(float, wavelengths), map(float, values)))}
    return {
        "type": "scene",
        # Coatlab: ≤ 8 surface interactions, roulette after 3 bounces. Mitsuba's depth
        # counts path segments: 9 = 8 interactions plus the segment to the light.
        "integrator": {"type": "path", "max_depth": 9, "rr_depth": 4},
        "sensor": {
            "type": "perspective",
            "fov_axis": "y",
            "fov": float(cam["vertical_fov_deg"]),
            "to_world": T().look_at(origin=cam["position"], target=cam["look_at"], up=cam["up"]),
            # `independent` by default; `ldsampler` (a scrambled (0, 2)-sequence) or
            # `multijitter` are Mitsuba's stratified ones (--mitsuba-sampler). A pass
            # of mi.render(spp=n) is one stratified set of n samples a pixel.
            "sampler": {"type": sampler, "sample_count": 1},
            "film": {
                "type": "hdrfilm",
                "width": int(cfg["width"]),
                "height": int(cfg["height"]),
                # Coatlab averages over the pixel's area (box filter).
                "rfilter": {"type": "box"},
                "pixel_format": "rgb",
            },
        },
        "environment": {
            "type": "envmap",
            "filename": str(scene_dir / cfg["environment"]),
            "scale": float(cfg["environment_scale"]),
        },
        # Coatlab's floor is the infinite plane y = 0; a 20 km square is as good from
        # a camera 2.3 m up (it misses only rays within 0.007° of the horizon).
        "floor": {
            "type": "rectangle",
            "to_world": T().rotate([1, 0, 0], -90.0).scale([1e4, 1e4, 1.0]),
            "bsdf": {"type": "diffuse", "reflectance": {"type": "spectrum", "value": float(cfg["floor_reflectance"])}},
        },
        "body": {
            "type": "ply",
            "filename": str(scene_dir / cfg["mesh"]),
            "face_normals": False,
            "bsdf": {
                "type": "twosided",
                "material": {
                    "type": "plastic",
                    "diffuse_reflectance": albedo,
                    "int_ior": float(cfg["coat_index"]),
                    "ext_ior": 1.0,
                    "nonlinear": True,
                },
            },
        },
    }


def mitsuba_render_main(argv: list[str]) -> None:
    t_start = time.perf_counter()
    p = argparse.ArgumentParser(prog="side_by_side.py mitsuba-render")
    p.add_argument("--scene-dir", type=Path, required=True)
    p.add_argument("--variant", required=True)
    p.add_argument("--spp", type=int, required=True)
    p.add_argument("--seed", type=int, required=True)
    p.add_argument("--out", type=Path, required=True)
    p.add_argument("--pass-spp", type=int, default=MITSUBA_PASS_SPP)
    p.add_argument("--sampler", default="independent")
    args = p.parse_args(argv)
    import drjit as dr
    import mitsuba as mi

    mi.set_variant(args.variant)
    t_import = time.perf_counter()
    cfg = json.loads((args.scene_dir / "scene.json").read_text())
    scene = mi.load_dict(mitsuba_scene_dict(args.scene_dir, cfg, mi, args.sampler))
    t_load = time.perf_counter()
    total = None
    done = 0
    k = 0
    while done < args.spp:
        n = min(args.pass_spp, args.spp - done)
        img = mi.render(scene, spp=n, seed=(args.seed * 100_003 + k) % 2**32)
        img = img * n
        total = img if total is None else total + img
        dr.eval(total)
        done += n
        k += 1
    dr.sync_thread()
    t_render = time.perf_counter()
    rgb = np.array(total / args.spp, dtype=np.float64)
    write_exr(args.out, rgb)
    t_end = time.perf_counter()
    print(
        json.dumps(
            {
                "import_s": t_import - t_start,
                "load_s": t_load - t_import,
                "render_s": t_render - t_load,
                "write_s": t_end - t_render,
                "passes": k,
            }
        )
    )


def llvm_library() -> str | None:
    """A libLLVM that Dr.Jit 1.5 can use. Debian 12's default LLVM 15 aborts while
    compiling Mitsuba's path tracer ("Cannot select: f32 = fminimum"); 19 works
    (`apt-get install libllvm19`). DRJIT_LIBLLVM_PATH, when set, wins."""
    if os.environ.get("DRJIT_LIBLLVM_PATH"):
        return os.environ["DRJIT_LIBLLVM_PATH"]
    for version in (21, 20, 19, 18, 17, 16):
        for candidate in (
            f"/usr/lib/x86_64-linux-gnu/libLLVM.so.{version}.1",
            f"/usr/lib/x86_64-linux-gnu/libLLVM-{version}.so",
            f"/usr/lib/llvm-{version}/lib/libLLVM.so",
        ):
            if Path(candidate).exists():
                return candidate
    return None


def run_mitsuba(args, spp: int, seed: int, out: Path, reference: bool = False) -> dict:
    cmd = [
        sys.executable,
        str(Path(__file__).resolve()),
        "mitsuba-render",
        "--scene-dir",
        str(args.scene_dir),
        "--variant",
        args.variant,
        "--spp",
        str(spp),
        "--seed",
        str(seed),
        "--out",
        str(out),
        # Only the timed runs: the references stay independent, as cached.
        "--sampler",
        "independent" if reference else args.mitsuba_sampler,
    ]
    env = dict(os.environ)
    library = llvm_library()
    if args.variant.startswith("llvm") and library:
        env["DRJIT_LIBLLVM_PATH"] = library
    t0, c0 = time.perf_counter(), children_cpu_s()
    proc = subprocess.run(cmd, capture_output=True, text=True, env=env)
    wall, cpu = time.perf_counter() - t0, children_cpu_s() - c0
    if proc.returncode != 0:
        raise SystemExit(f"mitsuba render failed ({' '.join(cmd)}):\n{proc.stderr}")
    # Mitsuba's log can leave a terminal colour code in front of the JSON line
    # (ldsampler's warnings do): read from its opening brace.
    last = proc.stdout.strip().splitlines()[-1]
    inner = json.loads(last[last.find("{") :])
    return {"wall_s": wall, "cpu_s": cpu, **inner, "command": " ".join(cmd)}


# ---------------------------------------------------------------------------
# Coatlab


def children_cpu_s() -> float:
    """User + system CPU seconds of all finished child processes (all their
    threads): a clock that machine load disturbs less than wall time."""
    import resource

    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def run_coatlab(args, spp: int, seed: int, out: Path, wavelengths: int, reference: bool = False) -> dict:
    d = args.scene_dir
    cmd = [
        str(args.coatlab),
        "render",
        "--scene",
        str(d / "body.glb"),
        "--environment",
        str(d / "studio.exr"),
        "--design",
        str(d / "design.toml"),
        "--spp",
        str(spp),
        "--size",
        f"{args.width}x{args.height}",
        "--wavelengths",
        str(wavelengths),
        "--seed",
        str(seed),
        "--out",
        str(out),
    ]
    if not reference:
        # Only the timed runs: the references stay uniform, as cached.
        cmd += args.coatlab_extra_args.split()
    t0, c0 = time.perf_counter(), children_cpu_s()
    proc = subprocess.run(cmd, capture_output=True, text=True)
    wall, cpu = time.perf_counter() - t0, children_cpu_s() - c0
    if proc.returncode != 0:
        raise SystemExit(f"coatlab render failed ({' '.join(cmd)}):\n{proc.stderr}")
    line = proc.stdout.strip().splitlines()[-1]
    m = re.search(r"([0-9.]+) M samples/s", line)
    if not m:
        raise SystemExit(f"cannot read the samples/s from coatlab's output: {line!r}")
    samples = spp * args.width * args.height
    render_s = samples / (float(m.group(1)) * 1e6)
    return {"wall_s": wall, "cpu_s": cpu, "render_s": render_s, "stdout": line, "command": " ".join(cmd)}


# ---------------------------------------------------------------------------
# Driver


def reference(args, name: str, render, halves_spp: int, seeds=(1, 2)) -> tuple[np.ndarray, dict]:
    """The mean of two independent renders, and the ΔE between the two halves."""
    images = []
    timings = []
    for seed in seeds:
        out = args.work / f"ref_{name}_{seed}.exr"
        if out.exists() and not args.rebuild_references:
            timings.append({"cached": True})
        else:
            timings.append(render(halves_spp, seed, out))
            print(f"reference {name} seed {seed}: {timings[-1]['wall_s']:.1f} s", flush=True)
        images.append(read_exr(out))
    ref = 0.5 * (images[0] + images[1])
    halves = image_error(images[0], images[1])
    return ref, {"spp": 2 * halves_spp, "halves_delta_e": halves, "timings": timings}


def load_average() -> str:
    return " ".join(Path("/proc/loadavg").read_text().split()[:3])


def crossing_time(points: list[tuple[float, float]], target: float) -> float | None:
    """Time at which the error falls to `target`, by log-log interpolation between
    the measured (time, error) points sorted by time; None outside their range."""
    pts = sorted(points)
    for (t0, e0), (t1, e1) in zip(pts, pts[1:]):
        if (e0 - target) * (e1 - target) <= 0 and e0 != e1:
            f = (math.log(target) - math.log(e0)) / (math.log(e1) - math.log(e0))
            return math.exp(math.log(t0) + f * (math.log(t1) - math.log(t0)))
    return None


def main() -> None:
    if len(sys.argv) > 1 and sys.argv[1] == "mitsuba-render":
        mitsuba_render_main(sys.argv[2:])
        return
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--work", type=Path, required=True, help="folder with scene/ (the export) and for outputs")
    p.add_argument("--coatlab", type=Path, required=True, help="the coatlab binary (release build)")
    p.add_argument("--variant", default="llvm_ad_spectral")
    p.add_argument("--spp-coatlab", default="1,2,4,8,16,32,64,128,256", help="Coatlab's sample counts")
    p.add_argument("--spp-mitsuba", default="1,2,4,8,16,32,64,128,256,512,1024", help="Mitsuba's sample counts")
    p.add_argument("--wavelengths", type=int, default=32, help="Coatlab's wavelengths in the timed runs")
    p.add_argument("--coatlab-ref-spp", type=int, default=2048, help="per half of the reference")
    p.add_argument("--mitsuba-ref-spp", type=int, default=4096, help="per half of the reference")
    p.add_argument("--rounds", type=int, default=1, help="repetitions of the timed series (other seeds)")
    p.add_argument("--rebuild-references", action="store_true")
    p.add_argument(
        "--coatlab-extra-args",
        default="",
        help="more arguments for Coatlab's timed renders, e.g. '--adaptive on' (not for its reference)",
    )
    p.add_argument(
        "--mitsuba-sampler",
        default="independent",
        help="Mitsuba's sampler in its timed renders: independent, ldsampler, multijitter, ... (not for its reference)",
    )
    args = p.parse_args()
    args.work = args.work.resolve()
    args.scene_dir = args.work / "scene"
    cfg = json.loads((args.scene_dir / "scene.json").read_text())
    args.width, args.height = int(cfg["width"]), int(cfg["height"])

    worst = check_ciede2000()
    print(f"CIEDE2000: Sharma's 34 pairs within {worst:.1e}", flush=True)
    results = {
        "variant": args.variant,
        "size": f"{args.width}x{args.height}",
        "coatlab_wavelengths": args.wavelengths,
        "coatlab_extra_args": args.coatlab_extra_args,
        "mitsuba_sampler": args.mitsuba_sampler,
        "cpu_count": os.cpu_count(),
        "load_start": load_average(),
        "ciede2000_sharma_worst": worst,
    }

    # Warm Mitsuba's on-disk kernel cache for every per-call sample count the timed
    # runs use, so no timed run pays a first-time LLVM compilation.
    spp_lists = {
        "coatlab": [int(s) for s in args.spp_coatlab.split(",")],
        "mitsuba": [int(s) for s in args.spp_mitsuba.split(",")],
    }
    sizes = sorted({min(s, MITSUBA_PASS_SPP) for s in spp_lists["mitsuba"]} | {MITSUBA_PASS_SPP})
    for s in sizes:
        run_mitsuba(args, s, 999, args.work / "warmup.exr")
    print("mitsuba kernel cache warm", flush=True)

    ref_c, info_c = reference(
        args, "coatlab", lambda spp, seed, out: run_coatlab(args, spp, seed, out, 81, reference=True), args.coatlab_ref_spp
    )
    ref_m, info_m = reference(args, "mitsuba", lambda spp, seed, out: run_mitsuba(args, spp, seed, out, reference=True), args.mitsuba_ref_spp)
    results["reference_coatlab"] = info_c
    results["reference_mitsuba"] = info_m
    # The model difference: the two converged images against each other.
    results["references_delta_e"] = image_error(ref_m, ref_c)
    lum_c, lum_m = float((ref_c @ LUMINANCE).mean()), float((ref_m @ LUMINANCE).mean())
    results["references_mean_luminance"] = {"coatlab": lum_c, "mitsuba": lum_m}
    write_exr(args.work / "reference_coatlab.exr", ref_c)
    write_exr(args.work / "reference_mitsuba.exr", ref_m)
    print(f"references: ΔE00 between them {results['references_delta_e']}", flush=True)

    runs = []
    results["load_timed_start"] = load_average()
    for r in range(args.rounds):
        for spp in sorted(set(spp_lists["coatlab"]) | set(spp_lists["mitsuba"])):
            seed = 1000 + 100_000 * r + spp
            for name in ("coatlab", "mitsuba"):
                if spp not in spp_lists[name]:
                    continue
                out = args.work / f"run_{name}_{spp}_{r}.exr"
                if name == "coatlab":
                    timing = run_coatlab(args, spp, seed, out, args.wavelengths)
                    err = image_error(read_exr(out), ref_c)
                else:
                    timing = run_mitsuba(args, spp, seed, out)
                    err = image_error(read_exr(out), ref_m)
                run = {"renderer": name, "spp": spp, "round": r, "load": load_average(), **timing, "error": err}
                runs.append(run)
                print(
                    f"{name:8s} {spp:5d} spp: wall {timing['wall_s']:7.3f} s, CPU {timing['cpu_s']:7.3f} s, render {timing['render_s']:7.3f} s, "
                    f"ΔE00 mean {err['mean']:.3f} p95 {err['p95']:.3f} (load {run['load']})",
                    flush=True,
                )
    results["runs"] = runs
    results["load_end"] = load_average()

    # Time to reach the same error: both renderers' curves at common error levels.
    summary = []
    for metric in ("mean", "p95"):
        for clock in ("render_s", "wall_s", "cpu_s"):
            curves = {}
            for name in ("coatlab", "mitsuba"):
                pts = {}
                for run in runs:
                    if run["renderer"] == name:
                        pts.setdefault(run["spp"], []).append((run[clock], run["error"][metric]))
                curves[name] = [(float(np.median([t for t, _ in v])), float(np.median([e for _, e in v]))) for v in pts.values()]
            lo = max(min(e for _, e in curves[n]) for n in curves)
            hi = min(max(e for _, e in curves[n]) for n in curves)
            if lo >= hi:
                continue
            for target in np.geomspace(hi, lo, 5):
                tc = crossing_time(curves["coatlab"], float(target))
                tm = crossing_time(curves["mitsuba"], float(target))
                if tc and tm:
                    summary.append({"metric": metric, "clock": clock, "delta_e": float(target), "coatlab_s": tc, "mitsuba_s": tm, "ratio": tc / tm})
    results["same_error"] = summary
    (args.work / "results.json").write_text(json.dumps(results, indent=2))
    write_markdown(args, results)
    write_plot(args, results)
    print(f"wrote {args.work / 'results.json'}, results.md, error_vs_time.svg")


def write_markdown(args, results: dict) -> None:
    lines = []
    lines.append("| renderer | spp | process wall (s) | process CPU (s) | rendering (s) | ΔE00 mean | ΔE00 p95 | load |")
    lines.append("| --- | ---: | ---: | ---: | ---: | ---: | ---: | --- |")
    for run in results["runs"]:
        lines.append(
            f"| {run['renderer']} | {run['spp']} | {run['wall_s']:.3f} | {run['cpu_s']:.3f} | {run['render_s']:.3f} | "
            f"{run['error']['mean']:.3f} | {run['error']['p95']:.3f} | {run['load']} |"
        )
    lines.append("")
    lines.append("| error | clock | ΔE00 level | Coatlab (s) | Mitsuba (s) | Coatlab ÷ Mitsuba |")
    lines.append("| --- | --- | ---: | ---: | ---: | ---: |")
    for s in results["same_error"]:
        clock = {"render_s": "rendering", "wall_s": "process wall", "cpu_s": "process CPU"}[s["clock"]]
        lines.append(
            f"| {s['metric']} | {clock} | {s['delta_e']:.3f} | {s['coatlab_s']:.3f} | {s['mitsuba_s']:.3f} | {s['ratio']:.2f} |"
        )
    (args.work / "results.md").write_text("\n".join(lines) + "\n")


def write_plot(args, results: dict) -> None:
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("matplotlib not installed: no plot")
        return
    fig, axes = plt.subplots(1, 2, figsize=(10, 4))
    for ax, metric in zip(axes, ("mean", "p95")):
        for name, colour in (("coatlab", "tab:red"), ("mitsuba", "tab:blue")):
            runs = [r for r in results["runs"] if r["renderer"] == name]
            for clock, style, what in (("render_s", "-o", "rendering, wall"), ("cpu_s", ":x", "process, CPU")):
                # The median over rounds per sample count, as the same-error table uses.
                by_spp = {}
                for r in runs:
                    by_spp.setdefault(r["spp"], []).append((r[clock], r["error"][metric]))
                pts = sorted(
                    (float(np.median([t for t, _ in v])), float(np.median([e for _, e in v]))) for v in by_spp.values()
                )
                ax.plot([t for t, _ in pts], [e for _, e in pts], style, color=colour, label=f"{name} ({what})")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("seconds")
        ax.set_ylabel(f"ΔE00 {metric} against own reference")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7)
    fig.suptitle(
        f"{results['size']}, Mitsuba {results['variant']}, Coatlab {results['coatlab_wavelengths']} λ; "
        f"load {results['load_timed_start']} → {results['load_end']}",
        fontsize=9,
    )
    fig.tight_layout()
    fig.savefig(args.work / "error_vs_time.svg")


if __name__ == "__main__":
    main()
