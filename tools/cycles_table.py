#!/usr/bin/env python3
"""Path-trace grooms with dualhair and with Blender Cycles and tabulate how far apart they are.

    .venv-cycles/bin/python tools/cycles_table.py HAIR.hair [HAIR.hair ...] -o DIR [--spp 2048]

For each .hair file and each light setup (brown hair lit from the front, blond hair lit from
behind: a sun of irradiance 3 and a dim sky, the accuracy benchmark's setups), writes the scene to
DIR, renders it with `dualhair render --integrator path` and with tools/cycles_reference.py at the
same resolution and spp, one after the other, and prints a Markdown table: mean luminance ratio
dualhair/Cycles and relative RMSE of 4x4 block means over fully covered blocks (`dualhair
compare`), with each renderer's wall time per sample. Needs the Python that has `bpy` (see
tools/cycles_reference.py) and a release build of dualhair.
"""

import argparse
import json
import os
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
DUALHAIR = os.path.join(ROOT, "target", "release", "dualhair")

SETUPS = {
    "brown_front": {"melanin": 1.3, "sun": [0.3, -1.0, 0.5]},
    "blond_back": {"melanin": 0.3, "sun": [0.2, 1.0, 0.35]},
}


def run(cmd):
    start = time.perf_counter()
    done = subprocess.run(cmd, capture_output=True, text=True)
    if done.returncode != 0:
        sys.exit(f"{' '.join(cmd)} failed:\n{done.stderr}")
    return done.stdout, time.perf_counter() - start


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("hair", nargs="+", help=".hair files")
    ap.add_argument("-o", "--output", required=True, help="folder for scenes, images and results.json")
    ap.add_argument("--spp", type=int, default=2048)
    ap.add_argument("--size", type=int, default=160, help="image width and height")
    ap.add_argument("--setups", default=",".join(SETUPS), help="comma-separated: " + ", ".join(SETUPS))
    args = ap.parse_args()
    if not os.path.exists(DUALHAIR):
        sys.exit(f"{DUALHAIR} is missing: run `cargo build --release` first")
    os.makedirs(args.output, exist_ok=True)
    rows = []
    for hair in args.hair:
        stem = os.path.splitext(os.path.basename(hair))[0]
        for name in args.setups.split(","):
            setup = SETUPS[name]
            scene = {
                "hair": {"file": os.path.abspath(hair)},
                "fiber": {"absorption": {"melanin": {"eumelanin": setup["melanin"]}}},
                "camera": {"width": args.size, "height": args.size},
                "lights": {
                    "environment": {"color": [0.02, 0.025, 0.03]},
                    "sun": {"direction": setup["sun"], "irradiance": 3.0},
                },
                "render": {"integrator": "path", "spp": args.spp},
            }
            base = os.path.join(args.output, f"{stem}_{name}")
            with open(base + ".json", "w") as f:
                json.dump(scene, f, indent=1)
            ours, ours_s = run([DUALHAIR, "render", base + ".json", "-o", base + "_dualhair.exr", "--aovs", "-q"])
            cycles, cycles_s = run([sys.executable, os.path.join(HERE, "cycles_reference.py"), base + ".json",
                                    "-o", base + "_cycles.exr", "--dualhair", DUALHAIR])
            cycles_render_s = json.loads(cycles.strip().splitlines()[-1])["render_seconds"]
            # Cycles' time includes turning the curves into its own and building its BVH: a 1-spp
            # render measures that, so that the difference is the time of spp - 1 samples.
            one, _ = run([sys.executable, os.path.join(HERE, "cycles_reference.py"), base + ".json",
                          "-o", base + "_cycles_1spp.exr", "--spp", "1", "--dualhair", DUALHAIR])
            cycles_setup_s = json.loads(one.strip().splitlines()[-1])["render_seconds"]
            os.remove(base + "_cycles_1spp.exr")
            # dualhair's own timing line: "... setup X s, render Y s" (setup: reading the hair and
            # building the BVH; render: the samples).
            ours_setup_s = float(ours.strip().split("setup ")[-1].split(" s")[0])
            ours_render_s = float(ours.strip().split("render ")[-1].split(" s")[0])
            report, _ = run([DUALHAIR, "compare", base + "_dualhair.exr", base + "_cycles.exr"])
            c = json.loads(report)
            row = {"hair": stem, "setup": name, "spp": args.spp, "size": args.size,
                   "mean_ratio": c["mean_ratio"], "block_rel_rmse": c["block_rel_rmse"],
                   "block_rel_noise_dualhair_only": c["block_rel_noise"], "pixels": c["pixels"],
                   "dualhair_setup_s": ours_setup_s, "dualhair_render_s": ours_render_s,
                   "dualhair_wall_s": ours_s, "cycles_setup_and_1spp_s": cycles_setup_s,
                   "cycles_render_s": cycles_render_s, "cycles_wall_s": cycles_s,
                   "dualhair_ms_per_spp": 1000 * ours_render_s / args.spp,
                   "cycles_ms_per_spp": 1000 * (cycles_render_s - cycles_setup_s) / max(args.spp - 1, 1)}
            rows.append(row)
            print(json.dumps(row), file=sys.stderr)
    with open(os.path.join(args.output, "results.json"), "w") as f:
        json.dump(rows, f, indent=1)
    print("| groom | hair, light | mean ratio dualhair/Cycles | block rel. RMSE (dualhair's noise) "
          "| dualhair s: setup + samples | Cycles s: setup + samples | ms per spp: dualhair / Cycles |")
    print("|---|---|---|---|---|---|---|")
    for r in rows:
        err = "-" if r["block_rel_rmse"] is None else \
            f"{100 * r['block_rel_rmse']:.1f}% ({100 * r['block_rel_noise_dualhair_only']:.1f}%)"
        cycles_samples = r["cycles_render_s"] - r["cycles_setup_and_1spp_s"]
        print(f"| {r['hair']} | {r['setup'].replace('_', ', ')} | {r['mean_ratio']:.3f} | {err} "
              f"| {r['dualhair_setup_s']:.1f} + {r['dualhair_render_s']:.1f} "
              f"| {r['cycles_setup_and_1spp_s']:.1f} + {cycles_samples:.1f} "
              f"| {r['dualhair_ms_per_spp']:.1f} / {r['cycles_ms_per_spp']:.1f} |")


if __name__ == "__main__":
    main()
