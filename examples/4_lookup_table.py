"""
From data to a lookup table and C code
======================================

The deployment path of ``pgcomm identify --family spline`` and ``pgcomm export``, in Python:
experiments at calibrated ``k̂, ζ̂`` (here the twin's true fundamental stands in for the result of
Algorithm 1), the physics-guided spline model identified from them, and the model's law exported
as a lookup table (the law is linear in the force, so per position it is one ``2L × 3`` matrix
``P(y)`` and a cogging vector) and as self-contained C.
"""

import re
import tempfile

import matplotlib.pyplot as plt
import numpy as np

from pgcomm import CLawOptions, TwinParams, build_lut, identify_spline, write_c
from pgcomm.data import coil_set_data_from_runs, generate_datasets
from pgcomm.export.lut import lut_error
from pgcomm.identify.spline import SplineOptions
from pgcomm.trajectory import data_generation_reference
from pgcomm.twin import true_fundamental

twin = TwinParams()
plant, motor = twin.plant(), twin.motor()
k_hat, zeta_hat = true_fundamental(twin)
drive = motor.with_nominal(k=tuple(k_hat), zeta=tuple(zeta_hat))
reference = data_generation_reference(motor.sample_time, stroke=0.1, velocities=(0.05, 0.15), dwell=0.1)
runs = generate_datasets(plant, drive, reference)
# the direction table C(y) tanh(v / v_eps) needs velocities: a zero-phase differentiator of the positions
data = [d.with_velocity(motor.sample_time) for d in coil_set_data_from_runs(runs)]

# %%
# Identification is one regularised least-squares problem per coil set and row. The command line
# chooses the knot spacings (fractions of the 30 mm pole pitch) and the smoothness weight by
# cross-validation; fixed here to keep the example short.

options = SplineOptions(gain_spacings=(0.5,), cog_spacings=(0.0625,), dir_spacings=(1.0,), lambdas=(1e-3,))
fit = identify_spline(data, motor.pole_pitch, options)
model = fit.model
# (the twin's force sensor alone leaves 0.8² = 0.64 N² in y)
for l, cost in enumerate(fit.cost):
    print(f"coil set {l + 1}: training residual y {cost['y']:.3f} N², x {cost['x']:.3f} N², z {cost['z']:.3f} N²m²")

# %%
# The table law at the default resolution (0.08 mm) against the model's own law, on a grid ten
# times finer, for demands up to 100 N; then the C files a controller compiles.

lut = build_lut(model, current_limit=motor.current_limit)
err = lut_error(lut, model, f_max=100.0)
print(f"{lut.n} rows, {lut.nbytes / 1e3:.0f} kB as float32; worst force error "
      f"{100 * err.rel.max():.3f} % of 100 N")
with tempfile.TemporaryDirectory() as out:
    header, source = write_c(model, out, CLawOptions("clm_law", current_limit=motor.current_limit))
    print(f"{header.name}: {len(header.read_text().splitlines())} lines, "
          f"{source.name}: {len(source.read_text().splitlines())} lines")
    print("functions:", ", ".join(re.findall(r"^int (clm_law_\w+)\(", header.read_text(), re.M)))

# %%
# The identified cogging force in y against the twin's own (what the table's ``F̂_cog`` column holds).

y = np.linspace(*model.training_range, 2001)
fig, ax = plt.subplots(figsize=(7, 3.5))
ax.plot(1e3 * y, np.asarray(plant.cogging(y))[:, 0], lw=2, color="0.7", label="twin (truth)")
ax.plot(1e3 * y, np.asarray(model.cogging(y))[:, 0], lw=0.8, label="spline model")
ax.set(xlabel="position y (mm)", ylabel="F_cog,y (N)", title="Cogging force in y")
ax.legend()
fig.tight_layout()
