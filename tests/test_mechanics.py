"""Tests of pgcomm.mechanics: RK4 translator dynamics against closed forms, convergence order, stability check."""

from __future__ import annotations

from functools import partial

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from pgcomm.mechanics import Mechanics, acceleration, check_stable, step


N_SAMPLES = 1000


@partial(jax.jit, static_argnames=("substeps", "n"))
def _run_traced(params, substeps, y0, v0, force, dt, n):
    mech = Mechanics(mass=params[0], viscous=params[1], coulomb=params[2], coulomb_velocity=params[3],
                     substeps=substeps)

    def body(c, _):
        y, v = step(mech, c[0], c[1], force, dt)
        return (y, v), (y, v)

    _, (ys, vs) = jax.lax.scan(body, (y0, v0), None, length=n)
    return jnp.concatenate([y0[None], ys]), jnp.concatenate([v0[None], vs])


def _run(mech, y0, v0, force, dt, n=N_SAMPLES):
    """``n`` controller samples of ``dt`` (s) under a constant force (N); trajectory ``(y, v)`` of length n + 1.

    The mechanics' values are traced, so one compilation serves all parameter sets with
    the same number of sub-steps and samples.
    """
    params = jnp.asarray([mech.mass, mech.viscous, mech.coulomb, mech.coulomb_velocity], dtype=float)
    f = lambda x: jnp.asarray(float(x))  # noqa: E731
    return _run_traced(params, mech.substeps, f(y0), f(v0), f(force), f(dt), n)


# (mass kg, viscous N s/m, force N, y0 m, v0 m/s)
LINEAR_CASES = {
    "default_translator": (30.0, 80.0, 100.0, 0.0, 0.0),
    "light_strong_damping": (5.0, 40.0, -20.0, 0.05, 0.1),
    "heavy_weak_damping": (80.0, 5.0, 300.0, -0.1, -0.2),
}


@pytest.mark.parametrize("name", list(LINEAR_CASES))
def test_viscous_only_matches_closed_form(name):
    m, fv, force, y0, v0 = LINEAR_CASES[name]
    mech = Mechanics(mass=m, viscous=fv, coulomb=0.0, substeps=4)
    dt, n = 1e-3, N_SAMPLES
    ys, vs = (np.asarray(a) for a in _run(mech, y0, v0, force, dt))
    t = np.arange(n + 1) * dt
    lam = fv / m
    v_inf = force / fv
    v_ex = v_inf + (v0 - v_inf) * np.exp(-lam * t)
    y_ex = y0 + v_inf * t + (v0 - v_inf) / lam * (1.0 - np.exp(-lam * t))
    # 1e-9 relative to the size of the response over 1 s (RK4 error ~ (h λ)^4 / 120 per unit time)
    np.testing.assert_allclose(vs, v_ex, rtol=0, atol=1e-9 * np.abs(v_ex).max())
    np.testing.assert_allclose(ys, y_ex, rtol=0, atol=1e-9 * np.abs(y_ex - y0).max())


def test_zero_friction_is_exact_double_integrator():
    mech = Mechanics(mass=30.0, viscous=0.0, coulomb=0.0, substeps=4)
    dt, n, force = 1e-3, N_SAMPLES, 60.0
    ys, vs = (np.asarray(a) for a in _run(mech, 0.01, -0.05, force, dt))
    t = np.arange(n + 1) * dt
    # RK4 is exact for polynomials of degree <= 4: only round-off over 4000 sub-steps remains
    v_ex = -0.05 + force / 30.0 * t
    y_ex = 0.01 - 0.05 * t + 0.5 * force / 30.0 * t**2
    np.testing.assert_allclose(vs, v_ex, rtol=0, atol=1e-12 * np.abs(v_ex).max())
    np.testing.assert_allclose(ys, y_ex, rtol=0, atol=1e-12 * np.abs(y_ex).max())


def test_acceleration_formula():
    mech = Mechanics(mass=30.0, viscous=80.0, coulomb=40.0, coulomb_velocity=1e-3)
    v = np.array([-0.1, -1e-3, 0.0, 2e-4, 0.3])
    got = np.asarray(acceleration(mech, jnp.asarray(v), 50.0))
    np.testing.assert_allclose(got, (50.0 - 80.0 * v - 40.0 * np.tanh(v / 1e-3)) / 30.0, rtol=1e-14)


