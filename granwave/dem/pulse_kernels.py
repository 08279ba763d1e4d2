"""Numba loop of a nonlinear pulse run: the engine's own steps plus contact bookkeeping.

The steps are the engine's: on one thread :func:`granwave.dem.serial.one_step`, many steps and
samples per call inside one chunk as the preparation engine runs them
(:func:`granwave.dem.serial.run_chunk`); on more threads the parallel passes a step at a time,
:func:`granwave.dem.chunk.one_step` after one :func:`~granwave.dem.chunk.chunk_start` per call (the
integrator, neighbour-list rebuild and force kernel stay in :mod:`granwave.dem`, the contact law
in :mod:`granwave.contact`). After every step the loop only *reads* the state to

- flag every contact (pair slot or wall slot) that opens, forms, or slides,
- track the largest displacement of any grain from its starting position;

and at every output sample (:class:`Readings`, inside the same call)

- record the top-wall contact force (``piston.f_con``),
- the pulse field (the height bins' mean velocity, their largest contact force) and with it the
  contact counts so far, and for the shear source, the top wall's force along x.

Contact state flags (``int8`` bit field, one per pair slot and per wall slot):
``INITIAL`` in contact at t = 0; ``OPENED`` an initial contact found without
overlap after some step; ``FORMED`` a contact not present at t = 0 found with
overlap after some step; ``SLID`` the tangential force found on its
slider's limit after some step: the tangential law's ``at_limit`` (granwave.contact_models; for
Mindlin's Coulomb slider ``|F_t| >= (1 - LIMIT_TOL) mu F_n``) with F_n the elastic normal force of
the engine's law (``contact_models.law_force`` of ``kernels.law_of(fpar)``, as the engine caps
F_t: a sliding contact sits exactly on the limit, a sticking one stays inside); ``LIMIT0`` on the limit at t = 0 already (fully mobilized in the
stored state).

The pair list can be rebuilt by the engine during a step (grains moved more
than skin/2); the flags are then carried to the new list by the pair key
i*N + j, as the engine carries the contact history.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numba
import numpy as np

# pulse_samples inlines the engine's step kernels (chunk, serial): numba alone would key its cache on
# this file only, granwave.kernel_cache stamps it with the whole package's source (an edit of
# kernels.py or contact.py recompiles it).
from .. import contact as C
from .. import contact_models as CM
from ..geometry import periodic_distance2
from . import chunk
from . import kernels as K
from . import serial
from .contact_law import PC_ROOT
from .mean_flow import M_GAMMA_M
from .. import kernel_cache  # noqa: F401  (cached kernels stamped with the whole package's source)

INITIAL, OPENED, FORMED, SLID, LIMIT0 = 1, 2, 4, 8, 16
#: Relative tolerance of the "on the slider's limit" test.
LIMIT_TOL = 1e-9


@numba.njit(cache=True, inline="always")
def _on_limit(tangential, ft, k, d, fel):
    """Whether contact ``k``'s tangential force (the first ``d`` columns of its history ``ft``;
    a rolling history may follow) sits on its tangential law's limit at normal force ``fel``."""
    return CM.tangential_at_limit(tangential, ft[k, 0], ft[k, 1], ft[k, 2] if d == 3 else 0.0, fel, LIMIT_TOL)


@numba.njit(cache=True, inline="always")
def _touching_state(s, at_limit, initial):
    """Flags of a contact that touches now: INITIAL / LIMIT0 when recording the initial state,
    else FORMED (it did not touch initially) and SLID (it is on its slider's limit)."""
    if initial:
        s |= INITIAL
        if at_limit:
            s |= LIMIT0
    else:
        if not (s & INITIAL):
            s |= FORMED
        if at_limit:
            s |= SLID
    return s


