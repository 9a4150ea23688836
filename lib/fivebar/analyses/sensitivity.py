r"""Global sensitivity of any scalar result to the uncertain inputs: Morris screening, Sobol indices.

The paper leaves many inputs unstated or misprinted; ``data/uncertainty.toml`` gives each a
plausible range (or a few alternative readings) with its reason (:func:`load_ranges`).  An
output is any scalar function of a :class:`fivebar.description.setup.Setup` (named ones in
:data:`SCALAR_OUTPUTS`: the midpoint peak-to-peak deflections of Figure 6, the largest Floquet
multiplier, the peak stress against yield).  Two methods of the field, both from SALib
(Herman and Usher 2017, https://salib.readthedocs.io):

* **Morris elementary effects** (:func:`morris`): ``r`` trajectories through a grid of the
  input box, one input changed at a time; for input :math:`i` the elementary effect
  :math:`EE_i = [Y(\mathbf x + \Delta\mathbf e_i) - Y(\mathbf x)] / \Delta` (inputs scaled to
  [0, 1], :math:`\Delta = p / (2(p - 1))` for ``p`` levels), its mean absolute value
  :math:`\mu^*_i` (about the change of the output over the input's range) and its spread
  :math:`\sigma_i` (nonlinearity or interaction); :math:`r(D + 1)` evaluations for D inputs.
  Inputs with a small :math:`\mu^*` are screened out (:meth:`MorrisResult.screen`).
* **Sobol indices** (:func:`sobol`): the share of the output's variance that input :math:`i`
  causes alone, :math:`S_i = V[E(Y | X_i)] / V(Y)`, and with all its interactions,
  :math:`S_{Ti} = E[V(Y | \mathbf X_{\sim i})] / V(Y)`, by Saltelli's scheme on a scrambled
  Sobol' sequence (:math:`N(D + 2)` evaluations; the estimators of Saltelli et al. 2010, Comput.
  Phys. Commun. 181: 259-270) with bootstrap confidence intervals.  ``N`` is doubled (the
  points already evaluated are kept) until every interval is narrower than ``width``.

Results are pure functions of the arguments: the samples come from ``seed``, every evaluation
runs with one BLAS thread (threaded BLAS rounds differently with the thread count), the
evaluations are put back in the order of the sample whatever order the executor finishes them
in, and the bootstrap takes its own seed derived from ``seed``.

Evaluations run in parallel on any :class:`concurrent.futures.Executor` (a
``ProcessPoolExecutor``, or a Dask cluster's ``client.get_executor()``), with a tqdm progress
bar.  Where one evaluation is too dear for the samples the intervals need, :func:`fit_surrogate`
fits a polynomial surrogate to direct evaluations (least squares, degree chosen by
leave-one-out error); :meth:`Surrogate.validate` compares it with further direct evaluations.
"""

from __future__ import annotations

import concurrent.futures as cf
import math
import warnings
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from importlib import resources
from itertools import combinations_with_replacement
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike, NDArray
from tqdm import tqdm

from ..errors import FivebarError, InputError, number, plain, read_toml
from ..numerics.blas import blas_threads
from ..description.params import Params, load_params
from ..description.setup import Setup, as_setup

__all__ = ["SCALAR_OUTPUTS", "RANGES_PATH", "MidpointPeakToPeak", "MorrisResult", "ResonanceSpeed", "SensitivityError", "SobolResult",
           "SteadyStateOutput", "Surrogate", "UncertainInput", "apply", "evaluate", "fit_surrogate",
           "load_ranges", "morris", "morris_indices", "output", "sobol", "sobol_indices", "spread", "unit_sample"]

#: The plausible ranges shipped with the package (``fivebar/data/uncertainty.toml``).
#:
#: :meta hide-value:
RANGES_PATH = Path(str(resources.files("fivebar") / "data" / "uncertainty.toml"))


class SensitivityError(FivebarError, ValueError):
    """Bad input to a sensitivity analysis, or an evaluation that gave no usable number (the
    message names the input, the sample or the output)."""


