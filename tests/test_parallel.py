"""Threads change nothing: same bytes for 1 and 2 threads (DEM preparation 2D and 3D, time
domain), the neighbour lists' growth path, the progress ETA, and SIGTERM leaving no file."""

import math
import os
import signal
import subprocess
import sys
import time

import numba
import numpy as np
import pytest

from granwave import team, threads
from granwave.dem import integrator
from granwave.dem import kernels as K
from granwave.dem import workspace as WS
from granwave.dem import serial
from granwave.dem.params import PrepareParams
from granwave.dem.protocol import prepare_packing
from granwave.errors import ResourceError
from granwave.linear import propagate
from granwave.linear.assemble import linearize
from granwave.linear.check import reference_lattice

#: mean-flow with critical settling, damped enough (b = 3) that the settled rate min(2 omega_b, gamma)
#: is below gamma in this short column, so that the lateral mean flow's own term acts
CRITICAL = PrepareParams(grains=120, aspect=3.0, background_damping=3.0, seed=11, tol=1e-9,
                         compaction="mean-flow", reference_height=2.0, mean_flow_settling="critical")
#: overdamped (b = 10), so that the adaptive end game lowers the background damping (4 changes, 25 640 steps)
END_GAME = PrepareParams(grains=90, seed=12, tol=1e-9, background_damping=10.0, end_game="adaptive")

two_threads = pytest.mark.skipif(numba.config.NUMBA_NUM_THREADS < 2, reason="needs 2 threads")


def _bytes(packing) -> bytes:
    c = packing.contacts
    return b"".join(np.ascontiguousarray(x).tobytes() for x in (
        packing.position, packing.box, c.i, c.j, c.overlap, c.force_normal, c.force_tangential))


def _at(n_threads, fn):
    keep = numba.get_num_threads()
    threads.set_threads(n_threads)
    try:
        return fn()
    finally:
        numba.set_num_threads(keep)


@two_threads
@pytest.mark.parametrize("params", [
    PrepareParams(grains=90, seed=11, tol=1e-9),
    PrepareParams(dim=3, grains=60, seed=12, tol=1e-9, friction=0.5),
    PrepareParams(grains=90, seed=11, tol=1e-9, compaction="mean-flow", reference_height=2.0),
    CRITICAL,
    END_GAME,
], ids=["2d-frictional", "3d-frictional", "2d-mean-flow", "2d-critical-settling", "2d-end-game"])
def test_prepared_packing_same_bytes_for_1_and_2_threads(params, monkeypatch):
    """The parallel passes run even on these small systems (threshold lowered): positions,
    contacts, forces and tangential forces byte for byte equal."""
    monkeypatch.setattr(K, "MIN_PARALLEL_GRAINS", 0)
    one = _at(1, lambda: prepare_packing(params))
    two = _at(2, lambda: prepare_packing(params))
    assert one.attrs["steps"] == two.attrs["steps"] > 1000
    assert _bytes(one) == _bytes(two)
    if params is CRITICAL:
        assert 0 < one.attrs["settling_damping_rate"] < one.attrs["background_damping_rate"]


@two_threads
@pytest.mark.parametrize("dim, mean_flow", [(2, False), (3, False), (2, True)],
                         ids=["2d", "3d", "2d-mean-flow"])
