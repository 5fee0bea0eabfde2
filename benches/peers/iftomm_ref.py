"""The one-degree-of-freedom reference of IFToMM benchmark A02 (the N four-bar mechanism) and
the error measure of the side-by-side table (BENCHMARKS.md, "IFToMM problems").

Every crank turns by the same angle th (the couplers translate), so the motion obeys
c_T th'' = -g c_V cos th with c_T = (N+1) m l^2/3 + N m l^2 (cranks about their pivots, couplers
as point masses on the crank tips) and c_V = (N+1) m l/2 + N m l; from th = pi/2, th' = -v0/l.
Integrated by scipy's DOP853 at rtol = atol = 1e-13 (tests/iftomm.rs holds kinema to the same
equation integrated by RK4).
"""
import math

from scipy.integrate import solve_ivp

G, L, M, V0 = 9.81, 1.0, 1.0, 1.0


def reference(n, times):
    """The crank angle of the one-degree-of-freedom motion at `times` (increasing, from 0)."""
    c_t = (n + 1) * M * L * L / 3 + n * M * L * L
    c_v = (n + 1) * M * L / 2 + n * M * L
    sol = solve_ivp(lambda _t, y: [y[1], -G * c_v * math.cos(y[0]) / c_t],
                    (0, float(times[-1])), [math.pi / 2, -V0 / L], method="DOP853",
                    rtol=1e-13, atol=1e-13, dense_output=True)
    return sol.sol(times)[0]
