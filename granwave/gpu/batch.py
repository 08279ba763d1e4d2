"""Ensembles per launch: several packings advanced by the same kernel launches on one GPU.

Each packing is prepared by the preparation protocol itself
(:func:`granwave.dem.protocol.prepare_packing`, unchanged) with its own engine, a
:class:`BatchMember` (a :class:`granwave.gpu.dem.GpuEngine`), and its own rules (compaction,
settling, end game, convergence) on the host. The device state of all of them lives in
concatenated arrays (:class:`Ensemble`): grains one packing after another, pairs likewise (each
packing's slots at its own capacity), one row per packing for its piston, parameters, mean-flow
rates, slabs, reduction and control words. Every index stored on the device is the packing's
own (grain i of a packing is stored as i, its pairs as its own pair list), so the kernels here
take each packing's slices and call the per-packing engine's own device functions
(:func:`granwave.gpu.dem._pair_force`, ``_grain_force``, ``_partials``, ``_finish`` and the
mean-flow rule's ``bin_grain``, ``sum_slab``): the same arithmetic in the same order, and the
per-packing reductions (piston force, contacts, maxima) have the single run's shape (NPART
blocks per packing, then one block per packing). Hence each packing's bytes are those of running
it alone on the GPU; no floating-point atomics.

One step is seven kernels for all packings together: the device rebuild of the packings of at
most ``small_rebuild`` grains (one block per packing, :func:`rb_small_batch`; with no rebuild
due a block returns at once), kick and drift, pair forces, the two of the mean-flow rule, grain
forces, the partial reductions on a grid of NPART x packings, the final reductions on one block
per packing. The larger packings' rebuild is one segmented launch sequence for all of them
(:mod:`granwave.gpu.batch_rebuild`: the twelve launches of one packing's rebuild, whatever their
number). Both rebuilds take a per-packing mask of the packings whose turn it is
(``GpuEngine.rebuild_every``); the others keep their lists.

The protocols run in threads, one per packing, that take turns (one lock): a packing's
``engine.run(n)`` hands its request to the driver (the calling thread of :meth:`Ensemble.run`)
and waits. When every unfinished packing waits, the driver uploads them and steps them together;
each packing pauses on the device at its own next stop (its next convergence check or the end
of its request: the control word ``C_STOP``; a paused packing's steps are no-ops), the driver
reads all of them at once, makes each one's check, and hands back the result of each packing
whose request is done (its state downloaded into its host arrays). A packing whose device
rebuild needs more pair slots waits until the others' requests are done; then its arrays are
enlarged (a new layout) and it goes on from the step that stopped, as the single engine does.
"""

from __future__ import annotations

import collections
import math
import threading
import time

import numpy as np

from ..dem import kernels as K
from ..dem.mean_flow import M_SLAB, N_MFLOW
from . import load_cuda, simulated
from . import batch_rebuild as BR
from . import dem as G
from . import mean_flow as MF
from . import neighbours as NB
from . import reductions as R
from .neighbours import C_NPAIRS, C_STATUS, C_STEPS, N_CTL

cuda = load_cuda()

#: The batch's extra control word: the step at which the packing pauses (status PAUSED).
C_STOP = N_CTL
N_CTL_BATCH = N_CTL + 1
#: Status of a packing paused at its stop (its kernels return at once, as for the single
#: engine's statuses 2 and 3); the driver sets it back to 0 when it goes on.
PAUSED = 4
#: A stop no run reaches.
NEVER = np.iinfo(np.int64).max // 2

#: Per-grain device arrays of the state (uploaded from the host arrays of the same name).
STATE = ("position", "velocity", "acceleration", "angular_velocity", "angular_acceleration", "pos0")


# ---------------------------------------------------------------- kernels
@cuda.jit
def kick_drift_batch(pos, vel, acc, omega, alpha, lateral, pos0, pistons, fpars, gv2, gdisp2, ctl, gk):
    """:func:`granwave.gpu.dem.kick_drift` of every grain of every running packing (``gk``: each
    grain's packing); thread k moves packing k's piston."""
    g = cuda.grid(1)
    for k in range(g, pistons.shape[0], cuda.gridsize(1)):
        if ctl[k, C_STATUS] == 0:
            piston = pistons[k]
            if piston.mass < math.inf:
                dt = fpars[k].dt
                piston.v += 0.5 * dt * piston.a
                piston.h += dt * piston.v
    for i in range(g, pos.shape[0], cuda.gridsize(1)):
        k = gk[i]
        if ctl[k, C_STATUS] != 0:
            continue
        dt = fpars[k].dt
        v2, s = G.DF.drift_grain(pos, vel, acc, omega, alpha, pos0, lateral[k], i, 0.5 * dt, dt)
        gv2[i] = v2
        gdisp2[i] = s