def test_rk4_fourth_order_with_coulomb_friction():
    """Halving the sub-step divides the error by ≈ 16 (between 12 and 20), velocity crossing zero."""
    params = dict(mass=30.0, viscous=80.0, coulomb=40.0, coulomb_velocity=1e-2)
    args = (0.0, -0.05, 100.0)
    # reference with sub-step 1e-3/64 s: 8 sub-steps of 8x shorter samples (the force is constant, so
    # holding it per sample changes nothing; a 64-fold unrolled step would compile slowly)
    y_ref, v_ref = _run(Mechanics(**params, substeps=8), *args, 1e-3 / 8, 8 * N_SAMPLES)
    y_ref, v_ref = np.asarray(y_ref[::8]), np.asarray(v_ref[::8])
    assert v_ref.min() < 0 < v_ref[-1]  # passes through the Coulomb kink region
    errs = []
    for s in (2, 4, 8):
        y, v = _run(Mechanics(**params, substeps=s), *args, 1e-3)
        errs.append((np.abs(np.asarray(y) - y_ref).max(), np.abs(np.asarray(v) - v_ref).max()))
    errs = np.asarray(errs)
    assert errs.min() > 1e-13  # above round-off: the ratios measure truncation error
    ratios = errs[:-1] / errs[1:]
    assert np.all((ratios > 12.0) & (ratios < 20.0)), ratios


def test_step_vectorised_over_batch():
    mech = Mechanics()
    y = jnp.asarray([0.0, 0.01, -0.02])
    v = jnp.asarray([0.0, 0.1, -0.05])
    f = jnp.asarray([10.0, -20.0, 50.0])
    yb, vb = step(mech, y, v, f, 1e-3)
    for j in range(3):
        ys, vs = step(mech, y[j], v[j], f[j], 1e-3)
        assert float(yb[j]) == pytest.approx(float(ys), rel=1e-14, abs=1e-18)
        assert float(vb[j]) == pytest.approx(float(vs), rel=1e-14, abs=1e-18)


@pytest.mark.parametrize("mech, dt", [
    (Mechanics(substeps=1), 1e-2),
    (Mechanics(coulomb=40.0, coulomb_velocity=1e-4, substeps=2), 1e-3),
    (Mechanics(mass=0.5, viscous=0.0, coulomb=10.0, coulomb_velocity=1e-3, substeps=4), 1e-3),
])
def test_check_stable_raises_for_too_few_substeps(mech, dt):
    with pytest.raises(ValueError, match="substeps") as err:
        check_stable(mech, dt)
    # the suggested number of sub-steps is enough
    suggested = int(str(err.value).rsplit("at least", 1)[1].split()[0])
    assert suggested > mech.substeps
    check_stable(Mechanics(mass=mech.mass, viscous=mech.viscous, coulomb=mech.coulomb,
                           coulomb_velocity=mech.coulomb_velocity, substeps=suggested), dt)


def test_check_stable_accepts_defaults():
    check_stable(Mechanics(), 1e-3)
    check_stable(Mechanics(viscous=0.0, coulomb=0.0, substeps=1), 1.0)


def test_default_substeps_keep_the_error_of_a_sample_below_the_encoder_quantum():
    """The default sub-steps on the default translator, along a closed loop with reversals and standstill:
    the position after one controller sample, from the loop's own states and held forces, against 64
    sub-steps, differs by less than a tenth of the encoder's quantum."""
    from pgcomm import trajectory
    from pgcomm.commutation import ClassicalLaw
    from pgcomm.control import Feedforward
    from pgcomm.sensors import Sensors
    from pgcomm.simulate import ClosedLoop, simulate
    from pgcomm.twin import DEFAULT_TWIN

    dt = 1e-3
    # there and back at the paper's fastest speed, with rests between
    ref = trajectory.sequence([(0.08, 0.4, 3.0, 1000.0), (0.0, 0.4, 3.0, 1000.0)], dt, dwell=0.2, initial_dwell=0.1)
    motor = DEFAULT_TWIN.motor()
    fine = Mechanics(substeps=64)
    res = simulate(DEFAULT_TWIN.plant(), ClassicalLaw.from_motor(motor), ref, drive=motor,
                   loop=ClosedLoop(mechanics=fine),
                   feedforward=Feedforward(mass=30.0, viscous=80.0, coulomb=12.0))
    force = jnp.asarray(res.f_true[:, 0])

    @jax.jit
    def states(force):  # the loop's states (y, v) at each sample: the fine integration of its held forces
        def body(c, f):
            y, v = step(fine, c[0], c[1], f, dt)
            return (y, v), c
        return jax.lax.scan(body, (jnp.asarray(res.y[0]), jnp.asarray(0.0)), force)[1]

    y, v = states(force)
    np.testing.assert_allclose(np.asarray(y), res.y, rtol=0, atol=1e-12)  # the same motion
    v_np = np.asarray(v)
    # both directions at speed, and samples inside the friction's kink |v| < v_c where the step is hardest
    assert v_np.max() > 0.1 and v_np.min() < -0.1 and (np.abs(v_np) < Mechanics().coulomb_velocity).sum() > 10
    one = jax.vmap(lambda a, b, f: step(Mechanics(), a, b, f, dt))(y, v, force)
    ref_step = jax.vmap(lambda a, b, f: step(fine, a, b, f, dt))(y, v, force)
    err = np.abs(np.asarray(one[0]) - np.asarray(ref_step[0])).max()
    assert err > 0  # the default really takes fewer sub-steps than the reference
    assert err < 0.1 * Sensors().encoder_resolution, err
