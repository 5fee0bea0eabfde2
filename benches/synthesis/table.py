"""The synthesis benchmark's table (BENCHMARKS.md): per problem, kinema fit's
best defect-free error (the literature's measure, the sum of squared
differences, from each variant's --summary: rms² × target values) and the
wall time of all its variants, the best published defect-free error, and
pylinkage's best error and its time to reach it; then how long kinema took
against pylinkage's time to the error pylinkage reached.

Run by run.sh after both sides; reads results/."""
import csv
import json
import os

HERE = os.path.dirname(os.path.abspath(__file__))
RES = os.path.join(HERE, "results")

# Target values per problem (rows × columns) and the best published
# defect-free error (README.md, recomputed by problems.py).
VALUES = {"straight6": 12, "arc5": 10, "closed18": 36, "semicircle6": 12,
          "ellipse10": 20, "log10": 11}
PUBLISHED = {"straight6": 4.067e-12, "arc5": 1.284e-6, "closed18": 0.0160777,
             "semicircle6": 2.58036, "ellipse10": 4.02e-4,
             "log10": 8.58e-4}  # log10: Freudenstein baseline, not published


def kinema():
    times = {}
    with open(os.path.join(RES, "kinema_times.txt")) as f:
        for line in f:
            tag, t = line.split()
            times[tag] = float(t)
    best = {}
    for tag, t in times.items():
        name = tag.split(".")[0]
        path = os.path.join(RES, f"{tag}.summary.csv")
        err = float("inf")
        if os.path.exists(path):
            with open(path) as f:
                rows = list(csv.DictReader(f))
            if rows:
                err = float(rows[0]["rms"]) ** 2 * VALUES[name]
        e, total = best.get(name, (float("inf"), 0.0))
        best[name] = (min(e, err), total + t)
    return best


def main():
    k = kinema()
    peer = {}
    path = os.path.join(RES, "pylinkage.json")
    if os.path.exists(path):
        for r in json.load(open(path))["results"]:
            e = r["best_error"]
            if e is None:
                continue
            old = peer.get(r["problem"])
            if old is None or e < old[0]:
                # Its time to its best, from below: when it first reached
                # the smallest decade at or above its best (levels), else
                # (no decade between) its wall time, marked ≤.
                reached = [(float(level), t) for level, (t, _) in r["levels"].items()
                           if float(level) >= e]
                if reached:
                    level, t = min(reached)
                    peer[r["problem"]] = (e, t, r["method"], f"≤ {level:g} after")
                else:
                    peer[r["problem"]] = (e, r["wall_s"], r["method"], "best after ≤")
    print("| problem | kinema fit: best error | kinema: time (all variants) | best published defect-free | pylinkage: best error (method) | pylinkage: time | pylinkage time / kinema time |")
    print("|---|---|---|---|---|---|---|")
    for name in VALUES:
        if name not in k:
            continue
        e, t = k[name]
        p = peer.get(name)
        if p:
            pe, pt, pm, how = p
            ratio = f"{pt / t:.0f}×" if e <= pe else "(worse error)"
            ps = f"{pe:.4g} ({pm})"
            pts = f"{how} {pt:.1f} s"
        else:
            ps, pts, ratio = "—", "—", "—"
        print(f"| {name} | {e:.4g} | {t:.2f} s | {PUBLISHED[name]:.4g} | {ps} | {pts} | {ratio} |")


if __name__ == "__main__":
    main()