# --- the inputs ------------------------------------------------------------------------------
@dataclass(frozen=True)
class UncertainInput:
    """One uncertain input: its dotted key, a range (uniform) or alternatives, and the reason.

    ``UncertainInput("material.E", (68e9, 72e9), reason="...")`` or
    ``UncertainInput("assumptions.gravity", choices=(0.0, 9.81), reason="...")``.  A point
    ``u`` of [0, 1] stands for ``low + u (high - low)``, or for choice ``floor(u k)`` of ``k``
    (each as likely).  ``reading``: the gap says which experiment is computed (the crank
    speed, the side of the section in the plane, the plane of motion) rather than how well a
    number is known.
    """

    key: str
    range: tuple[float, float] | None = None
    choices: tuple[Any, ...] = ()
    reason: str = ""
    reading: bool = False

    def __post_init__(self) -> None:
        if not isinstance(self.key, str) or not self.key:
            raise SensitivityError(f"key = {self.key!r} is not allowed: give the input's dotted key, e.g. 'material.E'")
        if not isinstance(self.reason, str) or not self.reason.strip():
            raise SensitivityError(f"input {self.key!r} has no reason: every range or set of alternatives must say "
                                   "where it comes from (reason = '...')")
        if (self.range is None) == (not self.choices):
            raise SensitivityError(f"input {self.key!r}: give either range = [low, high] or choices = [a, b, ...], "
                                   f"not {'both' if self.range is not None else 'neither'}")
        if self.range is not None:
            try:
                lo, hi = self.range
            except (TypeError, ValueError):
                raise SensitivityError(f"input {self.key!r}: range = {self.range!r} is not allowed: give [low, high]") from None
            lo = number(f"{self.key} range low", lo, error=SensitivityError)
            hi = number(f"{self.key} range high", hi, error=SensitivityError)
            if not lo < hi:
                raise SensitivityError(f"input {self.key!r}: range = [{lo!r}, {hi!r}] is not allowed: low must be below "
                                       "high (a fixed value is not uncertain: leave the input out)")
            object.__setattr__(self, "range", (lo, hi))
        else:
            ch = tuple(plain(c) for c in self.choices)
            if len(ch) < 2 or len(set(map(repr, ch))) != len(ch):
                raise SensitivityError(f"input {self.key!r}: choices = {list(self.choices)!r} is not allowed: give "
                                       "two or more different alternatives")
            object.__setattr__(self, "choices", ch)

    @property
    def name(self) -> str:
        """The key without its section (``"E"`` for ``"material.E"``)."""
        return self.key.split(".", 1)[-1]

    @property
    def discrete(self) -> bool:
        """True for a set of alternatives."""
        return self.range is None

    @property
    def levels(self) -> int:
        """Number of alternatives (0 for a range)."""
        return len(self.choices)

    def value(self, u: float) -> Any:
        """The input's value at the point ``u`` of [0, 1]."""
        if self.range is not None:
            lo, hi = self.range
            return lo + float(u) * (hi - lo)
        return self.choices[self.index(u)]

    def index(self, u: float | NDArray) -> Any:
        """The alternative chosen at ``u`` (0 ... k - 1; ``u = 1`` is the last one)."""
        return np.minimum((np.asarray(u) * len(self.choices)).astype(int), len(self.choices) - 1)

    def unit(self, value: Any) -> float:
        """The point of [0, 1] of ``value`` (the middle of an alternative's share); a value
        outside the range or not among the choices raises :class:`SensitivityError`."""
        if self.range is not None:
            lo, hi = self.range
            v = number(self.key, value, error=SensitivityError)
            if not lo <= v <= hi:
                raise SensitivityError(f"{self.key} = {v!r} is outside its range [{lo!r}, {hi!r}]")
            return (v - lo) / (hi - lo)
        for k, c in enumerate(self.choices):
            if c == plain(value) or (isinstance(c, float) and isinstance(plain(value), (int, float))
                                     and math.isclose(c, plain(value), rel_tol=1e-12)):
                return (k + 0.5) / len(self.choices)
        raise SensitivityError(f"{self.key} = {value!r} is not among its alternatives {list(self.choices)}")

    def describe(self) -> str:
        """The range or the alternatives as text."""
        if self.range is not None:
            return f"{self.range[0]:.4g} to {self.range[1]:.4g}"
        return " or ".join(f"{c:.4g}" if isinstance(c, float) else str(c) for c in self.choices)


def load_ranges(path: str | Path | None = None, params: Params | None = None) -> tuple[UncertainInput, ...]:
    """The uncertain inputs of a ranges file, validated.

    ``inputs = load_ranges()`` reads ``data/uncertainty.toml``.  Every ``[[input]]`` must name
    an entry of the parameter set (``params``, default the book's ``load_params()``) by its
    dotted key, give ``range = [low, high]`` with low < high or ``choices = [...]``, and a
    ``reason``; a key given twice, an unknown field or a bad entry raises
    :class:`SensitivityError` naming it.
    """
    p = Path(RANGES_PATH if path is None else path)
    doc = read_toml(p, "ranges file path", SensitivityError)
    entries = doc.get("input")
    if not isinstance(entries, list) or not entries or set(doc) != {"input"}:
        raise SensitivityError(f"ranges file {str(p)!r} must hold one or more [[input]] tables and nothing else "
                               f"(it has {sorted(doc)})")
    params = load_params() if params is None else params
    out = []
    for k, e in enumerate(entries, start=1):
        extra = set(e) - {"key", "range", "choices", "reason", "reading"}
        if extra:
            raise SensitivityError(f"{p.name}, input {k} ({e.get('key')!r}): unknown field(s) {sorted(extra)}; "
                                   "allowed are key, range, choices, reason, reading")
        if not isinstance(e.get("reading", False), bool):
            raise SensitivityError(f"{p.name}, input {k} ({e.get('key')!r}): reading = {e['reading']!r} is not "
                                   "allowed: give true or false")
        inp = UncertainInput(e.get("key", ""), e.get("range"), tuple(e.get("choices", ())), e.get("reason", ""),
                             e.get("reading", False))
        out.append(inp)
    return check_inputs(out, params)


