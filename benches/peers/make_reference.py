"""Copy the peers' checkpoint trajectories into reference/ (committed), so that Rust tests can
compare kinema's "same algorithm" trajectories with the peers' without Python.

Run after run_all.sh:  python3 make_reference.py   (standard library only)

For each mechanism, the reference is the trajectory of the base peer (sympy-numpy, or sympy-splu
where the dense peer did not run all 1000 steps), checked first against every other peer that ran
the full 1000 steps. Rows: checkpoints t = 0, 0.05, ..., 1 (21 rows). Columns: t, q0..q{n-1},
qd0.., qdd0.. (0-based coordinate index 3(k-1)+{0,1,2} for body k). Values are Python repr() of
doubles: they read back to the exact double. For the long chains (N > 50) only the columns of
bodies 1-5, every (N/20)-th body and the last 5 bodies are kept, to keep the files small; the
header names the columns that are there. reference/AGREEMENT.md records the cross-peer spread.
"""
import csv
import glob
import os

HERE = os.path.dirname(os.path.abspath(__file__))
RES = os.path.join(HERE, "results")
REF = os.path.join(HERE, "reference")
MECHS = ["slider_crank", "four_bar", "chain2", "chain10", "chain50", "chain200", "chain1000"]


def read(path):
    with open(path) as f:
        rows = list(csv.reader(f))
    return rows[0], [[float(x) for x in r] for r in rows[1:] if r]


def kept_bodies(n_bodies):
    if n_bodies <= 50:
        return list(range(1, n_bodies + 1))
    every = n_bodies // 20
    keep = set(range(1, 6)) | set(range(every, n_bodies + 1, every)) | set(range(n_bodies - 4, n_bodies + 1))
    return sorted(keep)


def main():
    os.makedirs(REF, exist_ok=True)
    notes = ["# Peer reference trajectories", "",
             "Written by `make_reference.py` from `results/traj_*.csv` of one `run_all.sh` run. "
             "Spread = max over checkpoints and all of q, qd, qdd of |peer - reference| / max(|reference|, 1), "
             "over every other peer that ran the full 1000 steps.", "",
             "| mechanism | reference peer | rows | columns kept | other peers | spread |", "|---|---|---|---|---|---|"]
    for m in MECHS:
        base = None
        for cand in ("sympy-numpy", "sympy-splu"):
            p = os.path.join(RES, f"traj_{m}_{cand}.csv")
            if os.path.exists(p):
                base = cand
                break
        if base is None:
            print(f"{m}: no trajectory, skipped")
            continue
        hdr, data = read(os.path.join(RES, f"traj_{m}_{base}.csv"))
        others, spread = [], 0.0
        for p in sorted(glob.glob(os.path.join(RES, f"traj_{m}_*.csv"))):
            peer = os.path.basename(p)[len(f"traj_{m}_"):-4]
            if peer == base:
                continue
            h2, d2 = read(p)
            if h2 != hdr or len(d2) != len(data):
                continue
            others.append(peer)
            for r1, r2 in zip(data, d2):
                for a, b in zip(r1, r2):
                    spread = max(spread, abs(b - a) / max(abs(a), 1.0))
        n = (len(hdr) - 1) // 3
        bodies = kept_bodies(n // 3)
        coords = [3 * (k - 1) + c for k in bodies for c in range(3)]
        cols = [0] + [1 + i for i in coords] + [1 + n + i for i in coords] + [1 + 2 * n + i for i in coords]
        out = os.path.join(REF, f"traj_{m}.csv")
        with open(os.path.join(RES, f"traj_{m}_{base}.csv")) as f:
            raw = [line.rstrip("\n").split(",") for line in f if line.strip()]
        with open(out, "w") as f:
            for r in raw:
                f.write(",".join(r[c] for c in cols) + "\n")
        kept = "all" if len(bodies) == n // 3 else f"{len(bodies)} of {n // 3} bodies"
        notes.append(f"| {m} | {base} | {len(data)} | {kept} | {len(others)} | {spread:.2e} |")
        print(f"{m}: {out} ({os.path.getsize(out)} B), reference {base}, spread {spread:.2e} over {len(others)} peers")
    notes += ["", "Compare kinema to a reference with a tolerance above the spread (1e-12 relative for the "
              "small mechanisms; the long chains' peers disagree among themselves by up to the spread shown)."]
    with open(os.path.join(REF, "AGREEMENT.md"), "w") as f:
        f.write("\n".join(notes) + "\n")


if __name__ == "__main__":
    main()
