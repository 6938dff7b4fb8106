"""
What classical commutation misses
=================================

Classical commutation inverts the ideal sinusoidal gain ``K(y)`` of eq. 8 with one motor constant
``k̂`` and phase offset ``ζ̂`` per coil set. The digital twin's electromagnetics carry what that
model leaves out (cogging, field harmonics, constants that differ between coil sets, out-of-plane
coupling), so even with ``k̂, ζ̂`` set to the twin's true fundamental the force is not the one
asked for. The force the twin makes for each law's currents, along the stroke, for a demand of
100 N forward:
"""

import matplotlib.pyplot as plt
import numpy as np

from pgcomm import ClassicalLaw, ModelLaw, TwinParams
from pgcomm.twin import true_fundamental

twin = TwinParams()
plant, motor = twin.plant(), twin.motor()  # the truth, and what a drive knows of it (nominal k, zeta)
k_true, zeta_true = true_fundamental(twin)
laws = {
    "classical, nominal k̂, ζ̂": ClassicalLaw.from_motor(motor),
    "classical, true fundamental": ClassicalLaw.from_motor(motor, k=k_true, zeta=zeta_true),
    "exact inverse of the twin": ModelLaw(plant),
}

y = np.linspace(-0.1, 0.1, 4001)  # positions over the stroke (m)
f_star = np.tile([100.0, 0.0, 0.0], (y.size, 1))  # [Fy, Fx, Tz] demanded (N, N, N m)
errors = {name: np.asarray(plant.force(y, law.currents(y, f_star))) - f_star for name, law in laws.items()}
for name, e in errors.items():
    print(f"{name:28s} mean Fy error {e[:, 0].mean():+7.3f} N, ripple (std) {e[:, 0].std():6.3f} N")

# %%
# Calibrating ``k̂, ζ̂`` (Algorithm 1) removes the mean error; what is left varies with the
# position — the part the physics-guided model (Algorithm 2) identifies and its law inverts.

fig, ax = plt.subplots(figsize=(7, 3.5))
for name, e in errors.items():
    ax.plot(1e3 * y, e[:, 0], label=name, lw=1)
ax.set(xlabel="position y (mm)", ylabel="Fy − Fy* (N)", title="Force error at Fy* = 100 N")
ax.legend(fontsize=8)
fig.tight_layout()
