"""The published four-bar synthesis benchmark problems, their published
designs, and an independent check of each design: its error by the
literature's own formula and its defects (assembly, branch, order, crank
rotation).

Conventions of the literature (Cabrera, Simon & Prado 2002, and every later
paper on these cases): ground pivot O = (x0, y0); the ground link O->D of
length r1 at angle theta0; crank r2 (input, angle theta2 measured from the
ground link), coupler r3 (A->B), rocker r4 (D->B); the coupler point C at
(rcx, rcy) in a frame at A with x along A->B. In the ground-link frame

    Cr = r2 (cos th2, sin th2) + R(th3) (rcx, rcy),   C = R(theta0) Cr + (x0, y0)

and th3 from Freudenstein's half-angle equation with the root

    th3 = 2 atan((-E - sqrt(E^2 - 4 D F)) / (2 D))

(MATLAB codes take real() of it, so a design that cannot assemble still
gets a number). The error is the sum of squared distances to the targets.

Run it: python3 problems.py  (numpy only) — prints, per problem and
published design, the error by the formula, the error on the assembly
branch the mechanism is in at its first target, and the defects found.
"""

import math

import numpy as np

PI = math.pi

# ---------------------------------------------------------------- problems
# Each: targets (x, y); timing = list of crank angles th2 (prescribed) or
# None (each target's crank angle is a design variable); fixed = variables
# fixed by the problem; bounds as published (see README.md for sources).
PROBLEMS = {
    "straight6": dict(
        title="6 points on a vertical line, without prescribed timing",
        targets=[(20, 20), (20, 25), (20, 30), (20, 35), (20, 40), (20, 45)],
        timing=None,
        fixed={},
        bounds=dict(r=(5, 60), rc=(-60, 60), xy0=(-60, 60), ang=(0, 2 * PI)),
    ),
    "arc5": dict(
        title="5 points on an arc, prescribed timing, frame fixed",
        targets=[(3, 3), (2.759, 3.363), (2.372, 3.663), (1.890, 3.862), (1.355, 3.943)],
        timing=[PI / 6, PI / 4, PI / 3, 5 * PI / 12, PI / 2],
        fixed=dict(x0=0.0, y0=0.0, theta0=0.0),
        bounds=dict(r=(0, 50), rc=(-50, 50)),
    ),
    "closed18": dict(
        title="18 points on a closed curve, crank angles th2_1 + (i-1) 20 deg",
        targets=[(0.5, 1.1), (0.4, 1.1), (0.3, 1.1), (0.2, 1.0), (0.1, 0.9), (0.05, 0.75),
                 (0.02, 0.6), (0.0, 0.5), (0.0, 0.4), (0.03, 0.3), (0.1, 0.25), (0.15, 0.2),
                 (0.2, 0.3), (0.3, 0.4), (0.4, 0.5), (0.5, 0.7), (0.6, 0.9), (0.6, 1.0)],
        # th2_i = th2_1 + (i-1) * pi/9; th2_1 is a design variable.
        timing="uniform20",
        fixed={},
        bounds=dict(r=(0, 50), rc=(-50, 50), xy0=(-50, 50), ang=(0, 2 * PI)),
    ),
    "semicircle6": dict(
        title="6 points on a half circle, prescribed timing",
        targets=[(0, 0), (1.9098, 5.8779), (6.9098, 9.5106), (13.09, 9.5106),
                 (18.09, 5.8779), (20, 0.0)],
        timing=[PI / 6, PI / 3, PI / 2, 2 * PI / 3, 5 * PI / 6, PI],
        fixed={},
        bounds=dict(r=(5, 50), rc=(-50, 50), xy0=(-50, 50), ang=(0, 2 * PI)),
    ),
    "ellipse10": dict(
        title="10 points on an ellipse (first = last), without prescribed timing",
        targets=[(20, 10), (17.66, 15.142), (11.736, 17.878), (5, 16.928), (0.60307, 12.736),
                 (0.60307, 7.2638), (5, 3.0718), (11.736, 2.1215), (17.66, 4.8577), (20, 10)],
        timing=None,
        fixed={},
        bounds=dict(r=(5, 80), rc=(-80, 80), xy0=(-80, 80), ang=(0, 2 * PI)),
    ),
}

