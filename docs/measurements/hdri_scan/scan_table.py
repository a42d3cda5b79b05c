"""Tables of the HDRI scan (see README.md): per environment map, how concentrated its power is,
and the MSE ratio uniform / importance of `dual` at each spp for brown and blond curls.

usage: python3 scan_table.py results.csv HDRI_DIR
results.csv: the runs' rows with their hair and map (this folder's); HDRI_DIR: the maps.
Needs numpy and the OpenEXR Python bindings (pip install OpenEXR numpy).
"""
import collections, csv, os, sys
import numpy as np
import OpenEXR

rows, maps = list(csv.DictReader(open(sys.argv[1]))), sys.argv[2]


def concentration(path):
    """Share of the map's power (luminance x solid angle) in its brightest 1% and 10% of the sphere."""
    with OpenEXR.File(path) as f:
        ch = f.channels()
        rgb = ch["RGB"].pixels if "RGB" in ch else np.stack([ch[c].pixels for c in "RGB"], -1)
    rgb = np.asarray(rgb, dtype=np.float64)
    h, w = rgb.shape[:2]
    lum = rgb @ [0.2126, 0.7152, 0.0722]
    solid = np.repeat(np.sin((np.arange(h) + 0.5) / h * np.pi)[:, None], w, 1).ravel()
    order = np.argsort(-lum.ravel())
    power = np.cumsum((lum.ravel() * solid)[order])
    area = np.cumsum(solid[order])
    share = lambda a: power[np.searchsorted(area, a * area[-1])] / power[-1]
    return share(0.01), share(0.1)


mse = collections.defaultdict(list)
for r in rows:
    mse[(r["hair"], r["map"], r["method"], int(r["spp"]))].append(float(r["mse"]))
spps = sorted({int(r["spp"]) for r in rows})
mean = lambda k: sum(mse[k]) / len(mse[k])


def ratios(hair, m):
    """MSE ratio uniform / importance (means over seeds) at each spp."""
    return " ".join(f"{mean((hair, m, 'dual-uniform', s)) / mean((hair, m, 'dual-importance', s)):.2f}" for s in spps)


def per_sample(hair, m, method):
    """MSE x spp at each spp: constant for a light-tailed estimator."""
    return " ".join(f"{mean((hair, m, method, s)) * s:.1e}" for s in spps)


spp_list = ", ".join(map(str, spps))
print(f"| map | power in brightest 1% / 10% of the sphere | brown: ratio at {spp_list} spp | blond: the same |")
print("|---|---|---|---|")
for m in sorted({r["map"] for r in rows}):
    c1, c10 = concentration(os.path.join(maps, f"{m}.exr"))
    print(f"| {m} | {c1:.2f} / {c10:.2f} | {ratios('brown', m)} | {ratios('blond', m)} |")
print()
print(f"| hair, map | method | MSE x spp at {spp_list} spp |")
print("|---|---|---|")
for hair in ("brown", "blond"):
    for m in sorted({r["map"] for r in rows}):
        for method in ("dual-importance", "dual-uniform"):
            print(f"| {hair}, {m} | {method} | {per_sample(hair, m, method)} |")