def test_plain_steps_in_a_team_same_bytes_as_a_region_per_pass(dim, mean_flow, monkeypatch):
    """On 2 threads the plain steps run in a team of threads (kernels._team_steps): after 600
    steps of a shaken packing under a moving piston (so that pair lists are rebuilt and the
    team leaves and enters again), positions, velocities, spins, tangential histories and the
    piston are byte for byte those of a parallel region per pass and of the one-thread loop;
    also with the mean-flow rule's slab means taken inside the team's second pass."""
    monkeypatch.setattr(K, "MIN_PARALLEL_GRAINS", 0)
    packing = prepare_packing(PrepareParams(dim=dim, grains=120 if dim == 2 else 80, seed=5, tol=1e-9))
    flow = dict(background_damping=0.05, mean_flow=(0.5, 2.0)) if mean_flow else {}

    def run(n_threads, in_team):
        monkeypatch.setattr(integrator, "PLAIN_STEPS_IN_TEAM", in_team)
        engine = _shaken_engine(packing, **flow)
        _at(n_threads, lambda: engine.run(600))
        state = b"".join(np.ascontiguousarray(x).tobytes() for x in (
            engine.position, engine.velocity, engine.angular_velocity, engine.pair_ft, engine.piston))
        return state, int(engine.ipar.team_steps), engine.rebuilds

    teamed, team_steps, rebuilds = run(2, True)
    regions, no_team_steps, _ = run(2, False)
    one, _, _ = run(1, True)
    assert rebuilds >= 2
    assert team_steps > 300 and no_team_steps == 0
    assert teamed == regions == one


def _shaken_engine(packing=None, **flow):
    """An engine on a prepared packing (default: 120 grains, 2D) under its piston, the grains
    shaken (speeds ~1e-2) so that pair lists are rebuilt within a few hundred steps."""
    if packing is None:
        packing = prepare_packing(PrepareParams(grains=120, seed=5, tol=1e-9))
    rng = np.random.default_rng(0)
    lateral = packing.box[:-1]
    return integrator.Engine(packing.position, packing.radius, lateral, packing.box[-1],
                             friction=packing.friction, damping=0.5, skin=0.2,  # lists rebuilt within 600 steps
                             piston_mass=float(packing.attrs["piston_mass"]),
                             piston_force=packing.pressure * float(np.prod(lateral)),
                             velocity=rng.normal(0.0, 1e-2, packing.position.shape), **flow)


def _engine_bytes(engine) -> bytes:
    return b"".join(np.ascontiguousarray(x).tobytes() for x in (
        engine.position, engine.velocity, engine.acceleration, engine.pair_ft, engine.piston, engine.fpar,
        np.array([engine.ipar.npairs, engine.ipar.steps, engine.ipar.rebuilds, engine.ipar.built])))


@two_threads
def test_dem_team_that_cannot_start_does_nothing(monkeypatch):
    """A team of 3 asked for on 2 threads: its threads give it up at the entry (after their
    patience) and it runs no step: no grain, piston or counter changes, and the kernel says so
    (ipar.team = -1) for the engine to run the passes in regions. The same without trying
    when the workspace has fewer per-thread scratches than the team has threads (one per thread
    numba can start, so such a team could not start either)."""
    monkeypatch.setattr(K, "MIN_PARALLEL_GRAINS", 0)
    engine = _shaken_engine()
    _at(2, lambda: engine.run(40))  # the blocks and incoming lists for 2 threads
    before = _engine_bytes(engine)
    engine.ws.claims[0] = 3
    room_for_3 = engine.ws._replace(tile=np.zeros((3, engine.ws.tile.shape[1])),
                                    tile_p=np.zeros((3, engine.ws.tile_p.shape[1]), np.int64),
                                    visit=np.zeros((3, engine.ws.visit.shape[1]), np.int64))
    for ws, tries in ((room_for_3, True), (engine.ws, False)):
        engine.ipar.team = 1
        sync = np.zeros(team.SYNC_LENGTH, np.int64)
        done, _ = _at(2, lambda: K._team_steps(
            engine.position, engine.velocity, engine.acceleration, engine.angular_velocity,
            engine.angular_acceleration, engine.radius, engine.mass, engine.inertia, engine.lateral, engine.pos0,
            engine.pair_i, engine.pair_j, engine.pair_ft, engine.pair_ov, engine.wall_ft, engine.wall_ov,
            engine.piston, engine.fpar, engine.ipar, ws, ws.blk.shape[0], 0, 100, 0.0, sync))
        assert done == 0 and engine.ipar.team == -1 and not team.entered(sync)
        assert sync[team.S_ENTRY] == (-1 if tries else 0)  # given up at the entry, or never tried
        assert _engine_bytes(engine) == before