# ------------------------------------------------------ published designs
# x = [r1, r2, r3, r4, rcx, rcy, x0, y0, theta0, th2_1 ...] (angles in rad),
# as published; "via" says where the numbers were read. NVR22 = the MATLAB
# files of Nguyen-Van et al. 2022 (github sy-nguyen-van/
# DE_Jaya_Synthesis_Four_Bar_Mechanisms, Case*/Check*.m, x_best_*.txt),
# which transcribe the earlier papers' tables.
PUBLISHED = {
    "straight6": [
        ("Cabrera et al. 2002 (GA)", "NVR22 Case1/Check_Case1.m",
         [39.46629, 8.56291, 19.09486, 47.83886, 13.38556, 12.21961, 29.72250, 23.45450, 6.20163,
          6.11937, 0.19304, 0.44083, 0.68467, 0.95835, 1.35533]),
        ("Acharyya & Mandal 2009 (GA)", "NVR22 Case1/Check_Case1.m",
         [28.77133, 5.00000, 35.36548, 59.13681, 0.00000, 14.85037, 29.91329, 32.60228, 5.28747,
          6.28319, 0.31821, 0.63852, 0.97995, 1.41273, 2.07625]),
        ("Acharyya & Mandal 2009 (PSO)", "NVR22 Case1/Check_Case1.m",
         [31.15501, 5.00000, 23.84561, 45.80352, 39.00066, 18.50846, 59.99999, 17.91696, 0.41984,
          4.84241, 0.40468, 0.65742, 0.92209, 1.24707, 2.29873]),
        ("Acharyya & Mandal 2009 (DE)", "NVR22 Case1/Check_Case1.m",
         [35.02074, 6.40420, 31.60722, 50.59949, 20.80324, 41.54364, 60.00000, 18.07791, 0.00000,
          6.28319, 0.26494, 0.50038, 0.73532, 0.99653, 1.33355]),
        ("MUMSA (per NVR22)", "NVR22 Case1/Check_Case1.m",
         [31.78826, 8.20465, 24.93213, 31.38593, 34.19372, 14.41567, -6.36652, 56.83676, 4.01596,
          1.36655, 2.33077, 2.87104, 3.39459, 3.97096, 4.96349]),
        ("IOA (per NVR22)", "NVR22 Case1/Check_Case1.m",
         [54.71582, 18.73099, 31.22310, 42.22374, -27.29874, 31.65051, 43.07086, 27.41706, 5.97746,
          6.42411, 6.53496, 0.36230, 0.46906, 0.57765, 0.69047]),
        ("Lin & Hsiao (DE, combined mutation)", "NVR22 Case1/Check.m",
         [45.9540268793200, 10.1413352283990, 36.1198616002200, 49.7905570636800, 51.4935231082160,
          16.4957302836340, 59.9251894962240, -0.267255177889410, 0.862384954187540,
          4.49683139849550, 3.94685292206840, 3.51208539098020, 3.11078124880880,
          2.71010931195190, 2.26549866257340]),
        ("Nguyen-Van et al. 2022 (HCDJ)", "NVR22 Case1/x_best_HCDJ_Case1.txt",
         [1.4201369e+01, 8.0143127e+00, 1.6309922e+01, 1.2253871e+01, 2.7797721e+01, 1.1305412e+01,
          -2.3095310e+00, 4.5695083e+01, 4.5172417e+00, 6.2532447e+00, 2.4038981e+00,
          2.9362397e+00, 3.4905751e+00, 4.0650776e+00, 5.2095019e+00]),
    ],
    "arc5": [
        ("Kunjur & Krishnamurty 1997 (GA)", "NVR22 Case2/CheckCASE2.m",
         [3.509643, 1.857606, 4.725835, 3.518721, 1.959538, 1.558898, 0, 0, 0]),
        ("Cabrera et al. 2002 (GA)", "NVR22 Case2/CheckCASE2.m",
         [3.0630424, 1.9959624, 3.305823, 2.524706, 1.645158, 1.708959, 0, 0, 0]),
        ("MUMSA (per NVR22)", "NVR22 Case2/CheckCASE2.m",
         [3.77326856, 2.00000403, 4.11697104, 2.74615671, 1.67848787, 1.67098007, 0, 0, 0]),
        ("IOA (per NVR22)", "NVR22 Case2/CheckCASE2.m",
         [2.803607, 1.99226, 3.030461, 2.474117, 1.64413, 1.714536, 0, 0, 0]),
        ("Nguyen-Van et al. 2022 (HCDJ)", "NVR22 Case2/x_best_HCDJ_Case2.txt",
         [4.2930812e+00, 1.9978324e+00, 4.7374099e+00, 2.9417301e+00, 1.7074051e+00,
          1.6441696e+00, 0, 0, 0]),
    ],
    "closed18": [
        ("Cabrera et al. 2002 (GA)", "NVR22 Case3/CheckCASE3.m",
         [3.057878, 0.237803, 4.828954, 2.056456, 0.767038, 1.850828, 1.776808, -0.641991, 1.002168,
          0.226186]),
        ("Kunjur & Krishnamurty 1997 (GA)", "NVR22 Case3/CheckCASE3.m",
         [1.879660, 0.274853, 1.180253, 2.138209, -0.833592, -0.378770, 1.132062, 0.663433,
          4.354224, 2.558625]),
        ("MUMSA (per NVR22)", "NVR22 Case3/CheckCASE3.m",
         [4.453772, 0.297057, 3.913095, 0.849372, -2.067338, 1.6610626, -1.309243, 2.806964,
          2.7387359, 4.853543]),
        ("IOA (per NVR22)", "NVR22 Case3/CheckCASE3.m",
         [4.040435, 0.245216, 6.382940, 2.620532, 1.139106, 1.866109, 1.891805, -0.761339, 1.187751,
          0.0]),
        ("Nguyen-Van et al. 2022 (HCDJ)", "NVR22 Case3/x_best_HCDJ_Case3.txt",
         [4.9800886e+01, 2.8817159e-01, 4.8476138e+01, 1.6336420e+00, -2.3412810e+01,
          7.6644886e+00, -1.4836153e+01, 2.0140223e+01, 2.5286091e+00, 5.0644224e+00]),
    ],
    "semicircle6": [
        # The six columns of NVR22 Case4/CheckCASE4.m are not labelled there.
        ("NVR22 comparison column 1", "NVR22 Case4/CheckCASE4.m",
         [49.994859, 5, 5.915643, 49.994867, 18.925715, 0, 14.472475, -12.494409, 0.467287]),
        ("NVR22 comparison column 2", "NVR22 Case4/CheckCASE4.m",
         [50, 5, 5.905345, 50, 18.819312, 0, 14.373772, -12.444295, 0.463633]),
        ("NVR22 comparison column 3", "NVR22 Case4/CheckCASE4.m",
         [50, 5, 7.031047, 48.134183, 16.976687, 12.952139, 12.197494, -15.998203, 0.0428247]),
        ("NVR22 comparison column 4", "NVR22 Case4/CheckCASE4.m",
         [49.999217, 1.3476638, 1.3476825, 49.999235, 11.383058, 4.4426855, 10.1944353, -3.6925458,
          6.2157809]),
        ("NVR22 comparison column 5", "NVR22 Case4/CheckCASE4.m",
         [49.968967, 4.785659, 6.491026, 48.393942, 16.444782, 11.988091, 12.046587, -14.774897,
          0.038678]),
        ("NVR22 comparison column 6", "NVR22 Case4/CheckCASE4.m",
         [60, 5, 7.06916, 58.1241, 16.8655, 13.0576, 11.8936, -16.0037, 6.28318]),
        ("Nguyen-Van et al. 2022 (HCDJ)", "NVR22 Case4/x_best_HCDJ_Case4.txt",
         [4.9999980e+01, 1.3484315e+00, 1.3484507e+00, 5.0000000e+01, 1.1384434e+01,
          4.4424357e+00, 1.0194752e+01, -3.6941340e+00, 6.2158799e+00]),
    ],
    "ellipse10": [
        ("MUMSA (per NVR22)", "NVR22 Case5/CheckCase5.m",
         [79.516068, 9.723973, 45.842524, 51.432848, 8.213922, -2.9539575, 2.021109, 13.2165878,
          5.5969445, 0.6376873, 1.3255329, 2.0080339, 2.6955659, 3.3845794, 4.08293762, 4.79845482,
          5.51170565, 6.2127919, 0.6371866]),
        ("IOA (per NVR22)", "NVR22 Case5/CheckCase5.m",
         [65.428771, 8.016387, 47.221655, 44.13656, -11.570858, -1.904914, 10.635414, -1.675477,
          3.86733, 2.419931, 3.109267, 3.81295, 4.50644, 5.181139, 5.88342, 0.296263, 0.991153,
          1.707787, 2.418865]),
        ("W.Y. Lin 2010 (GA-DE)", "NVR22 Case5/CheckCase5.m",
         [80.0, 8.045662, 50.81902, 42.20801, -10.63697, -2.29109, 8.494813, -0.7579678, 3.88921,
          2.449437, 3.153969, 3.837114, 4.520171, 5.204799, 5.898536, 0.316204, 1.023555, 1.738992,
          2.449437]),
        ("NVR22 comparison column 4", "NVR22 Case5/CheckCase5.m",
         [54.7218, 8.53201, 31.4848, 33.2131, 0.423061, 5.9996, 7.30574, 4.88892, 0.0965143, 0.0,
          0.714643, 1.42348, 2.1297, 2.80325, 3.4741, 4.14885, 4.85494, 5.56444, 6.28318]),
        ("Nguyen-Van et al. 2022 (HCDJ)", "NVR22 Case5/x_best_HCDJ_Case5.txt",
         [7.9999856e+01, 8.1232008e+00, 5.0870344e+01, 4.2360533e+01, -1.0853763e+01,
          9.1433127e-02, 7.5379031e+00, -5.2254141e-01, 4.0121195e+00, 2.3428599e+00,
          3.0535127e+00, 3.7417464e+00, 4.4255457e+00, 5.1086716e+00, 5.7983829e+00,
          2.1286893e-01, 9.1658554e-01, 1.6304135e+00, 2.3428152e+00]),
    ],
}


