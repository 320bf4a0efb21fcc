#!/usr/bin/env python3
"""Andrews' squeezing mechanism (issue 41 item 8; the IVP Test Set's ``andrews``, Mazzia,
Magherini & Iavernaro, ``andrews.f``) to a relative error of 1e-7 in q at t = 0.03, side by
side:

- SciPy's ``solve_ivp(method="DOP853")`` on a hand-written NumPy index-1 right-hand side (the
  Test Set's M, f, G and γ, the 13 × 13 augmented system solved per evaluation);
- with ``--cargo``: ``cargo bench -p lagrangian-benches --bench constrained --features jit``
  (about 45 s with the bench built), whose five Rust sides are read from criterion's estimates and
  ``andrews_meta.json``: the hand-written index-1 right-hand side with ``ode_solvers``' DOP853
  (the limit) and with this crate's DOP853, and this crate's model from the energies and the
  constraints (``lagrangian::scenes::Andrews::model``), by dual numbers and with M and f from the
  traced, compiled eq. 55 program, and with G and γ also from the compiled constraints; without
  it, the last bench run's numbers
  if there are any;
- this project through its Python API (``lg.Model(..., constraints=[...])``), when the module is
  installed and has constraints (``lagrangian_model`` below).

Each side runs at the loosest tolerance 10^{-k/2} (rtol = atol) that meets the target; the time
is the best of several runs. Prints a Markdown table with every side's ratio to the limit and
SciPy's ratio to each side.

    CARGO_TARGET_DIR=/work/target python3 benches/andrews.py --cargo

Not a test: timings depend on the machine and its load.
"""

import json
import os
import subprocess
import sys
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402
from scipy.integrate import solve_ivp  # noqa: E402

TARGET = 1e-7
T_END = 0.03

# The Test Set's parameters (andrews.f, andpar).
m1, m2, m3, m4, m5, m6, m7 = 0.04325, 0.00365, 0.02373, 0.00706, 0.07050, 0.00706, 0.05498
i1, i2, i3, i4, i5, i6, i7 = 2.194e-6, 4.410e-7, 5.255e-6, 5.667e-7, 1.169e-5, 5.667e-7, 1.912e-5
xa, ya, xb, yb, xc, yc = -0.06934, -0.00227, -0.03635, 0.03273, 0.014, 0.072
d, da, e, ea, rr, ra = 28e-3, 115e-4, 2e-2, 1421e-5, 7e-3, 92e-5
ss, sa, sb, sc, sd = 35e-3, 1874e-5, 1043e-5, 18e-3, 2e-2
ta, tb, u, ua, ub = 2308e-5, 916e-5, 4e-2, 1228e-5, 449e-5
zf, zt, fa, mom, c0, l0 = 2e-2, 4e-2, 1421e-5, 0.033, 4530.0, 0.07785

# The Test Set's consistent initial values (andini) and reference q at t = 0.03 (andsoln).
Q0 = np.array([-0.0617138900142764496358948458001, 0.0, 0.455279819163070380255912382449,
               0.222668390165885884674473185609, 0.487364979543842550225598953530,
               -0.222668390165885884674473185609, 1.23054744454982119249735015568])
Q_REF = np.array([0.1581077119629904e2, -0.1575637105984298e2, 0.4082224013073101e-1,
                  -0.5347301163226948, 0.5244099658805304, 0.5347301163226948,
                  0.1048080741042263e1])