@numba.njit(cache=True, parallel=True)
def classify(d, rad, pair_i, pair_j, npairs, pair_ft, pair_ov, wall_ft, wall_ov, tangential, pair_state,
             wall_state, initial, law):
    """Update the contact flags from the current history arrays (after a force evaluation).

    ``d``: the dimension (the tangential force's columns of the histories). ``initial``: set
    INITIAL / LIMIT0 from the current state instead of the run flags. ``tangential`` and ``law``:
    the engine's tangential and normal model tuples (granwave.contact_models;
    ``kernels.friction_of(fpar)``, ``kernels.law_of(fpar)``): the slider's limit and the normal
    force that sets it. Parallel over contacts (each writes only its own flag).
    """
    for p in numba.prange(npairs):
        _classify_pair(np.int64(p), d, rad, pair_i, pair_j, pair_ft, pair_ov, tangential, pair_state, initial,
                       law)
    for w in numba.prange(wall_ov.shape[0]):
        _classify_wall(np.int64(w), d, rad, wall_ft, wall_ov, tangential, wall_state, initial, law)


# inlined into classify's loops: called, they cost ~100 ns a grain after every pulse step, twice the
# step itself (benchmarks/pulse.py --shock); inlined, ~5 ns
@numba.njit(cache=True, inline="always")
def _classify_pair(p, d, rad, pair_i, pair_j, pair_ft, pair_ov, tangential, pair_state, initial, law):
    ov = pair_ov[p]
    s = pair_state[p]
    if ov > 0.0:
        fel = 0.0
        acts = CM.friction_acts(tangential)
        if acts:
            i = pair_i[p]
            j = pair_j[p]
            r12 = C.effective_radius(1.0 / rad[i], 1.0 / rad[j])
            fel = CM.law_force(law, ov, math.sqrt(r12), C.effective_young(False))
        s = _touching_state(s, acts and _on_limit(tangential, pair_ft, p, d, fel), initial)
    elif (s & INITIAL) and not initial:
        s |= OPENED
    pair_state[p] = s


