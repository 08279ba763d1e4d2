"""Critical settling of the mean flow once the plug has arrived (compaction 'mean-flow').

With the 'mean-flow' rule the mean vertical flow and the piston are damped at a rate
gamma_m ~ 1/H, so that a tall column is compacted like a 25 d one. Once the plug has
arrived, two slow modes of the column are left to decay, both with frequencies ~ 1/H:
its breathing under the piston (omega_b), damped at gamma_m with the same damping ratio
gamma_m / (2 omega_b) at every height (0.2-0.3 at p = 1e-4, measured), so that it
decays at gamma_m / 2; and its lowest shear mode (the slabs' mean lateral flow), damped
with the fluctuations at gamma = b / t_i, overdamped in a tall column (gamma > 2 omega_s),
so that it decays at only about omega_s^2 / gamma ~ 1 / H^2. In a width-25 column 800 d
tall they are what the last half of the steps waits for (docs/dem.md).

Critical settling measures omega_b and damps both mean flows near critically from then on:

1. every ``every`` steps (at step counts that are multiples of ``every``, whatever the
   chunks the caller runs: the switch is a function of the state alone, the same bits for
   any chunking or thread count) the piston's vertical velocity is read. The protocol
   samples every 10 convergence checks (200 steps): every call into the engine costs
   about half a step of 21 000 grains (measured), and at p = 1e-4 a breathing half period
   is about 1000 steps or more in any column taller than 25 d (omega_b H = 0.28 measured),
   so the swing is resolved to about 20 % or better;
2. the first sample with the piston moving up marks the plug's arrival (the compaction
   only ever pushes the piston down); the next sample with it moving down again ends that
   upward swing, half a breathing period: omega_b = pi / (its duration, steps x dt);
3. from then on the mean vertical flow (and the piston) and the slabs' mean lateral flow
   are damped at min(2 omega_b, gamma): critical damping of the breathing, and of the
   shear a damping ratio omega_b / omega_s (of order one; omega_s was not measured)
   instead of gamma / (2 omega_s), which grows as H; never more than the fluctuations' rate gamma =
   b / t_i (a short column's rate; it also bounds what a mismeasured swing could do).

Nothing else changes: the fluctuations about the slab means keep gamma, the convergence
test is the same. Where the piston never swings up (an overdamped plug), nothing
switches.

The 'late' rule measures omega_b the same way but keeps the compaction rate until the
kinetic energy (grains and piston, read at the same samples) has fallen below
:data:`LATE_FRACTION` of its value at the end of the swing: the breathing has then done
the settling it does under the compaction rate, and the critical damping only shortens
the slow tail of both mean flows.
"""

from __future__ import annotations

import math

from . import kernels as K
from .mean_flow import M_GAMMA_L, M_GAMMA_M

#: the piston is sampled every this many convergence checks
SAMPLE_CHECKS = 10

#: the 'late' rule switches once the kinetic energy is below this fraction of its value at the
#: end of the piston's first upward swing
LATE_FRACTION = 1e-3

#: the settling rules (PrepareParams.mean_flow_settling) and what they do (recorded)
SETTLING_RULES = {
    "critical": ("after the piston's first upward swing (the plug has arrived), the mean flow and the "
                 "piston and the slabs' mean lateral flow are damped at min(2 omega_b, gamma), "
                 f"omega_b = pi / (the swing's duration), piston velocity sampled every {SAMPLE_CHECKS} "
                 "check_every steps"),
    "late": ("as 'critical', but the switch waits until the kinetic energy (grains and piston, read at "
             f"the same samples) is below {LATE_FRACTION:g} of its value at the end of the swing"),
    "compaction": "the mean flow and the piston keep the compaction rate to the end",
}