def index1_rhs(_t: float, y: np.ndarray) -> np.ndarray:
    """y = (q, q̇); q̈ from [M Gᵀ; G 0] (q̈, λ) = (f, −γ): the Test Set's M, f, G, γ."""
    q, v = y[:7], y[7:]
    be, th, ga, ph, de, om, ep = q
    bep, thp, gap, php, dep, omp, epp = v
    sibe, cobe = np.sin(be), np.cos(be)
    sith, coth = np.sin(th), np.cos(th)
    siga, coga = np.sin(ga), np.cos(ga)
    siph, coph = np.sin(ph), np.cos(ph)
    side, code = np.sin(de), np.cos(de)
    siom, coom = np.sin(om), np.cos(om)
    siep, coep = np.sin(ep), np.cos(ep)
    sibeth, cobeth = np.sin(be + th), np.cos(be + th)
    siphde, cophde = np.sin(ph + de), np.cos(ph + de)
    siomep, coomep = np.sin(om + ep), np.cos(om + ep)

    a = np.zeros((13, 13))
    m = a[:7, :7]
    m[0, 0] = m1 * ra**2 + m2 * (rr**2 - 2 * da * rr * coth + da**2) + i1 + i2
    m[1, 0] = m[0, 1] = m2 * (da**2 - da * rr * coth) + i2
    m[1, 1] = m2 * da**2 + i2
    m[2, 2] = m3 * (sa**2 + sb**2) + i3
    m[3, 3] = m4 * (e - ea)**2 + i4
    m[4, 3] = m[3, 4] = m4 * ((e - ea)**2 + zt * (e - ea) * siph) + i4
    m[4, 4] = m4 * (zt**2 + 2 * zt * (e - ea) * siph + (e - ea)**2) + m5 * (ta**2 + tb**2) + i4 + i5
    m[5, 5] = m6 * (zf - fa)**2 + i6
    m[6, 5] = m[5, 6] = m6 * ((zf - fa)**2 - u * (zf - fa) * siom) + i6
    m[6, 6] = m6 * ((zf - fa)**2 - 2 * u * (zf - fa) * siom + u**2) + m7 * (ua**2 + ub**2) + i6 + i7

    xd = sd * coga + sc * siga + xb
    yd = sd * siga - sc * coga + yb
    lang = np.sqrt((xd - xc)**2 + (yd - yc)**2)
    force = -c0 * (lang - l0) / lang
    fx, fy = force * (xd - xc), force * (yd - yc)
    b = np.empty(13)
    b[0] = mom - m2 * da * rr * thp * (thp + 2 * bep) * sith
    b[1] = m2 * da * rr * bep**2 * sith
    b[2] = fx * (sc * coga - sd * siga) + fy * (sd * coga + sc * siga)
    b[3] = m4 * zt * (e - ea) * dep**2 * coph
    b[4] = -m4 * zt * (e - ea) * php * (php + 2 * dep) * coph
    b[5] = -m6 * u * (zf - fa) * epp**2 * coom
    b[6] = m6 * u * (zf - fa) * omp * (omp + 2 * epp) * coom

    g = a[7:, :7]
    g[0::2, 0] = -rr * sibe + d * sibeth
    g[0::2, 1] = d * sibeth
    g[1::2, 0] = rr * cobe - d * cobeth
    g[1::2, 1] = -d * cobeth
    g[0, 2], g[1, 2] = -ss * coga, -ss * siga
    g[2, 3], g[2, 4] = -e * cophde, -e * cophde + zt * side
    g[3, 3], g[3, 4] = -e * siphde, -e * siphde - zt * code
    g[4, 5], g[4, 6] = zf * siomep, zf * siomep - u * coep
    g[5, 5], g[5, 6] = -zf * coomep, -zf * coomep - u * siep
    a[:7, 7:] = g.T

    # γ: the constraints' second derivative along the motion with q̈ = 0.
    cx = d * cobeth * (bep + thp)**2 - rr * cobe * bep**2
    cy = d * sibeth * (bep + thp)**2 - rr * sibe * bep**2
    b[7] = -(cx + ss * siga * gap**2)
    b[8] = -(cy - ss * coga * gap**2)
    b[9] = -(cx + e * siphde * (php + dep)**2 + zt * code * dep**2)
    b[10] = -(cy - e * cophde * (php + dep)**2 + zt * side * dep**2)
    b[11] = -(cx + zf * coomep * (omp + epp)**2 + u * siep * epp**2)
    b[12] = -(cy + zf * siomep * (omp + epp)**2 - u * coep * epp**2)

    out = np.empty(14)
    out[:7] = v
    out[7:] = np.linalg.solve(a, b)[:7]
    return out


def error(q: np.ndarray) -> float:
    """Largest componentwise relative error of q against the Test Set's reference at 0.03."""
    return float(np.max(np.abs(q - Q_REF) / np.abs(Q_REF)))


def best_of(run, budget: float, at_most: int = 20) -> float:
    """Best wall time of `run()` over repeats within about `budget` seconds."""
    best = float("inf")
    spent = 0.0
    for _ in range(at_most):
        start = time.perf_counter()
        run()
        took = time.perf_counter() - start
        best = min(best, took)
        spent += took
        if spent > budget:
            break
    return best


def loosest(run):
    """The loosest tolerance 10^{-k/2} (k = 8..=28) whose q(0.03) meets TARGET: (tol, error)."""
    for k in range(8, 29):
        tol = 10.0 ** (-k / 2)
        q = run(tol)
        if q is not None and error(q) <= TARGET:
            return tol, error(q)
    return None