@cuda.jit
def pair_forces_batch(pos, vel, omega, rad, inv_rad, mass, lateral, pair_i, pair_j, ctl, pair_ft, pair_ov,
                      fpars, pf, tq_i, tq_j, pdelta, goff, poff, pk):
    """:func:`granwave.gpu.dem.pair_forces` over every pair slot (``pk``: each slot's packing),
    on the packing's slices: its listed pairs only."""
    for p in range(cuda.grid(1), pair_i.shape[0], cuda.gridsize(1)):
        k = pk[p]
        q = p - poff[k]
        if ctl[k, C_STATUS] != 0 or q >= ctl[k, C_NPAIRS]:
            continue
        o, e, a, b = goff[k], goff[k + 1], poff[k], poff[k + 1]
        G._pair_force(q, pos[o:e], vel[o:e], omega[o:e], rad[o:e], inv_rad[o:e], mass[o:e], lateral[k],
                      pair_i[a:b], pair_j[a:b], pair_ft[a:b], pair_ov[a:b], fpars[k], pf[a:b], tq_i[a:b],
                      tq_j[a:b], pdelta[a:b])


@cuda.jit
def slab_bin_batch(pos, mflow, mlen, fpars, slab_of, lo, hi, nslab, ctl, goff, gk):
    """:func:`granwave.gpu.mean_flow.slab_bin` for the packings under the rule 'mean-flow' whose
    background damping is on (where the single engine launches it)."""
    for i in range(cuda.grid(1), pos.shape[0], cuda.gridsize(1)):
        k = gk[i]
        if ctl[k, C_STATUS] != 0 or mlen[k] == 0 or not fpars[k].gamma > 0.0:
            continue
        o, e = goff[k], goff[k + 1]
        MF.bin_grain(i - o, pos[o:e], mflow[k], slab_of[o:e], lo[k, :nslab[k]], hi[k, :nslab[k]])


@cuda.jit
def slab_sums_batch(vel, mass, fpars, mflow, mlen, slab_of, lo, hi, slabs, nslab, ctl, goff):
    """:func:`granwave.gpu.mean_flow.slab_sums` over every (packing, slab) of those packings."""
    ks = lo.shape[1]
    for x in range(cuda.grid(1), lo.shape[0] * ks, cuda.gridsize(1)):
        k = x // ks
        s = x - k * ks
        if ctl[k, C_STATUS] != 0 or mlen[k] == 0 or not fpars[k].gamma > 0.0 or s >= nslab[k]:
            continue
        o, e, ns = goff[k], goff[k + 1], nslab[k]
        MF.sum_slab(s, vel[o:e], mass[o:e], fpars[k], mflow[k], slab_of[o:e], lo[k, :ns], hi[k, :ns],
                    slabs[k, :, :ns])


@cuda.jit
def grain_forces_batch(pos, vel, acc, omega, alpha, rad, mass, inertia, inc_ptr, inc_pair, pf, tq_i, tq_j,
                       wall_ft, wall_ov, pistons, fpars, gfp, gtop, gdmax, gcount, ctl, mflow, mlen, slabs, nslab,
                       goff, poff, gk):
    """:func:`granwave.gpu.dem.grain_forces` of every grain of every running packing, on its
    packing's slices (its incidence list: ``n + 1`` offsets from ``goff[k] + k``, twice its pair
    capacity of codes from ``2 poff[k]``; its wall slots from ``2 goff[k]``)."""
    for i in range(cuda.grid(1), pos.shape[0], cuda.gridsize(1)):
        k = gk[i]
        if ctl[k, C_STATUS] != 0:
            continue
        o, e, a, b = goff[k], goff[k + 1], poff[k], poff[k + 1]
        G._grain_force(i - o, pos[o:e], vel[o:e], acc[o:e], omega[o:e], alpha[o:e], rad[o:e], mass[o:e],
                       inertia[o:e], inc_ptr[o + k:e + k + 1], inc_pair[2 * a:2 * b], pf[a:b], tq_i[a:b],
                       tq_j[a:b], wall_ft[2 * o:2 * e], wall_ov[2 * o:2 * e], pistons[k], fpars[k], gfp[o:e],
                       gtop[o:e], gdmax[o:e], gcount[o:e], mflow[k, :mlen[k]], slabs[k, :, :nslab[k]])


