"""Parameter identification (``Model.fit``): least squares on measured coordinates with the exact
Jacobian of the run's sensitivities, by SciPy's ``least_squares`` (an optional dependency, like
matplotlib).

The residuals are wᵢₐ (qₐ(tᵢ; θ) − q̃ᵢₐ) over every sample i and measured coordinate a of every
trial; their Jacobian in θ is wᵢₐ ∂qₐ(tᵢ)/∂θ, read off the sensitivities of one run per trial
(``simulate(..., sensitivities=...)``), so each iteration costs one run of the variational
system per trial and no finite differences. The covariance is s² (JᵀJ)⁻¹ at the solution, with
s² the residual variance 2·cost/(m − p) (SciPy's ``curve_fit`` convention, ``absolute_sigma``
off).
"""

from __future__ import annotations

import math
from typing import Any, Dict, Generic, List, Mapping, Optional, Tuple, TypeVar, cast

import numpy as np
import numpy.typing as npt

from ._protocols import ModelLike
from ._validate import flag, real

FloatArray = npt.NDArray[np.float64]

__all__ = ["Fit", "fit"]

# The model a fit is of (``Model``, a scene's ``SceneModel``): ``Model.fit`` is :func:`fit`.
M = TypeVar("M", bound=ModelLike)


class Fit(Generic[M]):
    """The result of :meth:`Model.fit`.

    Attributes
    ----------
    parameters : dict of str to float
        The fitted values, in the order they were given.
    uncertainties : dict of str to float
        Their standard errors, √ of the covariance's diagonal.
    covariance : numpy.ndarray, shape (p, p)
        s² (JᵀJ)⁻¹ at the solution, in the order of ``parameters`` (then, with
        ``fit_initial_state``, each trial's q0 and qd0), s² = 2·cost/(m − p) the residual
        variance of the m weighted residuals.
    initial_states : list of (numpy.ndarray, numpy.ndarray)
        Each trial's (q0, qd0): fitted with ``fit_initial_state``, else as given.
    residuals : numpy.ndarray or list of numpy.ndarray
        Weighted residuals w (q(t) − q_measured) at the solution, shape (len(t), dof) (one per
        trial for several trials).
    cost : float
        ½ Σ residuals².
    success : bool
        Whether the solver converged (see ``message``).
    message : str
        The solver's reason for stopping, and what to try when it did not converge.
    nfev, njev : int
        Runs of the model (each with its sensitivities) and Jacobians used.
    model : Model
        The model with the fitted parameters.
    """

    __slots__ = (
        "parameters",
        "uncertainties",
        "covariance",
        "initial_states",
        "residuals",
        "cost",
        "success",
        "message",
        "nfev",
        "njev",
        "model",
        "_trials",
    )

    parameters: Dict[str, float]
    uncertainties: Dict[str, float]
    covariance: FloatArray
    initial_states: List[Tuple[FloatArray, FloatArray]]
    residuals: Any
    cost: float
    success: bool
    message: str
    nfev: int
    njev: int
    model: M
    _trials: List["_Trial"]

    def data(self, trial: int = 0) -> Tuple[FloatArray, FloatArray]:
        """The sample times and measured coordinates of a trial, as fitted."""
        tr = self._trials[trial]
        return tr.t, tr.data

    def plot(self, path: Optional[Any] = None, *, trial: int = 0,
             title: Optional[str] = None) -> Any:
        """A figure of a trial: the data and the fitted run against t (the fitted values and
        their uncertainties in its title), and the weighted residuals below. Needs
        matplotlib; ``path`` also saves it (the suffix picks the format)."""
        from ._plot import plot_fit  # not loaded by `import lagrangian`

        return plot_fit(self, path, trial=trial, title=title)

    def __repr__(self) -> str:
        values = ", ".join(
            f"{k}={v:.6g} ± {self.uncertainties[k]:.2g}" for k, v in self.parameters.items()
        )
        return f"Fit({values}; success={self.success}, cost={self.cost:.3g})"


class _Trial:
    """One measured run: times, data, weights and the initial state."""

    __slots__ = ("t", "data", "weights", "q0", "qd0")

    def __init__(self, t: FloatArray, data: FloatArray, weights: FloatArray, q0: FloatArray,
                 qd0: FloatArray) -> None:
        self.t, self.data, self.weights, self.q0, self.qd0 = t, data, weights, q0, qd0