def scipy_side():
    y0 = np.concatenate([Q0, np.zeros(7)])

    def run(tol: float):
        sol = solve_ivp(index1_rhs, (0.0, T_END), y0, method="DOP853", rtol=tol, atol=tol)
        return sol.y[:7, -1]

    found = loosest(run)
    if found is None:
        return None
    tol, err = found
    seconds = best_of(lambda: run(tol), budget=4.0, at_most=10)
    return {"side": "SciPy DOP853, NumPy index-1 RHS", "tol": tol, "error": err, "seconds": seconds}


def squeezer_expressions(lg):
    """The squeezer in this project's expressions: the coordinates, T (the bodies' ½ m v² +
    ½ I ω²), U (spring and torque) and the six loop closures g(q)."""
    be, th, ga, ph, de, om, ep = lg.coordinates("beta theta gamma phi delta omega epsilon")
    bt, pd, oe = be.d + th.d, ph.d + de.d, om.d + ep.d
    v2 = rr**2 * be.d**2 + da**2 * bt**2 - 2 * rr * da * lg.cos(th) * be.d * bt
    v4 = zt**2 * de.d**2 + (e - ea)**2 * pd**2 + 2 * zt * (e - ea) * lg.sin(ph) * de.d * pd
    v6 = u**2 * ep.d**2 + (zf - fa)**2 * oe**2 - 2 * u * (zf - fa) * lg.sin(om) * ep.d * oe
    kinetic = 0.5 * ((m1 * ra**2 + i1) * be.d**2 + m2 * v2 + i2 * bt**2
                     + (m3 * (sa**2 + sb**2) + i3) * ga.d**2 + m4 * v4 + i4 * pd**2
                     + (m5 * (ta**2 + tb**2) + i5) * de.d**2 + m6 * v6 + i6 * oe**2
                     + (m7 * (ua**2 + ub**2) + i7) * ep.d**2)
    xd = sd * lg.cos(ga) + sc * lg.sin(ga) + xb
    yd = sd * lg.sin(ga) - sc * lg.cos(ga) + yb
    lang = lg.sqrt((xd - xc)**2 + (yd - yc)**2)
    potential = 0.5 * c0 * (lang - l0)**2 - mom * be
    cx = rr * lg.cos(be) - d * lg.cos(be + th)
    cy = rr * lg.sin(be) - d * lg.sin(be + th)
    constraints = [
        cx - ss * lg.sin(ga) - xb,
        cy + ss * lg.cos(ga) - yb,
        cx - e * lg.sin(ph + de) - zt * lg.cos(de) - xa,
        cy + e * lg.cos(ph + de) - zt * lg.sin(de) - ya,
        cx - zf * lg.cos(om + ep) - u * lg.sin(ep) - xa,
        cy - zf * lg.sin(om + ep) + u * lg.cos(ep) - ya,
    ]
    return [be, th, ga, ph, de, om, ep], kinetic, potential, constraints


def lagrangian_model():
    """The squeezer through this project's Python API, ``lg.Model(..., constraints=[...])``.
    None when the module or its constraints API (issue 41 item 1) is not installed: then the
    table leaves its row out, and it appears by itself once that API is merged."""
    try:
        import lagrangian as lg
    except ImportError:
        return None
    coordinates, kinetic, potential, constraints = squeezer_expressions(lg)
    try:
        return lg.Model(coordinates=coordinates, kinetic=kinetic, potential=potential,
                        constraints=constraints)
    except TypeError:
        # lg.Model without a `constraints` keyword: the Python constraints API is not merged.
        return None


def lagrangian_side():
    model = lagrangian_model()
    if model is None:
        return None

    def run(tol: float):
        sol = model.simulate(Q0, np.zeros(7), T_END, method="dop853", rtol=tol, atol=tol)
        return np.asarray(sol.q)[-1]

    found = loosest(run)
    if found is None:
        return None
    tol, err = found
    seconds = best_of(lambda: run(tol), budget=4.0)
    return {"side": "lagrangian (Python API), DOP853", "tol": tol, "error": err,
            "seconds": seconds}


