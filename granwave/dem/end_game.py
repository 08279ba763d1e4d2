"""End-game damping: a lower background damping once the packing is all but static.

The background damping -gamma m v, -gamma I w (gamma = b / t_i) sets the compaction speed
and with it what a packing is. Once every acceleration is small, the packing's contacts
are settled and what is left to decay are its slowest modes. Those that are overdamped at
gamma (soft collective modes; in 3D frictional packings grains rolling on the walls and
on each other, docs/decisions/0008-end-game-rule.md) decay only at about omega^2 / gamma: 75 times
slower than gamma itself in a 10^5-sphere cube, where they held the convergence test for
most of the run. Lowering gamma by a factor f speeds such modes up by 1 / f (until they
are critically damped) and slows the underdamped ones, which decay at gamma / 2 (the
contact damping, unchanged, keeps damping every mode that loads a contact).

A fixed lower rate would slow the packings whose slowest modes are underdamped (a 300-disc
packing took 2.3 times the steps with gamma / 10). So the rule measures which case it is in
and matches the rate to the slowest mode, the damping ratio that decays it fastest:

1. every ``every`` steps (at step counts that are multiples of ``every``, as
   :class:`granwave.dem.settling.CriticalSettling` samples: every decision is a function of
   the state alone, the same bits for any chunking or thread count), once the settling of
   the mean flow has switched (where that rule is on), the largest acceleration (grains'
   |a| and |alpha|, the piston's |a|) is read; the first sample below :data:`START` x tol
   starts the end game;
2. from then on every sample reads the largest speed V the convergence test waits for
   (grains' |v| and |w| R, the piston's |v|), and every :data:`WINDOW` samples the decay rate
   r of V over those samples is fitted (least squares on ln V against time):
   - r > 0: a mode overdamped at the present rate gamma_c decays at r = omega^2 / gamma_c, and
     critical damping is 2 omega = 2 sqrt(r gamma_c): the rule sets that, held between
     :data:`FLOOR` gamma and gamma (an underdamped mode decays at gamma_c / 2 and gives
     1.4 gamma_c: the rate climbs back to gamma);
   - r <= 0, V did not fall while every acceleration stayed small: a creep, grains sliding or
     rolling towards a rearrangement at the speed their small force over the damping gives
     them (in 3D frictional cubes, most of the end game: docs/dem.md "End game"); the rule
     sets :data:`FLOOR` gamma, so the creep runs its course 1 / FLOOR times faster;
3. a sample with an acceleration at or above the threshold plus gamma times the largest
   speed (|v|, the piston's |v|, |w| for rotations; what a change of the damping alone can
   add to an acceleration: lowering it frees the force a creeping grain moves against) is a
   rearrangement (contacts slip or open): it sets gamma again, and the fit starts over from
   the next sample: grains rearrange under the protocol's damping, which the statistics of a
   packing depend on.

The decay is read from the speeds, not from the kinetic energy: a rule answering every rise of
the kinetic energy with gamma also answers a creep with gamma, and kept undoing itself in a
10^5-sphere cube (docs/decisions/0008-end-game-rule.md).

The rate applies to every background damping (grains, mean flows and piston; none is
raised above what it was). Nothing else changes: the convergence test is the same, and
the default (no end game) does not build this rule at all (the bits of the protocol
without it).
"""

from __future__ import annotations

import math

import numpy as np

from .settling import run_sampled

#: the end game starts at the first sample with every acceleration below this many tol
START = 100.0
#: samples over which the decay rate of the speeds is fitted
WINDOW = 20
#: the least rate, as a fraction of the protocol's b / t_i
FLOOR = 0.05

#: the end-game rules (PrepareParams.end_game) and what they do (recorded)
END_GAME_RULES = {
    "none": "the background damping b / t_i to the end",
    "adaptive": (f"from the first sample (every sampling interval, at multiples of it; after the mean flow's "
                 f"settling switch where that rule is on) with max |a|, |alpha| of grains and |a| of the "
                 f"piston below {START:g} tol: every {WINDOW} samples the decay rate r of the largest speed V "
                 f"(|v|, |w| R of grains, |v| of the piston) is fitted (least squares on ln V against time) and "
                 f"every background damping rate set to at most min(gamma, max({FLOOR:g} gamma, "
                 f"2 sqrt(r gamma_c))) (gamma_c the present rate, gamma = b / t_i), to {FLOOR:g} gamma where "
                 f"V did not fall (a creep); a sample with an acceleration at or above the threshold plus "
                 f"gamma x max(|v|, |v| of the piston, |w| R / R_min) sets gamma again and the fit starts over"),
}


def largest_acceleration(m: dict) -> float:
    """The largest of the accelerations the convergence test holds below tol (an engine's
    :meth:`measure` dict): grains' |a| and |alpha|, the piston's |a|."""
    return max(m["max_acceleration"], m["max_angular_acceleration"], m["piston_acceleration"])


def largest_speed(m: dict) -> float:
    """The largest of the speeds the convergence test holds below its velocity threshold (an
    engine's :meth:`measure` dict): grains' |v| and |w| R, the piston's |v|."""
    return max(m["max_speed"], m["max_rotation_speed"], m["piston_speed"])


def decay_rate(times, speeds) -> float:
    """The rate r (1 / time unit) of speeds ~ exp(-r t), fitted by least squares on their logarithm."""
    t = np.asarray(times, dtype=float)
    s = np.log(np.asarray(speeds, dtype=float))
    return -float(np.polyfit(t - t[0], s, 1)[0])


