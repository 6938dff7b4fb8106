"""
A classical law in closed loop
==============================

How well a law commutates shows in closed loop: the position controller asks for a force
``F*``, the law turns it into currents, the twin makes ``F`` and the translator moves. The
paper's two measures are the commutation error ``F − F*`` (mean square of the force sensor's
signal after a 50 Hz low-pass ``H(z)``, which removes most of the sensor noise) and the tracking
error ``r − y``. Here classical commutation at the twin's true fundamental against the oracle,
the exact inverse of everything the twin knows (the floor no commutation beats except by noise),
on one back-and-forth at 0.15 m/s.
"""

import matplotlib.pyplot as plt

from pgcomm import ClassicalLaw, TwinParams
from pgcomm.commutation import oracle_law
from pgcomm.control import PID, Feedforward
from pgcomm.metrics import commutation_mse, lowpass, tracking_mse
from pgcomm.simulate import ClosedLoop, simulate
from pgcomm.trajectory import single_velocity_reference
from pgcomm.twin import true_fundamental

twin = TwinParams()
plant, motor = twin.plant(), twin.motor()
k_true, zeta_true = true_fundamental(twin)
laws = {"classical": ClassicalLaw.from_motor(motor, k=k_true, zeta=zeta_true),
        "oracle": oracle_law(plant, current_limit=motor.current_limit)}
reference = single_velocity_reference(0.15, motor.sample_time, stroke=0.1, dwell=0.2)
# the twin's translator: 30 kg, 80 N s/m viscous and 12 N Coulomb friction (pgcomm.mechanics.Mechanics); the
# feedforward knows them here (pgcomm simulate identifies it in closed loop first), so the feedback is left
# with what the commutation gets wrong
pid = PID.tuned(mass=30.0, bandwidth_hz=6.0)
feedforward = Feedforward(mass=30.0, viscous=80.0, coulomb=12.0)
runs = {name: simulate(plant, law, reference, drive=motor, loop=ClosedLoop(pid=pid), feedforward=feedforward,
                       seed=0)
        for name, law in laws.items()}

for name, run in runs.items():
    mse = commutation_mse(run.f_meas, run.f_star, run.sample_time)
    print(f"{name:9s} commutation MSE (filtered) y {mse['y']['filtered']:6.3f} N², x {mse['x']['filtered']:6.3f} N²,"
          f" z {mse['z']['filtered']:6.3f} N²m²; tracking MSE {tracking_mse(run.e):.2e} m²")

# %%
# The filtered driving-force error along the run: classical commutation leaves the cogging and
# ripple the oracle cancels; what the oracle leaves is sensor noise through ``H(z)``.

fig, ax = plt.subplots(figsize=(7, 3.5))
for name, run in runs.items():
    ax.plot(run.t, lowpass(run.commutation_error[:, 0], run.sample_time), lw=0.8, label=name)
ax.set(xlabel="time (s)", ylabel="H(z)(Fy − Fy*) (N)", title="Filtered commutation error in y")
ax.legend()
fig.tight_layout()