def crank_angles(name, x):
    """The crank angles th2_i of design x for problem `name`."""
    p = PROBLEMS[name]
    n = len(p["targets"])
    if p["timing"] is None:
        return list(x[9:9 + n])
    if p["timing"] == "uniform20":
        return [x[9] + i * PI / 9 for i in range(n)]
    return list(p["timing"])


def th3_literature(r1, r2, r3, r4, th2):
    """The coupler angle by the literature's formula (complex-safe like MATLAB's real())."""
    k1, k4, k5 = r1 / r2, r1 / r3, (r4**2 - r1**2 - r2**2 - r3**2) / (2 * r3 * r2)
    d = math.cos(th2) - k1 + k4 * math.cos(th2) + k5
    e = -2 * math.sin(th2)
    f = k1 + (k4 - 1) * math.cos(th2) + k5
    disc = e * e - 4 * d * f
    root = (-e - np.sqrt(complex(disc))) / (2 * d)
    return float(np.real(2 * np.arctan(root))), disc


def th3_branch(r1, r2, r3, r4, th2, sigma):
    """The coupler angle on assembly branch sigma = +-1 (None if it cannot assemble).

    In the ground-link frame: A = r2 (cos th2, sin th2), D = (r1, 0); B is
    where circles (A, r3) and (D, r4) meet, on the left (sigma = +1) or the
    right (sigma = -1) of A->D.
    """
    ax, ay = r2 * math.cos(th2), r2 * math.sin(th2)
    dx, dy = r1 - ax, -ay
    d = math.hypot(dx, dy)
    a = (r3**2 - r4**2 + d * d) / (2 * d)
    h2 = r3**2 - a * a
    if h2 < 0:
        return None
    h = math.sqrt(h2)
    bx = ax + (a * dx - sigma * h * dy) / d
    by = ay + (a * dy + sigma * h * dx) / d
    return math.atan2(by - ay, bx - ax)