def check_inputs(inputs: Iterable[UncertainInput | str], params: Params,
                 known: Sequence[UncertainInput] | None = None) -> tuple[UncertainInput, ...]:
    """The inputs as :class:`UncertainInput`, checked against the parameter set.

    A string is the key of an input of ``known`` (default :func:`load_ranges`'s).  A key that
    names no entry of ``params``, or an input given twice, raises :class:`SensitivityError`.
    """
    out: list[UncertainInput] = []
    by_key = None
    for inp in inputs:
        if isinstance(inp, str):
            if by_key is None:
                by_key = {i.key: i for i in (load_ranges(params=params) if known is None else known)}
            if inp not in by_key:
                raise SensitivityError(f"input {inp!r} has no range: the ranges file has {sorted(by_key)}")
            inp = by_key[inp]
        if not isinstance(inp, UncertainInput):
            raise SensitivityError(f"input {inp!r} is not allowed: give an UncertainInput or the key of one")
        if inp.key not in params.values:
            raise SensitivityError(f"input key {inp.key!r} names no parameter: use a dotted key of the parameter file, "
                                   "e.g. 'material.E', 'assumptions.damping_ratio', an entry of [masses] or of a "
                                   "[motor<k>] section")
        if any(o.key == inp.key for o in out):
            raise SensitivityError(f"input {inp.key!r} is given twice")
        out.append(inp)
    if not out:
        raise SensitivityError("inputs = [] is not allowed: give one or more uncertain inputs")
    return tuple(out)


#: the dotted keys of a link section's sides, which ``bending_depth`` names by value
_SIDES = ("geometry.width", "geometry.thickness")


def apply(params: Params, inputs: Sequence[UncertainInput], u: ArrayLike) -> Params:
    """The parameter set with each input at its value for the point ``u`` of the unit box.

    ``bending_depth`` names a side of the section (the base set's width or thickness): where
    the width or the thickness varies, it follows that side.
    """
    u = np.asarray(u, float)
    changes = {inp.key: inp.value(x) for inp, x in zip(inputs, u)}
    depth = "assumptions.bending_depth"
    if depth in changes or any(k in changes for k in _SIDES):
        named = changes.get(depth, params.bending_depth)
        side = [k for k in _SIDES if math.isclose(named, params.values[k], rel_tol=1e-9)]
        if not side:
            raise SensitivityError(f"bending_depth = {named!r} names no side of the section (width "
                                   f"{params.width!r}, thickness {params.thickness!r} m)")
        changes[depth] = changes.get(side[0], params.values[side[0]])
    return params.replace(**changes)


def _setup_at(setup: Setup, inputs: Sequence[UncertainInput], u: NDArray) -> Setup:
    p = apply(setup.params, inputs, u)
    speed = p.crank_speed_rpm if any(i.key == "assumptions.crank_speed_rpm" for i in inputs) else setup.crank_speed_rpm
    return setup.replace(params=p, crank_speed_rpm=speed)


# --- outputs ---------------------------------------------------------------------------------
@dataclass(frozen=True)
class SteadyStateOutput:
    """A scalar of the set-up's periodic steady state (:func:`fivebar.analyses.branches.steady_state` at
    the set-up's S: a pure function of the set-up).  ``what`` is ``"max |multiplier|"`` (the
    largest Floquet multiplier) or ``"stress / yield"`` (the peak bending stress against the
    file's yield stress)."""

    what: str

    def __post_init__(self) -> None:
        if self.what not in ("max |multiplier|", "stress / yield"):
            raise SensitivityError(f"what = {self.what!r} is not allowed: use 'max |multiplier|' or 'stress / yield'")

    def __call__(self, setup: Setup) -> float:
        from .branches import steady_state

        res = steady_state(setup)
        if self.what == "max |multiplier|":
            return float(np.abs(res.floquet_multipliers).max())
        return float(res._checks()["stress / yield"])


@dataclass(frozen=True)
class MidpointPeakToPeak:
    """Figure 6's measure: the peak-to-peak deflection (um) of a link's midpoint over the
    steady period, ``direction`` "transverse" (Figure 6), "longitudinal" or "chord"."""

    link: str
    direction: str = "transverse"

    def __call__(self, setup: Setup) -> float:
        from .branches import steady_state

        return 1e3 * steady_state(setup).peak_to_peak_mm(self.link, self.direction)


@dataclass(frozen=True)
class ResonanceSpeed:
    """The crank speed (r/min) at which harmonic ``k`` of the crank meets mode ``mode`` of the
    linkage, with the effective frequencies of errata E28
    (:func:`fivebar.analyses.resonance.resonance_speeds`, ``frequencies="effective"``): where the
    response peaks and, with the geometric nonlinearity, where its folds begin."""

    k: int = 2
    mode: int = 1

    def __call__(self, setup: Setup) -> float:
        from .resonance import resonance_speeds

        df = resonance_speeds(setup, n_modes=self.mode, harmonics=self.k, frequencies="effective",
                              parametric=False, subharmonic_orders=())
        hit = df[(df["k"] == self.k) & (df["mode"] == str(self.mode)) & (df["type"] != "divergence")]
        if hit.empty:
            return float("nan")
        return float(hit["speed (r/min)"].iloc[0])


def _midpoint_outputs() -> dict[str, Callable[[Setup], float]]:
    """The midpoint outputs of the book's linkage's couplers (L2 and L3 of the paper's five-bar,
    Figure 6), named from its description."""
    from ..description.params import load_params

    couplers = load_params().linkage.couplers
    out: dict[str, Callable[[Setup], float]] = {f"{k} p-p (um)": MidpointPeakToPeak(k) for k in couplers}
    out.update({f"{k} bending p-p (um)": MidpointPeakToPeak(k, "chord") for k in couplers})
    return out