@two_threads
def test_dem_engine_gives_the_team_up_once_and_goes_on(monkeypatch):
    """When a run's team did not start (ipar.team = -1 from the kernel), Engine.run warns once
    and no later run tries a team (granwave.team.usable); the steps are those of the regions."""
    monkeypatch.setattr(K, "MIN_PARALLEL_GRAINS", 0)
    monkeypatch.setattr(team, "_given_up", False)  # restored after the test
    real = K.run_chunk

    def team_never_starts(*args):
        ipar = args[18]
        ipar.team = 0  # no team: the regions' passes, as after a failed entry
        status = real(*args)
        ipar.team = -1
        return status

    reference = _shaken_engine()
    monkeypatch.setattr(integrator, "PLAIN_STEPS_IN_TEAM", False)
    _at(2, lambda: reference.run(200))
    monkeypatch.setattr(integrator, "PLAIN_STEPS_IN_TEAM", True)
    engine = _shaken_engine()
    monkeypatch.setattr(K, "run_chunk", team_never_starts)
    with pytest.warns(RuntimeWarning, match="did not all start together"):
        _at(2, lambda: engine.run(100))
    monkeypatch.setattr(K, "run_chunk", real)
    assert not team.usable()
    _at(2, lambda: engine.run(100))
    assert engine.ipar.team == 0 and engine.ipar.team_steps == 0
    assert _engine_bytes(engine) == _engine_bytes(reference)


@pytest.mark.parametrize("params", [
    PrepareParams(grains=90, seed=11, tol=1e-9),
    PrepareParams(dim=3, grains=60, seed=12, tol=1e-9, friction=0.5),
    PrepareParams(grains=90, seed=11, tol=1e-9, compaction="mean-flow", reference_height=2.0),
    CRITICAL,
    END_GAME,
], ids=["2d-frictional", "3d-frictional", "2d-mean-flow", "2d-critical-settling", "2d-end-game"])
def test_single_pair_loop_equals_the_parallel_passes(params, monkeypatch):
    """One thread runs the single pair loop (dem/serial.py); the two passes of the parallel
    engine, run on one thread instead, give the same bytes."""
    serial_run = prepare_packing(params)
    monkeypatch.setattr(serial, "run_chunk", K.run_chunk)
    passes = prepare_packing(params)
    assert serial_run.attrs["steps"] == passes.attrs["steps"] > 1000
    assert _bytes(serial_run) == _bytes(passes)


def test_narrow_neighbour_lists_grow_to_the_same_result(monkeypatch):
    """Lists started with room for 2 neighbours per grain and few pairs must grow (engine and
    kernel paths) and give exactly the packing of the default sizes."""
    params = PrepareParams(grains=50, seed=4, tol=1e-9)
    ref = prepare_packing(params)
    monkeypatch.setattr(integrator, "NEIGHBOUR_WIDTH", {2: 2, 3: 2})
    grown = []
    keep = integrator.Engine.grow

    def spy(self, needed, width=0):
        grown.append((needed, width))
        keep(self, needed, width)

    monkeypatch.setattr(integrator.Engine, "grow", spy)
    again = prepare_packing(params)
    assert any(w > 2 for _, w in grown)
    assert _bytes(again) == _bytes(ref)


