# %% [markdown]
# # A slider-crank from Python
#
# A notebook-style script (cells marked `# %%`, as VS Code and Jupytext read
# them): load a model, run it, plot a path, sweep a parameter. CI runs it
# with matplotlib's Agg back end; the figures go to $KINEMA_EXAMPLE_OUT (the
# current directory by default).

# %%
import os
from pathlib import Path

import matplotlib

matplotlib.use(os.environ.get("MPLBACKEND", "Agg"))
import matplotlib.pyplot as plt
import numpy as np

import kinema

root = Path(__file__).resolve().parents[3]
out = Path(os.environ.get("KINEMA_EXAMPLE_OUT", "."))

# %% [markdown]
# ## Load and check
# The benchmark slider-crank: crank l1 = 0.3 m, rod l2 = 1 m, one crank
# revolution per second.

# %%
model = kinema.Model.from_file(root / "models" / "slider_crank.kin")
report = model.check()
print(f"{report['name']}: {len(report['bodies'])} bodies, {len(report['coordinates'])} coordinates, "
      f"{report['kinematic_equations']} + {report['driving_equations']} equations, DOF {report['dof']}")
print("parameters:", model.params)

# %% [markdown]
# ## Run one revolution
# `res.values` is a (rows x columns) float64 array; columns by name.

# %%
res = model.run(t_end=1.0, steps=400)
t, x = res["t"], res["slider.x"]
print(f"{res.values.shape[0]} rows x {res.values.shape[1]} columns; "
      f"slider stroke {x.max() - x.min():.6f} m (2 l1 = 0.6 m)")

# %% [markdown]
# ## The path of the rod's midpoint and the slider's motion

# %%
fig, (a, b) = plt.subplots(1, 2, figsize=(10, 4))
a.plot(res["rod.x"], res["rod.y"], label="rod midpoint")
a.plot(res["crank.pin.x"], res["crank.pin.y"], label="crank pin")
a.set_aspect("equal")
a.set_xlabel("x [m]")
a.set_ylabel("y [m]")
a.legend()
b.plot(t, x, label="x [m]")
b.plot(t, res["slider.x_dot"], label="ẋ [m/s]")
b.set_xlabel("t [s]")
b.legend()
fig.tight_layout()
fig.savefig(out / "path.png", dpi=80)

# %% [markdown]
# ## Sweep the rod length
# One long table, the columns of `kinema sweep`: `row`, the parameters, `t`, ...

# %%
lengths = np.linspace(0.8, 1.4, 7)
sweep = model.sweep({"l2": lengths}, t_end=1.0, steps=100)
df = None
try:
    df = sweep.to_pandas()
except ImportError:
    pass
fig, ax = plt.subplots(figsize=(6, 4))
for k, l2 in enumerate(lengths, start=1):
    rows = sweep["row"] == k
    ax.plot(sweep["t"][rows], sweep["slider.x_ddot"][rows], label=f"l2 = {l2:.1f} m")
ax.set_xlabel("t [s]")
ax.set_ylabel("slider acceleration [m/s²]")
ax.legend(fontsize=7)
fig.tight_layout()
fig.savefig(out / "sweep.png", dpi=80)
peak = [np.abs(sweep["slider.x_ddot"][sweep["row"] == k]).max() for k in range(1, 8)]
print("peak slider acceleration by rod length:", dict(zip(np.round(lengths, 2), np.round(peak, 3))))
if df is not None:
    print(df.groupby("l2")["slider.x"].agg(["min", "max"]))

# %% [markdown]
# ## Forward dynamics: a four-bar released under gravity
# A model with inertia and a free degree of freedom runs forward dynamics
# (HHT-alpha here, 1 ms steps): M q̈ + Φ_qᵀ λ = Q_A with Φ(q, t) = 0. With
# `energy=True` the kinetic and potential energies (J) come as columns; their
# sum less the work of the other forces stays constant when the integration
# is exact. The bars are a parallelogram: it passes the flat (singular)
# configuration, each passage a `SingularConfigurationWarning` and an event.
# The equilibrium is where it comes to rest.

# %%
bars = kinema.Model.from_file(root / "models" / "iftomm" / "a02_four_bar_1.kin")
print("motion:", bars.motion)
fd = bars.run(t_end=2.0, steps=200, step=1e-3, energy=True)
total = fd["energy.kinetic"] + fd["energy.potential"] - fd["energy.work"]
print(f"{fd.info['integrator']}; energy drift {np.ptp(total):.2e} J over 2 s")
print("singular configurations passed at t =", [round(e.t, 4) for e in fd.events])
rest = bars.equilibrium()
print(f"equilibrium: {rest.info['stability']}, crank0.phi = {rest['crank0.phi'][0]:.6f} rad")
fig, (a, b) = plt.subplots(1, 2, figsize=(10, 4))
a.plot(fd["t"], fd["crank0.phi"], label="crank angle [rad]")
a.axhline(rest["crank0.phi"][0], ls="--", c="k", lw=0.8, label="equilibrium")
a.set_xlabel("t [s]")
a.legend()
b.plot(fd["t"], fd["energy.kinetic"], label="kinetic [J]")
b.plot(fd["t"], fd["energy.potential"], label="potential [J]")
b.set_xlabel("t [s]")
b.legend()
fig.tight_layout()
fig.savefig(out / "dynamics.png", dpi=80)