def sigma_of(r1, r2, r3, th2, th3):
    """The branch (+1 left, -1 right of A->D) of a coupler angle th3."""
    ax, ay = r2 * math.cos(th2), r2 * math.sin(th2)
    bx, by = ax + r3 * math.cos(th3), ay + r3 * math.sin(th3)
    cross = (r1 - ax) * (by - ay) - (-ay) * (bx - ax)
    return 1 if cross > 0 else -1


def coupler_point(x, th2, th3):
    r1, r2, r3, r4, rcx, rcy, x0, y0, t0 = x[:9]
    crx = r2 * math.cos(th2) + rcx * math.cos(th3) - rcy * math.sin(th3)
    cry = r2 * math.sin(th2) + rcx * math.sin(th3) + rcy * math.cos(th3)
    return (math.cos(t0) * crx - math.sin(t0) * cry + x0,
            math.sin(t0) * crx + math.cos(t0) * cry + y0)


def error_literature(name, x):
    """The published objective: sum of squared distances, literature's th3 formula."""
    f = 0.0
    for (tx, ty), th2 in zip(PROBLEMS[name]["targets"], crank_angles(name, x)):
        th3, _ = th3_literature(*x[:4], th2)
        cx, cy = coupler_point(x, th2, th3)
        f += (cx - tx) ** 2 + (cy - ty) ** 2
    return f


