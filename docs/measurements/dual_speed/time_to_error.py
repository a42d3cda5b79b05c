"""Speed against accuracy from `dualhair converge` runs of `dual` (`dual-light`, the
default, where there is one) and `path`: `dual`'s converged
error (its MSE against the path-traced truth at its largest spp), the wall time `dual` needs to come
within 10% of it in RMSE (MSE within 1.21x), and the time `path` needs to reach it, interpolated
log-log between measured spp; past its largest spp, extrapolated from that point with the MSE
above the truth's own noise falling as 1/time. Usage: python3 time_to_error.py DIR..."""
import csv, math, re, sys
from collections import defaultdict


def curves(path):
    runs = defaultdict(lambda: defaultdict(list))
    for row in csv.DictReader(open(path)):
        runs[row["method"]][int(row["spp"])].append((float(row["seconds"]), float(row["mse"])))
    return {m: sorted((spp, sum(t for t, _ in v) / len(v), sum(e for _, e in v) / len(v)) for spp, v in r.items())
            for m, r in runs.items()}


def time_to(curve, target):
    """Seconds at which a (spp, seconds, mse) curve first reaches `target`, log-log interpolated."""
    if curve[0][2] <= target:
        return curve[0][1]
    for (_, t0, e0), (_, t1, e1) in zip(curve, curve[1:]):
        if e1 <= target:
            f = math.log(e0 / target) / math.log(e0 / e1)
            return math.exp(math.log(t0) + f * math.log(t1 / t0))
    return None


print("| run | dual converged MSE | dual time to it | path time to it | path / dual |")
print("|---|---|---|---|---|")
for d in sys.argv[1:]:
    c = curves(f"{d}/results.csv")
    dual = c.get("dual-light") or next(v for k, v in c.items() if k.startswith("dual"))
    path = next(v for k, v in c.items() if k.startswith("path"))
    noise = float(re.search(r"own noise is ([0-9.e+-]+)", open(f"{d}/summary.md").read()).group(1))
    floor = dual[-1][2]
    t_dual = time_to(dual, 1.21 * floor)
    t_path = time_to(path, floor)
    note = ""
    if t_path is None:
        _, t, e = path[-1]
        t_path = t * (e - noise) / (floor - noise)
        note = " (extrapolated)"
    name = d.rstrip("/").split("/")[-1]
    print(f"| {name} | {floor:.3e} | {t_dual:.3f} s | {t_path:.2f} s{note} | {t_path / t_dual:.0f}x |")
