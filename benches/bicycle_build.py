"""The Whipple bicycle's build time (issue 50: derive + compile ≤ 0.5 s), beside SymPy's
derivation of the same bicycle (Kane's method, ``sympy.physics.mechanics``' own benchmark test,
``sympy/physics/mechanics/tests/test_kane3.py::test_bicycle``: derive, linearize about upright
running with the speed symbolic, substitute the benchmark's values and check the state matrix
at v = 0 … 5 m/s).

    python benches/bicycle_build.py [--repeat 3] [--no-sympy]

Each measurement runs in a fresh interpreter (nothing cached between them), imports excluded:

- build: ``lg.scenes.whipple_bicycle()`` — the four bodies' T derived on the expression graph,
  the five constraint rows, eq. 55 and the rows compiled;
- pipeline: build, then ``linearize_steady`` at v = 0 … 5 m/s (what SymPy's test does).
"""

import argparse
import statistics
import subprocess
import sys
import time

OURS = r"""
import time
import numpy as np
import lagrangian as lg
t0, c0 = time.perf_counter(), time.process_time()
bike = lg.scenes.whipple_bicycle()
t1, c1 = time.perf_counter(), time.process_time()
for v in range(6):
    qd = np.zeros(8); qd[0], qd[6], qd[7] = v, -v / 0.3, -v / 0.35
    bike.linearize_steady(np.zeros(8), qd, independent=["phi", "delta"], steady=["theta_r"])
t2, c2 = time.perf_counter(), time.process_time()
print(t1 - t0, t2 - t0, c1 - c0, c2 - c0)
"""

SYMPY = r"""
import time
from sympy.physics.mechanics.tests.test_kane3 import test_bicycle
t0, c0 = time.perf_counter(), time.process_time()
test_bicycle()
print(time.perf_counter() - t0, time.process_time() - c0)
"""


def run(code: str, timeout: float) -> list:
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         timeout=timeout, check=True)
    return [float(x) for x in out.stdout.split()]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--no-sympy", action="store_true")
    args = parser.parse_args()
    ours = [run(OURS, 300) for _ in range(max(1, args.repeat))]
    build, pipeline, build_cpu, pipeline_cpu = (statistics.median(o[i] for o in ours)
                                                 for i in range(4))
    print(f"median of {len(ours)} fresh interpreters; wall clock (CPU time of the process)")
    print(f"lagrangian build (derive + compile):        {build:8.3f} s ({build_cpu:.3f} s)")
    print(f"lagrangian build + 6 steady linearizations: {pipeline:8.3f} s ({pipeline_cpu:.3f} s)")
    if not args.no_sympy:
        try:
            sym, sym_cpu = run(SYMPY, 3600)
        except (subprocess.SubprocessError, ImportError, ValueError) as exc:
            print(f"sympy: not run ({exc})")
        else:
            print(f"sympy.physics.mechanics test_bicycle:       {sym:8.1f} s ({sym_cpu:.1f} s), "
                  f"{sym_cpu / pipeline_cpu:.0f}× the pipeline's CPU time")


if __name__ == "__main__":
    main()
