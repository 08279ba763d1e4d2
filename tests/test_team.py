"""granwave.team: a team of threads in one parallel region (entry, barriers, giving up), and the
time domain run through it: bit for bit numba's per-step parallel loops, on any thread count."""

import numba
import numpy as np
import pytest

from granwave import team
from granwave.linear import propagate
from granwave.linear.assemble import linearize
from granwave.linear.check import reference_lattice

two_threads = pytest.mark.skipif(numba.config.NUMBA_NUM_THREADS < 2, reason="needs 2 threads")


@numba.njit(parallel=True)
def _relay(sync, slots, rounds, seen):
    """Per round: thread t writes its slot, waits, then reads every slot; a value not of this
    round (a barrier that let a thread through early) is counted in ``seen[t]``."""
    threads = team.team_size(sync)
    for t in numba.prange(threads):
        if team.enter(sync, threads):
            gen = 0
            for r in range(rounds):
                slots[t] = r * threads + t
                gen = team.barrier(sync, threads, gen)
                for u in range(threads):
                    if slots[u] != r * threads + u:
                        seen[t] += 1
                gen = team.barrier(sync, threads, gen)
            seen[threads + t] = 1  # ran


def _run_relay(threads, size, spins=team.ENTRY_SPINS, rounds=2000):
    sync = team.new_sync()
    slots = np.full(size, -1, np.int64)
    seen = np.zeros(2 * size, np.int64)
    with_threads = numba.get_num_threads()
    numba.set_num_threads(threads)
    try:
        team.reset_team(sync, size, spins)
        _relay(sync, slots, rounds, seen)
    finally:
        numba.set_num_threads(with_threads)
    return sync, seen


@two_threads
def test_barriers_order_the_phases():
    """2000 rounds on 2 threads: every read after a barrier sees every write of its round."""
    sync, seen = _run_relay(2, 2)
    assert team.entered(sync)
    assert seen[:2].tolist() == [0, 0]
    assert seen[2:].tolist() == [1, 1]


def test_a_team_of_one():
    sync, seen = _run_relay(1, 1)
    assert team.entered(sync) and seen.tolist() == [0, 1]


@two_threads
def test_a_team_larger_than_the_threads_gives_up_without_work():
    """Three iterations on two threads: one thread holds two, so the team can never be complete;
    the entry gives up after its patience and no iteration does any work (rather than a hang)."""
    sync, seen = _run_relay(2, 3, spins=100_000)
    assert not team.entered(sync)
    assert seen.tolist() == [0] * 6


def _lattice_state():
    system = linearize(reference_lattice(8, 5, pressure=1e-4, friction=0.5))
    dt, _ = propagate.stable_time_step(system)
    D = system.stiffness.tocsr()
    D.sort_indices()
    args = (D.indptr.astype(np.int64), D.indices.astype(np.int64), D.data, 1.0 / system.mass)
    u = np.zeros(system.n_dof)
    v = system.source_velocity.copy()
    return args, u, v, dt, D


@pytest.mark.parametrize("threads", [1, 2])
def test_team_steps_are_the_per_step_loops_bit_for_bit(threads):
    """verlet_steps (the team) at 1 and 2 threads against numba's two parallel loops per step on
    one thread, 301 steps (an odd count), flushing on; and against plain numpy velocity Verlet
    to roundoff."""
    if threads > numba.config.NUMBA_NUM_THREADS:
        pytest.skip("needs 2 threads")
    args, u0, v0, dt, D = _lattice_state()
    flush = 1e-30
    ref = [u0.copy(), v0.copy(), np.zeros_like(u0)]
    got = [u0.copy(), v0.copy(), np.zeros_like(u0)]
    with_threads = numba.get_num_threads()
    try:
        numba.set_num_threads(1)
        propagate._verlet_regions(*args, *ref, dt, 301, flush)
        numba.set_num_threads(threads)
        assert team.usable()
        propagate.verlet_steps(*args, *got, dt, 301, flush)
    finally:
        numba.set_num_threads(with_threads)
    for x, y in zip(got, ref):
        assert x.tobytes() == y.tobytes()
    u, v, a = u0.copy(), v0.copy(), np.zeros_like(u0)
    minv = args[3]
    for _ in range(301):
        v += 0.5 * dt * a
        u += dt * v
        a = -(D @ u) * minv
        v += 0.5 * dt * a
    scale = np.abs(u).max()
    assert scale > 0
    assert np.abs(got[0] - u).max() < 1e-10 * scale


@numba.njit(parallel=True)
def _claim_phases(sync, claims, k, phases, who, hold):
    """``phases`` phases of chunk claims: who[p, c] counts the claims of chunk c in phase p (each
    written by its one claimer), who[phases + p, c] = 1 + the thread that took it. With ``hold``,
    thread 1 starts each phase only after thread 0 has visited every chunk (``hold[0]``)."""
    threads = team.team_size(sync)
    for t in numba.prange(threads):
        if team.enter(sync, threads):
            gen = 0
            for p in range(phases):
                if hold.shape[0] > 0 and t == 1:
                    while team.atomic_load(hold, 0) <= p:
                        team.spin_pause()
                c, j = team.next_chunk(claims, t, threads, k, 0, gen + 1)
                while c >= 0:
                    who[p, c] += 1
                    who[phases + p, c] = t + 1
                    c, j = team.next_chunk(claims, t, threads, k, j, gen + 1)
                if hold.shape[0] > 0 and t == 0:
                    team.atomic_store(hold, 0, p + 1)
                gen = team.barrier(sync, threads, gen)