def grashof(r1, r2, r3, r4):
    """'crank' when the input link r2 turns fully, else the reason it cannot."""
    links = sorted([r1, r2, r3, r4])
    if links[0] + links[3] > links[1] + links[2]:
        return "non-Grashof: the crank cannot turn fully"
    if min(r1, r2, r3, r4) in (r2, r1):
        return "crank"
    return "Grashof, but the crank is not the shortest link (nor the ground): rocker input"


def defects(name, x):
    """The defects of a design: (list of strings, error on a consistent branch)."""
    r1, r2, r3, r4 = x[:4]
    ths = crank_angles(name, x)
    found = []
    g = grashof(r1, r2, r3, r4)
    if g != "crank":
        found.append(g)
    links = sorted([r1, r2, r3, r4])
    margin = (links[1] + links[2]) - (links[0] + links[3])
    if abs(margin) <= 1e-5 * links[3]:
        found.append(f"change point: s + l = p + q to {abs(margin):.1e}; the links fold into a "
                     "line (a singular configuration, where the branch can switch)")
    # Branch: the literature formula's branch at each target.
    sig = []
    for i, th2 in enumerate(ths):
        th3, disc = th3_literature(r1, r2, r3, r4, th2)
        if disc < 0:
            found.append(f"target {i + 1}: cannot assemble (discriminant {disc:.3g} < 0)")
            sig.append(0)
        else:
            sig.append(sigma_of(r1, r2, r3, th2, th3))
    live = [s for s in sig if s != 0]
    if live and len(set(live)) > 1:
        found.append("branch defect: targets on both assembly branches " + "".join(
            "+" if s > 0 else ("-" if s < 0 else "?") for s in sig))
    # Order: the crank angles must advance monotonically (either sense),
    # cyclically, by less than one turn in all.
    steps = [((b - a + PI) % (2 * PI)) - PI for a, b in zip(ths, ths[1:])]
    fwd = [s % (2 * PI) for s in np.diff(ths)]
    bwd = [(-s) % (2 * PI) for s in np.diff(ths)]
    if not (sum(fwd) < 2 * PI + 1e-9 or sum(bwd) < 2 * PI + 1e-9):
        found.append("order defect: the crank angles do not advance monotonically within one turn")
    del steps
    # Between targets (when the crank does not turn fully): assembly along
    # the sweep on the first target's branch.
    sigma0 = live[0] if live else 1
    if g != "crank" and len(ths) > 1:
        fwd_ok = sum(fwd) < 2 * PI + 1e-9
        for i, (a, b) in enumerate(zip(ths, ths[1:])):
            span = (b - a) % (2 * PI) if fwd_ok else -((a - b) % (2 * PI))
            for s in np.linspace(0, 1, 200):
                if th3_branch(r1, r2, r3, r4, a + s * span, sigma0) is None:
                    found.append(f"cannot move from target {i + 1} to {i + 2}: locks (dead point)")
                    break
    # Error on one branch throughout (what a defect-free reading gives).
    f = 0.0
    for (tx, ty), th2 in zip(PROBLEMS[name]["targets"], ths):
        th3 = th3_branch(r1, r2, r3, r4, th2, sigma0)
        if th3 is None:
            f = float("nan")
            break
        cx, cy = coupler_point(x, th2, th3)
        f += (cx - tx) ** 2 + (cy - ty) ** 2
    return found, f, sigma0