class EndGame:
    """Runs a preparation and matches its background damping to the slowest mode in the end game.

    ``engine``: an :class:`granwave.dem.integrator.Engine` (or its GPU subclass);
    ``advance``: the callable that advances it (``engine.run``, or the settling rule's
    ``run``); ``settling``: that rule (None: none), whose switch the end game waits for;
    ``gamma``: the background damping rate b / t_i (1 / time unit); ``tol``: the convergence
    threshold on every acceleration; ``every``: the sampling interval (steps). Use
    :meth:`run` in place of ``advance``.
    """

    def __init__(self, engine, advance, *, gamma: float, tol: float, every: int, settling=None):
        self.engine, self.advance, self.settling = engine, advance, settling
        self.gamma = float(gamma)
        self.rate = self.gamma  # the present rate
        self.threshold = START * float(tol)
        self.every = int(every)
        self.start_step: int | None = None  # the sample that started the end game
        self.changes = 0  # samples that changed the rate
        self.lowest_rate = self.gamma
        self._time = 0.0  # since the end game started, at the last sample
        self._last_sample = 0
        self._fit = ([], [])  # (time, largest speed) of the samples since the last decision
        self._base = None  # the engine's rates when the end game started
        self._smallest_radius = float(engine.radius.min())  # of the grains (d); radii are fixed

    @property
    def started(self) -> bool:
        return self.start_step is not None

    def run(self, n_steps: int) -> int:
        """Advance up to ``n_steps`` steps as ``engine.run`` does (same return codes), sampling
        at multiples of ``every``."""
        return run_sampled(self.engine, self.advance, n_steps, self.every, self._sample)

    def _sample(self) -> None:
        e = self.engine
        if not self.started:
            if self.settling is not None and not self.settling.done:
                return
            if largest_acceleration(e.measure()) < self.threshold:
                self.start_step = self._last_sample = e.steps
                self._base = e.damping_rates()
            return
        # the interval since the last sample, at the step of its end (dt changes at checks only)
        self._time += (e.steps - self._last_sample) * e.dt
        self._last_sample = e.steps
        m = e.measure()
        times, speeds = self._fit
        if largest_acceleration(m) >= self.threshold + self._damping_share(m):
            # a rearrangement: under the protocol's damping, and its decay read afresh afterwards
            times.clear()
            speeds.clear()
            self._set(self.gamma)
            return
        times.append(self._time)
        speeds.append(largest_speed(m))
        if len(times) < WINDOW:
            return
        decay = decay_rate(times, speeds)
        times.clear()
        speeds.clear()
        if decay > 0.0:
            # overdamped at the present rate c: decay = omega^2 / c, critical damping 2 omega;
            # an underdamped mode (decay c / 2) gives 1.4 c: the rate climbs back towards gamma
            rate = min(self.gamma, max(FLOOR * self.gamma, 2.0 * math.sqrt(decay * self.rate)))
        else:
            rate = FLOOR * self.gamma  # a creep: its speed is the force over the damping
        self._set(rate)

    def _damping_share(self, m: dict) -> float:
        """The most by which a change of the background damping alone can move any acceleration:
        gamma |v| for grains and the piston, gamma |w| for rotations (|w| <= max |w| R / R_min).
        A creeping grain moves at its small force over the damping; lowering the damping frees
        that force, an acceleration of up to (gamma - rate) |v| (in a 10^5-sphere cube 2e-8 at
        max |w| R 4e-6, twice the threshold): the rule's own change is not a rearrangement."""
        return self.gamma * max(m["max_speed"], m["piston_speed"], m["max_rotation_speed"] / self._smallest_radius)

    def _set(self, rate: float) -> None:
        if rate != self.rate:
            self.rate = rate
            self.changes += 1
            self.lowest_rate = min(self.lowest_rate, rate)
            self.engine.cap_background_damping(rate, self._base)

    def state(self) -> dict:
        """What the rule carries from one sample to the next (numbers and lists: JSON as is);
        :meth:`restore` on a rule built with the same arguments goes on with the same bits."""
        base = None if self._base is None else [self._base[0], [float(x) for x in self._base[1]]]
        return dict(rate=self.rate, start_step=self.start_step, changes=self.changes,
                    lowest_rate=self.lowest_rate, time=self._time, last_sample=self._last_sample,
                    fit=[list(self._fit[0]), list(self._fit[1])], base=base)

    def restore(self, state: dict) -> None:
        """Take back a :meth:`state`."""
        self.rate, self.start_step, self.changes = state["rate"], state["start_step"], state["changes"]
        self.lowest_rate, self._time, self._last_sample = state["lowest_rate"], state["time"], state["last_sample"]
        self._fit = (list(state["fit"][0]), list(state["fit"][1]))
        base = state["base"]
        self._base = None if base is None else (base[0], np.array(base[1], dtype=np.float64))

    def attrs(self) -> dict:
        """What the rule did, for the packing's attributes (-1 / NaN: did not start): the threshold
        on every acceleration (E*/(rho d)), the step it started, how often it changed the rate,
        the lowest and the final rate (1 / time unit)."""
        return dict(end_game_threshold=self.threshold,
                    end_game_step=-1 if self.start_step is None else self.start_step,
                    end_game_changes=self.changes,
                    end_game_lowest_rate=self.lowest_rate if self.started else math.nan,
                    end_game_final_rate=self.rate if self.started else math.nan)