#: The named outputs (:func:`output`): the peak-to-peak midpoint deflections of the couplers of the
#: book's linkage ("L2 p-p (um)", "L3 p-p (um)", "L2 bending p-p (um)", "L3 bending p-p (um)"), the
#: largest Floquet multiplier, stress / yield and a resonance speed; any callable of a Setup that
#: returns a number serves as well (:class:`MidpointPeakToPeak` of any link of any linkage).
SCALAR_OUTPUTS: dict[str, Callable[[Setup], float]] = {
    **_midpoint_outputs(),
    "max |multiplier|": SteadyStateOutput("max |multiplier|"),
    "stress / yield": SteadyStateOutput("stress / yield"),
    "resonance speed, mode 1 x harmonic 2 (r/min)": ResonanceSpeed(2, 1),
}


def output(name: str | Callable[[Setup], float]) -> Callable[[Setup], float]:
    """A named output of :data:`SCALAR_OUTPUTS`, or a callable as it is; anything else raises
    :class:`SensitivityError` listing the names."""
    if callable(name):
        return name
    if isinstance(name, str) and name in SCALAR_OUTPUTS:
        return SCALAR_OUTPUTS[name]
    raise SensitivityError(f"output = {name!r} is not allowed: give a callable of a fivebar.Setup that returns a "
                           f"number, or one of {list(SCALAR_OUTPUTS)}")


# --- evaluation ------------------------------------------------------------------------------
def _scalar(value: Any, out: Any, where: str) -> float:
    v = plain(value)
    if isinstance(v, np.ndarray) or isinstance(v, bool) or not isinstance(v, (int, float)):
        raise SensitivityError(f"output {out!r} returned {value!r} ({type(value).__name__}) {where}: it must return "
                               "one real number (a scalar output)")
    return float(v)


def _values_text(inputs: Sequence[UncertainInput], u: NDArray) -> str:
    return ", ".join(f"{i.key} = {i.value(x)!r}" for i, x in zip(inputs, u))


def _evaluate_rows(out: Callable, setup: Setup, inputs: tuple[UncertainInput, ...], U: NDArray) -> NDArray:
    """The output at each row of U (one BLAS thread); a top-level function, for worker processes."""
    y = np.empty(len(U))
    with blas_threads(1):
        for k, u in enumerate(U):
            where = "at " + _values_text(inputs, u)
            try:
                y[k] = _scalar(out(_setup_at(setup, inputs, u)), out, where)
            except SensitivityError:
                raise
            except FivebarError as exc:
                raise SensitivityError(f"output {out!r} could not be evaluated {where}: {type(exc).__name__}: {exc}") from exc
            if not math.isfinite(y[k]):
                raise SensitivityError(f"output {out!r} is {y[k]} {where}: every evaluation must give a finite number "
                                       "(narrow the range, or choose an output defined over all of it)")
    return y


def evaluate(out: str | Callable[[Setup], float], setup: Setup | Params, inputs: Sequence[UncertainInput],
             U: ArrayLike, *, executor: cf.Executor | None = None, progress: bool = True,
             chunk: int = 8) -> NDArray:
    """The output at each point (row) of ``U`` in the unit box of ``inputs``.

    ``y = evaluate("L2 p-p (um)", setup, inputs, U, executor=pool)``.  Rows are sent to the
    executor ``chunk`` at a time and put back in order.  An evaluation that fails, is not a
    real scalar or is not finite raises :class:`SensitivityError` naming the inputs' values.
    """
    out = output(out)
    s = as_setup(setup)
    inputs = check_inputs(inputs, s.params, known=[i for i in inputs if isinstance(i, UncertainInput)])
    U = np.asarray(U, float)
    if U.ndim != 2 or U.shape[1] != len(inputs) or np.any((U < 0) | (U > 1)) or not np.all(np.isfinite(U)):
        raise SensitivityError(f"U of shape {U.shape} is not allowed: give points of the unit box, shape (n, {len(inputs)})")
    if executor is not None and not callable(getattr(executor, "submit", None)):
        raise SensitivityError(f"executor = {executor!r} is not allowed: give a concurrent.futures.Executor or None")
    chunk = number("chunk", chunk, integer=True, low=1, error=SensitivityError)
    y = np.empty(len(U))
    pieces = [slice(a, min(a + chunk, len(U))) for a in range(0, len(U), chunk)]
    with tqdm(total=len(U), disable=not progress, desc="evaluations", unit="eval") as bar:
        if executor is None:
            for sl in pieces:
                y[sl] = _evaluate_rows(out, s, inputs, U[sl])
                bar.update(sl.stop - sl.start)
        else:
            futures = {executor.submit(_evaluate_rows, out, s, inputs, U[sl]): sl for sl in pieces}
            try:
                for fut in cf.as_completed(futures):
                    sl = futures[fut]
                    y[sl] = fut.result()
                    bar.update(sl.stop - sl.start)
            except BaseException:
                for fut in futures:
                    fut.cancel()
                raise
    return y


# --- seeds -----------------------------------------------------------------------------------
def _seeds(seed: int, n: int) -> list[int]:
    """``n`` positive integers derived from ``seed`` (SALib's Sobol analysis ignores a seed 0)."""
    seed = number("seed", seed, integer=True, low=0, error=SensitivityError)
    return [int(s) + 1 for s in np.random.SeedSequence(seed).generate_state(n, dtype=np.uint32)]