@cuda.jit
def step_partials_batch(gfp, gtop, gdmax, gcount, gv2, gdisp2, pdelta, ctl, part, goff, poff):
    """:func:`granwave.gpu.dem.step_partials` on a grid of NPART x packings: block (b, k) is
    block b of packing k alone (the same shares, the same order)."""
    k = cuda.blockIdx.y
    if ctl[k, C_STATUS] != 0:
        return
    o, e, a, b = goff[k], goff[k + 1], poff[k], poff[k + 1]
    G._partials(cuda.blockIdx.x, gfp[o:e], gtop[o:e], gdmax[o:e], gcount[o:e], gv2[o:e], gdisp2[o:e],
                pdelta[a:b], ctl[k, C_NPAIRS], part[k])


@cuda.jit
def finish_batch(part, pistons, fpars, mflow, mlen, red, ctl):
    """:func:`granwave.gpu.dem.finish`, block k for packing k; the packing pauses once it has
    done the steps up to its stop (``ctl[k, C_STOP]``)."""
    k = cuda.blockIdx.x
    if ctl[k, C_STATUS] != 0:
        return
    G._finish(part[k], pistons[k], fpars[k], mflow[k, :mlen[k]], red[k], ctl[k])
    if cuda.threadIdx.x == 0 and ctl[k, C_STEPS] >= ctl[k, C_STOP]:  # thread 0 counted the step
        ctl[k, C_STATUS] = PAUSED


@cuda.jit
def rb_small_batch(red, fpars, pistons, lateral, pos, rad, pos0, ctl, cell, ccount, cstart, members, gcnt, gptr, nbr,
                   row, pair_i, pair_j, pair_ft, pair_ov, new_i, new_j, new_ft, new_ov, new_code, inc_ptr, inc_code,
                   goff, poff, coff, small):
    """:func:`granwave.gpu.neighbours.rb_small`, block k for packing k where ``small[k]`` (the
    packings of at most ``small_rebuild`` grains), on the packing's slices of the concatenated
    rebuild work arrays (its cells from ``coff[k]``, its n + 1 and ncell + 1 offsets shifted by k)."""
    k = cuda.blockIdx.x
    if small[k] == 0:
        return
    o, e, a, b, c, f = goff[k], goff[k + 1], poff[k], poff[k + 1], coff[k], coff[k + 1]
    NB._small(cuda.threadIdx.x, cuda.blockDim.x, red[k], fpars[k], pistons[k], lateral[k], pos[o:e], rad[o:e],
              pos0[o:e], ctl[k], cell[o:e], ccount[c:f], cstart[c + k:f + k + 1], members[o:e], gcnt[o:e],
              gptr[o + k:e + k + 1], nbr[2 * a:2 * b], row[o + k:e + k + 1], pair_i[a:b], pair_j[a:b], pair_ft[a:b],
              pair_ov[a:b], new_i[a:b], new_j[a:b], new_ft[a:b], new_ov[a:b], new_code[2 * a:2 * b],
              inc_ptr[o + k:e + k + 1], inc_code[2 * a:2 * b])


@cuda.jit
def measure_batch(vel, acc, omega, alpha, mass, inertia, rad, stat, goff):
    """:func:`granwave.gpu.reductions.measure_kernel`, block k for packing k (the convergence
    check's measures of every packing in one launch)."""
    k = cuda.blockIdx.x
    o, e = goff[k], goff[k + 1]
    R._measure(cuda.threadIdx.x, vel[o:e], acc[o:e], omega[o:e], alpha[o:e], mass[o:e], inertia[o:e], rad[o:e],
               stat[k])


#: Every kernel of this module (compiled to PTX by tests/test_gpu_ptx.py).
KERNELS = (kick_drift_batch, pair_forces_batch, slab_bin_batch, slab_sums_batch, grain_forces_batch,
           step_partials_batch, finish_batch, rb_small_batch, measure_batch)


def _blocks(n: int) -> int:
    return G._blocks(n)