def out_of_bounds(name, x):
    """The variables of x outside the problem's bounds (as stated in this file)."""
    p = PROBLEMS[name]
    b = p["bounds"]
    names = ["r1", "r2", "r3", "r4", "rcx", "rcy", "x0", "y0", "theta0"]
    kinds = ["r"] * 4 + ["rc"] * 2 + ["xy0"] * 2 + ["ang"]
    out = []
    for n, k, v in zip(names, kinds, x[:9]):
        if n in p["fixed"] or k not in b:
            continue
        lo, hi = b[k]
        if not lo - 1e-9 <= v <= hi + 1e-9:
            out.append(f"{n} = {v:g} outside [{lo:g}, {hi:g}]")
    return out


def main():
    for name, designs in PUBLISHED.items():
        p = PROBLEMS[name]
        print(f"== {name}: {p['title']} ({len(p['targets'])} targets)")
        for label, via, x in designs:
            f = error_literature(name, x)
            found, fb, s0 = defects(name, x)
            print(f"  {label:40s} error {f:.6g}; on branch {s0:+d} throughout {fb:.6g}")
            for d in found:
                print(f"      DEFECT: {d}")
            for d in out_of_bounds(name, x):
                print(f"      BOUNDS: {d}")


if __name__ == "__main__":
    main()


# ------------------------------------------------------ function generation
# kinema's own statement in the textbook style (no published optimum was
# found to compare with; see README.md): y = log10(x), 1 <= x <= 10, eleven
# equally spaced x; crank th2 = th2s + (x - 1)/9 * 90 deg, rocker
# psi = psis + y * 90 deg (both from the ground link, r1 = 1, frame fixed).
# Design variables r2, r3, r4 in [0.05, 5], th2s, psis in [0, 2 pi].
FUNCTION = dict(
    name="log10",
    title="function generation: y = log10(x), 1 <= x <= 10, 90 deg in and 90 deg out",
    xs=[1 + 0.9 * i for i in range(11)],
    span_in=PI / 2,
    span_out=PI / 2,
    bounds=dict(r=(0.05, 5), ang=(0, 2 * PI)),
)


def function_targets():
    """(t_i, psi_i - psis) of the function-generation targets."""
    f = FUNCTION
    return [((x - 1) / 9 * f["span_in"], math.log10(x) * f["span_out"]) for x in f["xs"]]


