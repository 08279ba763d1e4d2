"""The same seed gives the same bits whatever numpy's SIMD code: numpy picks its loops for
power, exp, log, cbrt, ... by the CPU (AVX-512, AVX2, the baseline) and they differ in the last
bit of some elements, which once made every packing depend on the machine that prepared it
(the masses, pi d^3 / 6, docs/dem.md "The same bits on every machine"). A preparation in 2D and
a frictional one in 3D, run in a child process with numpy's dispatched CPU features switched
off (NPY_DISABLE_CPU_FEATURES), must give the bits of one with them on. Each run also cubes
10^5 numbers with numpy's power, a control that says whether this CPU's loops differ from the
baseline's where they once did (they do with AVX-512, not with AVX2 alone); the packings are
compared either way, since other loops (exp, log, ...) may differ on any CPU."""

import math
import os
from fractions import Fraction
import subprocess
import sys

import numpy as np
import pytest

from granwave.geometry import cube, grain_mass
from granwave.provenance import numpy_simd

CHILD = r"""
import hashlib, numpy as np
from granwave.dem.params import PrepareParams
from granwave.dem.protocol import prepare_packing

x = np.random.default_rng(0).uniform(0.4, 0.6, 10**5)
out = [hashlib.sha256((x ** 3).tobytes()).hexdigest()]  # numpy's own power: the control
for kw in (dict(grains=120, seed=4), dict(dim=3, grains=100, seed=2, friction=0.5)):
    p = prepare_packing(PrepareParams(**kw))
    h = hashlib.sha256()
    for a in (p.position, p.mass, p.inertia, p.contacts.force_normal, p.contacts.force_tangential):
        h.update(np.ascontiguousarray(a).tobytes())
    out.append(h.hexdigest())
print(" ".join(out))
"""


def _child_digests(disable: str) -> str:
    env = dict(os.environ, NPY_DISABLE_CPU_FEATURES=disable)
    run = subprocess.run([sys.executable, "-c", CHILD], env=env, capture_output=True, text=True, timeout=900)
    assert run.returncode == 0, run.stderr[-2000:]
    return run.stdout.strip().splitlines()[-1]


def test_cube_is_two_products():
    x = np.random.default_rng(0).uniform(0.3, 0.7, 1000)
    np.testing.assert_array_equal(cube(x), x * x * x)
    d = 2.0 * x
    np.testing.assert_array_equal(grain_mass(x), np.pi * (d * d * d) / 6.0)


def test_grain_mass_is_within_its_rounding_of_the_exact_value():
    """pi d^3 / 6 in exact rational arithmetic (of the float pi and the float radii) against
    grain_mass: four roundings (d*d, *d, pi*, /6) of at most half an ulp each bound the relative
    error by 4 * eps/2 = 2 eps, on any CPU (numpy's own power is not a reference: its SIMD
    loops differ by CPU, by up to ~2 eps here against AVX2's)."""
    x = np.random.default_rng(0).uniform(0.3, 0.7, 1000)
    m = grain_mass(x)
    eps = np.finfo(float).eps
    pi = Fraction(math.pi)
    worst = max(abs(Fraction(float(mi)) / (pi * (2 * Fraction(float(xi))) ** 3 / 6) - 1)
                for xi, mi in zip(x, m))
    assert worst <= 2 * eps, f"relative error {float(worst):.3g} > 2 eps"


def test_packings_do_not_depend_on_numpys_simd_code():
    features, _ = numpy_simd()
    if not features:
        pytest.skip("this numpy does not say which CPU features it dispatches on")
    control, *with_simd = _child_digests("").split()
    control_off, *without = _child_digests(" ".join(features)).split()
    loops = "differ" if control != control_off else "are the same"
    assert len(with_simd) == 2
    assert with_simd == without, f"packings depend on numpy's SIMD loops (its power's loops {loops} here)"
