"""Rigid bodies in three dimensions: the benchmark bicycle, a top and a two-link arm from URDF.

    python3 examples/bodies.py [--out DIR]

1. The Whipple bicycle of Meijaard et al. (2007), four bodies on two rolling wheels: its
   linearization in lean and steer about upright running, the weave and capsize speeds between
   which it steers itself upright, and a nonlinear run at 5 m/s whose lean dies out at the rate
   of the linear eigenvalue.
2. The heavy symmetric top from three revolute frames: a nutating run, its energy kept, and a
   3D picture of the body (``top.png``) when matplotlib is installed.
3. A two-link arm read from URDF text (no file needed), swinging from rest.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np
from scipy.optimize import brentq

import lagrangian as lg

ARM = """<robot name="arm">
  <link name="base"/>
  <link name="upper"><inertial><origin xyz="0 0 -0.25"/><mass value="2"/>
    <inertia ixx="0.042" ixy="0" ixz="0" iyy="0.042" iyz="0" izz="0.002"/></inertial></link>
  <link name="lower"><inertial><origin xyz="0 0 -0.2"/><mass value="1"/>
    <inertia ixx="0.014" ixy="0" ixz="0" iyy="0.014" iyz="0" izz="0.001"/></inertial></link>
  <joint name="shoulder" type="revolute"><parent link="base"/><child link="upper"/>
    <axis xyz="0 1 0"/><limit lower="-3" upper="3" effort="10" velocity="5"/></joint>
  <joint name="elbow" type="revolute"><parent link="upper"/><child link="lower"/>
    <origin xyz="0 0 -0.5"/><axis xyz="0 1 0"/>
    <limit lower="-3" upper="3" effort="10" velocity="5"/></joint>
</robot>"""


def bicycle() -> None:
    start = time.perf_counter()
    bike = lg.scenes.whipple_bicycle()
    built = time.perf_counter() - start

    def upright(v: float) -> lg.SteadyLinearization:
        qd = np.zeros(8)
        qd[0], qd[6], qd[7] = v, -v / 0.3, -v / 0.35
        return bike.linearize_steady(np.zeros(8), qd, independent=["phi", "delta"],
                                     steady=["theta_r"])

    def growth(v: float) -> float:
        return float(np.max(upright(v).eigenvalues.real))

    weave = brentq(growth, 4.0, 5.0, xtol=1e-12)
    capsize = brentq(growth, 5.5, 6.5, xtol=1e-12)
    print(f"Whipple bicycle: built in {built:.2f} s; self-stable from the weave speed "
          f"{weave:.6f} m/s to the capsize speed {capsize:.6f} m/s "
          "(Meijaard et al. 2007: 4.292383, 6.024262)")
    lin = upright(5.0)
    slowest = lin.eigenvalues[np.argmax(lin.eigenvalues.real)]
    print(f"  at 5 m/s the slowest mode decays at {slowest.real:.6f} 1/s")
    # Released at 5 m/s leaning by 1 mrad, projected onto the constraints (the pitch and the
    # wheels' rates follow): the lean dies out at the slowest mode's rate.
    q0, qd0 = np.zeros(8), np.zeros(8)
    q0[3] = 1e-3
    qd0[0], qd0[6], qd0[7] = 5.0, -5.0 / 0.3, -5.0 / 0.35
    q0, qd0 = bike.project(q0, qd0)
    sol = bike.simulate(q0, qd0, t_end=15.0, rtol=1e-10, atol=1e-12,
                        t_eval=np.linspace(0.0, 15.0, 301))
    lean = np.abs(sol.q[:, 3])
    late = sol.t >= 8.0
    rate = np.polyfit(sol.t[late], np.log(lean[late]), 1)[0]
    print(f"  nonlinear run: the lean decays at {rate:.4f} 1/s from t = 8 to 15 "
          f"(linear {slowest.real:.4f}); |lean| at 15 s: {lean[-1]:.2e} rad")


def top(out: Path) -> None:
    model = lg.scenes.spinning_top()
    sol = model.simulate([0.0, 0.5, 0.0], [0.0, 0.0, 60.0], t_end=2.0, rtol=1e-10, atol=1e-10)
    drift = float(np.max(np.abs(sol.energy - sol.energy[0])))
    th = sol.q[:, 1]
    print(f"Spinning top: nutation between θ = {th.min():.4f} and {th.max():.4f} rad, "
          f"energy kept to {drift:.1e}")
    try:
        import matplotlib

        matplotlib.use("Agg")
    except ImportError:
        return
    motion = model.body_motion(sol)
    motion.plot(out / "top.png", snapshots=4)
    print(f"  wrote {out / 'top.png'}")


def arm() -> None:
    robot = lg.Model.from_urdf(ARM)
    sol = robot.simulate([1.0, 0.0], [0.0, 0.0], t_end=1.0, rtol=1e-10, atol=1e-10,
                         t_eval=np.linspace(0.0, 1.0, 11))
    print(f"Two-link arm from URDF: coordinates {[c.name for c in robot.coordinates]}; "
          f"elbow at t = 1: {sol.q[-1, 1]:+.4f} rad")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("."), help="folder for the picture")
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    bicycle()
    top(args.out)
    arm()


if __name__ == "__main__":
    main()
