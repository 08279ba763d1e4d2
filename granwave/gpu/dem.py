"""The DEM engine on one GPU: :class:`GpuEngine`, a drop-in for :class:`granwave.dem.integrator.Engine`.

Same state, same parameters, same velocity-Verlet step and convergence checks as the CPU
engine (:func:`granwave.dem.kernels.run_chunk`); only :meth:`GpuEngine.run` differs: it moves
the state to the device, runs the steps there, and brings it back, so everything else
(:class:`granwave.dem.protocol.Compression`, measurements, the packing written) is the CPU code.

One step on the device (four kernels, six with the mean-flow rule; no floating-point atomics):

1. ``kick_drift`` (a thread per grain): half kick and drift, as the CPU loop; thread 0 moves the
   piston;
2. ``pair_forces`` (a thread per pair of the Verlet list): the pair's geometry and contact law
   (:func:`granwave.dem.kernels._pair_law`, the CPU engines' own, compiled for the device from
   its source, :mod:`granwave.gpu.compile`), history updated in place; the pair's force and the two
   torques (with rolling resistance on, each with the pair's rolling couple added, the CPU's
   ``pair_couple`` and ``add_torque_with_couple``) are stored per pair;
3. ``grain_forces`` (a thread per grain): sums its pairs' forces over a per-grain incidence
   list in increasing pair order (the order in which the CPU loop adds them), then the two
   wall contacts, the background damping, the accelerations and the second half kick;
   with the compaction rule 'mean-flow' two kernels before it compute the slabs' mean
   velocities in the CPU's order (:mod:`granwave.gpu.mean_flow`), and ``grain_forces`` adds
   each grain's slab term after its background damping;
4. ``step_partials`` (NPART blocks) and ``finish`` (one block): the piston force, largest
   overlap, contact counts, largest speed and displacement by a two-stage reduction of fixed
   shape (grid stride, then trees), then the piston's half kick (:mod:`granwave.gpu.reductions`).

Hence repeated runs give identical bytes, and each grain's force is summed in the CPU's order;
only the piston force, kinetic energy and the maxima are reduced in a different (fixed) order.

Neighbour list: rebuilt on the device (:mod:`granwave.gpu.neighbours`), the CPU's pairs in
the CPU's order with their histories carried, its trigger (the CPU engine's: reach against
half the skin, from the last step's reduction) evaluated there too, before every step. The
host only queues kernels; it reads the device (control words and the step's reduction) at
convergence checks, every :data:`GpuEngine.SYNC_EVERY` steps without checks, and at the end
of a run. A rebuild that needs more pairs than the arrays hold sets a flag and stops the run
on the device (every later kernel returns at once, the state stays that of the step before);
the host sees it at its next read, makes room, and goes on from there: the same bits. The
pulse (:mod:`granwave.gpu.pulse`) keeps the first version's host rebuild
(``device_rebuild = False``), because its contact flags are carried on the host.
"""

from __future__ import annotations

import math

import numpy as np

from ..dem import kernels as K
from ..dem.integrator import Engine
from . import load_cuda, simulated
from .compile import device_functions
from . import mean_flow as MF
from . import neighbours as NB
from .roofline import bytes_per_step  # noqa: F401  (benchmarks/gpu.py reads it here)
from .neighbours import C_NPAIRS, C_REBUILDS, C_STATUS, C_STEPS, C_NEED, N_CTL
from .reductions import (N_RED, N_STAT, NPART, R_DISP2, R_DMAX, R_FPISTON, R_NCONTACT, R_NTOP,  # noqa: F401
                         R_VMAX, R_VMAX2, RBLOCK, S_ALMAX2, S_AMAX2, S_KIN, S_VMAX2, S_WMAX2, _finish, _partials,
                         finish, measure_kernel, step_partials)

cuda = load_cuda()  # numba.cuda, with numpy's names it needs (granwave.gpu.load_cuda)

DF = device_functions()
add_torque3 = DF._add_torque3
wall_contact = DF.wall_contact
pair_law = DF._pair_law
pair_constants3 = DF.pair_constants3
effective_young = DF.effective_young
effective_shear = DF.effective_shear
law_of = DF.law_of
law_force = DF.law_force
couple_of = DF.couple_of
pair_couple = DF.pair_couple
add_torque_with_couple = DF.add_torque_with_couple
grain_walls = DF.grain_walls
grain_damping = DF.grain_damping

