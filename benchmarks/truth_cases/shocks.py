"""shocks.*: the front inside the column (granwave.analysis.shocks.front_picks, its defaults, as
``propagate --method dem`` calls it: pick ``peak`` for the impulse, ``crossing`` for the piston,
level 0.5, the speed fitted over the middle 60 % of the column) on pulse fields of known speed
V and width:

* **pulses** (the impulse's solitary wave): v(z, t) = v_m P((z − V t)/W) with the long-wave
  Hertz profile P = cos⁴ on |x| < π/2 (Nesterenko's, docs/method.md §12) or the weakly
  nonlinear sech⁴; W set so the full width at half maximum is the discrete chain's, 1.6 d
  (docs/shocks.md); truth: V, and the FWHM along the column;
* **fronts** (the piston's shock): v = v_p S((V t − z)/W), S = (1 + tanh)/2 of W = 1 d, or the
  same with a leading overshoot of 40 % of v_p behind the front (the Hertz shock's first
  oscillation, which sets the bin's largest velocity); truth: V.

Two kinds of column, each 100 and 1000 d tall (1 d bins, ``propagate``'s default), sampled as
``propagate`` samples (2001 samples over 1.3 crossings, the record length drawn within ± 2 % and
the time origin within one sample, so each bin's arrival falls anywhere between samples: 0.065 d
and 0.65 d of travel per sample):

* **chain**: one grain per bin at its centre, the exact travelling profile (a chain run as a
  2D column);
* **packing** (a disordered 2D column ~8 grains wide): per bin 1 + Poisson(7) grains at uniform
  heights inside it, each with its own arrival delay (Gaussian, 0.2 d / V: the disorder's), a
  formation delay 2 (d / V) e^{−z / 5 d} near the source (the wave forming), and an incoherent
  band-limited velocity remainder of 2 % of v_m per grain (correlation time 0.3 d / V); the bin's
  velocity is the mean over its grains, as the pulse field's.

The interval checked is the speed ± 2 quoted errors (the report's reading of ``front_speed_error``);
the width quotes no interval: tolerance 5 %.
"""

from __future__ import annotations

import math

import numpy as np

from granwave.analysis.shocks import front_picks

from . import Case, interval

SAMPLES = 2001      # granwave.params.PropagateParams.samples
CROSSINGS = 1.3     # the record of tests/test_shocks.py and of the default t_max's bound
SPEED = 0.84        # the uncompressed chain's speed at a 1e-3 kick (any V: the picks scale with it)
FWHM = 1.6          # d, the discrete chain's (docs/shocks.md)
SHOCK_W = 1.0       # d
OVERSHOOT = 0.4
JITTER = 0.2        # d / V per grain
FORMATION = (2.0, 5.0)  # delay (d / V) and length (d) of the wave's formation near the source
NOISE = 0.02
NOISE_TIME = 0.3    # d / V
GRAINS_PER_BIN = 7.0
WIDTH_TOL = 0.05
HEIGHTS = (100, 1000)


def _cos4(x):
    out = np.zeros(np.shape(x))
    inside = np.abs(x) < 0.5 * math.pi
    out[inside] = np.cos(x[inside]) ** 4
    return out


def _sech4(x):
    c = 1.0 / np.cosh(np.clip(x, -150, 150))
    c *= c
    return c * c


def _tanh(x):
    return 0.5 * (1.0 + np.tanh(x))


def _overshoot(x):
    return _tanh(x) + OVERSHOOT * np.exp(-0.5 * (x - 1.5) ** 2)


#: (profile, half-maximum point x_h of P: FWHM = 2 W x_h)
PULSES = {"cos⁴": (_cos4, math.acos(2 ** -0.25)), "sech⁴": (_sech4, math.acosh(2 ** 0.25))}
FRONTS = {"tanh": _tanh, "tanh with a 40 % overshoot": _overshoot}


