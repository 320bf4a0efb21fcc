"""Parameters from measurements: the seed's damped oscillator (§4, eq. 54) and forced two-mass
system (§3.6, eq. 41–44) identified from noisy records by ``Model.fit``, with the exact Jacobian
of the runs' sensitivities.

    python3 examples/fit.py [--out DIR]

Prints the fitted values against the true ones with their standard errors, and writes
``fit_damped.png`` and ``fit_two_mass.png`` (data, fit and residuals) to DIR (default: here) when
matplotlib is installed.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

import lagrangian as lg


def damped_oscillator(rng: np.random.Generator) -> lg.Fit:
    """k and c of m ẍ + c ẋ + k x = 0 (Φ = ½ c ẋ²) from a free decay sampled 200 times."""
    x, = lg.coordinates("x")
    m, k, c = lg.parameters("m k c")
    model = lg.Model([x], kinetic=0.5 * m * x.d**2, potential=0.5 * k * x**2,
                     dissipation=0.5 * c * x.d**2, parameters={"m": 1.0, "k": 4.0, "c": 0.3})
    t = np.linspace(0.0, 15.0, 200)
    record = model.simulate([1.0], [0.0], 15.0, t_eval=t, rtol=1e-12, atol=1e-12).q
    noisy = record + 0.01 * rng.standard_normal(record.shape)
    start = time.perf_counter()
    fit = model.with_parameters(k=3.0, c=0.1).fit(
        t, noisy, {"k": 3.0, "c": 0.1}, q0=[1.0], qd0=[0.0], bounds={"c": (0.0, np.inf)}
    )
    elapsed = time.perf_counter() - start
    report("damped oscillator (noise σ = 0.01)", fit, {"k": 4.0, "c": 0.3}, elapsed)
    return fit


def forced_two_mass(rng: np.random.Generator) -> lg.Fit:
    """k₁ and k₂ of the seed's two masses under F cos Ωt (eq. 41–44) from their measured
    response, both coordinates sampled 300 times."""
    x1, x2 = lg.coordinates("x1 x2")
    m1, m2, k1, k2, F1, F2, W = lg.parameters("m1 m2 k1 k2 F1 F2 Omega")
    truth = dict(m1=1.0, m2=0.5, k1=10.0, k2=5.0, F1=1.0, F2=0.5, Omega=2.0)
    model = lg.Model([x1, x2], kinetic=0.5 * m1 * x1.d**2 + 0.5 * m2 * x2.d**2,
                     potential=0.5 * k1 * x1**2 + 0.5 * k2 * (x2 - x1) ** 2,
                     forces=[F1 * lg.cos(W * lg.t), F2 * lg.cos(W * lg.t)], parameters=truth)
    t = np.linspace(0.0, 10.0, 300)
    record = model.simulate([0.0, 0.0], [0.0, 0.0], 10.0, t_eval=t, rtol=1e-12, atol=1e-12).q
    noisy = record + 0.002 * rng.standard_normal(record.shape)
    start = time.perf_counter()
    fit = model.fit(t, noisy, {"k1": 8.0, "k2": 6.0}, q0=[0.0, 0.0], qd0=[0.0, 0.0],
                    bounds={"k1": (0.0, np.inf), "k2": (0.0, np.inf)})
    elapsed = time.perf_counter() - start
    report("forced two-mass system (noise σ = 0.002)", fit, {"k1": 10.0, "k2": 5.0}, elapsed)
    return fit


def report(title: str, fit: lg.Fit, truth: dict, elapsed: float) -> None:
    print(f"{title}: {fit.message} ({fit.nfev} runs, {elapsed * 1e3:.1f} ms)")
    for name, value in fit.parameters.items():
        sigma = fit.uncertainties[name]
        off = (value - truth[name]) / sigma
        print(f"  {name:3s} = {value:.6f} ± {sigma:.2g}   (true {truth[name]}, {off:+.1f} σ)")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("."), help="where the figures go")
    args = parser.parse_args()
    rng = np.random.default_rng(2026)
    fits = {"fit_damped.png": damped_oscillator(rng), "fit_two_mass.png": forced_two_mass(rng)}
    try:
        import matplotlib  # noqa: F401
    except ImportError:
        print("matplotlib is not installed: no figures")
        return
    args.out.mkdir(parents=True, exist_ok=True)
    for name, fit in fits.items():
        fit.plot(args.out / name)
        print(f"wrote {args.out / name}")


if __name__ == "__main__":
    main()