#: Threads per block of the per-grain and per-pair kernels (smaller in the CUDA simulator, which
#: runs every thread as a Python thread); the reductions' shapes: granwave.gpu.reductions.
BLOCK = 8 if simulated() else 128
#: Most blocks a per-item kernel gets in the simulator (:func:`_blocks`).
SIM_BLOCKS = 2


@cuda.jit
def kick_drift(pos, vel, acc, omega, alpha, lateral, pos0, piston1, dt, gv2, gdisp2, ctl):
    """Half kick and drift of every grain (the CPU's ``drift_grain``; thread 0 also moves the
    piston); per-grain |v|^2 and squared displacement since the last rebuild into ``gv2``,
    ``gdisp2``. Like every step kernel, nothing once ``ctl[C_STATUS]`` is set (the run stopped
    on the device: a rebuild without room, or a blown-up state)."""
    piston = piston1[0]  # the record (granwave.dem.layout), uploaded as a one-element array
    n = pos.shape[0]
    if ctl[C_STATUS] != 0:
        return
    if cuda.grid(1) == 0 and piston.mass < math.inf:
        piston.v += 0.5 * dt * piston.a
        piston.h += dt * piston.v
    for i in range(cuda.grid(1), n, cuda.gridsize(1)):
        v2, s = DF.drift_grain(pos, vel, acc, omega, alpha, pos0, lateral, i, 0.5 * dt, dt)
        gv2[i] = v2
        gdisp2[i] = s


@cuda.jit
def pair_forces(pos, vel, omega, rad, inv_rad, mass, lateral, pair_i, pair_j, ctl, pair_ft, pair_ov,
                fpar1, pf, tq_i, tq_j, pdelta):
    """Force on i of every listed pair (the CPU force loop's pair body; ``ctl[C_NPAIRS]`` pairs,
    a grid-stride loop), its torques on i and j (with the rolling couple), and its overlap (-1:
    not touching); its history (tangential, then rolling) updated in place."""
    fpar = fpar1[0]  # the record (granwave.dem.layout), uploaded as a one-element array
    if ctl[C_STATUS] != 0:
        return
    for p in range(cuda.grid(1), ctl[C_NPAIRS], cuda.gridsize(1)):
        _pair_force(p, pos, vel, omega, rad, inv_rad, mass, lateral, pair_i, pair_j, pair_ft, pair_ov, fpar, pf,
                    tq_i, tq_j, pdelta)


@cuda.jit(device=True)
def _pair_force(p, pos, vel, omega, rad, inv_rad, mass, lateral, pair_i, pair_j, pair_ft, pair_ov, fpar, pf,
                tq_i, tq_j, pdelta):
    d = pos.shape[1]
    r = omega.shape[1]
    dt = fpar.dt
    poisson = fpar.poisson
    rescale = fpar.rescale != 0.0
    for a in range(3):
        pf[p, a] = 0.0
    for a in range(r):
        tq_i[p, a] = 0.0
        tq_j[p, a] = 0.0
    pdelta[p] = -1.0
    i = pair_i[p]
    j = pair_j[p]
    r12, root_r12, meff = pair_constants3(inv_rad[i], inv_rad[j], mass[i], mass[j])
    law = law_of(fpar)
    e_pair = effective_young(False)
    touching, delta, ai, aj, nx, ny, nz, fx, fy, fz, hx, hy, hz = pair_law(
        pos, vel, omega, rad, lateral, pair_ft, pair_ov, p, i, j, dt, DF.dashpot_of(fpar), DF.friction_of(fpar),
        rescale, e_pair, effective_shear(poisson, False), r12, root_r12, meff, law)
    if not touching:
        if pair_ov[p] != 0.0:  # the contact opened: its history is destroyed
            pair_ov[p] = 0.0
            for a in range(pair_ft.shape[1]):  # the tangential history and a rolling one after it
                pair_ft[p, a] = 0.0
        return
    if DF.friction_acts(DF.friction_of(fpar)):  # the tangential law's history
        pair_ft[p, 0] = hx
        pair_ft[p, 1] = hy
        if d == 3:
            pair_ft[p, 2] = hz
    pair_ov[p] = delta
    pf[p, 0] = fx
    pf[p, 1] = fy
    pf[p, 2] = fz
    if r > 0:
        couple = couple_of(fpar)
        if couple.code != 0:  # the rolling couple c on i, -c on j, stored with the force's torque
            # the law's elastic normal force, as contact_force3 computed it inside _pair_law
            fel = law_force(law, delta, root_r12, e_pair)
            cx, cy, cz = pair_couple(omega, pair_ft, p, i, j, nx, ny, nz, r12, fel, dt, couple)
            add_torque_with_couple(tq_i, p, ai, nx, ny, nz, fx, fy, fz, cx, cy, cz)
            add_torque_with_couple(tq_j, p, aj, nx, ny, nz, fx, fy, fz, -cx, -cy, -cz)
        else:
            add_torque3(tq_i, p, ai, nx, ny, nz, fx, fy, fz)
            add_torque3(tq_j, p, aj, nx, ny, nz, fx, fy, fz)
    pdelta[p] = delta


