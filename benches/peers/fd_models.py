"""Forward-dynamics benchmark mechanisms (issue 17; README.md section 6), exactly as
kinema's crates/kinema-bench/models/fd_slider_crank.kin and
kinema_model::chain::pendulum_chain_kin(n) define them.

Absolute coordinates q_i = (x_i, y_i, phi_i), frames at the link midpoints (the slider's at
its pin), x' along the link. Every mechanism starts consistent and at rest, with gravity
(0, -9.81) on every body.

  fd_slider_crank: crank (L1 = 0.3, m 1, J = m L1^2/12) pinned to ground at the origin at its
    end s' = (-L1/2, 0); rod (L2 = 1, m 2, J = 2 L2^2/12) pinned to the crank's other end by its
    end (-L2/2, 0); slider (m 0.5, J 0.01) pinned at its frame origin to the rod's end
    (L2/2, 0); slider y = 0 and phi = 0. Crank at phi1 = pi/4, the slider on the +x side.
  fd_chainN: N links (L 1, m 1, J 1/12); link 1's end (-0.5, 0) pinned to ground at the
    origin; link k's end (0.5, 0) pinned to link k+1's end (-0.5, 0); all along +x at phi = 0.

Each mechanism is a dict: bodies [(m, J, (x0, y0, phi0))], pins [(i, s_i, j, s_j)] with
i = 0 for ground (s_i then a global point), locks [(i, 'y' | 'phi')] (coordinate = its
initial value). Bodies are numbered from 1.
"""
import math

G = (0.0, -9.81)


def fd_slider_crank():
    l1, l2, phi0 = 0.3, 1.0, math.pi / 4
    s = l1 * math.sin(phi0)
    c = math.sqrt(l2 * l2 - s * s)
    xa = l1 * math.cos(phi0)
    bodies = [
        (1.0, l1 * l1 / 12, (l1 / 2 * math.cos(phi0), l1 / 2 * math.sin(phi0), phi0)),
        (2.0, 2 * l2 * l2 / 12, (xa + c / 2, s / 2, -math.asin(s / l2))),
        (0.5, 0.01, (xa + c, 0.0, 0.0)),
    ]
    pins = [
        (0, (0.0, 0.0), 1, (-l1 / 2, 0.0)),
        (1, (l1 / 2, 0.0), 2, (-l2 / 2, 0.0)),
        (2, (l2 / 2, 0.0), 3, (0.0, 0.0)),
    ]
    locks = [(3, "y"), (3, "phi")]
    return dict(name="fd_slider_crank", bodies=bodies, pins=pins, locks=locks)


def fd_chain(n):
    bodies = [(1.0, 1.0 / 12, (k - 0.5, 0.0, 0.0)) for k in range(1, n + 1)]
    pins = [(0, (0.0, 0.0), 1, (-0.5, 0.0))]
    pins += [(k - 1, (0.5, 0.0), k, (-0.5, 0.0)) for k in range(2, n + 1)]
    return dict(name=f"fd_chain{n}", bodies=bodies, pins=pins, locks=[])


def get(name):
    if name == "fd_slider_crank":
        return fd_slider_crank()
    if name.startswith("fd_chain"):
        return fd_chain(int(name[len("fd_chain"):]))
    raise SystemExit(f"unknown mechanism {name}")


# Integration (every peer): HHT-alpha alpha = -0.1 or generalized-alpha at the same spectral
# radius rho_inf = (1 + alpha) / (1 - alpha); fixed step h = 1e-3, t in [0, 1] (1000 steps).
ALPHA = -0.1
RHO_INF = (1 + ALPHA) / (1 - ALPHA)
H = 1e-3
STEPS = 1000
