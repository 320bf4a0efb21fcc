"""The eigenvalues of the benchmark bicycle's upright straight running against its speed
(docs/site/bicycle.rst), from the model's own reduced linearization at each speed:

    python docs/site/bicycle_figure.py        # writes docs/site/_static/bicycle_eigenvalues.png

and prints the table of the page (v = 0 … 10 m/s)."""

from pathlib import Path

import matplotlib
import numpy as np

import lagrangian as lg

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

HERE = Path(__file__).resolve().parent
WEAVE, CAPSIZE = 4.29238253634111, 6.02426201538837  # Meijaard et al. (2007), §5


def eigenvalues(bike: lg.Model, v: float) -> np.ndarray:
    qd = np.zeros(8)
    qd[0], qd[6], qd[7] = v, -v / 0.3, -v / 0.35
    lin = bike.linearize_steady(np.zeros(8), qd, independent=["phi", "delta"],
                                steady=["theta_r"])
    return lin.eigenvalues


def main() -> None:
    bike = lg.scenes.whipple_bicycle()
    speeds = np.linspace(0.0, 10.0, 201)
    eig = np.array([eigenvalues(bike, v) for v in speeds])
    fig, ax = plt.subplots(figsize=(7.0, 4.2))
    ax.plot(speeds, eig.real, "k.", markersize=2.5)
    imag = np.where(np.abs(eig.imag) > 1e-9, np.abs(eig.imag), np.nan)  # complex pairs only
    ax.plot(speeds, imag, ".", color="tab:blue", markersize=2.5)
    ax.plot([], [], "k.", label="Re λ")
    ax.plot([], [], ".", color="tab:blue", label="|Im λ|")
    ax.axvspan(WEAVE, CAPSIZE, color="tab:green", alpha=0.15, label="self-stable")
    ax.axhline(0.0, color="grey", linewidth=0.6)
    ax.set_xlim(0.0, 10.0)
    ax.set_ylim(-10.0, 10.0)
    ax.set_xlabel("forward speed v (m/s)")
    ax.set_ylabel("eigenvalue (1/s)")
    ax.set_title("Whipple bicycle (benchmark): lean and steer eigenvalues")
    ax.legend(loc="lower left")
    fig.tight_layout()
    out = HERE / "_static" / "bicycle_eigenvalues.png"
    fig.savefig(out, dpi=110)
    print(f"wrote {out}")
    for v in range(11):
        e = eigenvalues(bike, float(v))
        print(f"{v:4d}  " + "  ".join(f"{z.real:+.6f}{z.imag:+.6f}j" for z in e))


if __name__ == "__main__":
    main()
