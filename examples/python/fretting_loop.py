#!/usr/bin/python3
"""Mindlin-Deresiewicz fretting loop of a steel sphere on a steel flat (reference H1): F_x over
u_x for the initial loading to +15 N and a full cycle +15 -> -15 -> +15 N at F_N = 100 N, and
the shear traction at the loop's two turning points, plotted into a PNG. Usage: fretting_loop.py [OUT.png] (default fretting_loop.png)."""
import os
import sys

import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

import mdr

out = sys.argv[1] if len(sys.argv) > 1 else "fretting_loop.png"
scene_file = os.path.join(os.path.dirname(__file__), "..", "fretting_mindlin_deresiewicz.yaml")
force = np.concatenate([np.linspace(0, 15, 26), np.linspace(15, -15, 51)[1:],
                        np.linspace(-15, 15, 51)[1:]])
with mdr.Client.embedded() as client, \
        client.session(scene_file) as s:
    s.apply({"normal_force": 100})
    loop = s.apply([{"tangential_force": f} for f in force])
    a = loop.state.contact_radius
    r = np.linspace(0, a, 200)
    tractions = s.query(["tractions"], radii=r).tractions                 # at F_x = +15 N
    s.apply([{"tangential_force": f} for f in np.linspace(15, -15, 51)[1:]])
    reversed_tractions = s.query(["tractions"], radii=r).tractions        # at F_x = -15 N

fig, (left, right) = plt.subplots(1, 2, figsize=(10, 4))
left.plot(loop.tangential_displacement * 1e6, loop.tangential_force)
left.set(xlabel="u_x [µm]", ylabel="F_x [N]", title="Fretting loop, F_N = 100 N")
right.plot(r * 1e3, tractions["value"] / 1e6, label="F_x = +15 N")
right.plot(r * 1e3, reversed_tractions["value"] / 1e6, label="F_x = -15 N")
right.set(xlabel="r [mm]", ylabel="τ [MPa]", title="Shear traction")
right.legend()
fig.tight_layout()
fig.savefig(out, dpi=100)
print(f"{out}: {len(force)} steps, max traction error estimate "
      f"{tractions['error_estimate'].max():.3g} Pa")
