#!/bin/bash
# The simulated machining pass of benchmarks/suggest.py in parallel shards of one seed each,
# merged into one report (issue 32). Run from the repository root with OUT set to a folder;
# PYBIN names a Python with numpy, scipy, numba, matplotlib (lark is installed from .whl/),
# LAST the last seed (47: 48 seeds), JOBS the shards at a time, DRAWS random designs per seed.
# It installs postproc and the wheels in .whl/ into /tmp/site first (a bare machine); fetch
# lark there beforehand: python3 -m pip download --no-deps --only-binary=:all: -d .whl lark==1.3.1
${PYBIN:-python3} -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --target /tmp/site .whl/*.whl || exit 3
${PYBIN:-python3} -m pip install -q --no-index --no-deps --no-build-isolation --no-cache-dir --target /tmp/site . || exit 4
export PYTHONPATH=/tmp/site OPENBLAS_NUM_THREADS=1 OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 PYTHONUNBUFFERED=1
PY="${PYBIN:-python3} -W ignore"
S=$OUT/shards; mkdir -p $S
nproc; ${PYBIN:-python3} -c "import numpy, scipy, numba; print(numpy.__version__, scipy.__version__, numba.__version__)"
START=$(date +%s)
timeout ${CAP:-420} sh -c "seq 0 ${LAST:-47} | xargs -P ${JOBS:-16} -I{} sh -c '$PY benchmarks/suggest.py --pass-only --skip-share0 --noise-draws 6 --random-draws ${DRAWS:-48} --seed-start {} --seeds 1 --shard-out $S/{}.npz 2>$S/{}.log'"
echo "shards took $(( $(date +%s) - START )) s; $(ls $S/*.npz 2>/dev/null | wc -l) finished"
cp benchmarks/results/suggest.npz $OUT/suggest.npz
$PY benchmarks/suggest.py --merge-shards $S/*.npz --output $OUT/suggest_pass_shards.txt --merge-into $OUT/suggest.npz --figure $OUT/suggest-poses.png > /dev/null
tail -40 $OUT/suggest_pass_shards.txt