# ---------------------------------------------------------------- engines
class BatchMember(G.GpuEngine):
    """A packing's engine in an :class:`Ensemble` (the class's ``ensemble``): the state, rules
    and checks of :class:`granwave.gpu.dem.GpuEngine`, its device arrays slices of the
    ensemble's; :meth:`run` asks the ensemble to advance it with the others."""

    ensemble = None  # set on the subclass that Ensemble.member_class makes

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.k = -1  # the packing's row in the ensemble's layout
        self.target = self.stop = 0
        self.room_needed = 0

    def run(self, n_steps: int) -> int:
        return self.ensemble.request(self, int(n_steps))

    def step(self) -> int:
        raise RuntimeError("a batch member steps with its ensemble (Ensemble.step)")

    def set_dt(self, dt: float) -> None:
        """The time step on the host; the ensemble writes the changed parameters of all its
        members to the device at once after their checks (:meth:`Ensemble.advance`)."""
        self.fpar.dt = dt
        self.ensemble.fpar_changed.add(self)

    def upload(self) -> None:
        """The host state into the member's slices (what :meth:`GpuEngine.upload` copies, the
        same values); the rebuilds' work arrays are the ensemble's (:meth:`Ensemble.cells`)."""
        g, gp = self.g, self.gp
        for name in (*STATE, "radius", "mass", "inertia", "lateral", "wall_ft", "wall_ov"):
            _put(g[name], getattr(self, name))
        _put(g["inv_rad"], 1.0 / self.radius)
        _put(g["piston"], K.as_array(self.piston))
        _put(g["fpar"], K.as_array(self.fpar))
        _put(g["red"], self._host_red())
        ctl = self._host_ctl(N_CTL_BATCH)
        ctl[C_NPAIRS] = int(self.ipar.npairs)
        ctl[C_STOP] = NEVER
        _put(g["ctl"], ctl)
        e, k = self.ensemble, self.k
        m = self.mflow.shape[0]
        row = np.zeros(N_MFLOW)
        row[:m] = self.mflow
        _put(e.d["mflow"][k], row)
        _put(e.d["mlen"][k:k + 1], np.array([m], np.int64))
        slabs = np.zeros(g["slabs"].shape)
        slabs[:self.slabs.shape[0], :self.slabs.shape[1]] = self.slabs
        _put(g["slabs"], slabs)
        n = self.position.shape[0]
        _put(e.d["lo"][k], np.full(e.d["lo"].shape[1], n, np.int64))
        _put(e.d["hi"][k], np.full(e.d["hi"].shape[1], -1, np.int64))
        for name, key in (("pair_i", "i"), ("pair_j", "j"), ("pair_ft", "ft"), ("pair_ov", "ov")):
            _put(gp[key], getattr(self, name))
        ptr, code2, row_ = self._host_incidence()
        _put(gp["ptr"], ptr)
        _put(gp["code"], code2)
        _put(gp["row"], row_)
        self._queued = 0  # (the rebuild's work arrays are the ensemble's: Ensemble.layout, Ensemble.cells)


def _put(view, host) -> None:
    """Copy ``host`` into the device slice ``view`` (nothing for an empty one)."""
    if view.size:
        view.copy_to_device(np.ascontiguousarray(host))


