"""How identification's cost grows with a rotary motor's highest order: CPU seconds per slot/pole combination.

Usage: ``python bench/rotary_orders.py [--motors 12N14P,36N42P,54N48P,72N64P]``.

For each combination, a twin drawn from the description (as ``pgcomm reproduce --motor`` draws it, seed 0), one
round of ``reproduce``'s running logs (two speeds, both directions, the alias guard's speed for the model's highest
order) and :func:`pgcomm.rotary.identify.identify` on them. Prints the highest order of the model
(``3 LCM(Q, 2p)``, ``12 p``), the columns of the screening (every order up to the highest), the logged rows and
the CPU seconds of the logs and of the identification: the figures behind the motor TOML's bound
(:data:`pgcomm.io.config.MAX_ROTARY_ORDER`). CPU seconds of this process (the machine may be shared).
"""

from __future__ import annotations

import argparse
import re
import resource


def cpu_seconds() -> float:
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--motors", default="12N14P,36N42P,54N48P,72N64P", help="QNmP combinations (m = 2p poles)")
    a = ap.parse_args()
    from pgcomm.rotary import experiment as rexp
    from pgcomm.settings import RotaryIdentifyOptions
    from pgcomm.rotary.identify import identify
    from pgcomm.rotary.motor import RotaryMotor
    from pgcomm.rotary.regression import Orders, _full, _Layout
    from pgcomm.rotary.zoo import default_truth

    for spec in a.motors.split(","):
        m = re.fullmatch(r"(\d+)N(\d+)P", spec.strip())
        if m is None or int(m.group(2)) % 2:
            raise SystemExit(f"--motors: {spec!r} is not QNmP with an even m (e.g. 36N42P)")
        motor = RotaryMotor(pole_pairs=int(m.group(2)) // 2, slots=int(m.group(1)), sample_time=1e-3, k_t=0.97,
                            current_limit=17.5)
        orders = Orders.for_motor(motor)
        full = Orders(_full(orders.cogging), _full(orders.ripple), orders.direction)
        columns = int(_Layout.of(full, (), 4).keep.sum())
        truth = default_truth(motor, seed=0)
        c0 = cpu_seconds()
        drive_orders, a_nom, gains, classical = rexp._tuned_drive(truth)
        refs = rexp.running_references(motor, a_nom, rexp.RotarySettings(), drive_orders)
        logs = [rexp.running_log(truth, r, classical, gains, 1000 + i) for i, r in enumerate(refs)]
        c1 = cpu_seconds()
        identify(logs, motor, RotaryIdentifyOptions(orders=drive_orders))
        c2 = cpu_seconds()
        rows = sum(len(lg["t"]) for lg in logs)
        print(f"{motor.name}: highest order {orders.highest}, screening columns {columns}, rows {rows}, "
              f"logs {c1 - c0:.1f} s CPU, identify {c2 - c1:.1f} s CPU", flush=True)


if __name__ == "__main__":
    main()
