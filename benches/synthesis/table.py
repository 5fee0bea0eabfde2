"""The synthesis benchmark's table (BENCHMARKS.md), from run.sh's results/.

Per problem: kinema fit's best defect-free error with run.sh's starts (the
literature's measure, the sum of squared differences: each variant's
--summary rms² × the target values; the best over the variants) and the
wall time of all its variants; the best published defect-free error;
pylinkage's best error (its better method) and its time to reach it (when
its best error last improved, pylinkage_bench.py's time_to_best_s); kinema's time to
reach the same or better error — the smallest rung of the ladder (1, 2,
4, … starts per variant) whose best design is at or below pylinkage's
best, the variants' times summed; and the ratio of the two times.
"""
import csv
import json
import os

HERE = os.path.dirname(os.path.abspath(__file__))
RES = os.path.join(HERE, "results")

# Target values per problem (rows × columns) and the best published
# defect-free error (README.md, recomputed by problems.py).
VALUES = {"straight6": 12, "arc5": 10, "closed18": 36, "semicircle6": 12,
          "ellipse10": 20, "log10": 11, "crankrocker30": 30}
PUBLISHED = {"straight6": 4.067e-12, "arc5": 1.284e-6, "closed18": 0.0160777,
             "semicircle6": 2.58036, "ellipse10": 4.02e-4,
             "log10": 8.58e-4,  # log10: Freudenstein baseline, not published
             "crankrocker30": 0.00759237360533}  # the book's optimum, recomputed


def runs(directory):
    """{(problem, starts): (best error over variants, total time)}."""
    out = {}
    path = os.path.join(directory, "kinema_times.txt")
    if not os.path.exists(path):
        return out
    for line in open(path):
        tag, starts, t = line.split()
        name = tag.split(".")[0]
        err = float("inf")
        summary = os.path.join(directory, f"{tag}.summary.csv")
        if os.path.exists(summary):
            rows = list(csv.DictReader(open(summary)))
            if rows:
                err = float(rows[0]["rms"]) ** 2 * VALUES[name]
        key = (name, int(starts))
        e, total = out.get(key, (float("inf"), 0.0))
        out[key] = (min(e, err), total + float(t))
    return out


def peers():
    out = {}
    path = os.path.join(RES, "pylinkage.json")
    if not os.path.exists(path):
        return out
    for r in json.load(open(path))["results"]:
        e = r["best_error"]
        if e is None:
            continue
        old = out.get(r["problem"])
        if old is None or e < old[0]:
            t = r.get("time_to_best_s")
            if t is not None:
                out[r["problem"]] = (e, t, r["method"], f"{t:.1f} s")
            else:
                out[r["problem"]] = (e, r["wall_s"], r["method"], f"≤ {r['wall_s']:.1f} s")
    return out


def main():
    main_runs = runs(RES)
    ladder = runs(os.path.join(RES, "ladder"))
    peer = peers()
    print("| problem | best published defect-free | kinema fit: best error | kinema: time, all variants | pylinkage: best error (method) | pylinkage: time to it | kinema: time to the same or better | ratio |")
    print("|---|---|---|---|---|---|---|---|")
    for name in VALUES:
        full = [(s, v) for (n, s), v in main_runs.items() if n == name]
        if not full:
            continue
        starts, (e, t) = max(full)
        p = peer.get(name)
        if p:
            pe, pt, pm, shown = p
            rungs = sorted((s, v) for (n, s), v in ladder.items() if n == name)
            reach = next(((s, v[1]) for s, v in rungs if v[0] <= pe), None)
            if reach:
                s, kt = reach
                kshown = f"{kt:.2f} s ({s} start{'s' if s > 1 else ''})"
                ratio = f"{pt / kt:.0f}×"
            else:
                kshown, ratio = "not on the ladder", "—"
            ps = f"{pe:.4g} ({pm})"
        else:
            ps, shown, kshown, ratio = "—", "—", "—", "—"
        print(f"| {name} | {PUBLISHED[name]:.4g} | {e:.4g} ({starts} starts) | {t:.2f} s | {ps} | {shown} | {kshown} | {ratio} |")


if __name__ == "__main__":
    main()