def run_sampled(engine, advance, n_steps: int, every: int, sample, finished=None) -> int:
    """Advance ``engine`` up to ``n_steps`` steps with ``advance`` (``engine.run`` or a rule
    wrapping it; same return codes), stopping at every step count that is a multiple of
    ``every`` to call ``sample()`` (samples at fixed step counts: the same bits for any
    chunking); once ``finished()`` is true, the rest in one call."""
    target = engine.steps + int(n_steps)
    while engine.steps < target:
        if finished is not None and finished():
            return advance(target - engine.steps)
        before = engine.steps
        status = advance(min(target, (before // every + 1) * every) - before)
        if engine.steps % every == 0:
            sample()
        if status != 0:
            return status
    return 0


class CriticalSettling:
    """Runs an engine whose mean-flow rule is on and switches it to critical settling.

    ``engine``: an :class:`granwave.dem.integrator.Engine` built with ``mean_flow``;
    ``gamma``: the fluctuations' damping rate (the cap); ``every``: the sampling interval
    (steps); ``late``: None (rule 'critical': switch at the end of the swing) or the
    fraction of the kinetic energy at the end of the swing below which to switch (rule
    'late'). Use :meth:`run` in place of ``engine.run``.
    """

    def __init__(self, engine, gamma: float, every: int, late: float | None = None):
        self.engine, self.gamma, self.every = engine, float(gamma), int(every)
        self.late = late
        self.rise_step: int | None = None  # first sample with the piston moving up
        self.swing_end_step: int | None = None  # the sample that ended the swing
        self.switch_step: int | None = None  # the sample that switched the damping
        self._kinetic_at_swing_end = math.nan
        self.breathing_frequency = math.nan  # omega_b (1 / time unit)
        self._swing_time = 0.0  # time since rise_step (steps x dt of each sampled interval)
        self._last_sample = 0

    @property
    def done(self) -> bool:
        return self.switch_step is not None

    def run(self, n_steps: int) -> int:
        """Advance up to ``n_steps`` steps as ``engine.run`` does (same return codes), sampling
        the piston at multiples of ``every`` until the switch."""
        return run_sampled(self.engine, self.engine.run, n_steps, self.every, self._sample,
                           finished=lambda: self.done)

    def _sample(self) -> None:
        e = self.engine
        if self.swing_end_step is not None:  # rule 'late', waiting for the kinetic energy to fall
            if e.measure()["kinetic_energy"] < self.late * self._kinetic_at_swing_end:
                self._switch()
            return
        up = e.piston.v > 0.0
        if self.rise_step is None:
            if up:
                self.rise_step = self._last_sample = e.steps
            return
        # the interval since the last sample, at the step of its end (dt changes at checks only)
        self._swing_time += (e.steps - self._last_sample) * e.dt
        self._last_sample = e.steps
        if not up:
            self.breathing_frequency = math.pi / self._swing_time
            self.swing_end_step = e.steps
            if self.late is None:
                self._switch()
            else:
                self._kinetic_at_swing_end = e.measure()["kinetic_energy"]

    def _switch(self) -> None:
        e = self.engine
        rate = min(2.0 * self.breathing_frequency, self.gamma)
        e.mflow[M_GAMMA_M] = rate
        e.mflow[M_GAMMA_L] = rate
        self.switch_step = e.steps

    def state(self) -> dict:
        """What the rule carries from one sample to the next (numbers: JSON as is);
        :meth:`restore` on a rule built with the same arguments goes on with the same bits."""
        return dict(rise_step=self.rise_step, swing_end_step=self.swing_end_step,
                    switch_step=self.switch_step, kinetic_at_swing_end=self._kinetic_at_swing_end,
                    breathing_frequency=self.breathing_frequency, swing_time=self._swing_time,
                    last_sample=self._last_sample)

    def restore(self, state: dict) -> None:
        """Take back a :meth:`state` (the engine's damping rates come back with the engine's)."""
        self.rise_step, self.swing_end_step = state["rise_step"], state["swing_end_step"]
        self.switch_step, self._kinetic_at_swing_end = state["switch_step"], state["kinetic_at_swing_end"]
        self.breathing_frequency, self._swing_time = state["breathing_frequency"], state["swing_time"]
        self._last_sample = state["last_sample"]

    def attrs(self) -> dict:
        """What the rule measured, for the packing's attributes (-1 / NaN: did not happen)."""
        return dict(settling_rise_step=-1 if self.rise_step is None else self.rise_step,
                    settling_swing_end_step=-1 if self.swing_end_step is None else self.swing_end_step,
                    settling_step=-1 if self.switch_step is None else self.switch_step,
                    breathing_frequency=self.breathing_frequency,
                    settling_damping_rate=float(self.engine.mflow[M_GAMMA_M]) if self.done else math.nan)
