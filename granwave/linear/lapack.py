"""Dense symmetric eigensolves that a signal can stop (one home for the LAPACK calls that
hold the interpreter's lock: eigensolve, linearize's check, the moduli's dense fallback)."""

from __future__ import annotations

import mmap
import os
import signal

import numpy as np
import scipy.linalg
import scipy.sparse as sp

#: From this many dofs on, :func:`dense_eigh` runs LAPACK in a child process (below it the call
#: takes well under a second and a fork would cost more than it saves).
INTERRUPTIBLE_MIN_DOF = 400


def dense_eigh(A, *, vectors: bool = True):
    """``scipy.linalg.eigh(A, driver="evd")`` (A dense or sparse, symmetric) that Ctrl-C,
    SIGTERM and SIGHUP stop at once: (w, V), or w alone without ``vectors``.

    scipy's LAPACK wrappers hold the interpreter's lock for the whole call (measured: a
    second Python thread waited 34 s through one 1500 x 1500 eigh), so a signal handler
    would run only at its end, minutes or hours later. From
    :data:`INTERRUPTIBLE_MIN_DOF` dofs on, the call runs in a forked child that writes the
    eigenvalues and vectors into shared memory, while this process waits in ``waitpid``,
    where signals are handled: an interrupt kills the child and propagates at once (no
    file is open at that point). The dense matrix exists only in the child (memory as
    before: the child's matrix and workspace, the shared vectors). A child killed by the
    system (out of memory) is a MemoryError; a LAPACK failure is retried here to raise
    scipy's own error.
    """
    n = A.shape[0]
    dense = (lambda: A.toarray()) if sp.issparse(A) else (lambda: np.array(A, dtype=float))

    def solve():
        return scipy.linalg.eigh(dense(), driver="evd", overwrite_a=True, check_finite=False,
                                 eigvals_only=not vectors)

    if n < INTERRUPTIBLE_MIN_DOF or not hasattr(os, "fork"):
        return solve()
    buf = mmap.mmap(-1, 8 * n * (n + 1 if vectors else 1))
    w = np.frombuffer(buf, dtype=np.float64, count=n)
    V = np.frombuffer(buf, dtype=np.float64, count=n * n, offset=8 * n).reshape(n, n) if vectors else None
    pid = os.fork()
    if pid == 0:  # the child: default signal handling, compute, leave without any cleanup
        code = 1
        try:
            for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
                signal.signal(sig, signal.SIG_DFL)
            if vectors:
                w[:], V[:] = solve()
            else:
                w[:] = solve()
            code = 0
        finally:
            os._exit(code)
    try:
        _, status = os.waitpid(pid, 0)  # a signal's handler raises here (PEP 475)
    except BaseException:
        os.kill(pid, signal.SIGKILL)
        os.waitpid(pid, 0)
        raise
    if os.WIFSIGNALED(status) and os.WTERMSIG(status) in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
        raise KeyboardInterrupt  # the same signal reached the child first (a terminal's Ctrl-C)
    if os.WIFSIGNALED(status):
        raise MemoryError(f"the eigensolve's process was killed (signal {os.WTERMSIG(status)})")
    if os.WEXITSTATUS(status) != 0:  # LAPACK refused: raise its error here
        return solve()
    return (w, V) if vectors else w