def _problem(inputs: Sequence[UncertainInput]) -> dict:
    return {"num_vars": len(inputs), "names": [i.key for i in inputs], "bounds": [[0.0, 1.0]] * len(inputs)}


def _model_values(func: Callable, U: NDArray, what: str) -> NDArray:
    y = np.asarray(func(U))
    if y.shape != (len(U),):
        raise SensitivityError(f"the model returned shape {y.shape} for {len(U)} points: it must return one number per "
                               f"point, shape ({len(U)},) ({what})")
    y = y.astype(float)
    bad = np.flatnonzero(~np.isfinite(y))
    if bad.size:
        raise SensitivityError(f"the model returned {y[bad[0]]} at point {bad[0]} of the {what} sample (unit box "
                               f"{np.round(U[bad[0]], 6).tolist()}): every evaluation must give a finite number")
    return y


# --- Morris ----------------------------------------------------------------------------------
@dataclass
class MorrisResult:
    """Morris elementary effects: ``mu``, ``mu_star`` (mean absolute effect), ``sigma`` (their
    spread) and ``mu_star_conf`` (bootstrap 95 % half-width) per input, in output units; ``U``
    and ``Y`` the points and outputs; ``reference`` the output the effects are compared with
    (the nominal set-up's, or the mean of |Y|)."""

    inputs: tuple[UncertainInput, ...]
    mu: NDArray
    mu_star: NDArray
    sigma: NDArray
    mu_star_conf: NDArray
    U: NDArray
    Y: NDArray
    reference: float
    trajectories: int
    levels: int

    @property
    def evaluations(self) -> int:
        return len(self.Y)

    def table(self) -> pd.DataFrame:
        """One row per input, largest mu* first; ``relative mu*`` is mu* / reference."""
        df = pd.DataFrame({"input": [i.key for i in self.inputs], "range": [i.describe() for i in self.inputs],
                           "mu*": self.mu_star, "mu* conf": self.mu_star_conf, "mu": self.mu, "sigma": self.sigma,
                           "relative mu*": self.mu_star / abs(self.reference)})
        return df.sort_values("mu*", ascending=False, kind="stable").reset_index(drop=True)

    def screen(self, relative: float = 0.01) -> tuple[UncertainInput, ...]:
        """The inputs whose mu* is at least ``relative`` times the reference output (their
        effect over the range reaches that fraction), largest first."""
        relative = number("relative", relative, low=0.0, error=SensitivityError)
        order = np.argsort(-self.mu_star, kind="stable")
        return tuple(self.inputs[i] for i in order if self.mu_star[i] >= relative * abs(self.reference))


def morris_indices(func: Callable[[NDArray], ArrayLike], inputs: Sequence[UncertainInput], *, trajectories: int = 10,
                   levels: int = 4, seed: int = 0, reference: float | None = None) -> MorrisResult:
    """Morris elementary effects of ``func`` (points of the unit box of ``inputs``, shape (n, D),
    to outputs, shape (n,)), from ``trajectories`` trajectories on a grid of ``levels`` levels."""
    from SALib.analyze import morris as analyze
    from SALib.sample import morris as sample

    inputs = tuple(inputs)
    if not inputs or not all(isinstance(i, UncertainInput) for i in inputs):
        raise SensitivityError(f"inputs = {inputs!r} is not allowed: give one or more UncertainInput")
    r = number("trajectories", trajectories, integer=True, low=2, error=SensitivityError)
    p = number("levels", levels, integer=True, low=2, error=SensitivityError)
    if p % 2:
        raise SensitivityError(f"levels = {p} is not allowed: give an even number (the step is p / (2 (p - 1)))")
    s_sample, s_boot = _seeds(seed, 2)
    problem = _problem(inputs)
    U = sample.sample(problem, r, num_levels=p, seed=s_sample)
    Y = _model_values(func, U, "Morris")
    res = analyze.analyze(problem, U, Y, num_levels=p, seed=s_boot, num_resamples=1000)
    ref = float(np.mean(np.abs(Y))) if reference is None else float(reference)
    return MorrisResult(inputs, np.asarray(res["mu"], float), np.asarray(res["mu_star"], float),
                        np.asarray(res["sigma"], float), np.asarray(res["mu_star_conf"], float), U, Y, ref, r, p)


class _LinkageModel:
    """Unit-box points -> the output of the set-up with the inputs at those values (evaluated on
    the executor)."""

    def __init__(self, out, setup, inputs, executor, progress, chunk):
        self.out, self.setup, self.inputs = output(out), as_setup(setup), inputs
        self.executor, self.progress, self.chunk = executor, progress, chunk

    def __call__(self, U: NDArray) -> NDArray:
        return evaluate(self.out, self.setup, self.inputs, U, executor=self.executor, progress=self.progress,
                        chunk=self.chunk)


def _linkage_inputs(setup: Setup | Params, inputs) -> tuple[Setup, tuple[UncertainInput, ...]]:
    s = as_setup(setup)
    if inputs is None:
        return s, load_ranges(params=s.params)
    if isinstance(inputs, (str, UncertainInput)):
        inputs = [inputs]
    return s, check_inputs(list(inputs), s.params)


