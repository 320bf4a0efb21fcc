#!/usr/bin/env python3
"""Print the tables of `cargo bench -p lagrangian-benches --bench integrators` as Markdown (AD
route ÷ closed form, and against the ode_solvers crate's DOP853).

Reads criterion's estimates (medians) from target/criterion (or $CARGO_TARGET_DIR/criterion) and
the tolerances the bench chose from integrators_meta.json there; all numbers come from the same
bench run, so the ratios are comparable even on a noisy machine.
"""
import json
import os
import sys
from pathlib import Path

root = Path(os.environ.get("CARGO_TARGET_DIR", "target")) / "criterion"
STEPS = 100  # steps per timed run of the per-step groups (benches/integrators.rs)
METHODS = ["rk4", "dopri5", "dop853", "midpoint", "gauss4", "gauss6", "radau5"]
SIZES = [2, 4, 8, 16, 32]


def median_ns(*parts):
    path = root.joinpath(*parts, "new", "estimates.json")
    if not path.exists():
        sys.exit(f"missing {path}: run `cargo bench -p lagrangian-benches --bench integrators` first")
    return json.loads(path.read_text())["median"]["point_estimate"]


def us(ns):
    return f"{ns / 1000:.2f} µs" if ns < 1e6 else f"{ns / 1e6:.2f} ms"


print("Cost per step on the double pendulum (100 steps of 0.01):\n")
print("| method | closed form | AD route | AD ÷ closed |")
print("|---|---|---|---|")
for m in METHODS:
    c = median_ns("step_double_pendulum", f"closed_{m}") / STEPS
    a = median_ns("step_double_pendulum", f"ad_{m}") / STEPS
    print(f"| `{m}` | {us(c)} | {us(a)} | {a / c:.2f}× |")
ode = median_ns("step_double_pendulum", "ode_solvers_dop853") / STEPS
ours = median_ns("step_double_pendulum", "closed_dop853") / STEPS
print(
    f"\n`ode_solvers` DOP853 on the same closed form at the same step: {us(ode)} per step; "
    f"this crate's `dop853` on it: {ours / ode:.2f}× that.\n"
)

print("Cost per step on the N-pendulum (100 steps of 0.002): AD route ÷ closed form, and the AD")
print("route's cost per step:\n")
print("| N | " + " | ".join(f"`{m}`" for m in METHODS) + " | closed `dop853` ÷ `ode_solvers` |")
print("|---|" + "---|" * (len(METHODS) + 1))
for n in SIZES:
    cells = []
    for m in METHODS:
        c = median_ns("step_n_pendulum", f"closed_{m}", str(n))
        a = median_ns("step_n_pendulum", f"ad_{m}", str(n))
        cells.append(f"{a / c:.2f}× ({us(a / STEPS)})")
    ode = median_ns("step_n_pendulum", "ode_solvers_dop853", str(n))
    ours = median_ns("step_n_pendulum", "closed_dop853", str(n))
    print(f"| {n} | " + " | ".join(cells) + f" | {ours / ode:.2f}× |")

meta = json.loads((root / "integrators_meta.json").read_text())
print("\nTime to reach error 1e-8 at t = 10 on the double pendulum (θ = 0.4, 0.3 from rest), at the")
print("loosest tolerance 10^(-k/2) that does:\n")
print("| method | tolerance | steps | closed form | AD route | AD ÷ closed | closed ÷ `ode_solvers` DOP853 |")
print("|---|---|---|---|---|---|---|")
ode = median_ns("error_1e-8_double_pendulum", "ode_solvers_dop853")
for m in ["dopri5", "dop853", "radau5"]:
    if m not in meta:
        continue
    c = median_ns("error_1e-8_double_pendulum", f"closed_{m}")
    a = median_ns("error_1e-8_double_pendulum", f"ad_{m}")
    info = meta[m]
    print(
        f"| `{m}` | {info['tol']:.0e} | {int(info['steps'])} | {us(c)} | {us(a)} | {a / c:.2f}× "
        f"| {c / ode:.2f}× |"
    )
info = meta["ode_solvers_dop853"]
print(
    f"| `ode_solvers` DOP853 | {info['tol']:.0e} | {int(info['steps'])} | {us(ode)} | — | — | 1× |"
)