def test_growth_makes_new_only_the_arrays_whose_size_changes():
    """Growing the pair room, the width or the incoming room gives the shapes of a new
    workspace of those sizes, the pair constants carried over, and leaves every other array
    the same object (a new workspace per growth left an 87 MB step in a 10^5-sphere run's
    resident memory); lists not kept are cleared."""
    n, d, r = 100, 3, 3
    ws = K.workspace(n, d, r, 64, 4, 64, blocks=8)
    ws.pair_c[:] = np.arange(64 * K.N_PCOL).reshape(64, K.N_PCOL)
    ws.ncount[:] = 7
    more_pairs = K.grown_workspace(ws, 200, 4, 64, keep_lists=True)
    fresh = K.workspace(n, d, r, 200, 4, 64, blocks=8)
    assert [a.shape for a in more_pairs] == [a.shape for a in fresh]
    assert np.array_equal(more_pairs.pair_c[:64], ws.pair_c)
    assert not more_pairs.pair_c[64:].any()
    changed = [w for w in ws._fields if getattr(more_pairs, w) is not getattr(ws, w)]
    assert changed == ["pair_c"]
    assert (more_pairs.ncount == 7).all()
    wider = K.grown_workspace(more_pairs, 200, 10, 300, keep_lists=False)
    fresh = K.workspace(n, d, r, 200, 10, 300, blocks=8)
    assert [a.shape for a in wider] == [a.shape for a in fresh]
    changed = [w for w in ws._fields if getattr(wider, w) is not getattr(more_pairs, w)]
    assert changed == ["nbr", "gather", "slot_pair", "out_slot", "bnd_f"]
    assert not wider.ncount.any()


@two_threads
@pytest.mark.parametrize("fused_above", [4, 1], ids=["two-phases", "one-barrier-a-step"])
def test_time_domain_same_bytes_for_1_and_2_threads(fused_above, monkeypatch):
    """Signal, snapshots and energy records byte for byte equal (threshold lowered); also with
    the team of more threads' one phase per step (propagate.FUSED_ABOVE lowered): sample
    intervals of an odd and an even number of steps, and single steps around the snapshots."""
    monkeypatch.setattr(propagate, "MIN_PARALLEL_ROWS", 0)
    monkeypatch.setattr(propagate, "FUSED_ABOVE", fused_above)
    system = linearize(reference_lattice(8, 5, pressure=1e-4, friction=0.5))

    def run(dt):
        return propagate.time_domain_signal(system, ic="B", t_max=30.0, samples=61, snapshots=[3.0, 10.0], dt=dt)

    for dt, sub in ((None, 4), (0.1, 5)):  # steps per sample interval
        one, two = _at(1, lambda: run(dt)), _at(2, lambda: run(dt))
        assert one.attrs["n_steps"] == 60 * sub
        assert one.force.tobytes() == two.force.tobytes()
        assert one.snapshot_displacement.tobytes() == two.snapshot_displacement.tobytes()
        for key in ("energy_max_rel_deviation", "modified_energy_max_rel_deviation"):
            assert one.attrs[key] == two.attrs[key]
        assert np.abs(one.force).max() > 0