RUST_SIDES = {
    "ode_solvers_dop853_hand": "hand-written Rust index-1 RHS, ode_solvers DOP853 (limit)",
    "dop853_hand": "hand-written Rust index-1 RHS, lagrangian DOP853",
    "dop853_model": "lagrangian Constrained model from energies, DOP853",
    "dop853_model_compiled": "the same, M and f from the traced, compiled eq. 55 program, DOP853",
    "dop853_model_compiled_rows":
        "the same, and G, γ from the traced, compiled constraints, DOP853",
}


def rust_sides(run_cargo: bool):
    target = Path(os.environ.get("CARGO_TARGET_DIR", "target"))
    if run_cargo:
        done = subprocess.run(
            ["cargo", "bench", "-p", "lagrangian-benches", "--bench", "constrained",
             "--features", "jit"],
            capture_output=True, text=True)
        if done.returncode != 0:
            sys.exit(f"cargo bench failed:\n{done.stderr[-3000:]}")
    root = target / "criterion"
    meta_path = root / "andrews_meta.json"
    if not meta_path.exists():
        return []
    meta = json.loads(meta_path.read_text())
    rows = []
    for key, label in RUST_SIDES.items():
        est = root / "andrews_1e-7" / key / "new" / "estimates.json"
        if not meta.get(key) or not est.exists():
            continue
        ns = json.loads(est.read_text())["median"]["point_estimate"]
        rows.append({"side": label, "tol": meta[key]["tol"], "error": meta[key]["error"],
                     "seconds": ns * 1e-9, "steps": meta[key]["steps"]})
    return rows


EVALUATION = {
    "hand_index1": "hand-written index-1 q̈ (M, f, G, γ, 13 × 13 solve)",
    "model_evaluate": "model: Constrained::evaluate (q̈, λ)",
    "unconstrained_accelerations": "  of which: eq. 55 q̈₀ of the wrapped system (AD)",
    "mass_matrix": "  of which: M by AD (computed again for the Schur complement)",
    "constraint_jacobian": "  of which: G by AD",
    "gamma": "  of which: γ by AD",
    "model_compiled_evaluate":
        "model, M and f from the compiled eq. 55 program: Constrained::evaluate",
    "compiled_mass_and_force": "  of which: M and f from the compiled program (one run)",
    "model_compiled_rows_evaluate": "model, M, f, G and γ all compiled: Constrained::evaluate",
    "model_compiled_rows_accelerations":
        "  the same through Dynamics::accelerations_into (the integrators' call)",
    "compiled_rows": "  of which: G and γ from the compiled constraints (one run)",
}


def evaluation_table() -> None:
    """Where one evaluation's time goes (`andrews_evaluation` of the same bench)."""
    root = Path(os.environ.get("CARGO_TARGET_DIR", "target")) / "criterion" / "andrews_evaluation"
    times = {}
    for key in EVALUATION:
        est = root / key / "new" / "estimates.json"
        if est.exists():
            times[key] = json.loads(est.read_text())["median"]["point_estimate"]
    if "hand_index1" not in times:
        return
    print("\nOne evaluation at the reference state:\n")
    print("| part | time | ÷ hand-written |")
    print("|---|---|---|")
    for key, label in EVALUATION.items():
        if key in times:
            ratio = times[key] / times["hand_index1"]
            print(f"| {label} | {times[key] / 1e3:.2f} µs | {ratio:.2f}× |")


def main() -> None:
    run_cargo = "--cargo" in sys.argv[1:]
    rows = rust_sides(run_cargo)
    scipy = scipy_side()
    lagrangian_py = lagrangian_side()
    rows += [r for r in (lagrangian_py, scipy) if r is not None]
    if lagrangian_py is None:
        print("(lagrangian's Python API with constraints is not installed: its row is left out)")
    limit = next((r["seconds"] for r in rows if r["side"].endswith("(limit)")), None)
    print(f"Andrews' squeezer, t = 0 → {T_END}, relative error in q ≤ {TARGET:g} "
          "against the IVP Test Set's reference\n")
    print("| side | tol | error in q | time | ÷ limit | SciPy ÷ this |")
    print("|---|---|---|---|---|---|")
    for r in rows:
        over = f"{r['seconds'] / limit:.2f}×" if limit else "–"
        scipy_ratio = f"{scipy['seconds'] / r['seconds']:.1f}×" if scipy else "–"
        print(f"| {r['side']} | {r['tol']:.0e} | {r['error']:.1e} | "
              f"{r['seconds'] * 1e3:.3f} ms | {over} | {scipy_ratio} |")
    evaluation_table()


if __name__ == "__main__":
    main()