class Ensemble:
    """The packings of one batch on one GPU: their concatenated device arrays, and the driver
    that advances them together (module docstring)."""

    def __init__(self):
        self.members: list[BatchMember] = []
        self.cv = threading.Condition()
        self.pending: dict = {}
        self.results: dict = {}
        self.key = None  # (members, capacities) the device arrays were laid out for
        self.d: dict = {}
        self.rounds = 0  # rounds of requests advanced together (for the record)
        self.steps_queued = 0  # batched steps queued (each advances every running packing by one)
        self.small_rebuild_launches = 0  # launches of rb_small_batch (one for all small packings)
        self.rebuild_launches = 0  # launches of both rebuilds, in all
        #: steps by the launches their rebuilds took ({launches: steps}): a batch's large packings
        #: take batch_rebuild.LAUNCHES together (the simulator: 1 where none of them is due)
        self.launches_per_rebuild = collections.Counter()
        self.seconds = 0.0  # wall time in the driver's rounds (uploads, steps, checks, downloads)
        self.fpar_changed: set = set()  # members whose parameters the device must be given (set_dt)
        self.measures = 0  # launches of measure_batch (one for the checks of all packings at a stop)

    def member_class(self) -> type:
        """The engine class for the protocol (``engine=``): its engines join this ensemble."""
        return type("BatchMember", (BatchMember,), {"ensemble": self})

    # ------------------------------------------------------------ the protocols' threads
    def run(self, jobs) -> list:
        """Run every callable of ``jobs`` (each prepares one packing with an engine of
        :meth:`member_class`) in a thread of its own, taking turns, and advance their engines
        together; returns, in order, (True, result) or (False, exception) for each."""
        outcome = [None] * len(jobs)
        alive = [len(jobs)]

        def body(idx):
            with self.cv:
                try:
                    outcome[idx] = (True, jobs[idx]())
                except BaseException as exc:  # noqa: BLE001 - handed back to the caller
                    outcome[idx] = (False, exc)
                finally:
                    alive[0] -= 1
                    self.cv.notify_all()

        threads = [threading.Thread(target=body, args=(idx,), daemon=True) for idx in range(len(jobs))]
        with self.cv:
            for t in threads:
                t.start()
            while True:
                # every unfinished protocol waits on a run (they take turns: one holds the lock)
                self.cv.wait_for(lambda: len(self.pending) == alive[0] and not self.results)
                if alive[0] == 0:
                    break
                requests, self.pending = self.pending, {}
                t0 = time.perf_counter()
                try:
                    self.results = self.advance(requests)
                except BaseException as exc:  # noqa: BLE001 - each waiting protocol raises it
                    self.results = {m: exc for m in requests}
                self.seconds += time.perf_counter() - t0
                self.cv.notify_all()
        for t in threads:
            t.join()
        return outcome

    def request(self, member: BatchMember, n_steps: int) -> int:
        """A protocol's ``engine.run(n_steps)``: wait for the driver; its status (0, 1, 3)."""
        with self.cv:
            self.pending[member] = n_steps
            self.cv.notify_all()
            self.cv.wait_for(lambda: member in self.results)
            result = self.results.pop(member)
            self.cv.notify_all()
        if isinstance(result, BaseException):
            raise result
        return result

    # ------------------------------------------------------------ the driver
    def advance(self, requests: dict) -> dict:
        """Advance every member of ``requests`` (member: steps) as :meth:`GpuEngine.run` would,
        together; returns member: status, each member's state downloaded."""
        self.rounds += 1
        live = list(requests)
        self.layout(live)
        results = {}
        done = []
        for m in live:
            m.upload()
        self.cells(live)
        self.fpar_changed.clear()  # (uploaded)
        for m in list(live):
            m.target = m.steps + requests[m]
            m.room_needed = 0
            if m.steps >= m.target:  # nothing to do (GpuEngine.run: upload, download)
                m.download()
                results[m] = 0
                live.remove(m)
        while live:
            running = [m for m in live if not m.room_needed]
            if not running:  # as GpuEngine._make_room, for every member that asked, at once
                for m in live:
                    m.download()
                    m._grow_pairs(m.room_needed)
                    m.room_made += 1
                    m.room_needed = 0
                self.layout(live)
                for m in live:
                    m.upload()
                self.cells(live)
                self.fpar_changed.clear()
                continue
            self.chunk(running)
            ctl = self.d["ctl"].copy_to_host()
            red = self.d["red"].copy_to_host()
            measured = None
            for m in running:
                status, needed = m._read_counters(ctl[m.k], red[m.k])
                if status == 2:
                    m.room_needed = needed
                    continue
                result = None
                if status == 3:
                    result = 3
                elif int(m.ipar.check) > 0 and m.steps % int(m.ipar.check) == 0:
                    if measured is None:  # every packing's measures and piston in one launch, two reads
                        measured = self.measure()
                    status = m._check_from(measured[0][m.k], measured[1][m.k:m.k + 1])
                    if status:
                        result = status
                if result is None and m.steps >= m.target:
                    result = 0
                if result is not None:
                    done.append((m, result))
            self.write_fpars()
            for m, result in done:
                m.download()
                results[m] = result
                live.remove(m)
            done.clear()
        return results

    def measure(self) -> tuple:
        """(measures, pistons) of every packing, read from the device: the convergence check's
        (:func:`measure_batch`, the single engine's measure per packing)."""
        d = self.d
        self.measures += 1
        measure_batch[len(self.key[0]), G.RBLOCK](d["velocity"], d["acceleration"], d["angular_velocity"],
                                                  d["angular_acceleration"], d["mass"], d["inertia"], d["radius"],
                                                  d["stat"], d["goff"])
        return d["stat"].copy_to_host(), d["pistons"].copy_to_host()

    def write_fpars(self) -> None:
        """The parameters of the members whose checks changed them (their time step) to the
        device, in one copy (GpuEngine.set_dt copies each engine's own)."""
        if not self.fpar_changed:
            return
        fp = self.d["fpars"].copy_to_host()
        for m in self.fpar_changed:
            fp[m.k] = K.as_array(m.fpar)[0]
        self.d["fpars"].copy_to_device(fp)
        self.fpar_changed.clear()

    def chunk(self, running: list) -> int:
        """Queue the steps up to each running member's next stop (its next check, the end of its
        request, or SYNC_EVERY steps); the others paused."""
        ctl = self.d["ctl"].copy_to_host()
        for m in self.key[0]:
            if ctl[m.k, C_STATUS] == 0 or ctl[m.k, C_STATUS] == PAUSED:
                ctl[m.k, C_STATUS] = PAUSED
        for m in running:
            now, check = m.steps, int(m.ipar.check)
            m.stop = min(m.target, now + m.SYNC_EVERY if check <= 0 else (now // check + 1) * check)
            ctl[m.k, C_STATUS] = 0
            ctl[m.k, C_STOP] = m.stop
        self.d["ctl"].copy_to_device(ctl)
        n = max(m.stop - m.steps for m in running)
        start = {m: m.steps for m in running}
        for s in range(n):
            self.step([m for m in running if start[m] + s < m.stop])

    def step(self, active: list) -> None:
        """Queue one step of every packing (those paused return at once): the rebuilds of the
        ``active`` ones whose turn it is (on every k-th step, as GpuEngine.step; the small ones
        by one launch of :func:`rb_small_batch`, the large ones by one segmented rebuild), then
        the batched kernels."""
        due = frozenset(m.k for m in active if m._queued % max(1, int(m.rebuild_every)) == 0)
        for m in active:
            m._queued += 1
        d = self.d
        launches = 0
        if due:
            small, large = self._masks(due)
            if small is not None:
                rb_small_batch[len(self.key[0]), G.RBLOCK](
                    d["red"], d["fpars"], d["pistons"], d["lateral"], d["position"], d["radius"], d["pos0"],
                    d["ctl"], d["cell"], d["ccount"], d["cstart"], d["members"], d["gcnt"], d["gptr"], d["nbr"],
                    d["row"], d["i"], d["j"], d["ft"], d["ov"], d["ni"], d["nj"], d["nft"], d["nov"], d["ncode"],
                    d["ptr"], d["code"], d["goff"], d["poff"], d["coff"], small)
                self.small_rebuild_launches += 1
                launches += 1
            if large is not None:
                launches += BR.launch(d, large, len(self.key[0]))
        self.rebuild_launches += launches
        self.launches_per_rebuild[launches] += 1
        n = d["position"].shape[0]
        nb = _blocks(n)
        kick_drift_batch[nb, G.BLOCK](d["position"], d["velocity"], d["acceleration"], d["angular_velocity"],
                                      d["angular_acceleration"], d["lateral"], d["pos0"], d["pistons"],
                                      d["fpars"], d["v2"], d["disp2"], d["ctl"], d["gk"])
        pair_forces_batch[_blocks(d["i"].shape[0]), G.BLOCK](
            d["position"], d["velocity"], d["angular_velocity"], d["radius"], d["inv_rad"], d["mass"],
            d["lateral"], d["i"], d["j"], d["ctl"], d["ft"], d["ov"], d["fpars"], d["pf"], d["tqi"], d["tqj"],
            d["delta"], d["goff"], d["poff"], d["pk"])
        if self.mean_flow:
            slab_bin_batch[nb, G.BLOCK](d["position"], d["mflow"], d["mlen"], d["fpars"], d["slab_of"], d["lo"],
                                        d["hi"], d["nslab"], d["ctl"], d["goff"], d["gk"])
            slab_sums_batch[_blocks(d["lo"].size), G.BLOCK](d["velocity"], d["mass"], d["fpars"], d["mflow"],
                                                            d["mlen"], d["slab_of"], d["lo"], d["hi"], d["slabs"],
                                                            d["nslab"], d["ctl"], d["goff"])
        grain_forces_batch[nb, G.BLOCK](d["position"], d["velocity"], d["acceleration"], d["angular_velocity"],
                                        d["angular_acceleration"], d["radius"], d["mass"], d["inertia"], d["ptr"],
                                        d["code"], d["pf"], d["tqi"], d["tqj"], d["wall_ft"], d["wall_ov"],
                                        d["pistons"], d["fpars"], d["fp"], d["top"], d["dmax"], d["count"],
                                        d["ctl"], d["mflow"], d["mlen"], d["slabs"], d["nslab"], d["goff"],
                                        d["poff"], d["gk"])
        npack = len(self.key[0])
        step_partials_batch[(G.NPART, npack), G.RBLOCK](d["fp"], d["top"], d["dmax"], d["count"], d["v2"],
                                                        d["disp2"], d["delta"], d["ctl"], d["part"], d["goff"],
                                                        d["poff"])
        finish_batch[npack, G.RBLOCK](d["part"], d["pistons"], d["fpars"], d["mflow"], d["mlen"], d["red"],
                                      d["ctl"])
        self.steps_queued += 1

    def _masks(self, due: frozenset) -> tuple:
        """Device masks (one int64 per packing) of the small and of the large packings of ``due``
        (None where there are none), kept per set of packings for the layout."""
        if due not in self._mask_cache:
            npack = len(self.key[0])
            masks = []
            for want in (True, False):
                ks = [k for k in due if (k in self.small) == want]
                host = np.zeros(npack, np.int64)
                host[ks] = 1
                masks.append(cuda.to_device(host) if ks else None)
            self._mask_cache[due] = tuple(masks)
        return self._mask_cache[due]

    def layout(self, members: list) -> None:
        """Device arrays for ``members`` (kept when the members and their pair capacities are
        those of the current layout); each member's ``g`` and ``gp`` are its slices of them.
        The contents are set by the members' uploads."""
        caps = tuple(max(len(m.pair_i), 1) for m in members)
        key = (tuple(members), caps)
        if self.key is not None and self.key[0] == key[0] and self.key[1] == key[1]:
            return
        first = members[0]
        d_, r = first.dim, first.angular_velocity.shape[1]
        hist = first.pair_ft.shape[1]
        for m in members:
            if (m.dim, m.angular_velocity.shape[1], m.pair_ft.shape[1]) != (d_, r, hist):
                raise ValueError("the packings of a batch must have the same dimension, rotations and "
                                 "contact history")
        sizes = [m.position.shape[0] for m in members]
        goff = np.concatenate([[0], np.cumsum(sizes)]).astype(np.int64)
        poff = np.concatenate([[0], np.cumsum(caps)]).astype(np.int64)
        n, p, npack = int(goff[-1]), int(poff[-1]), len(members)
        rows = max(m.slabs.shape[0] for m in members)
        nslab = np.array([m.slabs.shape[1] for m in members], np.int64)
        ks = int(nslab.max())
        z = cuda.device_array
        to = cuda.to_device
        d = dict(
            position=z((n, d_)), velocity=z((n, d_)), acceleration=z((n, d_)), angular_velocity=z((n, r)),
            angular_acceleration=z((n, r)), pos0=z((n, d_)), radius=z(n), mass=z(n), inertia=z(n), inv_rad=z(n),
            v2=z(n), disp2=z(n), fp=z(n), top=z(n), dmax=z(n), count=z(n), slab_of=z(n, np.int64),
            wall_ft=z((2 * n, hist)), wall_ov=z(2 * n), lateral=z((npack, d_ - 1)),
            pistons=to(np.zeros(npack, K.PISTON)), fpars=to(np.zeros(npack, K.PARAMS)), red=z((npack, G.N_RED)),
            part=z((npack, G.NPART, G.N_RED)), stat=z((npack, G.N_STAT)),
            ctl=to(np.zeros((npack, N_CTL_BATCH), np.int64)), mflow=z((npack, N_MFLOW)),
            mlen=to(np.zeros(npack, np.int64)), slabs=z((npack, rows, ks)), nslab=to(nslab),
            lo=z((npack, ks), np.int64), hi=z((npack, ks), np.int64),
            i=z(p, np.int64), j=z(p, np.int64), ft=z((p, hist)), ov=z(p), pf=z((p, 3)), tqi=z((p, max(r, 1))),
            tqj=z((p, max(r, 1))), delta=z(p), code=z(2 * p, np.int64), ptr=z(n + npack, np.int64),
            row=z(n + npack, np.int64), goff=to(goff), poff=to(poff),
            # the batched one-block rebuild's work arrays (rb_small_batch; cells: Ensemble.cells)
            # (gcnt zeroed: the segmented rebuild's scan sums every packing's rows, due or not)
            cell=z(n, np.int64), members=z(n, np.int64), gcnt=to(np.zeros((n, 2), np.int64)),
            gptr=z((n + npack, 2), np.int64),
            nbr=z(2 * p, np.int64), ni=z(p, np.int64), nj=z(p, np.int64), nft=z((p, hist)), nov=z(p),
            ncode=z(2 * p, np.int64),
            gk=to(np.repeat(np.arange(npack, dtype=np.int64), sizes)),
            pk=to(np.repeat(np.arange(npack, dtype=np.int64), caps)))
        grain = ("position", "velocity", "acceleration", "angular_velocity", "angular_acceleration", "pos0",
                 "radius", "mass", "inertia", "inv_rad", "v2", "disp2", "fp", "top", "dmax", "count")
        for k, m in enumerate(members):
            o, e, a, b = int(goff[k]), int(goff[k + 1]), int(poff[k]), int(poff[k + 1])
            m.k = k
            m.g = {name: d[name][o:e] for name in grain}
            m.g.update(wall_ft=d["wall_ft"][2 * o:2 * e], wall_ov=d["wall_ov"][2 * o:2 * e],
                       lateral=d["lateral"][k], piston=d["pistons"][k:k + 1], fpar=d["fpars"][k:k + 1],
                       red=d["red"][k], part=d["part"][k], stat=d["stat"][k], ctl=d["ctl"][k],
                       slabs=d["slabs"][k])
            m.gp = dict(i=d["i"][a:b], j=d["j"][a:b], ft=d["ft"][a:b], ov=d["ov"][a:b], pf=d["pf"][a:b],
                        tqi=d["tqi"][a:b], tqj=d["tqj"][a:b], delta=d["delta"][a:b], code=d["code"][2 * a:2 * b],
                        ptr=d["ptr"][o + k:e + k + 1], row=d["row"][o + k:e + k + 1])
        self.d = d
        self.key = key
        self.mean_flow = any(m.mflow.shape[0] > 0 for m in members)
        self.small = {k for k, m in enumerate(members) if m.position.shape[0] <= m.small_rebuild}
        self._mask_cache = {}

    def cells(self, members: list) -> None:
        """The rebuilds' cell arrays after the members' uploads: each packing's cells as
        GpuEngine's upload sizes them (granwave.gpu.neighbours.cell_capacity, from the piston's
        height now), counts zero; the segmented rebuild's sums (granwave.gpu.batch_rebuild.work)."""
        ncell = np.ones(len(self.key[0]), np.int64)  # a packing not in this round: paused, one cell
        for m in members:
            ncell[m.k] = NB.cell_capacity(m.lateral, m.piston.h, m.fpar.r_max, m.fpar.skin_max)
        coff = np.concatenate([[0], np.cumsum(ncell)]).astype(np.int64)
        self.d.update(ccount=cuda.to_device(np.zeros((int(coff[-1]), 2), np.int64)),
                      cstart=cuda.device_array((int(coff[-1]) + len(ncell), 2), np.int64), coff=cuda.to_device(coff))
        self.d.update(BR.work(self.d["position"].shape[0], int(coff[-1])))


def prepare_packings(params, seeds, progress=None, ensemble: Ensemble | None = None, checkpoints=None) -> list:
    """One packing per seed of ``seeds`` (``params`` with each seed), prepared together on the GPU
    (:class:`Ensemble`); each the packing :func:`granwave.dem.protocol.prepare_packing` makes for
    that seed with :class:`granwave.gpu.dem.GpuEngine`. ``progress``: one line of text, prefixed
    by the seed. The first failure (in the order of ``seeds``) is raised once all have ended.
    ``ensemble``: the :class:`Ensemble` to use (a new one by default; its counters are the run's).
    ``checkpoints``: None, or one :class:`granwave.dem.checkpoint.Checkpoint` (or None) per seed:
    each seed resumes from its own and writes it in its own protocol's thread (a member's state is
    whole in its host arrays between two of its runs, as the single engine's)."""
    import dataclasses

    from ..dem.protocol import prepare_packing

    ensemble = Ensemble() if ensemble is None else ensemble
    engine = ensemble.member_class()

    checkpoints = [None] * len(seeds) if checkpoints is None else list(checkpoints)

    def job(seed, saved):
        tell = None if progress is None else (lambda line: progress(f"seed {seed}: {line}"))
        return lambda: prepare_packing(dataclasses.replace(params, seed=seed), progress=tell, engine=engine,
                                       checkpoint=saved)

    outcome = ensemble.run([job(s, c) for s, c in zip(seeds, checkpoints)])
    for seed, (ok, value) in zip(seeds, outcome):
        if not ok:
            if hasattr(value, "args") and value.args and isinstance(value.args[0], str):
                value.args = (f"seed {seed}: {value.args[0]}", *value.args[1:])
            raise value
    return [value for _, value in outcome]
