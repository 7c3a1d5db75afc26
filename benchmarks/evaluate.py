"""Time of one model prediction and one identification Jacobian (1,000 poses, every effect).

Run: .venv/bin/python benchmarks/evaluate.py [--n 1000]
The Jacobian is what every least-squares iteration of ``fit`` computes; best of 7 x 10 calls.
"""

from __future__ import annotations

import timeit

from simulated_kr160 import measured_truth, poses_option

EVERYTHING = "geometric,base_frame,tool_offset,joint_compliance,external_load,joint_harmonics[joints=1,2,3,4,5,6;orders=1,2],backlash,thermal,link_bending"


def main():
    n = poses_option(__doc__)
    _, _, truth, data = measured_truth(EVERYTHING, n)
    prep = truth.prepare(data)
    jac = min(timeit.repeat(lambda: truth.evaluate(prep), number=10, repeat=7)) / 10
    pred = min(timeit.repeat(lambda: truth.predict_prepared(prep), number=10, repeat=7)) / 10
    print(f"{n} poses, {len(truth.params)} parameters: predict {1e3 * pred:.1f} ms, predict + Jacobian {1e3 * jac:.1f} ms")


if __name__ == "__main__":
    main()
