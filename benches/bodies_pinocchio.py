"""Pinocchio's ABA on the spatial arm of `lg.scenes.spatial_chain` (issue 50), for the table in
docs/site/crate.rst beside `cargo bench -p lagrangian-benches --bench bodies`.

The arm is built with Pinocchio's own model-building API: N revolute joints about the parent's
x axis (odd joints: y), each placed at the end of the previous link (0, 0, −l), each link a solid
cylinder of mass m, length l and radius a with its centre at (0, 0, −l/2), gravity (0, 0, −g).
The accelerations are checked against `lg.scenes.spatial_chain(...).accelerations` when the
package is importable. Times are per call of `pin.aba` from Python, so they include the Python
call's overhead (about 0.1–0.3 µs), not Pinocchio's C++ time alone.

    PYTHONPATH=python /work/venvs/pin/bin/python benches/bodies_pinocchio.py
"""

import timeit

import numpy as np
import pinocchio as pin


def arm(n, m=1.0, length=0.5, radius=0.05):
    model = pin.Model()
    parent = 0
    side = m * (3 * radius**2 + length**2) / 12.0
    inertia = pin.Inertia(m, np.array([0.0, 0.0, -length / 2]),
                          np.diag([side, side, 0.5 * m * radius**2]))
    for k in range(n):
        joint = pin.JointModelRX() if k % 2 == 0 else pin.JointModelRY()
        place = pin.SE3(np.eye(3), np.array([0.0, 0.0, -length if k else 0.0]))
        parent = model.addJoint(parent, joint, place, f"q{k + 1}")
        model.appendBodyToJoint(parent, inertia, pin.SE3.Identity())
    model.gravity.linear = np.array([0.0, 0.0, -9.81])
    return model


def main():
    try:
        import lagrangian as lg

        chain = getattr(lg.scenes, "spatial_chain", None)
    except ImportError:
        chain = None
    print("N   pin.aba per call (µs, from Python)   max |q̈ − lagrangian's|")
    for n in (2, 4, 8, 16, 32):
        model = arm(n)
        data = model.createData()
        q = np.array([0.5 * np.sin(0.7 * i) for i in range(n)])
        v = np.array([0.3 * np.cos(1.3 * i) for i in range(n)])
        tau = np.zeros(n)
        a = pin.aba(model, data, q, v, tau)
        diff = float("nan")
        if chain is not None:
            scene = chain(masses=[1.0] * n, lengths=[0.5] * n, radius=0.05)
            diff = float(np.max(np.abs(scene.accelerations(0.0, q, v) - a)))
        reps = 20000
        best = min(timeit.repeat(lambda: pin.aba(model, data, q, v, tau), number=reps, repeat=5))
        print(f"{n:<3d} {best / reps * 1e6:10.3f}                          {diff:.1e}")


if __name__ == "__main__":
    main()
