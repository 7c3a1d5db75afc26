"""Memory a fit will need, estimated before it starts, and the refusal when it would not fit.

A kernel OOM kill gives the user nothing: no message, no model, a machine that swapped.
So every fit whose memory grows with the data states its need first and is refused (a
typed error, exit 2) when the need exceeds what this machine has free (or the limit the
user gave), naming the option that would fit.

The exact GP's figure is scikit-learn's marginal-likelihood gradient: the kernel matrix,
its inverse, the (N, N, n_theta) kernel gradient and the temporaries of the product and
sum kernels that build it, about 8 * N^2 * (2 n_theta + 8) bytes (measured at N = 500,
1000 and 2000 with 8 hyperparameters: 192 bytes per kernel entry; see
benchmarks/gpr_scaling.py).
"""

from __future__ import annotations

from pathlib import Path

import psutil

from postproc.errors import InputError

GB = 1024**3


class MemoryBudgetError(InputError):
    """A fit that would need more memory than is free or allowed: refused before it starts."""


def gp_fit_bytes(n_points: int, n_features: int, anisotropic: bool) -> int:
    """Peak memory of an exact GP hyperparameter fit on n_points (see the module docstring)."""
    n_theta = (n_features if anisotropic else 1) + 2  # length scale(s), signal, noise
    return int(8 * n_points**2 * (2 * n_theta + 8))


def lean_fit_bytes(n_points: int) -> int:
    """Peak memory of one marginal-likelihood evaluation of gp_lml: six (N, N) matrices."""
    return int(8 * 6 * n_points**2)


def available_bytes() -> int:
    """Memory this process may still take: free memory, or the cgroup's limit if lower."""

    free = int(psutil.virtual_memory().available)
    limit_file = Path("/sys/fs/cgroup/memory.max")
    try:
        text = limit_file.read_text().strip()
        used = int(Path("/sys/fs/cgroup/memory.current").read_text().strip())
    except (OSError, ValueError):
        return free
    if text == "max":
        return free
    return max(0, min(free, int(text) - used))


def check_budget(need_bytes: int, what: str, limit_gb: float | None, alternative: str | None) -> None:
    """Raise MemoryBudgetError if need_bytes exceeds the free memory or the user's limit."""
    free = available_bytes()
    allowed = free if limit_gb is None else min(free, int(limit_gb * GB))
    if need_bytes <= allowed:
        return
    why = f"{free / GB:.1f} GB free" if limit_gb is None or free < limit_gb * GB else f"--memory-limit {limit_gb:g} GB"
    hint = f"; {alternative}" if alternative else ""
    raise MemoryBudgetError(f"{what} needs about {need_bytes / GB:.1f} GB of memory ({why}): not started{hint}")