def rocker_angle(r1, r2, r3, r4, th2, sigma):
    """The rocker angle (D->B from the ground link) on branch sigma, or None."""
    th3 = th3_branch(r1, r2, r3, r4, th2, sigma)
    if th3 is None:
        return None
    bx = r2 * math.cos(th2) + r3 * math.cos(th3)
    by = r2 * math.sin(th2) + r3 * math.sin(th3)
    return math.atan2(by, bx - r1)


def function_error(r2, r3, r4, th2s, psis, sigma=1):
    """Sum of squared rocker-angle errors [rad^2] (angles compared modulo 2 pi)."""
    f = 0.0
    for t, dpsi in function_targets():
        psi = rocker_angle(1.0, r2, r3, r4, th2s + t, sigma)
        if psi is None:
            return float("nan")
        e = (psi - psis - dpsi + PI) % (2 * PI) - PI
        f += e * e
    return f


def freudenstein_reference(th2s=PI / 4, psis=2 * PI / 3):
    """Freudenstein's three-point design at Chebyshev spacing (the textbook method).

    K1 cos(psi) - K2 cos(th2) + K3 = cos(th2 - psi), K1 = r1/r2, K2 = r1/r4,
    K3 = (r2^2 - r3^2 + r4^2 + r1^2) / (2 r2 r4), r1 = 1.
    """
    xs = [5.5 - 4.5 * math.cos((2 * k - 1) * PI / 6) for k in (1, 2, 3)]
    rows, rhs = [], []
    for x in xs:
        th2 = th2s + (x - 1) / 9 * FUNCTION["span_in"]
        psi = psis + math.log10(x) * FUNCTION["span_out"]
        rows.append([math.cos(psi), -math.cos(th2), 1.0])
        rhs.append(math.cos(th2 - psi))
    k1, k2, k3 = np.linalg.solve(np.array(rows), np.array(rhs))
    r2, r4 = 1 / k1, 1 / k2
    r3 = math.sqrt(r2 * r2 + r4 * r4 + 1 - 2 * k3 * r2 * r4)
    return r2, r3, r4, th2s, psis


# ------------------------------------------- function generation: crankrocker30
# A published function-generation optimization problem (see README.md,
# `crankrocker30`): the crank-rocker of the Chinese textbook tradition
# ("reproduce a given motion law", Sun Jingmin's Mechanical Optimization
# Design, as coded in the companion code of Yu Shengwei's "MATLAB
# optimization algorithms: case analysis and application", chapter 14,
# github codes-books/matlab-optimization). Crank l1 = 1, frame l4 = 5; the
# crank turns 90 deg from phi0, the crank angle at the rocker's right
# extreme position (crank and coupler in line), while the rocker should
# follow psiE = psi0 + 2 (phi - phi0)^2 / (3 pi), psi0 the rocker's angle
# there; 30 points phi_i = phi0 + (pi/2) i/30, i = 1..30. Design variables:
# the coupler l2 and the rocker l3 in [1, 10]; constraints: the
# transmission angle between 45 and 135 deg over the turn. Error: the sum
# of squared rocker-angle errors [rad^2], the book's jfg_f.m verbatim.
CRANKROCKER = dict(
    name="crankrocker30",
    title="function generation: crank-rocker, psi = psi0 + 2 (phi - phi0)^2 / (3 pi), "
          "30 points over 90 deg (textbook problem)",
    crank=1.0,
    frame=5.0,
    points=30,
    bounds=dict(l=(1.0, 10.0)),
    gamma=(PI / 4, 3 * PI / 4),
)


def crankrocker_targets():
    """(t_i, psi_i - psi0): t = phi - phi0 = (pi/2) i/30, i = 1..30 (the book's sum)."""
    n = CRANKROCKER["points"]
    return [(0.5 * PI * i / n, 2 * (0.5 * PI * i / n) ** 2 / (3 * PI)) for i in range(1, n + 1)]


