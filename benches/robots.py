"""Robots from URDF against Pinocchio: the cost of one evaluation of the forward dynamics.

(a) The UR5 and the Panda of example-robot-data: ``model.accelerations(t, q, q̇)`` of
    ``lg.Model.from_urdf`` against ``pin.aba(model, data, q, v, τ)``, both called from Python
    at the same states (τ = −d q̇, the joint damping lagrangian's model carries), the median over
    many calls; and lagrangian's batch form (k states as rows in one call), per state.
(b) A spatial chain of N links (N = 2 … 32; revolute joints about z, y, x in turn, offsets off
    the axes), generated as URDF: lagrangian's build time (``from_urdf``: parse, derive T on the
    expression graph, derive eq. 55 and compile it to machine code) against Pinocchio's
    (``buildModelFromXML``), and the per-call costs as in (a).

Run with Pinocchio installed (``pip install pin example-robot-data``) and the package built:

    python benches/robots.py [--figure docs/site/_static/robots.png] [--markdown benches/robots.md]

Not a test: timings depend on the machine and its load. Each case is timed once (a median of
many calls); the two libraries' calls alternate in rounds so that a change of load hits both.
"""

import argparse
import importlib.metadata
import os
import statistics
import sys
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402
import pinocchio as pin  # noqa: E402

import lagrangian as lg  # noqa: E402

ROBOTS = {"UR5": "ur_description/urdf/ur5_robot.urdf",
          "Panda": "panda_description/urdf/panda.urdf"}
CHAIN = (2, 4, 8, 16, 32)
BATCH = 1000


def robots_dir() -> Path:
    dist = importlib.metadata.distribution("example-robot-data")
    return Path(str(dist.locate_file("cmeel.prefix/share/example-robot-data/robots")))


def chain_urdf(n: int) -> str:
    """An N-link spatial arm: links 0.3 m long along z with their centres off the axis, joints
    about z, y, x in turn, each placed with a small turn so no two axes stay parallel."""
    axes = ("0 0 1", "0 1 0", "1 0 0")
    links = ['<link name="base"/>']
    joints = []
    for i in range(n):
        m = 1.0 - 0.5 * i / max(n, 1)
        links.append(
            f'<link name="link{i}"><inertial><origin xyz="0.01 -0.005 0.15" rpy="0.1 0 0.2"/>'
            f'<mass value="{m:.4f}"/><inertia ixx="{0.008 * m:.6f}" ixy="0.0001" ixz="0" '
            f'iyy="{0.0075 * m:.6f}" iyz="0" izz="{0.001 * m:.6f}"/></inertial></link>')
        parent = "base" if i == 0 else f"link{i - 1}"
        z = 0.0 if i == 0 else 0.3
        joints.append(
            f'<joint name="j{i}" type="revolute"><parent link="{parent}"/>'
            f'<child link="link{i}"/><origin xyz="0.02 0 {z}" rpy="0.05 -0.03 0.1"/>'
            f'<axis xyz="{axes[i % 3]}"/><dynamics damping="0.01"/>'
            f'<limit lower="-3" upper="3" effort="10" velocity="5"/></joint>')
    return f'<robot name="chain{n}">' + "".join(links + joints) + "</robot>"


def per_call(f, calls: int, rounds: int) -> list:
    """Seconds per call of ``f()`` over ``rounds`` rounds of ``calls`` calls each."""
    out = []
    for _ in range(rounds):
        t0 = time.perf_counter()
        for _ in range(calls):
            f()
        out.append((time.perf_counter() - t0) / calls)
    return out


def compare(model: lg.Model, pmodel, seed: int = 0, calls: int = 2000, rounds: int = 15):
    """Median seconds per call: lagrangian one state, lagrangian per state of a batch, pin.aba;
    and the largest deviation of q̈ over the batch's first 10 states (relative to max |q̈|)."""
    data = pmodel.createData()
    rng = np.random.default_rng(seed)
    n = model.dof
    qs = rng.uniform(-np.pi, np.pi, (BATCH, n))
    vs = rng.uniform(-2.0, 2.0, (BATCH, n))
    d = np.asarray(pmodel.damping)
    taus = -d * vs
    q, v, tau = qs[0].copy(), vs[0].copy(), taus[0].copy()
    dev = 0.0
    for k in range(10):
        a = pin.aba(pmodel, data, qs[k], vs[k], taus[k])
        b = model.accelerations(0.0, qs[k], vs[k])
        dev = max(dev, float(np.max(np.abs(a - b)) / max(1.0, np.max(np.abs(a)))))
    lag, batch, aba = [], [], []
    for _ in range(rounds):  # alternate, one round each
        lag += per_call(lambda: model.accelerations(0.0, q, v), calls, 1)
        aba += per_call(lambda: pin.aba(pmodel, data, q, v, tau), calls, 1)
        batch += [x / BATCH for x in per_call(lambda: model.accelerations(0.0, qs, vs), 3, 1)]
    return statistics.median(lag), statistics.median(batch), statistics.median(aba), dev