@cuda.jit
def grain_forces(pos, vel, acc, omega, alpha, rad, mass, inertia, inc_ptr, inc_pair, pf, tq_i, tq_j,
                 wall_ft, wall_ov, piston1, fpar1, gfp, gtop, gdmax, gcount, ctl, mflow, slabs):
    """:func:`_grain_force` of every grain (a grid-stride loop); ``mflow``, ``slabs``: the
    compaction rule 'mean-flow' (empty ``mflow``: off; :mod:`granwave.gpu.mean_flow`)."""
    piston = piston1[0]  # the records (granwave.dem.layout), uploaded as one-element arrays
    fpar = fpar1[0]
    if ctl[C_STATUS] != 0:
        return
    for i in range(cuda.grid(1), pos.shape[0], cuda.gridsize(1)):
        _grain_force(i, pos, vel, acc, omega, alpha, rad, mass, inertia, inc_ptr, inc_pair, pf, tq_i, tq_j,
                     wall_ft, wall_ov, piston, fpar, gfp, gtop, gdmax, gcount, mflow, slabs)


@cuda.jit(device=True)
def _grain_force(i, pos, vel, acc, omega, alpha, rad, mass, inertia, inc_ptr, inc_pair, pf, tq_i, tq_j,
                 wall_ft, wall_ov, piston, fpar, gfp, gtop, gdmax, gcount, mflow, slabs):
    """Total force and torque of each grain (pairs in increasing pair order, then the bottom and
    top wall, then background damping and the mean-flow rule's slab term), accelerations and the
    second half kick of velocity Verlet; per-grain piston force, top contacts, largest wall
    overlap and wall contacts.

    ``inc_pair`` holds p + 1 where the grain is the pair's i, -(p + 1) where it is its j."""
    d = pos.shape[1]
    r = omega.shape[1]
    dt = fpar.dt
    poisson = fpar.poisson
    gamma = fpar.gamma
    rescale = fpar.rescale != 0.0
    law = law_of(fpar)
    h = piston.h
    vp = piston.v
    for a in range(d):
        acc[i, a] = 0.0
    for a in range(r):
        alpha[i, a] = 0.0
    for k in range(inc_ptr[i], inc_ptr[i + 1]):
        q = inc_pair[k]
        if q > 0:
            p = q - 1
            for a in range(d):
                acc[i, a] += pf[p, a]
            for a in range(r):
                alpha[i, a] += tq_i[p, a]
        else:
            p = -q - 1
            for a in range(d):
                acc[i, a] -= pf[p, a]
            for a in range(r):
                alpha[i, a] += tq_j[p, a]
    # the walls, damping and slab term: the CPU engines' own per-grain routines (grain_step, mean_flow)
    top, ntop, dmax, count = grain_walls(i, pos, vel, omega, rad, mass, wall_ft, wall_ov, h, vp,
                                         effective_young(True), effective_shear(poisson, True), dt,
                                         DF.dashpot_of(fpar), DF.friction_of(fpar),
                                         rescale, law, couple_of(fpar), acc, alpha, 0.0, 0)
    fpiston = 0.0
    if ntop:
        fpiston -= top
    if gamma > 0.0:
        grain_damping(i, vel, omega, mass, inertia, gamma, acc, alpha)
        if mflow.shape[0] > 0:  # after the grain's damping, as the CPU force loop
            MF.add_slab_damping(i, i + 1, pos, mass, gamma, mflow, slabs, acc)
    inv = 1.0 / mass[i]
    for a in range(d):
        acc[i, a] *= inv
        vel[i, a] += 0.5 * dt * acc[i, a]
    inv = 1.0 / inertia[i]
    for a in range(r):
        alpha[i, a] *= inv
        omega[i, a] += 0.5 * dt * alpha[i, a]
    gfp[i] = fpiston
    gtop[i] = ntop
    gdmax[i] = dmax
    gcount[i] = count