def morris(out: str | Callable[[Setup], float], setup: Setup | Params,
           inputs: Sequence[UncertainInput | str] | None = None, *, trajectories: int = 10, levels: int = 4,
           seed: int = 0, executor: cf.Executor | None = None, progress: bool = True,
           chunk: int = 8) -> MorrisResult:
    """Morris screening of an output of the linkage over the inputs' ranges.

    ``m = morris("L2 p-p (um)", setup)``; ``m.table()``; ``survivors = m.screen(0.01)``.

    Parameters
    ----------
    out
        A name of :data:`SCALAR_OUTPUTS` or a callable of a :class:`fivebar.description.setup.Setup` returning a
        number (top-level, to run in worker processes).
    setup
        The problem at its nominal values (a Setup, or a Params); the inputs not varied keep them.
    inputs
        :class:`UncertainInput` or their keys; ``None``: every input of :func:`load_ranges`.
    trajectories, levels
        ``r`` trajectories (``r (D + 1)`` evaluations) on a grid of ``levels`` (even) levels.
    seed
        The sample and the bootstrap of the intervals (the same seed, the same numbers).
    executor, progress, chunk
        As :func:`evaluate`.

    The reference of :meth:`MorrisResult.screen` is the output at the nominal set-up.
    """
    s, inp = _linkage_inputs(setup, inputs)
    model = _LinkageModel(out, s, inp, executor, progress, chunk)
    with blas_threads(1):
        ref = _scalar(model.out(s), model.out, "at the nominal set-up")
    return morris_indices(model, inp, trajectories=trajectories, levels=levels, seed=seed, reference=ref)


# --- Sobol -----------------------------------------------------------------------------------
@dataclass
class SobolResult:
    """First-order and total Sobol indices with bootstrap 95 % intervals (``*_conf``: the
    half-width, SALib's), from ``N`` base points (``N (D + 2)`` evaluations); ``history`` has
    the widest interval at each N tried, ``converged`` whether it fell below ``width``."""

    inputs: tuple[UncertainInput, ...]
    S1: NDArray
    S1_conf: NDArray
    ST: NDArray
    ST_conf: NDArray
    N: int
    width: float
    converged: bool
    history: pd.DataFrame
    U: NDArray = field(repr=False)
    Y: NDArray = field(repr=False)

    @property
    def evaluations(self) -> int:
        return len(self.Y)

    @property
    def widest(self) -> float:
        """The widest 95 % interval of all the indices (full width)."""
        return float(2 * max(self.S1_conf.max(), self.ST_conf.max()))

    def table(self) -> pd.DataFrame:
        """One row per input, largest total index first, with the intervals (low, high)."""
        df = pd.DataFrame({"input": [i.key for i in self.inputs], "range": [i.describe() for i in self.inputs],
                           "S1": self.S1, "S1 low": self.S1 - self.S1_conf, "S1 high": self.S1 + self.S1_conf,
                           "ST": self.ST, "ST low": self.ST - self.ST_conf, "ST high": self.ST + self.ST_conf})
        return df.sort_values("ST", ascending=False, kind="stable").reset_index(drop=True)


def _sobol_sample(inputs, N: int, seed: int) -> NDArray:
    from SALib.sample import sobol as sample

    return sample.sample(_problem(inputs), N, calc_second_order=False, scramble=True, seed=seed)


def unit_sample(inputs: Sequence[UncertainInput], n: int, seed: int = 0) -> NDArray:
    """``n`` points of the unit box of ``inputs`` (scrambled Sobol' sequence of ``seed``), for
    fitting or checking a surrogate; independent of the samples of :func:`sobol` of the same seed."""
    from scipy.stats import qmc

    n = number("n", n, integer=True, low=1, error=SensitivityError)
    with warnings.catch_warnings():  # any n is allowed: a power of 2 balances best
        warnings.simplefilter("ignore", UserWarning)
        return qmc.Sobol(len(inputs), scramble=True, seed=_seeds(seed, 3)[2]).random(n)


def sobol_indices(func: Callable[[NDArray], ArrayLike], inputs: Sequence[UncertainInput], *, width: float = 0.05,
                  n_start: int = 256, n_max: int = 2**16, seed: int = 0, num_resamples: int = 200,
                  progress: bool = False) -> SobolResult:
    """First-order and total Sobol indices of ``func`` (unit-box points (n, D) -> outputs (n,)).

    Starts with ``n_start`` base points (a power of 2) and doubles them, evaluating only the new
    points, until every 95 % bootstrap interval (full width, twice SALib's ``conf``) is below
    ``width`` or ``n_max`` is reached (then ``converged`` is False).
    """
    from SALib.analyze import sobol as analyze

    inputs = tuple(inputs)
    if not inputs or not all(isinstance(i, UncertainInput) for i in inputs):
        raise SensitivityError(f"inputs = {inputs!r} is not allowed: give one or more UncertainInput")
    width = number("width", width, low=0.0, high=1.0, low_open=True, error=SensitivityError)
    n0 = number("n_start", n_start, integer=True, low=2, error=SensitivityError)
    n_max = number("n_max", n_max, integer=True, low=n0, error=SensitivityError)
    if n0 & (n0 - 1) or n_max & (n_max - 1):
        raise SensitivityError(f"n_start = {n0}, n_max = {n_max} are not allowed: give powers of 2 (the Sobol' sequence)")
    B = number("num_resamples", num_resamples, integer=True, low=10, error=SensitivityError)
    s_sample, s_boot = _seeds(seed, 2)
    problem = _problem(inputs)
    D = len(inputs)
    U = np.empty((0, D))
    Y = np.empty(0)
    rows = []
    N = n0
    while True:
        Ui = _sobol_sample(inputs, N, s_sample)
        old = len(Y)
        if old and not np.array_equal(Ui[:old], U):  # the doubled sequence must extend the last one
            raise SensitivityError("the doubled Sobol' sample does not extend the last one (SALib changed?)")
        with tqdm(total=len(Ui) - old, disable=not progress, desc=f"Sobol N = {N}", unit="eval"):
            Ynew = _model_values(func, Ui[old:], f"Sobol N = {N}")
        U, Y = Ui, np.concatenate([Y, Ynew])
        if np.ptp(Y) == 0.0:
            raise SensitivityError(f"the output is the same at all {len(Y)} points: it has no variance to share out")
        res = analyze.analyze(problem, Y, calc_second_order=False, num_resamples=B, seed=s_boot)
        widest = float(2 * max(np.max(res["S1_conf"]), np.max(res["ST_conf"])))
        rows.append({"N": N, "evaluations": len(Y), "widest interval": widest})
        if widest <= width or 2 * N > n_max:
            break
        N *= 2
    return SobolResult(inputs, np.asarray(res["S1"], float), np.asarray(res["S1_conf"], float),
                       np.asarray(res["ST"], float), np.asarray(res["ST_conf"], float), N, width, widest <= width,
                       pd.DataFrame(rows), U, Y)