def crankrocker_start_angles(l2, l3):
    """(phi0, psi0): crank and rocker angles at the rocker's right extreme
    position (crank and coupler in line), from the frame line A->D."""
    a, d = CRANKROCKER["crank"], CRANKROCKER["frame"]
    phi0 = math.acos(((a + l2) ** 2 - l3 ** 2 + d ** 2) / (2 * (a + l2) * d))
    psi0 = math.acos(((a + l2) ** 2 - l3 ** 2 - d ** 2) / (2 * l3 * d))
    return phi0, psi0


def crankrocker_error(l2, l3):
    """The book's objective (jfg_f.m): sum of squared rocker-angle errors [rad^2]."""
    a, d = CRANKROCKER["crank"], CRANKROCKER["frame"]
    phi0, psi0 = crankrocker_start_angles(l2, l3)
    f = 0.0
    for t, dpsi in crankrocker_targets():
        phi = phi0 + t
        r = math.sqrt(a * a + d * d - 2 * a * d * math.cos(phi))
        alf = math.acos((r * r + l3 * l3 - l2 * l2) / (2 * r * l3))
        bet = math.acos((r * r + d * d - a * a) / (2 * r * d))
        psi = PI - alf - bet if phi <= PI else PI - alf + bet
        f += (psi0 + dpsi - psi) ** 2
    return f


def crankrocker_gammas(l2, l3):
    """(gamma_min, gamma_max): the transmission angle's extremes over a turn
    (crank towards the frame pivot D, and away from it)."""
    a, d = CRANKROCKER["crank"], CRANKROCKER["frame"]
    gmin = math.acos((l2 * l2 + l3 * l3 - (d - a) ** 2) / (2 * l2 * l3))
    gmax = math.acos((l2 * l2 + l3 * l3 - (d + a) ** 2) / (2 * l2 * l3))
    return gmin, gmax


def crankrocker_l3(l2, gmax):
    """The rocker length that makes the largest transmission angle gmax: the
    change of variables (l2, l3) -> (l2, gmax) that turns the constraint
    gamma_max <= 135 deg into a bound (kinema fit takes bounds, not
    inequality constraints)."""
    a, d = CRANKROCKER["crank"], CRANKROCKER["frame"]
    return l2 * math.cos(gmax) + math.sqrt((d + a) ** 2 - (l2 * math.sin(gmax)) ** 2)


def crankrocker_defects(l2, l3):
    """Constraint violations and defects of a design (list of strings)."""
    a, d = CRANKROCKER["crank"], CRANKROCKER["frame"]
    found = []
    links = sorted([a, l2, l3, d])
    if links[0] + links[3] > links[1] + links[2] or links[0] != a:
        found.append("not a crank-rocker (Grashof with the crank shortest)")
        return found
    gmin, gmax = crankrocker_gammas(l2, l3)
    lo, hi = CRANKROCKER["gamma"]
    if gmin < lo - 1e-9:
        found.append(f"transmission angle {math.degrees(gmin):.4f} deg < 45 deg")
    if gmax > hi + 1e-9:
        found.append(f"transmission angle {math.degrees(gmax):.4f} deg > 135 deg")
    return found


def crankrocker_reference():
    """The problem's constrained optimum by the book's method (a gradient
    method on its objective and constraints: MATLAB's fmincon there, SciPy's
    SLSQP here) from the book's start x0 = (4.5, 4). Needs scipy."""
    from scipy.optimize import minimize

    cg = math.cos(PI / 4)

    def cons(x):
        l2, l3 = x
        # The book's cdj_g.m, as g >= 0: gamma_min >= 45 deg, gamma_max <= 135 deg.
        return [-(l2 * l2 + l3 * l3 - 16 - 2 * l2 * l3 * cg),
                -(-l2 * l2 - l3 * l3 + 36 - 2 * l2 * l3 * cg)]

    r = minimize(lambda x: crankrocker_error(*x), [4.5, 4.0], method="SLSQP",
                 bounds=[CRANKROCKER["bounds"]["l"]] * 2,
                 constraints={"type": "ineq", "fun": cons},
                 options=dict(ftol=1e-15, maxiter=1000))
    return float(r.x[0]), float(r.x[1]), float(r.fun)
