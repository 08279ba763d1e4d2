"""moduli.*: the fits made of the packings' moduli.

* ``moduli.c_l_exponent``, ``moduli.c_t_exponent``: the report's exponent of c_ℓ(p), c_t(p)
  at one height (granwave.report.tables.power_exponent: log-log least squares through the
  per-pressure means of each packing's c_ℓ, c_t), on packings with c = c1 (p/p1)^κ (1 + 3 % ε),
  30 per pressure at 1e-7 … 1e-4; its 95 % interval as the report prints it (Student t, n − 2:
  "value ± 2 errors" held κ in only ~80 % of the seeds with four pressures).
* ``moduli.c_l_inf``: the bulk speed of `analyze continuum` (granwave.analysis.continuum.
  bulk_speed: 1/c_ℓ² = 1/c_ℓ∞² + b/L over the packings) on columns whose c_ℓ follows that law
  exactly (c_ℓ∞ = 0.194, b = 31.9, the whole cell's values of continuum2d_p4) with a per-packing
  scatter of 1 %, the scene's heights and packings; ± 2 errors.
"""

from __future__ import annotations

import numpy as np

from granwave.analysis.continuum import bulk_speed
from granwave.report.tables import power_exponent

from . import Case, interval

PRESSURES = (1e-7, 1e-6, 1e-5, 1e-4)
NU = {"c_l": 0.22, "c_t": 0.26}
C_INF, B = 0.194, 31.9
HEIGHTS = (8.0, 16.0, 32.0, 64.0, 128.0, 256.0, 512.0)
PACKINGS = (30, 30, 30, 10, 10, 10, 10)


def exponent_run(speed):
    def run(seed):
        rng = np.random.default_rng(seed)
        out = {}
        for name, nu in NU.items():  # both speeds from one stream, as before
            means = [np.mean(0.19 * (p / 1e-4) ** nu * (1 + 0.03 * rng.standard_normal(30)))
                     for p in PRESSURES]
            out[name] = power_exponent(PRESSURES, means)
        value, _, lo, hi = out[speed]
        return value, lo, hi
    return run


def c_l_inf(seed):
    rng = np.random.default_rng(seed)
    L = np.repeat(HEIGHTS, PACKINGS)
    c = (1 / C_INF**2 + B / L) ** -0.5 * (1 + 0.01 * rng.standard_normal(L.size))
    r = bulk_speed(L, c)
    return interval(r["c_l_inf"], r["c_l_inf_err"])


CASES = [Case(f"moduli.{speed}_exponent", f"four pressures 1e-7 … 1e-4, 30 packings each, κ = {nu:g}; "
              "the report's 95 % interval (Student t, 2 dof)", nu, exponent_run(speed), fast=speed == "c_l")
         for speed, nu in NU.items()]
CASES.append(Case("moduli.c_l_inf", "1/c_ℓ² = 1/0.194² + 31.9/L at 8 … 512 d̄ (30/10 packings), "
                  "1 % scatter per packing; ± 2 errors", C_INF, c_l_inf, fast=True))
