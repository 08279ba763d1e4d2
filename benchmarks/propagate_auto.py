"""Does ``propagate(method="auto")`` pick the faster linear method?

For triangular lattices of growing size and records of growing length, times the
modal route (dense eigensolve + modal sum) and the time domain (safety 0.1) in one
run, and prints, per case, the cost model's predicted ratio t_modal/t_time
(granwave.api.choose_method) beside the measured one and whether auto chose the
faster method. Ratios only: absolute times drift on a shared machine.

    PYTHONPATH=. python benchmarks/propagate_auto.py
"""

from __future__ import annotations

import time
import warnings

from granwave import api
from granwave.params import PropagateParams


def timed(fn):
    t0 = time.perf_counter()
    fn()
    return time.perf_counter() - t0


def main():
    # warm up numba (the Verlet kernel compiles once per process)
    small = api.linearize(api.lattice(rows=4, width=4, pressure=1e-4))
    api.propagate(small, t_max=10.0, samples=11, method="time")
    print(f"{'rows x width':>12} {'dofs':>6} {'t_max/H':>8} {'pred modal/time':>16} "
          f"{'meas modal/time':>16} {'auto':>6} {'right':>6}")
    right = total = 0
    for rows, width in ((8, 8), (16, 16), (24, 24), (32, 32)):
        system = api.linearize(api.lattice(rows=rows, width=width, pressure=1e-4))
        for factor in (3.0, 30.0, 300.0):
            p = PropagateParams(t_max=factor * system.height / 0.3, samples=2001, method="auto")
            method, why = api.choose_method(system, p)
            import re

            t_a, t_b = (float(x) for x in re.findall(r"predicted ([0-9.e+-]+) s against ([0-9.e+-]+) s", why)[0])
            predicted = t_a / t_b if method == "modal" else t_b / t_a
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                t_modal = timed(lambda: api.propagate(system, p, method="modal"))
                t_time = timed(lambda: api.propagate(system, p, method="time"))
            measured = t_modal / t_time
            ok = (method == "modal") == (t_modal <= t_time)
            right += ok
            total += 1
            print(f"{rows:>5} x {width:<4} {system.n_dof:6d} {factor:8.0f} {predicted:16.3g} "
                  f"{measured:16.3g} {method:>6} {'yes' if ok else 'no':>6}")
    print(f"auto chose the faster method in {right} of {total} cases")


if __name__ == "__main__":
    main()