@numba.njit(cache=True, inline="always")
def _classify_wall(w, d, rad, wall_ft, wall_ov, tangential, wall_state, initial, law):
    ov = wall_ov[w]
    s = wall_state[w]
    if ov > 0.0:
        fel = 0.0
        acts = CM.friction_acts(tangential)
        if acts:
            r = rad[w // 2]  # a wall: R12 = R_i, as kernels.wall_contact
            fel = CM.law_force(law, ov, math.sqrt(r), C.effective_young(True))
        s = _touching_state(s, acts and _on_limit(tangential, wall_ft, w, d, fel), initial)
    elif (s & INITIAL) and not initial:
        s |= OPENED
    wall_state[w] = s


@numba.njit(cache=True)
def carry_flags(n_grains, old_i, old_j, old_state, n_old, pair_i, pair_j, npairs, pair_state, archive):
    """Flags of a rebuilt (sorted) pair list from the old one, merged by the key i*N + j. A pair
    that leaves the list with flags keeps them in ``archive`` (a numba typed dict key -> flags,
    :func:`flag_archive`) and one that comes back takes them from there: each contact's flags
    then hold over the whole run whatever the skin (a small skin drops an opened contact from
    the list sooner, and its flags with it)."""
    q = 0
    for p in range(npairs):
        key = pair_i[p] * n_grains + pair_j[p]
        while q < n_old and old_i[q] * n_grains + old_j[q] < key:  # an old pair not in the new list
            _archive(archive, old_i[q] * n_grains + old_j[q], old_state[q])
            q += 1
        if q < n_old and old_i[q] * n_grains + old_j[q] == key:
            pair_state[p] = old_state[q]
            q += 1
        else:
            pair_state[p] = archive.pop(key, np.int8(0))
    while q < n_old:
        _archive(archive, old_i[q] * n_grains + old_j[q], old_state[q])
        q += 1


@numba.njit(cache=True, inline="always")
def _archive(archive, key, state):
    if state != 0:
        archive[key] = state


# this and archived_flags compiled and cached: made or iterated from Python, a typed dict compiles
# its constructor and iterator in every process (about a second, more than a small scene's push)
@numba.njit(cache=True)
def flag_archive():
    """An empty archive of :func:`carry_flags` (pair key int64 -> flags int8)."""
    return numba.typed.Dict.empty(numba.types.int64, numba.types.int8)


@numba.njit(cache=True)
def archived_flags(archive):
    """The archive's flags as an int8 array (to count them with the listed pairs')."""
    flags = np.empty(len(archive), np.int8)
    k = 0
    for state in archive.values():
        flags[k] = state
        k += 1
    return flags


#: Grains per block of the largest-displacement maximum (a size independent of the threads).
DISP_BLOCK = 256


@numba.njit(cache=True, parallel=True)
def max_displacement(pos, pos_ref, lateral):
    """Largest |r_i - r_i(0)| over the grains (nearest periodic image); parallel over fixed
    blocks (a maximum: the same value for any thread count)."""
    n = pos.shape[0]
    nblk = (n + DISP_BLOCK - 1) // DISP_BLOCK
    part = np.zeros(max(1, nblk))
    for b in numba.prange(nblk):
        part[b] = _block_displacement2(np.int64(b), pos, pos_ref, lateral)
    best = 0.0
    for b in range(nblk):
        best = max(best, part[b])
    return math.sqrt(best)


@numba.njit(cache=True)
def _block_displacement2(b, pos, pos_ref, lateral):
    best = 0.0
    for i in range(b * DISP_BLOCK, min(pos.shape[0], (b + 1) * DISP_BLOCK)):
        s = periodic_distance2(pos, i, pos_ref, i, lateral)
        if s > best:
            best = s
    return best


class Readings(NamedTuple):
    """What a pulse run reads at every output sample besides the top-wall force (the arrays are
    written in place; an empty array: that reading is off). Units of docs/method.md §1.

    ``axis``: the kick's axis (the field's velocity component); ``bin_width``: the pulse field's
    height bin (d); ``grain_bin`` (N,) int64: each grain's bin from its starting height (empty:
    no field); ``count`` (n_bins,) int64: grains per bin; ``velocity`` (n_bins, samples): the
    bins' mean velocity along ``axis`` at every sample (np.bincount's sum in grain order over
    max(count, 1)); ``force_max`` (n_bins,): the largest elastic pair normal force at a sample,
    binned by the pair's mid-height; ``shear`` (samples,): the top wall's force along x
    (:func:`top_shear_force`; empty: not read); ``contacts`` (samples, 3) int64, with the field:
    the run's contact counts so far at every sample (:func:`count_contacts`, columns
    :data:`CONTACT_COUNTS`)."""
    axis: int
    bin_width: float
    grain_bin: np.ndarray
    count: np.ndarray
    velocity: np.ndarray
    force_max: np.ndarray
    shear: np.ndarray
    contacts: np.ndarray


#: Columns of :attr:`Readings.contacts`: contacts of t = 0 opened so far (OPENED), contacts formed
#: (FORMED), contacts on their slider's limit that were not at t = 0 (SLID without LIMIT0).
CONTACT_COUNTS = ("opened", "formed", "sliding_new")


def readings(n_grains: int, samples: int, *, axis: int = 0, bin_width: float = 1.0,
             grain_bin: np.ndarray | None = None, n_bins: int = 0, shear: bool = False) -> Readings:
    """A :class:`Readings` record: the field's arrays when ``grain_bin`` is given (``n_bins``
    bins), the shear force's when ``shear``; the others empty (one compiled signature)."""
    field = grain_bin is not None
    gb = np.ascontiguousarray(grain_bin, np.int64) if field else np.zeros(0, np.int64)
    return Readings(int(axis), float(bin_width), gb,
                    np.bincount(gb, minlength=n_bins).astype(np.int64) if field else np.zeros(0, np.int64),
                    np.zeros((n_bins, samples)) if field else np.zeros((0, 0)),
                    np.zeros(n_bins if field else 0), np.zeros(samples if shear else 0),
                    np.zeros((samples if field else 0, len(CONTACT_COUNTS)), np.int64))


@numba.njit(cache=True, inline="always")
def _tally(state, counts):
    s = np.int64(state)
    counts[0] += np.int64((s & OPENED) != 0)
    counts[1] += np.int64((s & FORMED) != 0)
    counts[2] += np.int64((s & SLID) != 0 and (s & LIMIT0) == 0)


@numba.njit(cache=True)
def tally_states(states):
    """The :data:`CONTACT_COUNTS` of an array of flags (int64, 3)."""
    counts = np.zeros(len(CONTACT_COUNTS), np.int64)
    for q in range(states.shape[0]):
        _tally(states[q], counts)
    return counts


@numba.njit(cache=True)
def count_contacts(k, pair_state, npairs, wall_state, archive, rd):
    """Sample ``k``'s row of ``rd.contacts`` (nothing without the field): the flags so far of the
    listed pairs, the wall slots and the pairs that left the list (``archive``, :func:`carry_flags`),
    counted as the run's totals are (granwave.dem.pulse), so the last sample's row is the run's."""
    if rd.contacts.shape[0] == 0:
        return
    counts = np.zeros(len(CONTACT_COUNTS), np.int64)
    for p in range(npairs):
        _tally(pair_state[p], counts)
    for w in range(wall_state.shape[0]):
        _tally(wall_state[w], counts)
    for state in archive.values():
        _tally(state, counts)
    for c in range(len(CONTACT_COUNTS)):
        rd.contacts[k, c] = counts[c]


@numba.njit(cache=True)
def read_sample(k, pos, vel, omega, rad, mass, pair_i, pair_j, npairs, pair_ov, pair_c, wall_ft, wall_ov, piston, fpar,
                rd):
    """The readings of sample ``k`` (:class:`Readings`) from the current state, which is only
    read (:func:`top_shear_force` puts back what it evaluates). ``pair_c``: the listed pairs'
    constants (``ws.pair_c``, :func:`granwave.dem.contact_law.pair_constants`: the force takes
    their sqrt(R12), the value the contact law computes)."""
    if rd.grain_bin.shape[0] > 0:
        n, d = pos.shape
        nb = rd.count.shape[0]
        for b in range(nb):
            rd.velocity[b, k] = 0.0
        for i in range(n):  # np.bincount's sum: grain order
            rd.velocity[rd.grain_bin[i], k] += vel[i, rd.axis]
        for b in range(nb):
            rd.velocity[b, k] = rd.velocity[b, k] / max(rd.count[b], 1)
        law = K.law_of(fpar)
        e12 = C.effective_young(False)
        w = rd.bin_width
        for p in range(npairs):
            ov = pair_ov[p]
            if ov > 0.0:
                i = pair_i[p]
                j = pair_j[p]
                f = CM.law_force(law, ov, pair_c[p, PC_ROOT], e12)
                b = min(max(int(0.5 * (pos[i, d - 1] + pos[j, d - 1]) / w), 0), nb - 1)
                if f > rd.force_max[b]:
                    rd.force_max[b] = f
    if rd.shear.shape[0] > 0:
        rd.shear[k] = top_shear_force(pos, vel, omega, rad, mass, wall_ft, wall_ov, piston, fpar)


@numba.njit(cache=True, error_model="numpy")
def _classify_serial(d, rad, pair_c, npairs, pair_ft, pair_ov, wall_ft, wall_ov, walls, tangential,
                     pair_state, wall_state, law):
    """:func:`classify` of the run (not the initial state) on the calling thread, the walls of
    the engine's wall list ``walls`` only (``ws.walls`` as the step used it: only its grains'
    wall slots change in a step, and every other slot has no overlap and no history, its flags
    set when it last changed). The pairs in one branch-free loop: without a slider (frictionless)
    over the overlaps alone, which the compiler vectorizes (a touching contact then never sits on
    a limit); with one over the overlaps and histories, each pair's sqrt(R12) taken from
    ``pair_c`` (the listed pairs' constants, ``ws.pair_c``: the value :func:`_classify_pair`
    computes, so the same flags)."""
    if CM.friction_acts(tangential):
        # one pair at a time, _classify_pair's three quotients and two roots took longer than
        # the engine's whole step (benchmarks/pulse.py --shock --shock-friction)
        e12 = C.effective_young(False)
        for p in range(npairs):
            ov = pair_ov[p]
            fel = CM.law_force(law, ov, pair_c[p, PC_ROOT], e12)
            pair_state[p] = _flag_with_slider(pair_state[p], ov, fel, _on_limit(tangential, pair_ft, p, d, fel))
        for q in range(1, walls[0] + 1):
            for w in range(2 * walls[q], 2 * walls[q] + 2):
                _classify_wall(np.int64(w), d, rad, wall_ft, wall_ov, tangential, wall_state, np.bool_(False), law)
        return
    for p in range(npairs):
        pair_state[p] = _flag_without_slider(pair_state[p], pair_ov[p])
    for q in range(1, walls[0] + 1):
        for w in range(2 * walls[q], 2 * walls[q] + 2):
            wall_state[w] = _flag_without_slider(wall_state[w], wall_ov[w])


@numba.njit(cache=True, inline="always")
def _flag_with_slider(state, ov, fel, at_limit):
    """:func:`_flag_without_slider` and SLID on a touching contact on its slider's limit
    (``at_limit``, evaluated with the elastic normal force ``fel`` at the overlap ``ov``; branch-free:
    the flags of :func:`_classify_pair`)."""
    touching = np.int64(ov > 0.0)
    return _flag_without_slider(state, ov) | (touching & np.int64(at_limit)) * SLID


@numba.njit(cache=True, inline="always")
def _flag_without_slider(state, ov):
    """FORMED on a touching contact that did not touch at t = 0, OPENED on a t = 0 contact that
    does not touch (branch-free: the flags of :func:`_classify_pair` without a slider)."""
    s = np.int64(state)
    touching = np.int64(ov > 0.0)
    initial = s & INITIAL
    return s | (touching & (initial ^ 1)) * FORMED | ((touching ^ 1) & initial) * OPENED


#: Relative margin of the candidates' bound (:func:`_displacement_candidates`): far above rounding.
CANDIDATE_MARGIN = 1e-9


@numba.njit(cache=True)
def _displacement_candidates(pos0, pos_ref, lateral, floor, cand):
    """The grains whose displacement from ``pos_ref`` at the last rebuild (``pos0``) is at least
    ``floor``, into ``cand[1:cand[0] + 1]``. A grain outside, displaced since the rebuild by at
    most D (the step's largest displacement since the rebuild, which the engine keeps), is
    displaced by less than floor + D from ``pos_ref`` (the triangle inequality of the nearest
    image distance), so while floor + D stays below the largest displacement so far (with a
    margin), only the candidates can raise it: :func:`_track_largest`."""
    c = 0
    for i in range(pos0.shape[0]):
        if math.sqrt(periodic_distance2(pos0, i, pos_ref, i, lateral)) >= floor:
            c += 1
            cand[c] = i
    cand[0] = c


@numba.njit(cache=True)
def _track_largest(pos, pos0, pos_ref, lateral, skin, disp2, stats, cand, floor):
    """The largest displacement so far (``stats[0]``) after a step of the one-thread loop: its
    value over every grain (:func:`max_displacement`), computed over the candidates of
    :func:`_displacement_candidates` alone while their bound holds (``disp2``: the step's
    largest squared displacement since the last rebuild); the list is made again (``floor`` =
    best - D - skin) when it does not. Returns the floor in use."""
    best = stats[0]
    reach = math.sqrt(disp2)
    if not (floor + reach <= best - CANDIDATE_MARGIN * (best + reach)):
        floor = best - reach - skin
        _displacement_candidates(pos0, pos_ref, lateral, floor, cand)
    top = 0.0
    for q in range(1, cand[0] + 1):
        i = cand[q]
        s = periodic_distance2(pos, i, pos_ref, i, lateral)
        if s > top:
            top = s
    u = math.sqrt(top)
    if u > best:
        stats[0] = u
    return floor


@numba.njit(cache=True)
def _after_step(n, rad, pos, pos_ref, lateral, pair_i, pair_j, pair_c, pair_ft, pair_ov, wall_ft, wall_ov, walls,
                tangential, ipar, rebuilds, old_i, old_j, pair_state, wall_state, archive, npairs, stats, law):
    """The bookkeeping after one step of the pulse loops: the contact flags carried over
    a rebuild (``rebuilds``: the count before the step), the contacts classified and the step
    counted in ``stats[1]``. Returns the pair keys and count of the current list (new arrays
    after a rebuild). The largest displacement is the caller's."""
    if ipar.rebuilds != rebuilds:
        old_state = pair_state[:npairs].copy()
        carry_flags(n, old_i, old_j, old_state, npairs, pair_i, pair_j, ipar.npairs, pair_state, archive)
        npairs = ipar.npairs
        old_i = pair_i[:npairs].copy()
        old_j = pair_j[:npairs].copy()
    _classify_serial(pos.shape[1], rad, pair_c, npairs, pair_ft, pair_ov, wall_ft, wall_ov, walls,
                     tangential, pair_state, wall_state, law)
    stats[1] += 1.0
    return old_i, old_j, npairs


@numba.njit(cache=True)
def pulse_samples(pos, vel, acc, omega, alpha, rad, mass, inertia, lateral, pos0, pos_ref, pair_i,
                  pair_j, pair_ft, pair_ov, wall_ft, wall_ov, piston, fpar, ipar, out, ws, pair_state,
                  wall_state, archive, k_start, k_stop, sub, force_out, stats, rd):
    """Advance from output sample ``k_start - 1`` to ``k_stop - 1``, ``sub`` steps per sample,
    on the parallel engine's passes (:func:`granwave.dem.chunk.one_step` after one
    :func:`~granwave.dem.chunk.chunk_start` per call: the bookkeeping runs between steps).

    ``force_out[k]`` receives the top-wall contact force (elastic + viscous
    normal forces of the top-wall contacts) at sample k, and ``rd`` (:class:`Readings`) the
    sample's other readings. ``stats[0]`` holds
    the largest grain displacement so far. Returns the next sample to run
    (``k_stop`` when done), or minus it when the pair list needs more room
    (``ipar.needed`` pairs, ``ipar.width`` neighbours; the state is then between steps of that
    sample, which the caller resumes after growing the arrays: the steps
    already done inside the sample are kept in ``stats[1]``). A state that blew up (non-finite
    reach) ends the call with ``stats[0]`` NaN.
    """
    n = pos.shape[0]
    tangential = K.friction_of(fpar)
    law = K.law_of(fpar)
    # the pair keys of the current list, refreshed only after a rebuild
    npairs = ipar.npairs
    old_i = pair_i[:npairs].copy()
    old_j = pair_j[:npairs].copy()
    # once per call, not per step: a chunk's start costs about a third of a step (1/m, the block lists)
    disp2 = chunk.chunk_start(pos, rad, mass, inertia, lateral, pos0, wall_ov, piston, fpar, ipar, ws)
    if disp2 < 0.0:
        return -k_start
    for k in range(k_start, k_stop):
        for _ in range(int(stats[1]), sub):
            rebuilds = ipar.rebuilds
            status, disp2 = chunk.one_step(pos, vel, acc, omega, alpha, rad, mass, inertia, lateral, pos0, pair_i,
                                           pair_j, pair_ft, pair_ov, wall_ft, wall_ov, piston, fpar, ipar, out, ws,
                                           disp2)
            if status == 2:
                return -k
            if status == 3:
                stats[0] = math.nan
                return k + 1
            old_i, old_j, npairs = _after_step(n, rad, pos, pos_ref, lateral, pair_i, pair_j, ws.pair_c, pair_ft,
                                               pair_ov, wall_ft, wall_ov, ws.walls, tangential, ipar, rebuilds, old_i,
                                               old_j, pair_state, wall_state, archive, npairs, stats, law)
            u = max_displacement(pos, pos_ref, lateral)  # every grain (the one-thread loop: candidates)
            if u > stats[0]:
                stats[0] = u
        stats[1] = 0.0
        force_out[k] = piston.f_con
        read_sample(k, pos, vel, omega, rad, mass, pair_i, pair_j, npairs, pair_ov, ws.pair_c, wall_ft, wall_ov, piston,
                    fpar, rd)
        count_contacts(k, pair_state, npairs, wall_state, archive, rd)
    return k_stop


# The same loop as pulse_samples but stepping on one thread: written twice on purpose. One body
# taking the step function as an argument would not be cached by numba (a jitted function as an
# argument makes the caller uncacheable), and one body with a run-time flag would compile the
# parallel kernels in every one-thread process, the cost this variant exists to avoid.
@numba.njit(cache=True)
def pulse_samples_serial(pos, vel, acc, omega, alpha, rad, mass, inertia, lateral, pos0, pos_ref, pair_i,
                         pair_j, pair_ft, pair_ov, wall_ft, wall_ov, piston, fpar, ipar, out, ws, pair_state,
                         wall_state, archive, k_start, k_stop, sub, force_out, stats, rd):
    """:func:`pulse_samples` on one thread (same arguments, returns and bits), stepping with
    :func:`granwave.dem.serial.one_step` inside one chunk (:func:`granwave.dem.serial.chunk_start`
    once per call, as the preparation engine's :func:`granwave.dem.serial.run_chunk`), the
    bookkeeping between steps. The parallel engine's kernels take several times longer to
    compile, which a one-thread process would spend for nothing on a cold cache."""
    n = pos.shape[0]
    tangential = K.friction_of(fpar)
    law = K.law_of(fpar)
    npairs = ipar.npairs
    old_i = pair_i[:npairs].copy()
    old_j = pair_j[:npairs].copy()
    mflow = ws.mflow
    gamma_piston = mflow[M_GAMMA_M] if mflow.shape[0] > 0 else fpar.gamma
    disp2 = serial.chunk_start(pos, rad, mass, inertia, lateral, pos0, wall_ov, piston, fpar, ws)
    cand = np.empty(n + 1, np.int64)  # the largest displacement's candidates (_track_largest)
    floor = math.inf  # none yet: made at the first step
    for k in range(k_start, k_stop):
        for _ in range(int(stats[1]), sub):
            rebuilds = ipar.rebuilds
            status, disp2 = serial.one_step(pos, vel, acc, omega, alpha, rad, mass, inertia, lateral, pos0, pair_i,
                                            pair_j, pair_ft, pair_ov, wall_ft, wall_ov, piston, fpar, ipar, out, ws,
                                            mflow, ws.slabs, gamma_piston, disp2)
            if status == 2:
                return -k
            if status == 3:
                stats[0] = math.nan
                return k + 1
            old_i, old_j, npairs = _after_step(n, rad, pos, pos_ref, lateral, pair_i, pair_j, ws.pair_c, pair_ft,
                                               pair_ov, wall_ft, wall_ov, ws.walls, tangential, ipar, rebuilds, old_i,
                                               old_j, pair_state, wall_state, archive, npairs, stats, law)
            if ipar.rebuilds != rebuilds:  # pos0 moved: the candidates are made again
                floor = math.inf
            floor = _track_largest(pos, pos0, pos_ref, lateral, fpar.skin, disp2, stats, cand, floor)
        stats[1] = 0.0
        force_out[k] = piston.f_con
        read_sample(k, pos, vel, omega, rad, mass, pair_i, pair_j, npairs, pair_ov, ws.pair_c, wall_ft, wall_ov, piston,
                    fpar, rd)
        count_contacts(k, pair_state, npairs, wall_state, archive, rd)
    return k_stop


@numba.njit(cache=True)
def top_shear_force(pos, vel, omega, rad, mass, wall_ft, wall_ov, piston, fpar):
    """The force along x that the grains exert on the top wall (elastic + viscous tangential
    parts of the top-wall contacts): the detector of the shear kick (docs/method.md §8).

    Each top-wall contact is evaluated by the engine's own :func:`granwave.dem.kernels.wall_contact`
    with slip step 0 (the history is read, not advanced) on a saved copy of its slots, which
    are put back: the state is only read. Summed in grain order."""
    n, d = pos.shape
    e_wall = C.effective_young(True)
    g_wall = C.effective_shear(fpar.poisson, True)
    rescale = fpar.rescale != 0.0
    h = piston.h
    vp = piston.v
    saved = np.zeros(d)
    total = 0.0
    for i in range(n):
        w = 2 * i + 1
        if rad[i] - (h - pos[i, d - 1]) <= 0.0:
            continue
        ov = wall_ov[w]
        for a in range(d):
            saved[a] = wall_ft[w, a]
        out = K.wall_contact(pos, vel, omega, rad, mass, wall_ft, wall_ov, i, 1, h, vp, e_wall, g_wall,
                             0.0, K.dashpot_of(fpar), K.friction_of(fpar), rescale, K.law_of(fpar))
        total -= out[5]  # the wall feels minus the force on the grain
        wall_ov[w] = ov
        for a in range(d):
            wall_ft[w, a] = saved[a]
    return total
