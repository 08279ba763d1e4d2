"""Layout of the DEM engine's small parameter arrays: the indices of ``fpar``, ``ipar``,
``piston`` and ``out`` that every kernel of :mod:`granwave.dem` reads.

``fpar``: dt, zeta, mu, poisson, background damping rate, skin, dt safety,
overlap floor for the time step, acceleration tol, velocity tol, largest
radius, smallest mass, last max speed, unloading rule (1: rescale F_t on
unloading, 0: plain incremental; contact.update_tangential), piston height when the wall
list was made (:func:`granwave.dem.workspace.wall_list`), smallest and largest skin (an adaptive
skin when they differ: :func:`granwave.dem.time_step.next_skin`), the normal law's code and
stiffness k (granwave.contact_models, :func:`granwave.dem.contact_law.law_of`), the rolling
sub-model's code, k_r, gamma_r and mu_r (:func:`granwave.dem.contact_law.rolling_of`); ``ipar``: pairs
listed, steps asked, steps done, steps between checks, adaptive dt, rebuilds, sizes a rebuild
needs (pairs, width), step of the last rebuild, whether plain steps run in a team of threads
(1: yes, 0: no, -1: a team did not start; :func:`granwave.dem.team_steps._team_steps`), steps
run so far in teams; ``piston``: height, velocity, acceleration, mass (inf = fixed wall),
downward force p*A, contact force; ``out``: the statistics of a step or check.
"""

from __future__ import annotations

# fpar indices
F_DT, F_ZETA, F_MU, F_POISSON, F_GAMMA, F_SKIN, F_SAFETY, F_DFLOOR, F_TOLA, F_TOLV, F_RMAX, F_MMIN, \
    F_VMAX, F_RESCALE, F_WALLH, F_SKIN_MIN, F_SKIN_MAX, F_LAW, F_KLAW, F_ROLL, F_KROLL, F_GROLL, \
    F_MUROLL = range(23)
N_FPAR = 23
# piston indices
P_H, P_V, P_A, P_MASS, P_FEXT, P_FCON = range(6)
N_PISTON = 6
# ipar indices
I_NPAIRS, I_NSTEPS, I_STEPS, I_CHECK, I_ADAPTIVE, I_REBUILDS, I_NEEDED, I_WIDTH, I_BUILT, I_TEAM, \
    I_TEAMSTEPS = range(11)
N_IPAR = 11
# out (statistics) indices
O_AMAX, O_ALPHAMAX, O_APISTON, O_VMAX, O_WMAX, O_KIN, O_NTOP, O_DMAX, O_NCONTACT = range(9)
N_OUT = 9