def _array(what: str, value: object, ndim: int) -> FloatArray:
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise TypeError(f"{what} must be an array of numbers") from None
    if arr.ndim != ndim:
        raise ValueError(f"{what} must have {ndim} dimension(s), not shape {arr.shape}")
    if not np.isfinite(arr).all():
        raise ValueError(f"{what} has non-finite entries: measurements must be finite numbers")
    return arr


def _trials(model: ModelLike, t: Any, q_measured: Any, q0: Any, qd0: Any,
            weights: Any) -> Tuple[List[_Trial], bool]:
    """The trials: one (arrays) or several (sequences of them, one per trial), and which."""
    n = model.dof
    several = isinstance(t, (list, tuple)) and len(t) > 0 and np.ndim(t[0]) == 1
    if not several:
        t, q_measured, q0, qd0, weights = [t], [q_measured], [q0], [qd0], [weights]
    else:
        count = len(t)
        for what, v in (("q_measured", q_measured), ("q0", q0), ("qd0", qd0)):
            if not isinstance(v, (list, tuple)) or len(v) != count:
                raise ValueError(f"{count} trials: give {what} as a list of {count}, one per trial")
        if weights is None or np.ndim(weights) == 0:
            weights = [weights] * count
        elif not isinstance(weights, (list, tuple)) or len(weights) != count:
            raise ValueError(f"{count} trials: give weights as a list of {count}, or one number")
    out = []
    for k, (tk, yk, a, b, w) in enumerate(zip(t, q_measured, q0, qd0, weights)):
        tag = f" (trial {k})" if several else ""
        times = _array(f"t{tag}", tk, 1)
        if len(times) < 1 or (np.diff(times) <= 0).any():
            raise ValueError(f"t{tag} must be strictly increasing sample times")
        data = _array(f"q_measured{tag}", yk, 2)
        if data.shape != (len(times), n):
            raise ValueError(
                f"q_measured{tag} has shape {data.shape}; {len(times)} samples of {n} "
                f"coordinates need ({len(times)}, {n})"
            )
        if a is None or b is None:
            raise ValueError(f"q0 and qd0{tag} are needed: the state at t[0] the runs start from")
        q0k, qd0k = _array(f"q0{tag}", a, 1), _array(f"qd0{tag}", b, 1)
        if q0k.shape != (n,) or qd0k.shape != (n,):
            raise ValueError(f"q0 and qd0{tag} must have {n} entries each")
        wk = np.ones_like(data) if w is None else _array(f"weights{tag}", w, np.ndim(w))
        try:
            wk = np.ascontiguousarray(np.broadcast_to(wk, data.shape))
        except ValueError:
            raise ValueError(
                f"weights{tag} of shape {np.shape(w)} do not broadcast to the data's "
                f"{data.shape}"
            ) from None
        if (wk < 0).any():
            raise ValueError(f"weights{tag} must be ≥ 0")
        out.append(_Trial(times, data, wk, q0k, qd0k))
    return out, several


