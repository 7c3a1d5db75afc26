"""GPR fit time and peak memory at several training-set sizes (issue 17).

Each size runs in a fresh process (peak RSS is per process). The field is a smooth
synthetic position error over a KR160-sized workspace with 0.01 mm noise; the method is
the predictor's default (exact up to 2,000 poses, local experts above) unless given.
Run: .venv/bin/python benchmarks/gpr_scaling.py [SIZES, default 1000,5000,20000] [METHOD]
e.g. .venv/bin/python benchmarks/gpr_scaling.py 1000,10000,100000 auto
"""

from __future__ import annotations

import resource
import subprocess
import sys
import time

import numpy as np


def field(n, seed=0):
    rng = np.random.default_rng(seed)
    X = np.column_stack([rng.uniform(-1000, 1000, n), rng.uniform(-1000, 1000, n), rng.uniform(300, 1300, n), rng.uniform(-30, 30, (n, 3))])
    f = np.column_stack([np.sin(X[:, 0] / 300), np.cos(X[:, 1] / 250), np.sin((X[:, 0] + X[:, 2]) / 400)]) * 0.2
    return X, f + rng.normal(0, 0.01, f.shape), f


def one(n: int, method: str) -> None:
    from postproc.model.learn import GPRPredictor

    X, y, _ = field(n)
    Xt, _, ft = field(2000, seed=1)
    t0 = time.perf_counter()
    model = GPRPredictor(anisotropic=True, method=method).fit(X, y)
    seconds = time.perf_counter() - t0
    rms = float(np.sqrt(np.mean(np.sum((model.predict(Xt) - ft) ** 2, axis=1))))
    peak_gb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024**2
    print(f"{n:>8}  {model.method_:>6}  {seconds:8.1f} s  {peak_gb:6.2f} GB peak RSS  held-out RMS {rms:.4f} mm", flush=True)


if __name__ == "__main__":
    if len(sys.argv) > 1 and sys.argv[1] == "--one":
        one(int(sys.argv[2]), sys.argv[3])
        sys.exit(0)
    sizes = [int(s) for s in (sys.argv[1] if len(sys.argv) > 1 else "1000,5000,20000").split(",")]
    method = sys.argv[2] if len(sys.argv) > 2 else "auto"
    print(f"{'poses':>8}  {'method':>6}  {'fit':>10}  {'memory':>17}")
    for n in sizes:
        subprocess.run([sys.executable, __file__, "--one", str(n), method], check=False)