def sobol(out: str | Callable[[Setup], float], setup: Setup | Params,
          inputs: Sequence[UncertainInput | str] | None = None, *, width: float = 0.05, n_start: int = 64,
          n_max: int = 1024, seed: int = 0, executor: cf.Executor | None = None, progress: bool = True,
          chunk: int = 8) -> SobolResult:
    """Sobol indices of an output of the linkage, evaluated directly (no surrogate).

    ``s = sobol("L2 p-p (um)", setup, ["assumptions.shaft_diameter_1", "masses.m02"], executor=pool)``.
    Arguments as :func:`morris`; ``width``, ``n_start``, ``n_max`` as :func:`sobol_indices`.
    Each doubling costs ``N (D + 2)`` more evaluations: where that is too dear, fit a
    surrogate (:func:`fit_surrogate`) and pass it to :func:`sobol_indices`.
    """
    s, inp = _linkage_inputs(setup, inputs)
    model = _LinkageModel(out, s, inp, executor, progress, chunk)
    return sobol_indices(model, inp, width=width, n_start=n_start, n_max=n_max, seed=seed)


# --- surrogate -------------------------------------------------------------------------------
def _features(inputs: Sequence[UncertainInput], U: NDArray) -> NDArray:
    """The inputs as variables in [-1, 1]: a range linearly, an alternative as its index."""
    Z = np.empty_like(U, dtype=float)
    for j, inp in enumerate(inputs):
        if inp.discrete:
            Z[:, j] = -1.0 + 2.0 * inp.index(U[:, j]) / (inp.levels - 1)
        else:
            Z[:, j] = 2.0 * U[:, j] - 1.0
    return Z


#: a surrogate of total degree p also has the powers up to p + this of each input alone
_EXTRA_UNIVARIATE = 3


def _basis(inputs: Sequence[UncertainInput], degree: int) -> list[tuple[int, ...]]:
    """Multi-indices of total degree <= ``degree``, and the powers of each input alone up to
    ``degree + 3`` (a strong effect of one input, as a shaft's stiffness with the fourth power
    of its diameter, costs few terms); an alternative of k choices to powers below k."""
    D = len(inputs)
    top = degree + _EXTRA_UNIVARIATE
    cap = [inp.levels - 1 if inp.discrete else top for inp in inputs]
    terms = [()]
    for d in range(1, degree + 1):
        for combo in combinations_with_replacement(range(D), d):
            if all(combo.count(j) <= cap[j] for j in set(combo)):
                terms.append(combo)
    for j in range(D):
        terms += [(j,) * d for d in range(degree + 1, cap[j] + 1)]
    return terms


def _design(Z: NDArray, terms: list[tuple[int, ...]], degree: int) -> NDArray:
    from numpy.polynomial import legendre

    P = np.stack([legendre.legval(Z, np.eye(degree + 1)[k]) for k in range(degree + 1)])  # (degree+1, n, D)
    A = np.ones((Z.shape[0], len(terms)))
    for t, combo in enumerate(terms):
        for j in set(combo):
            A[:, t] *= P[combo.count(j), :, j]
    return A


@dataclass
class Surrogate:
    """A polynomial (Legendre, total degree ``degree``) least-squares fit of an output over the
    unit box of ``inputs`` (of ``log`` of the output, if ``log``).  Call it on points (n, D).
    ``loo_error`` is its leave-one-out RMS error relative to the outputs' standard deviation."""

    inputs: tuple[UncertainInput, ...]
    degree: int
    log: bool
    terms: list[tuple[int, ...]] = field(repr=False)
    coef: NDArray = field(repr=False)
    loo_error: float
    samples: int

    def __call__(self, U: ArrayLike, chunk: int = 65536) -> NDArray:
        U = np.asarray(U, float)
        top = self.degree + _EXTRA_UNIVARIATE
        y = np.concatenate([_design(_features(self.inputs, U[a:a + chunk]), self.terms, top) @ self.coef
                            for a in range(0, len(U), chunk)]) if len(U) else np.empty(0)
        return np.exp(y) if self.log else y

    def validate(self, U: ArrayLike, Y: ArrayLike) -> pd.DataFrame:
        """The surrogate against direct evaluations ``Y`` at ``U`` (points it was not fitted
        to): one row per point with both values and the relative difference."""
        U, Y = np.asarray(U, float), np.asarray(Y, float)
        s = self(U)
        return pd.DataFrame({"direct": Y, "surrogate": s, "relative difference": s / Y - 1.0})