def fit(
    self: M,
    t: Any,
    q_measured: Any,
    parameters: Mapping[str, float],
    *,
    q0: Any = None,
    qd0: Any = None,
    fit_initial_state: bool = False,
    weights: Any = None,
    bounds: Optional[Mapping[str, Tuple[float, float]]] = None,
    method: str = "auto",
    rtol: float = 1e-10,
    atol: float = 1e-10,
    max_nfev: Optional[int] = None,
    tolerance: float = 1e-10,
) -> "Fit[M]":
    """Fit parameters (and optionally the initial state) to measured coordinates by least
    squares, with the exact Jacobian from the run's sensitivities (see :meth:`simulate`'s
    ``sensitivities``); SciPy's ``least_squares`` (trust region, ``x_scale="jac"``) does
    the iterations. Needs SciPy.

    >>> import numpy as np, lagrangian as lg
    >>> x, = lg.coordinates("x")
    >>> k, c = lg.parameters("k c")
    >>> osc = lg.Model([x], kinetic=0.5 * x.d**2, potential=0.5 * k * x**2,
    ...                dissipation=0.5 * c * x.d**2, parameters={"k": 4.0, "c": 0.3})
    >>> t = np.linspace(0.0, 10.0, 200)
    >>> data = osc.simulate([1.0], [0.0], 10.0, t_eval=t, rtol=1e-10).q
    >>> fit = osc.fit(t, data, {"k": 3.0, "c": 0.1}, q0=[1.0], qd0=[0.0],
    ...               bounds={"c": (0.0, np.inf)})
    >>> round(fit.parameters["k"], 6), round(fit.parameters["c"], 6), fit.success
    (4.0, 0.3, True)

    Parameters
    ----------
    t : array_like, shape (m,)
        Sample times, strictly increasing; the runs start at ``t[0]``. For several trials,
        a list of such arrays, one per trial (and lists for ``q_measured``, ``q0``,
        ``qd0`` and ``weights``).
    q_measured : array_like, shape (m, dof)
        The measured coordinates at those times (finite numbers).
    parameters : mapping of str to float
        The parameters to fit and their initial guesses; the model's other parameters keep
        their values.
    q0, qd0 : array_like, shape (dof,)
        The state at ``t[0]``: known, or the initial guess with ``fit_initial_state``.
    fit_initial_state : bool
        Fit each trial's q0 and qd0 too.
    weights : float or array_like broadcasting to (m, dof), optional
        Multiply each residual (1/σ for a sample's standard deviation σ; 0 leaves a sample
        out).
    bounds : mapping of str to (low, high), optional
        Bounds of the fitted parameters (a mass is positive: ``{"m": (0, np.inf)}``); the
        guess must lie strictly inside.
    method, rtol, atol
        The runs' method and tolerances (:meth:`simulate`); the tolerances bound how well
        the parameters can be determined.
    max_nfev : int, optional
        Most runs before giving up (SciPy's default: 100 per unknown).
    tolerance : float
        SciPy's ``xtol``, ``ftol`` and ``gtol``.

    Returns
    -------
    Fit
        ``parameters``, ``uncertainties``, ``covariance`` (s²(JᵀJ)⁻¹ with the residual
        variance s², in the order of ``parameters``, then each trial's q0 and qd0),
        ``residuals``, ``cost``, ``success``, ``message``, ``initial_states``, ``model``.

    Raises
    ------
    ValueError
        For unknown parameters, non-finite data, shapes that do not match, bad bounds,
        no more samples than unknowns, or data that do not determine every unknown.
    ImportError
        Without SciPy.
    """
    model: ModelLike = self
    try:
        from scipy.optimize import least_squares  # type: ignore[import-untyped]
    except ImportError:  # pragma: no cover - scipy is a test dependency
        raise ImportError("Model.fit needs SciPy: pip install scipy") from None
    fit_initial_state = flag("fit_initial_state", fit_initial_state)
    if not isinstance(parameters, Mapping) or not parameters:
        raise ValueError("parameters: give the parameters to fit with initial guesses, "
                         "{name: guess, ...}")
    names = list(parameters)
    known = model.parameters
    for name in names:
        if name not in known:
            raise ValueError(f"{name!r} is not a parameter of the model: name one of "
                             + ", ".join(repr(p) for p in known))
    guess = np.array([real(f"parameters[{name!r}]", parameters[name]) for name in names])
    lo, hi = np.full(len(names), -np.inf), np.full(len(names), np.inf)
    for name, pair in (bounds or {}).items():
        if name not in parameters:
            raise ValueError(f"bounds for {name!r}, which is not among the parameters fitted")
        try:
            a, b = pair
        except (TypeError, ValueError):
            raise ValueError(f"bounds[{name!r}] must be a pair (low, high)") from None
        i = names.index(name)
        lo[i], hi[i] = float(a), float(b)
        if not lo[i] < hi[i]:
            raise ValueError(f"bounds[{name!r}] = ({a}, {b}): low must be below high")
        if not lo[i] < guess[i] < hi[i]:
            raise ValueError(
                f"the guess {name} = {guess[i]} lies outside its bounds ({a}, {b}): start "
                "strictly inside them"
            )
    trials, several = _trials(model, t, q_measured, q0, qd0, weights)
    n, p = model.dof, len(names)
    wanted = names + (["q0", "qd0"] if fit_initial_state else [])
    x0 = [guess]
    if fit_initial_state:
        x0 += [np.concatenate([tr.q0, tr.qd0]) for tr in trials]
        lo = np.concatenate([lo] + [np.full(2 * n, -np.inf)] * len(trials))
        hi = np.concatenate([hi] + [np.full(2 * n, np.inf)] * len(trials))
    x_start = np.concatenate(x0)
    m = sum(int(np.count_nonzero(tr.weights)) for tr in trials)
    if m <= len(x_start):
        raise ValueError(
            f"{m} weighted samples for {len(x_start)} unknowns: the fit needs more samples "
            "than unknowns"
        )
    cache: Dict[str, Any] = {}

    def unpack(x: FloatArray) -> Tuple[Dict[str, float], List[Tuple[FloatArray, FloatArray]]]:
        values = {name: float(v) for name, v in zip(names, x[:p])}
        states = []
        for k, tr in enumerate(trials):
            if fit_initial_state:
                at = p + 2 * n * k
                states.append((x[at : at + n], x[at + n : at + 2 * n]))
            else:
                states.append((tr.q0, tr.qd0))
        return values, states

    def evaluate(x: FloatArray) -> Tuple[FloatArray, FloatArray]:
        key = x.tobytes()
        if cache.get("key") == key:
            return cache["r"], cache["J"]
        values, states = unpack(x)
        current = model.with_parameters(**values)
        rs, js = [], []
        for k, (tr, (a, b)) in enumerate(zip(trials, states)):
            sol = current.simulate(
                a, b, float(tr.t[-1]), t0=float(tr.t[0]), t_eval=tr.t, method=method,
                rtol=rtol, atol=atol, sensitivities=wanted,
            )
            if len(sol.t) != len(tr.t):
                raise RuntimeError(
                    f"the run of trial {k} stopped at t = {sol.t[-1]} before the last sample "
                    f"({sol.message}) at {values}"
                )
            w = tr.weights
            rs.append((w * (sol.q - tr.data)).ravel())
            jac = np.zeros((len(tr.t) * n, len(x)))
            sens: Dict[str, FloatArray] = sol.sensitivities or {}
            for j, name in enumerate(names):
                jac[:, j] = (w * sens[name][:, :n]).ravel()
            if fit_initial_state:
                at = p + 2 * n * k
                for which, off in (("q0", 0), ("qd0", n)):
                    s = sens[which][:, :n, :]  # (len(t), n: ∂q, n: direction)
                    jac[:, at + off : at + off + n] = (w[:, :, None] * s).reshape(-1, n)
            js.append(jac)
        r, jac_all = np.concatenate(rs), np.vstack(js)
        cache.update(key=key, r=r, J=jac_all)
        return r, jac_all

    result = least_squares(
        lambda x: evaluate(x)[0],
        x_start,
        jac=lambda x: evaluate(x)[1],
        bounds=(lo, hi),
        method="trf",
        x_scale="jac",
        xtol=tolerance,
        ftol=tolerance,
        gtol=tolerance,
        max_nfev=max_nfev,
    )
    r, jac = evaluate(result.x)
    values, states = unpack(result.x)
    covariance = _covariance(jac, r, m)
    out: Fit[M] = Fit()
    out.parameters = values
    diag = np.diag(covariance)
    out.uncertainties = {name: float(math.sqrt(max(diag[j], 0.0))) for j, name in
                         enumerate(names)}
    out.covariance = covariance
    out.initial_states = [(np.array(a, dtype=np.float64), np.array(b, dtype=np.float64))
                          for a, b in states]
    shaped, at = [], 0
    for tr in trials:
        size = tr.data.size
        shaped.append(r[at : at + size].reshape(tr.data.shape))
        at += size
    out.residuals = shaped if several else shaped[0]
    out.cost = float(0.5 * r @ r)
    out.success = bool(result.success) and result.status > 0
    out.message = str(result.message)
    if not out.success:
        out.message += (
            " — the fit did not converge: try a better guess, bounds, more evaluations "
            "(max_nfev) or fewer unknowns"
        )
    out.nfev, out.njev = int(result.nfev), int(result.njev or 0)
    # A scene's model rebinds as a scene: the same class as the model fitted.
    out.model = cast(M, model.with_parameters(**values))
    out._trials = trials
    return out


def _covariance(jac: FloatArray, r: FloatArray, m: int) -> FloatArray:
    """s² (JᵀJ)⁻¹ with s² = |r|²/(m − p), by the SVD of J; ``ValueError`` when JᵀJ is singular
    (an unknown the data do not determine)."""
    p = jac.shape[1]
    _, sv, vt = np.linalg.svd(jac, full_matrices=False)
    threshold = np.finfo(np.float64).eps * max(jac.shape) * (sv[0] if sv.size else 0.0)
    if sv.size < p or (sv <= threshold).any():
        raise ValueError(
            "the data do not determine every unknown (JᵀJ is singular): fix some parameters, "
            "or measure what they change"
        )
    s2 = float(r @ r) / (m - p)
    inv = (vt.T / sv**2) @ vt
    cov: FloatArray = s2 * inv
    return cov