def test_state_sums_match_the_plain_sums():
    """Blocked energies agree with numpy to roundoff; the detector sum over its nonzero
    entries is bit for bit the full sequential sum."""
    rng = np.random.default_rng(0)
    n = 3 * propagate.SUM_BLOCK + 17
    u, v, a, m = (rng.normal(size=n) for _ in range(4))
    det = np.zeros(n)
    det[rng.choice(n, 30, replace=False)] = rng.normal(size=30)
    idx = np.flatnonzero(det)
    blocks = np.zeros(((n + propagate.SUM_BLOCK - 1) // propagate.SUM_BLOCK, 3))
    kin, pot, ama, force = propagate.state_sums(u, v, a, m, idx, det[idx], blocks)
    np.testing.assert_allclose([kin, pot, ama], [0.5 * np.dot(m * v, v), -0.5 * np.dot(u, m * a),
                                                 np.dot(a, m * a)], rtol=1e-12)
    full = 0.0
    for i in range(n):
        full += det[i] * u[i]
    assert force == full


def test_eta_from_the_decay_of_max_acceleration():
    """An exact exponential decay gives the exact time to tol; growth, too few chunks or
    max |a| already below tol: None; bursts above the lowest value so far do not count."""
    k, tol, sps = 1e-4, 1e-10, 500.0
    hist = [(s, 1e-3 * math.exp(-k * s)) for s in range(0, 10_000, 1000)]
    want = math.log(tol / hist[-1][1]) / -k / sps
    assert integrator.eta_seconds([(hist, tol)], sps) == pytest.approx(want, rel=1e-9)
    assert integrator.eta_seconds([([(s, 1e-3 * math.exp(k * s)) for s, _ in hist], tol)], sps) is None
    assert integrator.eta_seconds([(hist[:2], tol)], sps) is None
    # tol beyond the step limit at this rate: unknown, not an absurd number of seconds
    left = math.log(tol / hist[-1][1]) / -k
    assert integrator.eta_seconds([(hist, tol)], sps, steps_left=1.01 * left) == pytest.approx(want, rel=1e-9)
    assert integrator.eta_seconds([(hist, tol)], sps, steps_left=0.99 * left) is None
    assert integrator.eta_seconds([(hist + [(10_000, 1e-11)], tol)], sps) is None
    bursts = [(s, a * (50.0 if i % 2 else 1.0)) for i, (s, a) in enumerate(hist)]
    assert integrator.eta_seconds([(bursts[:-1], tol)], sps) == pytest.approx(
        math.log(tol / hist[-2][1]) / -k / sps, rel=1e-9)


def test_eta_waits_for_the_slowest_tested_quantity():
    """With max |a| and the speeds, the ETA is the later of their exact decays; a quantity
    already below its threshold does not count; one above it whose envelope does not fall (the
    3D end game's speeds rising while max |a| is at rest), or that dipped below and rose again,
    makes the ETA unknown."""
    tol_a, tol_v, sps = 1e-10, 1e-8, 500.0
    steps = range(0, 10_000, 1000)
    acc = [(s, 1e-3 * math.exp(-2e-4 * s)) for s in steps]
    speed = [(s, 1e-4 * math.exp(-5e-5 * s)) for s in steps]
    t_acc = math.log(tol_a / acc[-1][1]) / -2e-4 / sps
    t_speed = math.log(tol_v / speed[-1][1]) / -5e-5 / sps
    assert t_speed > t_acc
    assert integrator.eta_seconds([(acc, tol_a), (speed, tol_v)], sps) == pytest.approx(t_speed, rel=1e-9)
    assert integrator.eta_seconds([(acc, tol_a)], sps) == pytest.approx(t_acc, rel=1e-9)
    at_rest = acc + [(10_000, 0.5 * tol_a)]
    speed_on = speed + [(10_000, 1e-4 * math.exp(-5e-1))]
    t_on = math.log(tol_v / speed_on[-1][1]) / -5e-5 / sps
    assert integrator.eta_seconds([(at_rest, tol_a), (speed_on, tol_v)], sps) == pytest.approx(t_on, rel=1e-9)
    rising = [(s, 1e-6 * math.exp(1e-5 * s)) for s in steps]
    assert integrator.eta_seconds([(at_rest, tol_a), (rising, tol_v)], sps) is None
    dipped = speed + [(10_000, 0.5 * tol_v), (11_000, 2.0 * tol_v)]
    assert integrator.eta_seconds([(acc, tol_a), (dipped, tol_v)], sps) is None
    assert integrator.eta_seconds([(at_rest, tol_a), ([(10_000, 0.5 * tol_v)], tol_v)], sps) is None


def test_time_domain_refused_when_it_cannot_fit(monkeypatch):
    from granwave import resources

    system = linearize(reference_lattice(4, 4, pressure=1e-4, friction=0.5))
    monkeypatch.setattr(resources, "available_memory", lambda: 1000)
    with pytest.raises(ResourceError, match=r"time-domain run of \d+ dofs .* needs about"):
        propagate.time_domain_signal(system, ic="A", t_max=5.0, samples=11)


def test_sigterm_mid_run_leaves_no_file(tmp_path):
    """A preparation stopped by SIGTERM (a scheduler's limit) exits 130 and leaves nothing."""
    out = tmp_path / "p.h5"
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}
    proc = subprocess.Popen([sys.executable, "-m", "granwave", "prepare-packing", "--grains", "3000",
                             "--threads", "1", "-o", str(out)], stderr=subprocess.PIPE, text=True,
                            env=env, cwd=tmp_path)
    deadline = time.monotonic() + 120
    line = ""
    while time.monotonic() < deadline:  # wait for the first progress line: the run is under way
        line = proc.stderr.readline()
        if line.startswith("step") or not line:
            break
    assert line.startswith("step") and "ETA" in line, line
    proc.send_signal(signal.SIGTERM)
    rest = proc.communicate(timeout=60)[1]
    assert proc.returncode == 130, rest
    assert "interrupted; no output written" in rest
    assert list(tmp_path.iterdir()) == []


def test_blocks_grow_room_for_incoming_pairs_to_the_same_result(monkeypatch):
    """The block engine with room for a single incoming pair (many blocks, 4 on 90 grains) must
    grow it, through run_chunk's status and Engine.grow keeping the lists, and still give the
    bytes of the one-thread pair loop."""
    params = PrepareParams(grains=90, seed=11, tol=1e-9)
    ref = prepare_packing(params)
    monkeypatch.setattr(serial, "run_chunk", K.run_chunk)
    monkeypatch.setattr(WS, "boundary_room", lambda n: 1)  # read by workspace() in its module
    rooms = []
    keep = integrator.Engine.grow

    def spy(self, needed, width=0):
        keep(self, needed, width)
        rooms.append(len(self.ws.slot_pair))

    monkeypatch.setattr(integrator.Engine, "grow", spy)
    again = prepare_packing(params)
    assert rooms and max(rooms) > 1
    assert again.attrs["steps"] == ref.attrs["steps"]
    assert _bytes(again) == _bytes(ref)


@two_threads
@pytest.mark.parametrize("blocks", [3, 7, 16])
def test_any_block_partition_gives_the_same_bytes(blocks, monkeypatch):
    """The number of grain blocks (which grows with the thread count, kernels.block_count) only
    decides who computes what: odd and many blocks on 2 threads give the one-thread loop's bytes."""
    params = PrepareParams(grains=90, seed=11, tol=1e-9)
    ref = prepare_packing(params)
    monkeypatch.setattr(K, "MIN_PARALLEL_GRAINS", 0)
    monkeypatch.setattr(K, "block_count", lambda n, threads=1: blocks)
    run = _at(2, lambda: prepare_packing(params))
    assert run.attrs["steps"] == ref.attrs["steps"] > 1000
    assert _bytes(run) == _bytes(ref)


def test_block_count_grows_with_threads_and_keeps_blocks_large():
    assert K.block_count(10_200, 1) == K.block_count(10_200, 2) == 8
    assert K.block_count(10_200, 16) == 32  # 2 per thread, a multiple of 16
    assert K.block_count(102_000, 16) == 112  # the size rule already gives more than 2 per thread
    assert K.block_count(1_000, 16) == 15  # no block under MIN_BLOCK_GRAINS grains
    assert K.block_count(3, 16) == 3


def _reference_order(t: int, threads: int, nblk: int) -> list[tuple[int, int]]:
    """Thread t's blocks as documented (visit_order): its own share ascending, then the shares
    of t + 1, t + 2, ... (cyclically) each from its far end, with the first block of each foreign
    share (-1 for its own)."""
    def share(u):
        return u * nblk // threads, (u + 1) * nblk // threads

    b0, b1 = share(t)
    order = [(b, -1) for b in range(b0, b1)]
    for s in range(1, threads):
        c0, c1 = share((t + s) % threads)
        order += [(b, c0) for b in reversed(range(c0, c1))]
    return order


@pytest.mark.parametrize("threads, nblk", [(1, 8), (2, 8), (3, 7), (16, 32), (16, 15), (5, 112)])
def test_visit_order_is_each_share_once_own_first(threads, nblk):
    for t in range(threads):
        order = np.full(2 * nblk, -7, np.int64)
        K.visit_order(t, threads, nblk, order)
        got = list(zip(order[:nblk].tolist(), order[nblk:].tolist()))
        assert got == _reference_order(t, threads, nblk)
        assert sorted(order[:nblk].tolist()) == list(range(nblk))


def test_claims_give_each_block_once_and_leave_an_owner_its_next_block():
    """Thread 0 of 4 done early over 16 blocks: it takes the far ends of the others' shares while
    their owners have not reached the block before, never an owner's next block nor a share's
    first; the owners then take the rest, and every block is taken exactly once."""
    threads, nblk = 4, 16
    claims = np.zeros(nblk + 2, np.int64)
    orders = np.zeros((threads, 2 * nblk), np.int64)
    for t in range(threads):
        K.visit_order(t, threads, nblk, orders[t])
    phase = 1
    # thread 1 has taken its first block (4), thread 2 its first two (8, 9), thread 3 none
    taken = {1: [], 2: [], 3: []}
    for t, j in ((1, 0), (2, 0), (2, 1)):
        taken[t].append(K.claim_block(claims, orders[t], nblk, j, phase))
    taken[0] = [K.claim_block(claims, orders[0], nblk, j, phase) for j in range(nblk)]
    assert [b for b in taken[0] if b >= 0] == [0, 1, 2, 3, 7, 6, 11, 15, 14, 13]
    for t in (1, 2, 3):
        taken[t] += [K.claim_block(claims, orders[t], nblk, j, phase) for j in range(nblk)]
    assert [b for b in taken[1] if b >= 0] == [4, 5]
    assert [b for b in taken[2] if b >= 0] == [8, 9, 10]
    assert [b for b in taken[3] if b >= 0] == [12]
    assert np.all(claims[1:nblk + 1] == phase)


#: The step's kernels, each reached from several call sites (one-thread loop, parallel passes,
#: team of threads, frozen forces): one machine-code version each. A literal argument (a
#: constant True, a 0 numba has not yet unified with the int64 it becomes, a prange index typed
#: uint64) compiles a kernel once more for that type; on a cold cache the parallel passes took
#: 206 CPU-s to compile instead of about 130.
ONE_SIGNATURE = [
    ("granwave.dem.passes", ("_incoming_pass", "_incoming_block", "_row_pass", "_row_block", "_forces",
                             "_finish", "_slab_job", "compute_forces")),
    ("granwave.dem.team_steps", ("_team_steps", "_team_region", "_team_thread")),
    ("granwave.dem.chunk", ("run_chunk",)),
    ("granwave.dem.serial", ("run_chunk", "_force_loop", "compute_forces")),
    ("granwave.dem.workspace", ("refresh_wall_list", "_lists", "incoming_lists")),
    ("granwave.dem.time_step", ("needs_rebuild",)),
    ("granwave.dem.blocks", ("visit_order",)),
]


def _signatures(kernel) -> set:
    """The argument types ``kernel`` has machine code for on this CPU: compiled or loaded in this
    process, or in numba's cache index (a kernel called only from cached kernels is never
    loaded itself; the index holds what any process compiled from this source)."""
    found = {tuple(sig) for sig in kernel.signatures}
    magic = kernel.targetctx.codegen().magic_tuple()
    index = kernel._cache._cache_file._load_index()  # numba's: {(signature, magic, stamps): file}
    return found | {tuple(sig) for sig, m, *_ in index if m == magic}


@two_threads
def test_each_step_kernel_compiles_for_one_signature(monkeypatch):
    """A preparation on one thread and on two (parallel passes and a team of threads) and the
    frozen forces of its packing: every kernel of the step has machine code for exactly one
    tuple of argument types."""
    import importlib

    from granwave.dem.forces import frozen_history_forces

    monkeypatch.setattr(K, "MIN_PARALLEL_GRAINS", 0)
    params = PrepareParams(grains=40, seed=3, tol=1e-6, friction=0.5, compaction="mean-flow",
                           reference_height=2.0)
    _at(1, lambda: prepare_packing(params))
    packing = _at(2, lambda: prepare_packing(params))
    frozen_history_forces(packing)
    counts = {f"{module}.{name}": len(_signatures(getattr(importlib.import_module(module), name)))
              for module, names in ONE_SIGNATURE for name in names}
    assert {k: n for k, n in counts.items() if n != 1} == {}