def us(x: float) -> str:
    return f"{x * 1e6:.2f}" if x < 1e-4 else f"{x * 1e6:.0f}"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--figure", default=None)
    parser.add_argument("--markdown", default=None)
    parser.add_argument("--replot", default=None, metavar="MARKDOWN",
                        help="redraw --figure from the chain table of an earlier run, no timing")
    args = parser.parse_args()
    if args.replot:
        figure(chain_rows(Path(args.replot).read_text()), args.figure or "robots.png")
        return
    lines = [f"lagrangian {lg.__version__}, Pinocchio {pin.__version__}, Python "
             f"{sys.version.split()[0]}; medians; μs = microseconds.", ""]

    lines += ["| robot | dof | lagrangian build (s) | Pinocchio build (ms) | lagrangian "
              "accelerations (μs/call) | lagrangian, batch of 1000 (μs/state) | pin.aba "
              "(μs/call) | call ratio | batch ratio | max rel. dev. of q̈ |",
              "|---|---|---|---|---|---|---|---|---|---|"]
    rows = []
    for name, rel in ROBOTS.items():
        path = str(robots_dir() / rel)
        t0 = time.perf_counter()
        model = lg.Model.from_urdf(path)
        build = time.perf_counter() - t0
        t0 = time.perf_counter()
        pmodel = pin.buildModelFromUrdf(path)
        pbuild = time.perf_counter() - t0
        lag, batch, aba, dev = compare(model, pmodel)
        lines.append(f"| {name} | {model.dof} | {build:.2f} | {pbuild * 1e3:.1f} | {us(lag)} | "
                     f"{us(batch)} | {us(aba)} | {lag / aba:.1f} | {batch / aba:.2f} | "
                     f"{dev:.1e} |")
        print(lines[-1], flush=True)
    lines += ["", "| chain N | lagrangian build (s) | build, velocities=\"bodies\" (s) | "
              "Pinocchio build (ms) | lagrangian "
              "accelerations (μs/call) | lagrangian, batch of 1000 (μs/state) | pin.aba "
              "(μs/call) | call ratio | batch ratio | max rel. dev. of q̈ |",
              "|---|---|---|---|---|---|---|---|---|---|"]
    for n in CHAIN:
        text = chain_urdf(n)
        slow = "—"
        if n <= 8:
            t0 = time.perf_counter()
            lg.Model.from_urdf(text, velocities="bodies")
            slow = f"{time.perf_counter() - t0:.2f}"
        t0 = time.perf_counter()
        model = lg.Model.from_urdf(text)
        build = time.perf_counter() - t0
        t0 = time.perf_counter()
        pmodel = pin.buildModelFromXML(text)
        pbuild = time.perf_counter() - t0
        calls = 2000 if n <= 8 else 300
        lag, batch, aba, dev = compare(model, pmodel, calls=calls, rounds=9)
        rows.append((n, build, pbuild, lag, batch, aba))
        lines.append(f"| {n} | {build:.2f} | {slow} | {pbuild * 1e3:.1f} | {us(lag)} | "
                     f"{us(batch)} | "
                     f"{us(aba)} | {lag / aba:.1f} | {batch / aba:.2f} | {dev:.1e} |")
        print(lines[-1], flush=True)
    text = "\n".join(lines) + "\n"
    print(text)
    if args.markdown:
        Path(args.markdown).write_text(text)
    if args.figure:
        figure(rows, args.figure)


def chain_rows(markdown: str) -> list:
    """(N, build, Pinocchio build, call, batch, aba) in seconds from the chain table."""
    rows = []
    for line in markdown.splitlines():
        cells = [c.strip() for c in line.strip("|").split("|")]
        if len(cells) == 10 and cells[0].isdigit():
            rows.append((int(cells[0]), float(cells[1]), float(cells[3]) / 1e3,
                         float(cells[4]) / 1e6, float(cells[5]) / 1e6, float(cells[6]) / 1e6))
    return rows


def figure(rows, path: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    n = [r[0] for r in rows]
    fig, (left, right) = plt.subplots(1, 2, figsize=(10, 4))
    left.loglog(n, [r[3] * 1e6 for r in rows], "o-", label="lagrangian, one call")
    left.loglog(n, [r[4] * 1e6 for r in rows], "s-", label="lagrangian, per state of a batch")
    left.loglog(n, [r[5] * 1e6 for r in rows], "^-", label="pin.aba, one call")
    left.set_xlabel("links N")
    left.set_ylabel("μs per evaluation of q̈")
    left.set_title("forward dynamics of an N-link spatial chain")
    left.legend()
    right.loglog(n, [r[1] for r in rows], "o-", label="lagrangian: from_urdf (derive, compile)")
    right.loglog(n, [r[2] for r in rows], "^-", label="Pinocchio: buildModelFromXML")
    right.set_xlabel("links N")
    right.set_ylabel("build time (s)")
    right.set_title("building the model")
    right.legend()
    for ax in (left, right):
        ax.minorticks_off()
        ax.set_xticks(n)
        ax.set_xticklabels([str(k) for k in n])
        ax.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


if __name__ == "__main__":
    main()