def fit_surrogate(inputs: Sequence[UncertainInput], U: ArrayLike, Y: ArrayLike, *, degrees: Sequence[int] = (1, 2, 3, 4),
                  log: bool | None = None) -> Surrogate:
    """Least-squares polynomial surrogate of the outputs ``Y`` at the points ``U`` (unit box).

    Tries each total degree of ``degrees`` that has at most half as many terms as points, and
    ``log`` of the output and the output itself (``log=None``; log only where every output is
    positive), and keeps the fit with the smallest leave-one-out error (computed in closed form
    from the hat matrix, in units of the output).  A few lines of least squares: a
    polynomial-chaos package would add a dependency for them.
    """
    inputs = tuple(inputs)
    U, Y = np.asarray(U, float), np.asarray(Y, float)
    if U.ndim != 2 or U.shape != (len(Y), len(inputs)) or not np.all(np.isfinite(Y)):
        raise SensitivityError(f"U of shape {U.shape} and Y of shape {Y.shape} are not allowed: give (n, {len(inputs)}) "
                               "points and n finite outputs")
    logs = [False, True] if log is None else [bool(log)]
    if True in logs and not np.all(Y > 0):
        if log:
            raise SensitivityError("log = True is not allowed: some outputs are not positive")
        logs = [False]
    Z = _features(inputs, U)
    best = None
    scale = float(np.std(Y))
    if scale == 0.0:
        raise SensitivityError("the outputs are all equal: nothing to fit")
    for degree in degrees:
        terms = _basis(inputs, number("degree", degree, integer=True, low=1, error=SensitivityError))
        if 2 * len(terms) > len(Y):
            continue
        A = _design(Z, terms, degree + _EXTRA_UNIVARIATE)
        Q, R = np.linalg.qr(A)
        h = np.einsum("ij,ij->i", Q, Q)  # leverage (diagonal of the hat matrix)
        for lg in logs:
            t = np.log(Y) if lg else Y
            coef = np.linalg.solve(R, Q.T @ t)
            loo_t = t - (t - A @ coef) / (1.0 - h)  # the prediction at each point without it
            loo = np.exp(loo_t) if lg else loo_t
            err = float(np.sqrt(np.mean((loo - Y) ** 2)) / scale)
            if best is None or err < best.loo_error:
                best = Surrogate(inputs, degree, lg, terms, coef, err, len(Y))
    if best is None:
        raise SensitivityError(f"{len(Y)} points are too few for any of the degrees {list(degrees)} over "
                               f"{len(inputs)} inputs: give more points (at least twice the terms)")
    return best


# --- which gaps to close -----------------------------------------------------------------------
def spread(func: Callable[[NDArray], ArrayLike], inputs: Sequence[UncertainInput], nominal: ArrayLike,
           order: Sequence[int], *, n: int = 4096, coverage: float = 0.95, seed: int = 0) -> pd.DataFrame:
    """How the output's spread shrinks as the inputs are fixed one after the other.

    ``func`` maps unit-box points (n, D) to outputs; ``nominal`` is the point of the nominal
    values (:meth:`UncertainInput.unit`).  Row k fixes the inputs ``order[:k]`` at their
    nominal values, varies the rest over their ranges (``n`` points of a scrambled Sobol'
    sequence of ``seed``) and gives the central ``coverage`` interval of the output relative to
    its nominal value (``low (%)``, ``high (%)``, and ``largest (%)`` of the two in size).
    """
    inputs = tuple(inputs)
    u0 = np.asarray(nominal, float)
    if u0.shape != (len(inputs),):
        raise SensitivityError(f"nominal of shape {u0.shape} is not allowed: give one point of the unit box, "
                               f"shape ({len(inputs)},)")
    order = [int(i) for i in order]
    if sorted(set(order)) != sorted(order) or any(not 0 <= i < len(inputs) for i in order):
        raise SensitivityError(f"order = {order!r} is not allowed: give distinct indices of the inputs, 0 to {len(inputs) - 1}")
    coverage = number("coverage", coverage, low=0.0, high=1.0, low_open=True, high_open=True, error=SensitivityError)
    y0 = float(_model_values(func, u0[None, :], "nominal")[0])
    if y0 == 0.0:
        raise SensitivityError("the nominal output is 0: a relative spread is not defined")
    U = unit_sample(inputs, n, seed)
    rows = []
    for k in range(len(order) + 1):
        V = U.copy()
        V[:, order[:k]] = u0[order[:k]]
        y = _model_values(func, V, "spread") / y0 - 1.0
        lo, hi = np.quantile(y, [(1 - coverage) / 2, (1 + coverage) / 2])
        rows.append({"fixed": "(none)" if k == 0 else inputs[order[k - 1]].key, "inputs varied": len(inputs) - k,
                     "low (%)": 100 * lo, "high (%)": 100 * hi, "largest (%)": 100 * max(abs(lo), abs(hi))})
    return pd.DataFrame(rows)