def _run_claims(threads, k, phases, hold):
    sync = team.new_sync()
    claims = np.zeros(k * threads, np.int64)
    who = np.zeros((2 * phases, k * threads), np.int64)
    with_threads = numba.get_num_threads()
    numba.set_num_threads(threads)
    try:
        team.reset_team(sync, threads)
        _claim_phases(sync, claims, k, phases, who, np.zeros(1 if hold else 0, np.int64))
    finally:
        numba.set_num_threads(with_threads)
    assert team.entered(sync)
    return who[:phases], who[phases:]


def test_one_thread_claims_each_chunk_once_in_order():
    count, taker = _run_claims(1, 8, 5, hold=False)
    assert (count == 1).all() and (taker == 1).all()


@two_threads
def test_chunks_are_each_claimed_once_and_a_late_threads_far_end_is_taken_over():
    """Every chunk exactly once per phase, whoever is fast (500 phases, free running); with
    thread 1 held until thread 0 has visited every chunk, thread 0 takes its own k chunks and
    the last k - 1 of thread 1's share, and thread 1 keeps the first of its own."""
    k = 8
    count, _ = _run_claims(2, k, 500, hold=False)
    assert (count == 1).all()
    count, taker = _run_claims(2, k, 20, hold=True)
    assert (count == 1).all()
    expected = np.array([1] * k + [2] + [1] * (k - 1))
    assert (taker == expected).all()


@two_threads
def test_given_up_team_leaves_the_state_and_the_fallback_runs(monkeypatch):
    """A team that cannot be complete does no step; verlet_steps then warns once and runs numba's
    per-step loops, from then on without trying a team: the same bytes as a team that ran."""
    monkeypatch.setattr(team, "_given_up", False)  # restored after the test
    args, u0, v0, dt, _ = _lattice_state()
    state = [u0.copy(), v0.copy(), np.zeros_like(u0)]
    sync = team.new_sync()
    with_threads = numba.get_num_threads()
    numba.set_num_threads(2)
    try:
        ran = [u0.copy(), v0.copy(), np.zeros_like(u0)]
        propagate.verlet_steps(*args, *ran, dt, 50, 0.0)

        team.reset_team(sync, 3, 100_000)
        claims = np.zeros(3 * propagate.CHUNKS_PER_THREAD, np.int64)
        propagate._verlet_team(*args, *state, dt, 50, 0.0, sync, claims, propagate.CHUNKS_PER_THREAD)
        assert not team.entered(sync)
        assert state[0].tobytes() == u0.tobytes() and state[1].tobytes() == v0.tobytes()
        assert not state[2].any()

        real_reset = team.reset_team
        monkeypatch.setattr(team, "reset_team", lambda s, t: real_reset(s, t + 1, 100_000))
        fell_back = [u0.copy(), v0.copy(), np.zeros_like(u0)]
        with pytest.warns(RuntimeWarning, match="did not all start together"):
            propagate.verlet_steps(*args, *fell_back, dt, 50, 0.0)
        assert not team.usable()
        again = [u0.copy(), v0.copy(), np.zeros_like(u0)]
        propagate.verlet_steps(*args, *again, dt, 50, 0.0)  # no team tried: no second warning
    finally:
        numba.set_num_threads(with_threads)
    for x, y, z in zip(fell_back, ran, again):
        assert x.tobytes() == y.tobytes() == z.tobytes()
    assert np.abs(ran[0]).max() > 0


OVERSUBSCRIBED = r"""
import numba, numpy as np
from granwave.linear import propagate
from granwave.linear.assemble import linearize
from granwave.linear.check import reference_lattice
system = linearize(reference_lattice(8, 5, pressure=1e-4, friction=0.5))
dt, _ = propagate.stable_time_step(system)
D = system.stiffness.tocsr()
D.sort_indices()
args = (D.indptr.astype(np.int64), D.indices.astype(np.int64), D.data, 1.0 / system.mass)
out = []
for t in (1, 4):
    numba.set_num_threads(t)
    u, v, a = np.zeros(system.n_dof), system.source_velocity.copy(), np.zeros(system.n_dof)
    propagate.verlet_steps(*args, u, v, a, dt, 2000, 0.0)
    out.append(u.tobytes() + v.tobytes())
print("same" if out[0] == out[1] else "differ")
"""


def test_more_threads_than_cores_same_bits_and_no_stall():
    """Four threads on however many cores this machine has (two in CI): the waits yield, so the
    team neither stalls nor gives up, and the bits are one thread's (a subprocess: the thread
    pool's size is fixed at start)."""
    import os
    import subprocess
    import sys

    env = dict(os.environ, NUMBA_NUM_THREADS="4")
    r = subprocess.run([sys.executable, "-W", "error::RuntimeWarning", "-c", OVERSUBSCRIBED], env=env,
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr[-2000:]
    assert r.stdout.strip().splitlines()[-1] == "same"