def field(seed: int, shape: str, height: int, column: str, *, samples: int = SAMPLES, crossings: float = CROSSINGS,
          front_width: float = SHOCK_W, formation: tuple[float, float] = FORMATION):
    """(time, bin centres, velocity (B, T)) of one seed (module docstring); ``samples`` over
    ``crossings`` crossings, the front's ``front_width`` W and the ``formation`` delay (d / V,
    length d) as other callers sample them."""
    rng = np.random.default_rng(seed)
    t_cross = height / SPEED
    t_max = crossings * t_cross * (1.0 + 0.02 * (2.0 * rng.random() - 1.0))
    time = np.linspace(0.0, t_max, samples)
    time_shift = rng.random() * (time[1] - time[0])
    z_bin = np.arange(height) + 0.5
    if shape in PULSES:
        prof, xh = PULSES[shape]
        w = 0.5 * FWHM / xh

        def velocity(z, t):
            return prof((z - SPEED * t) / w)
    else:
        prof = FRONTS[shape]

        def velocity(z, t):
            return prof((SPEED * t - z) / front_width)

    t = time[None, :] + time_shift
    if column == "chain":
        return time, z_bin, velocity(z_bin[:, None], t)
    count = 1 + rng.poisson(GRAINS_PER_BIN, height)
    owner = np.repeat(np.arange(height), count)
    z = owner + rng.random(owner.size)
    delay = JITTER / SPEED * rng.standard_normal(owner.size) + formation[0] / SPEED * np.exp(-z / formation[1])
    starts = np.concatenate([[0], np.cumsum(count)[:-1]])
    out = np.add.reduceat(velocity(z[:, None], t - delay[:, None]), starts, axis=0) / count[:, None]
    # the mean of the grains' independent remainders: one per bin, of standard deviation NOISE / sqrt(count)
    return time, z_bin, out + NOISE / np.sqrt(count)[:, None] * _noise(rng, height, samples, NOISE_TIME / SPEED
                                                                        / (time[1] - time[0]))


def _noise(rng, rows, n, corr_samples) -> np.ndarray:
    """Per row, white noise low-passed by a Gaussian of ``corr_samples`` (at least one sample),
    of unit standard deviation."""
    from scipy.ndimage import gaussian_filter1d

    x = rng.standard_normal((rows, n))
    s = max(corr_samples, 1.0)
    x = gaussian_filter1d(x, s, axis=1, mode="wrap")
    return x / x.std()


def _shared(shape, height, column):
    cache = {}
    pick = "peak" if shape in PULSES else "crossing"

    def measured(seed):
        if seed not in cache:
            time, z, v = field(seed, shape, height, column)
            cache.clear()  # one seed at a time: the cases of one setting read it in turn
            cache[seed] = front_picks(time, z, v, pick=pick, column=float(height))
        return cache[seed]
    return measured


def cases() -> list[Case]:
    out = []
    for column in ("chain", "packing"):
        for height in HEIGHTS:
            travel = CROSSINGS * height / (SAMPLES - 1)
            where = (f"{'a chain, one grain per bin' if column == 'chain' else 'a disordered column, ~8 grains per bin, jitter, formation, 2 % remainder'}, "
                     f"{height} d, {travel:.2g} d of travel per sample")
            for shape in (*PULSES, *FRONTS):
                measured = _shared(shape, height, column)
                pick = "peak" if shape in PULSES else "crossing"
                setting = f"{shape} {'pulse' if shape in PULSES else 'front'} (pick {pick}), {where}"
                fast = height == 100 and shape in ("cos⁴", "tanh with a 40 % overshoot")

                def speed(seed, measured=measured):
                    r = measured(seed)
                    return interval(r["speed"] / SPEED, r["speed_error"] / SPEED)
                out.append(Case(f"shocks.{pick}_speed", setting, 1.0, speed, fast=fast))
                if shape in PULSES:
                    def width(seed, measured=measured):
                        return measured(seed)["width"] / FWHM, None, None
                    out.append(Case("shocks.width", setting, 1.0, width, fast=fast, tolerance=WIDTH_TOL))
    return out


CASES = cases()
