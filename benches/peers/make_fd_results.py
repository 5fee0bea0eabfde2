#!/usr/bin/env python3
"""The forward-dynamics section of RESULTS.md (README.md section 6) from results/fd_*.json
(bench_exudyn.py), reference/fd_q_t1.csv (kinema's accurate mode at rtol 1e-11 and kinema's
HHT, from `cargo run --release -p kinema-bench --example fd_reference`) and criterion's
estimates of `cargo bench -p kinema-bench --bench forward_tape` (target/criterion/). Replaces
the part of RESULTS.md between the FD markers (appends it the first time); make_results.py keeps
that part when it rewrites the file. Standard library only.
"""
import json
import os

HERE = os.path.dirname(os.path.abspath(__file__))
R = os.path.join(HERE, "results")
CRITERION = os.path.join(HERE, "..", "..", "target", "criterion")
MECHS = ["fd_slider_crank", "fd_chain10", "fd_chain100"]
BEGIN, END = "<!-- FD BEGIN (make_fd_results.py) -->", "<!-- FD END -->"


def reference():
    out = {}
    with open(os.path.join(HERE, "reference", "fd_q_t1.csv")) as f:
        next(f)
        for line in f:
            parts = line.strip().split(",")
            if len(parts) > 2:
                out[(parts[0], parts[1])] = [float(x) for x in parts[2:]]
    return out


def gap(q, ref):
    return max(abs(a - b) for a, b in zip(q, ref)) if q and ref and len(q) == len(ref) else None


def criterion_us(mech):
    p = os.path.join(CRITERION, f"forward_tape_{mech}", "hht_step", "new", "estimates.json")
    if not os.path.exists(p):
        return None
    e = json.load(open(p))["median"]
    ci = e["confidence_interval"]
    return e["point_estimate"] / 1e3, ci["lower_bound"] / 1e3, ci["upper_bound"] / 1e3


def fmt(v):
    if v is None:
        return "-"
    return f"{v:.3g}" if v < 1000 else f"{v:,.0f}"


def section():
    ref = reference()
    L = [BEGIN, "", "## Forward dynamics (issue 17)", "",
         "Models: README.md section 6 (`fd_models.py`; kinema: "
         "`crates/kinema-bench/models/fd_slider_crank.kin`, `kinema_model::chain::pendulum_chain_kin(n)`). "
         "Released from rest, gravity; HHT-alpha alpha = -0.1 (kinema) / generalized-alpha at the same "
         "spectral radius rho_inf = 0.8182 (Exudyn, index 3), h = 1e-3, 1000 steps. Per step = wall time of the "
         "1000 steps / 1000 (the start - consistent initial accelerations - not timed). Exudyn: median "
         "[min, max] over repetitions, each on a freshly built model; kinema tape: criterion's median "
         "[95% confidence interval]. max|dq| = max over q at t = 1 of |tool - kinema accurate mode at "
         "rtol 1e-11| (`reference/fd_q_t1.csv`), so every column solved the same problem to the same accuracy "
         "(both second-order, same step).", "",
         "| mechanism | n | Exudyn best setting | Exudyn per-step us | Exudyn max\\|dq\\| | kinema tape per-step us "
         "| kinema HHT max\\|dq\\| | kinema generated per-step us | tape vs Exudyn |",
         "|---|---|---|---|---|---|---|---|---|"]
    details = []
    for m in MECHS:
        p = os.path.join(R, f"fd_exudyn_{m}.json")
        r = ref.get((m, "kinema-accurate-1e-11"))
        hht = ref.get((m, "kinema-hht-tape"))
        tape = criterion_us(m)
        best = None
        if os.path.exists(p):
            d = json.load(open(p))
            for v in d["variants"]:
                g = gap(v["q"], r)
                details.append(f"| {m} | {v['solver']} | {v['newton_kind']} | {fmt(v['us_median'])} "
                               f"[{fmt(v['us_min'])}, {fmt(v['us_max'])}] | {v['reps']} | "
                               f"{v['newton']} | {v['jacobians']} | {g:.2e} |" if g is not None else
                               f"| {m} | {v['solver']} | {v['newton_kind']} | {fmt(v['us_median'])} | "
                               f"{v['reps']} | {v['newton']} | {v['jacobians']} | - |")
                if best is None or v["us_median"] < best["us_median"]:
                    best = v
        n = len(r) if r else "-"
        if best is None:
            L.append(f"| {m} | {n} | (not run) | - | - | "
                     f"{fmt(tape[0]) if tape else '-'} | - | (lead) | - |")
            continue
        g = gap(best["q"], r)
        gh = gap(hht, r)
        tape_s = f"{fmt(tape[0])} [{fmt(tape[1])}, {fmt(tape[2])}]" if tape else "-"
        ratio = f"{best['us_median'] / tape[0]:.2g}x" if tape else "-"
        L.append(f"| {m} | {n} | {best['solver']}, {best['newton_kind']} Newton | {fmt(best['us_median'])} "
                 f"[{fmt(best['us_min'])}, {fmt(best['us_max'])}] | {g:.2e} | {tape_s} | "
                 f"{gh:.2e} | (lead) | {ratio} |")
    L += ["", "Every Exudyn setting (`bench_exudyn.py`; Newton iterations and Jacobian computations over the 1000 "
          "steps):", "",
          "| mechanism | linear solver | Newton | per-step us median [min, max] | reps | iterations | Jacobians "
          "| max\\|dq\\| |",
          "|---|---|---|---|---|---|---|---|"] + details
    L += ["", "Reproduce: `./run_fd.sh` (Exudyn into .venv, the criterion bench, the reference, this section).",
          "", END]
    return "\n".join(L)


def main():
    path = os.path.join(HERE, "RESULTS.md")
    text = open(path).read() if os.path.exists(path) else ""
    s = section()
    if BEGIN in text and END in text:
        head, rest = text.split(BEGIN, 1)
        tail = rest.split(END, 1)[1]
        text = head + s + tail
    else:
        text = text.rstrip("\n") + "\n\n" + s + "\n"
    with open(path, "w") as f:
        f.write(text)
    print(s)


if __name__ == "__main__":
    main()
