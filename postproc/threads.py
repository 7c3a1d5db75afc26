"""Thread pools set on purpose.

Identification works on thin matrices (3N x P with P of a few dozen): a multi-threaded
BLAS only spins its threads on them, and on a machine shared with another job the spinning
threads wait for cores and slow the whole command down many times (issue 26: diagnose of
250 poses took 362 s with the default threads, 16 s with one). Every library entry point
whose matrices are that small runs under ``small_matrices()``; a set large enough for
threads to pay (``BLAS_THREADS_FROM_ROWS`` Jacobian rows) keeps the pool as it is.
"""

from __future__ import annotations

import contextlib

from threadpoolctl import threadpool_limits

#: Jacobian rows (3 x poses) from which the pool is left as it is: at 50,000 poses the
#: products are large enough that threads may pay (an estimate, not measured here; at
#: 600 poses one thread is what benchmarks/diagnose.py measured).
BLAS_THREADS_FROM_ROWS = 150_000


def small_matrices(rows: int = 0):
    """One BLAS/OpenMP thread for work on ``rows`` x P matrices below the threshold (a
    context manager; a no-op above it)."""
    if rows >= BLAS_THREADS_FROM_ROWS:
        return contextlib.nullcontext()
    return threadpool_limits(limits=1)

