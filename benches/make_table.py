#!/usr/bin/env python3
"""Writes the side-by-side table of BENCHMARKS.md (between the markers
<!-- compare --> and <!-- /compare -->) from the peers' results
(benches/peers/results/) and kinema's criterion estimates
(target/criterion/step/<mechanism>/<backend>_<mode>/new/estimates.json).
Standard library only."""
import csv
import datetime
import json
import os
import platform
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
PEERS = os.path.join(ROOT, "benches", "peers", "results")
CRIT = os.path.join(ROOT, "target", "criterion")

MECHS = [("slider_crank", "slider-crank", 9, 0.37), ("four_bar", "four-bar", 9, 0.50),
         ("chain2", "chain N=2", 6, None), ("chain10", "chain N=10", 30, 2.0),
         ("chain50", "chain N=50", 150, None), ("chain200", "chain N=200", 600, 50.0),
         ("chain1000", "chain N=1000", 3000, 290.0)]
PEER_COLS = [("sympy-numpy", "SymPy + numpy"), ("sympy-splu", "SymPy + splu"),
             ("casadi-c-cse-own", "CasADi C, dense LU"),
             ("casadi-c-step-sparseqr", "CasADi C, whole step"), ("casadi-py", "CasADi Python")]


def crit_median_us(group, bench):
    """Median in µs of a criterion benchmark, or None."""
    path = os.path.join(CRIT, group, bench, "new", "estimates.json")
    if not os.path.exists(path):
        return None
    with open(path) as f:
        return json.load(f)["median"]["point_estimate"] / 1000.0


def peers():
    out = {}
    with open(os.path.join(PEERS, "summary.csv")) as f:
        for row in csv.DictReader(f):
            out[(row["mechanism"], row["peer"])] = float(row["per_step_us_median"])
    return out


def fmt(us):
    if us is None:
        return "–"
    if us >= 1000:
        return f"{us:,.0f}"
    if us >= 100:
        return f"{us:.0f}"
    if us >= 10:
        return f"{us:.1f}"
    return f"{us:.2f}"


def machine():
    cpu = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    cpu = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    rustc = subprocess.run(["rustc", "--version"], capture_output=True, text=True).stdout.strip()
    return (f"{cpu}, {os.cpu_count()} cores, {platform.system()} {platform.release()}; {rustc}; "
            f"Python {platform.python_version()}; measured {datetime.date.today().isoformat()}")


def table():
    p = peers()
    lines = [f"Machine: {machine()}.", "",
             "Per full step (Newton to ‖Φ‖∞ ≤ 1e-12, velocity, acceleration), µs, medians. "
             "kinema 'same' = the peers' loop (`Options::same_algorithm()`), 'default' = kinema's "
             "defaults (`Options::default()`: predictor, full Newton). Ratio = best peer / kinema same-algorithm generated (target ≥ 3). "
             "JIT = the model file compiled at load time (`Backend::Jit`, the default for model files; – above its size bounds, where it runs the tape); "
             "JIT ratio = best peer / JIT same (target ≥ 3); JIT / generated = JIT same / generated same (target ≤ 1.5).", "",
             "| mechanism (n) | " + " | ".join(name for _, name in PEER_COLS)
             + " | best peer | kinema generated, same | generated, default | tape, same | tape, default "
             "| JIT, same | JIT, default | hand-written, same | ratio | JIT ratio | JIT / generated | target |",
             "|---|" + "---|" * (len(PEER_COLS) + 12)]
    for key, name, n, target in MECHS:
        peer_vals = [p.get((key, col)) for col, _ in PEER_COLS]
        best = min((v for v in peer_vals if v is not None), default=None)
        k = {f"{b}/{m}": crit_median_us(f"step_{key}", f"{b}_{m}")
             for b in ("generated", "tape", "jit", "handwritten") for m in ("same", "default")}
        ratio = best / k["generated/same"] if best and k["generated/same"] else None
        jit_ratio = best / k["jit/same"] if best and k["jit/same"] else None
        jit_gen = k["jit/same"] / k["generated/same"] if k["jit/same"] and k["generated/same"] else None
        ok = "" if target is None or k["generated/same"] is None else (
            f"≤ {fmt(target)} {'✓' if k['generated/same'] <= target else '✗'}")
        lines.append(f"| {name} ({n}) | " + " | ".join(fmt(v) for v in peer_vals)
                     + f" | {fmt(best)} | **{fmt(k['generated/same'])}** | {fmt(k['generated/default'])}"
                     f" | {fmt(k['tape/same'])} | {fmt(k['tape/default'])}"
                     f" | {fmt(k['jit/same'])} | {fmt(k['jit/default'])} | {fmt(k['handwritten/same'])}"
                     f" | {'–' if ratio is None else f'{ratio:.1f}×'}"
                     f" | {'–' if jit_ratio is None else f'{jit_ratio:.1f}×'}"
                     f" | {'–' if jit_gen is None else f'{jit_gen:.2f}'} | {ok} |")
    # Derivation of the N = 1000 chain.
    try:
        with open(os.path.join(PEERS, "casadi_chain1000.json")) as f:
            casadi = json.load(f)["t_derive"]
        with open(os.path.join(PEERS, "sympy_chain1000.json")) as f:
            sympy = json.load(f)["derive"]["t_derive"]
    except (OSError, KeyError):
        casadi = sympy = None
    derive = crit_median_us("derivation", "text to derivation/1000")
    alone = crit_median_us("derivation", "checked model to derivation/1000")
    tapes = crit_median_us("derivation", "text to runnable tapes/1000")
    lines += ["", "Derivation of the chain N = 1000 (Φ, Φ_q, ν, γ), seconds:", "",
              "| SymPy | CasADi | kinema, derivation (checked model → Φ, Φ_q, ν, γ) "
              "| kinema, text → derivation | kinema, text → runnable tapes |",
              "|---|---|---|---|---|",
              f"| {'–' if sympy is None else f'{sympy:.2f}'} | {'–' if casadi is None else f'{casadi:.3f}'} "
              f"| {'–' if alone is None else f'{alone / 1e6:.3f}'} "
              f"| {'–' if derive is None else f'{derive / 1e6:.3f}'} | {'–' if tapes is None else f'{tapes / 1e6:.3f}'} |"]
    # Growth exponent of the generated same-algorithm step over N = 10 … 1000.
    import math
    pts = [(n, crit_median_us(f"step_chain{n}", "generated_same")) for n in (10, 50, 200, 1000)]
    pts = [(n, t) for n, t in pts if t]
    if len(pts) >= 2:
        xs = [math.log(n) for n, _ in pts]
        ys = [math.log(t) for _, t in pts]
        mx, my = sum(xs) / len(xs), sum(ys) / len(ys)
        slope = sum((x - mx) * (y - my) for x, y in zip(xs, ys)) / sum((x - mx) ** 2 for x in xs)
        lines += ["", f"Growth of the chain's generated same-algorithm step with N (least squares over "
                  f"N = {', '.join(str(n) for n, _ in pts)}): N^{slope:.2f}."]
    return "\n".join(lines)


def main():
    path = os.path.join(ROOT, "BENCHMARKS.md")
    with open(path) as f:
        text = f.read()
    start, end = "<!-- compare -->", "<!-- /compare -->"
    if start not in text or end not in text:
        sys.exit(f"{path} lacks the {start} … {end} markers")
    head, rest = text.split(start, 1)
    _, tail = rest.split(end, 1)
    with open(path, "w") as f:
        f.write(head + start + "\n" + table() + "\n" + end + tail)


if __name__ == "__main__":
    main()