#: Every kernel of this module (compiled to PTX by tests/test_gpu_ptx.py).
KERNELS = (kick_drift, pair_forces, grain_forces, step_partials, finish, measure_kernel)


def incidence(pair_i: np.ndarray, pair_j: np.ndarray, npairs: int, n: int) -> tuple[np.ndarray, np.ndarray]:
    """(inc_ptr (n+1,), inc_pair): for each grain its pairs in increasing pair index, stored as
    p + 1 where it is the pair's i and -(p + 1) where it is its j (host, numpy)."""
    p = np.arange(npairs, dtype=np.int64)
    grain = np.concatenate([pair_i[:npairs], pair_j[:npairs]])
    code = np.concatenate([p + 1, -(p + 1)])
    order = np.lexsort((np.concatenate([p, p]), grain))
    ptr = np.zeros(n + 1, np.int64)
    np.cumsum(np.bincount(grain, minlength=n), out=ptr[1:])
    return ptr, np.ascontiguousarray(code[order])


def _blocks(n: int) -> int:
    """Blocks of BLOCK threads for n items: one per item on a GPU; in the simulator at most
    SIM_BLOCKS (the per-item kernels are grid-stride loops: each simulated thread costs)."""
    b = max(1, (n + BLOCK - 1) // BLOCK)
    return min(b, SIM_BLOCKS) if simulated() else b


class GpuEngine(Engine):
    """:class:`~granwave.dem.integrator.Engine` whose :meth:`run` steps on the GPU.

    Between calls of :meth:`run` the state lives in the host arrays, exactly as for the CPU
    engine; a call copies it to the device (:meth:`upload`), steps (:meth:`step`), and copies
    it back (:meth:`download`).

    With ``device_rebuild`` (the default) the pair list is rebuilt on the device
    (:mod:`granwave.gpu.neighbours`): :meth:`step` only queues kernels, and the host reads the
    device (:meth:`sync`) only at convergence checks, every :data:`SYNC_EVERY` steps without
    checks, and at the end of a run. Without it (the pulse, whose contact flags are carried on
    the host) the first version's host rebuild runs: the host reads the step's reduction after
    every step, and ``on_rebuild`` (None or a callable taking the old pair keys (i, j) and their
    count) is called after every host rebuild, before the new list is uploaded.
    """

    device = "gpu"
    on_rebuild = None
    device_rebuild = True
    #: Steps queued between two reads of the device when the run has no checks.
    SYNC_EVERY = 200
    #: Steps between two launches of the device rebuild's kernels (its test then looks that many
    #: steps ahead: granwave.gpu.neighbours.rb_trigger). 1: the CPU engine's test before every
    #: step, the CPU's rebuild steps; k > 1 launches a k-th of the kernels (fewer launches per
    #: step) and rebuilds earlier, and changes no bit of the state (docs/gpu.md).
    rebuild_every = 1
    #: Grains up to which the device rebuild runs as one single-block kernel (granwave.gpu.neighbours).
    small_rebuild = NB.SMALL
    #: Times a device rebuild stopped for more room (:meth:`_make_room`).
    room_made = 0

    # ------------------------------------------------------------ device session
    def upload(self) -> None:
        """Copy the state to the device and allocate the per-step work arrays."""
        n = self.position.shape[0]
        to = cuda.to_device
        self.g = {name: to(getattr(self, name)) for name in
                  ("position", "velocity", "acceleration", "angular_velocity", "angular_acceleration",
                   "radius", "mass", "inertia", "lateral", "pos0", "wall_ft", "wall_ov")}
        # the records (granwave.dem.layout) as one-element arrays: a kernel's ``fpar1[0]`` is the record
        self.g.update(piston=to(K.as_array(self.piston)), fpar=to(K.as_array(self.fpar)))
        self.g["inv_rad"] = to(1.0 / self.radius)
        for name in ("v2", "disp2", "fp", "top", "dmax", "count"):
            self.g[name] = cuda.device_array(n)
        self.g["red"] = to(self._host_red())
        self.g["part"] = cuda.device_array((NPART, N_RED))
        self.g["stat"] = cuda.device_array(N_STAT)
        self.g["ctl"] = to(self._host_ctl())
        self._upload_mean_flow()
        self._queued = 0  # steps queued since the upload (the rebuild's kernels go with every k-th)
        self._upload_pairs()

    def _host_red(self) -> np.ndarray:
        """The reduction a run starts from (the host's counters; ``_disp2`` from the positions)."""
        x = self.position - self.pos0
        x[:, :-1] -= self.lateral * np.round(x[:, :-1] / self.lateral)  # nearest image (folded drifts)
        self._disp2 = float(np.max(np.sum(x * x, axis=1), initial=0.0))
        red = np.zeros(N_RED)
        red[R_FPISTON] = self.piston.f_con
        red[R_NTOP] = self.out.ntop
        red[R_NCONTACT] = self.out.ncontact
        red[R_DMAX] = self.out.d_max
        red[R_VMAX2] = self.fpar.v_max ** 2
        red[R_DISP2] = self._disp2
        red[R_VMAX] = self.fpar.v_max
        return red

    def _host_ctl(self, width: int = N_CTL) -> np.ndarray:
        """The control words a run starts from (``width`` words, the first N_CTL used here)."""
        ctl = np.zeros(width, np.int64)
        ctl[C_STEPS] = self.ipar.steps
        ctl[C_REBUILDS] = self.ipar.rebuilds
        ctl[NB.C_AHEAD] = max(1, int(self.rebuild_every))
        return ctl

    def _upload_mean_flow(self) -> None:
        """The rule 'mean-flow''s rates (as the host has them now: the settling and end-game rules
        change them between runs) and slab arrays; empty ``mflow`` when the rule is off."""
        to = cuda.to_device
        g = self.g
        g["mflow"] = to(self.mflow)
        g["slabs"] = to(self.slabs)
        if self.mflow.shape[0] > 0:
            n, ns = self.position.shape[0], self.slabs.shape[1]
            g["slab_of"] = cuda.device_array(n, np.int64)
            g["slab_lo"] = to(np.full(ns, n, np.int64))
            g["slab_hi"] = to(np.full(ns, -1, np.int64))

    def _cpu_only(self) -> None:
        """Nothing to refuse: the device runs every rule of the CPU engine (the CPU engine's
        constructor calls this where a rule might be missing on another engine)."""

    def _upload_pairs(self) -> None:
        """The pair list, its history and incidence list, and the rebuild's work arrays, at the
        host arrays' capacity; the pair count into ``ctl``."""
        m = int(self.ipar.npairs)
        cap = max(len(self.pair_i), 1)
        r = max(self.angular_velocity.shape[1], 1)
        to = cuda.to_device
        ptr, code2, row = self._host_incidence()
        gp = dict(i=to(self.pair_i), j=to(self.pair_j), ft=to(self.pair_ft), ov=to(self.pair_ov), ptr=to(ptr),
                  code=to(code2), pf=cuda.device_array((cap, 3)), tqi=cuda.device_array((cap, r)),
                  tqj=cuda.device_array((cap, r)), delta=cuda.device_array(cap), row=to(row))
        if self.device_rebuild:
            gp.update(self._rebuild_work(cap))
        self.gp = gp
        self.g["ctl"][C_NPAIRS:C_NPAIRS + 1].copy_to_device(np.array([m], np.int64))

    def _host_incidence(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(inc_ptr, inc_pair at twice the capacity, row): the incidence list of :func:`incidence`
        and each grain's first pair (``row``, the rebuild's), from the host pair list."""
        n = self.position.shape[0]
        m = int(self.ipar.npairs)
        cap = max(len(self.pair_i), 1)
        ptr, code = incidence(self.pair_i, self.pair_j, m, n)
        code2 = np.zeros(2 * cap, np.int64)
        code2[:len(code)] = code
        row = np.zeros(n + 1, np.int64)
        np.cumsum(np.bincount(self.pair_i[:m], minlength=n), out=row[1:])
        return ptr, code2, row

    def _rebuild_work(self, cap: int) -> dict:
        """The device rebuild's work arrays for ``cap`` pairs (the cell list's capacity from the
        piston's height now, as at every upload)."""
        n = self.position.shape[0]
        ncell = NB.cell_capacity(self.lateral, self.piston.h, self.fpar.r_max, self.fpar.skin_max)
        z = cuda.device_array
        return dict(ni=z(cap, np.int64), nj=z(cap, np.int64), nft=z((cap, self.pair_ft.shape[1])), nov=z(cap),
                    ncode=z(2 * cap, np.int64), nbr=z(2 * cap, np.int64), cell=z(n, np.int64),
                    members=z(n, np.int64), ccount=cuda.to_device(np.zeros((ncell, 2), np.int64)),
                    cstart=z((ncell + 1, 2), np.int64), gcnt=z((n, 2), np.int64),
                    gptr=z((n + 1, 2), np.int64), part=z((NB.NPART, 2), np.int64))

    def _download_pairs(self) -> None:
        m = int(self.ipar.npairs)
        if self.device_rebuild:  # the list itself may have been made on the device
            if m > len(self.pair_i):
                self._grow_pairs(m)
            for name, key in (("pair_i", "i"), ("pair_j", "j"), ("pair_ft", "ft"), ("pair_ov", "ov")):
                getattr(self, name)[:m] = self.gp[key].copy_to_host()[:m]
        elif m:
            self.pair_ft[:m] = self.gp["ft"].copy_to_host()[:m]
            self.pair_ov[:m] = self.gp["ov"].copy_to_host()[:m]

    def _grow_pairs(self, needed: int) -> None:
        """Host pair arrays with room for ``needed`` pairs (as Engine.grow; contents kept)."""
        cap = max(int(needed * 1.5) + 64, len(self.pair_i))
        for name in ("pair_i", "pair_j", "pair_ft", "pair_ov"):
            old = getattr(self, name)
            new = np.zeros((cap,) + old.shape[1:], old.dtype)
            new[:len(old)] = old
            setattr(self, name, new)

    def sync(self) -> tuple[int, int]:
        """Read the device's control words and the last step's reduction into the host's
        counters (steps, rebuilds, pairs, largest speed, piston force, overlaps, contacts):
        (status, pairs needed); status 0 running, 2 a rebuild needs more room, 3 blown up."""
        return self._read_counters(self.g["ctl"].copy_to_host(), self.g["red"].copy_to_host())

    def _read_counters(self, ctl: np.ndarray, red: np.ndarray) -> tuple[int, int]:
        """:meth:`sync` from the control words and reduction read from the device."""
        ipar, out = self.ipar, self.out
        ipar.steps = ctl[C_STEPS]
        ipar.rebuilds = ctl[C_REBUILDS]
        ipar.npairs = ctl[C_NPAIRS]
        self.fpar.v_max = red[R_VMAX]
        self._disp2 = red[R_DISP2]
        self.piston.f_con = red[R_FPISTON]
        out.d_max = red[R_DMAX]
        out.ntop = red[R_NTOP]
        out.ncontact = red[R_NCONTACT]
        return int(ctl[C_STATUS]), int(ctl[C_NEED])

    def download(self) -> None:
        """Copy the state back to the host arrays."""
        if self.device_rebuild:
            self.sync()
        for name in ("position", "velocity", "acceleration", "angular_velocity", "angular_acceleration",
                     "pos0", "wall_ft", "wall_ov"):
            getattr(self, name)[...] = self.g[name].copy_to_host()
        rows, ns = self.slabs.shape
        self.slabs[...] = self.g["slabs"].copy_to_host()[:rows, :ns]  # a batch's rows are padded
        K.copy_record(self.piston, self.g["piston"].copy_to_host())
        self._download_pairs()

    def set_dt(self, dt: float) -> None:
        """Change the time step (host and device copies of the parameters)."""
        self.fpar.dt = dt
        self.g["fpar"].copy_to_device(K.as_array(self.fpar))

    def _host_rebuild(self) -> int:
        """The first version's rebuild test and host rebuild before a step (``device_rebuild``
        off): 0, or 3 when the state blew up (non-finite reach)."""
        fpar, ipar, g = self.fpar, self.ipar, self.g
        reach = math.sqrt(self._disp2) + 2.0 * fpar.v_max * fpar.dt
        if not math.isfinite(reach):
            return 3
        if reach > 0.5 * fpar.skin:
            self.position[...] = g["position"].copy_to_host()
            self._download_pairs()
            m_old = int(ipar.npairs)
            old = (self.pair_i[:m_old].copy(), self.pair_j[:m_old].copy())
            self._rebuild()  # grows the arrays if needed, pos0 = position
            ipar.rebuilds += 1
            if self.on_rebuild is not None:
                self.on_rebuild(old[0], old[1], m_old)
            g["position"].copy_to_device(self.position)
            g["pos0"].copy_to_device(self.pos0)
            self._upload_pairs()
        return 0

    def step(self) -> int:
        """Queue one velocity-Verlet step on the device (between :meth:`upload` and
        :meth:`download`), the device rebuild's kernels first. Returns 0; without
        ``device_rebuild``, 3 when the state blew up, and the host counters are updated after
        the step (the host reads the reduction)."""
        fpar, ipar, out, g = self.fpar, self.ipar, self.out, self.g
        if self.device_rebuild:
            if self._queued % max(1, int(self.rebuild_every)) == 0:
                NB.launch_rebuild(g, self.gp, self.small_rebuild)
            self._queued += 1
        elif self._host_rebuild() == 3:
            return 3
        gp = self.gp
        n = self.position.shape[0]
        cap = gp["i"].shape[0]
        ctl = g["ctl"]
        dt = fpar.dt
        nb = _blocks(n)
        kick_drift[nb, BLOCK](g["position"], g["velocity"], g["acceleration"], g["angular_velocity"],
                              g["angular_acceleration"], g["lateral"], g["pos0"], g["piston"], dt, g["v2"],
                              g["disp2"], ctl)
        pair_forces[_blocks(cap), BLOCK](g["position"], g["velocity"], g["angular_velocity"], g["radius"],
                                         g["inv_rad"], g["mass"], g["lateral"], gp["i"], gp["j"], ctl,
                                         gp["ft"], gp["ov"], g["fpar"], gp["pf"], gp["tqi"], gp["tqj"],
                                         gp["delta"])
        if self.mflow.shape[0] > 0 and fpar.gamma > 0.0:  # the slab means the force kernel adds
            MF.slab_bin[nb, BLOCK](g["position"], g["mflow"], g["slab_of"], g["slab_lo"], g["slab_hi"], ctl)
            MF.slab_sums[_blocks(self.slabs.shape[1]), BLOCK](g["velocity"], g["mass"], g["fpar"], g["mflow"],
                                                              g["slab_of"], g["slab_lo"], g["slab_hi"],
                                                              g["slabs"], ctl)
        grain_forces[nb, BLOCK](g["position"], g["velocity"], g["acceleration"], g["angular_velocity"],
                                g["angular_acceleration"], g["radius"], g["mass"], g["inertia"], gp["ptr"],
                                gp["code"], gp["pf"], gp["tqi"], gp["tqj"], g["wall_ft"], g["wall_ov"],
                                g["piston"], g["fpar"], g["fp"], g["top"], g["dmax"], g["count"], ctl,
                                g["mflow"], g["slabs"])
        step_partials[NPART, RBLOCK](g["fp"], g["top"], g["dmax"], g["count"], g["v2"], g["disp2"],
                                     gp["delta"], ctl, g["part"])
        finish[1, RBLOCK](g["part"], g["piston"], g["fpar"], g["mflow"], g["red"], ctl)
        if self.device_rebuild:
            return 0
        red = g["red"].copy_to_host()
        fpar.v_max = red[R_VMAX]
        self._disp2 = red[R_DISP2]
        self.piston.f_con = red[R_FPISTON]
        out.d_max = red[R_DMAX]
        out.ntop = red[R_NTOP]
        out.ncontact = red[R_NCONTACT]
        ipar.steps += 1
        return 0

    def _check(self) -> int:
        """The CPU engine's check (every ``check_every`` steps): 3 blown up, 1 converged
        candidate, else 0; adapts the time step."""
        g = self.g
        measure_kernel[1, RBLOCK](g["velocity"], g["acceleration"], g["angular_velocity"],
                                  g["angular_acceleration"], g["mass"], g["inertia"], g["radius"], g["stat"])
        return self._check_from(g["stat"].copy_to_host(), g["piston"].copy_to_host())

    def _check_from(self, stat: np.ndarray, piston_rec: np.ndarray) -> int:
        """:meth:`_check` from the measures (``stat``) and the piston's record read from the
        device (the batched engine reads every packing's at once)."""
        fpar, ipar, out, piston = self.fpar, self.ipar, self.out, self.piston
        K.copy_record(piston, piston_rec)
        out.a_max = math.sqrt(stat[S_AMAX2])
        out.alpha_max = math.sqrt(stat[S_ALMAX2])
        out.v_max = math.sqrt(stat[S_VMAX2])
        out.w_max = math.sqrt(stat[S_WMAX2])
        kin = stat[S_KIN]
        if piston.mass < np.inf:
            out.a_piston = abs(piston.a)
            kin += 0.5 * piston.mass * piston.v * piston.v
        else:
            out.a_piston = 0.0
        out.kin = kin
        if not (out.d_max < fpar.r_max and math.isfinite(out.kin)):
            return 3
        if ipar.adaptive:
            self.set_dt(K.stable_dt_at(fpar, out.d_max))
        tol_a, tol_v = fpar.tol_a, fpar.tol_v
        if (out.ntop > 0 and out.a_max < tol_a and out.alpha_max < tol_a
                and out.a_piston < tol_a and out.v_max < tol_v and out.w_max < tol_v
                and abs(piston.v) < tol_v):
            return 1
        return 0

    def _make_room(self, needed: int) -> None:
        """After a device rebuild ran out of room (status 2): the state back to the host (that
        of the step before, untouched), larger pair arrays, and up again; the next step redoes
        the rebuild."""
        self.download()
        self._grow_pairs(needed)
        self.upload()
        self.room_made += 1

    # ------------------------------------------------------------ the engine's interface
    def run(self, n_steps: int) -> int:
        """Advance up to ``n_steps`` steps; same statuses as :meth:`Engine.run` (0, 1 converged
        candidate, 3 blown up)."""
        check = int(self.ipar.check)
        target = self.steps + int(n_steps)
        self.upload()
        try:
            if not self.device_rebuild:
                for _ in range(int(n_steps)):
                    if self.step() == 3:
                        return 3
                    if check > 0 and self.ipar.steps % check == 0:
                        status = self._check()
                        if status:
                            return status
                return 0
            return self.advance(target)
        finally:
            self.download()

    def advance(self, target: int) -> int:
        """Step on the device (between :meth:`upload` and :meth:`download`, ``device_rebuild``
        on) until ``target`` steps in all: runs of steps queued up to the next check (or
        :data:`SYNC_EVERY` steps), then one read of the device; room made when a rebuild asked
        for it. Returns as :meth:`run`."""
        check = int(self.ipar.check)
        while self.steps < target:
            now = self.steps
            stop = min(target, now + self.SYNC_EVERY if check <= 0 else (now // check + 1) * check)
            for _ in range(stop - now):
                self.step()
            status, needed = self.sync()
            if status == 2:
                self._make_room(needed)
                continue
            if status == 3:
                return 3
            if check > 0 and self.steps % check == 0:
                status = self._check()
                if status:
                    return status
        return 0
