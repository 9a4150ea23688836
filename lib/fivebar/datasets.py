"""The book's results as CSV files a reader can plot in their own tools.

Four tables, each computed by the library (never copied from a notebook):

* :func:`figure6_curves`: the midpoint displacements of L2 and L3 over one steady period
  (Figure 6: transverse, longitudinal and chord deflection, µm, against the crank angle);
* :func:`frequencies_table`: the lowest natural frequencies along the cycle (Hz);
* :func:`resonance_speeds_table`: the crank speeds at which the resonance conditions of section 3
  hold, from :func:`fivebar.resonance.resonance_speeds`;
* :func:`sweep_table`: the steady-state midpoint amplitude over a range of crank speeds,
  from :func:`fivebar.sweep.speed_sweep`.

:func:`write_datasets` writes them with a provenance line at the top of each file
(``# fivebar <version> | parameters <file> sha256 <hash> | <how> | <title> | source <hash>``;
read them with ``pandas.read_csv(path, comment="#")``) and skips a file whose ``source`` hash
(of the parameter file and the library's sources, :func:`source_hash`) is current.
"""

from __future__ import annotations

import hashlib
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np
import pandas as pd

from .errors import InputError, InputTypeError, array, number
from .kinematics import crank_laws
from .modal import frequencies_along_cycle
from .params import DEFAULT_PARAMS_PATH, Params, load_params

__all__ = [
    "DATASETS",
    "Dataset",
    "figure6_curves",
    "frequencies_table",
    "resonance_speeds_table",
    "sweep_table",
    "source_hash",
    "write_datasets",
    "read_dataset",
]

#: Steps per period of the Figure 6 curves: the converged reference of chapter 09
#: (the paper's S = 100 with its own rule has an unstable discrete orbit, errata E26).
FIGURE6_STEPS = 1600
#: Crank angles (deg) of the frequency table: every degree of one turn of crank AB.
FREQUENCY_ANGLES_DEG = np.arange(0.0, 361.0, 1.0)
#: Crank speeds (r/min) of the speed sweep: the range chapter 07 sweeps for the flat bar.
SWEEP_SPEEDS_RPM = np.linspace(600.0, 3300.0, 120)


def _params(params: Params) -> Params:
    if not isinstance(params, Params):
        raise InputTypeError(f"params = {params!r} ({type(params).__name__}) is not allowed: give a "
                             "fivebar.Params (fivebar.load_params())")
    return params


def _file(name: str, path: str | Path) -> Path:
    """An existing, readable file's path; else an InputError naming the argument."""
    p = Path(path)
    if not p.is_file():
        raise InputError(f"{name} = {str(path)!r} is not allowed: "
                         + ("it is a directory" if p.is_dir() else "no such file") + "; give a file")
    return p


def figure6_curves(params: Params, steps_per_period: int = FIGURE6_STEPS) -> pd.DataFrame:
    """Midpoint displacements (µm) of L2 and L3 over one steady period (Figure 6).

    Columns ``crank angle (deg)`` and ``<link> <direction> (um)`` for L2, L3 and the
    directions of :meth:`fivebar.steady.SteadyState.midpoint` (transverse, longitudinal,
    chord).  The steady state is :func:`fivebar.steady.steady_state` at ``steps_per_period``.
    """
    from .steady import steady_state

    res = steady_state(_params(params), steps_per_period=steps_per_period)
    out = {"crank angle (deg)": res.crank_angle}
    for link in ("L2", "L3"):
        for direction in ("transverse", "longitudinal", "chord"):
            out[f"{link} {direction} (um)"] = 1e3 * res.midpoint(link, direction)
    return pd.DataFrame(out)


def frequencies_table(params: Params, angles_deg=FREQUENCY_ANGLES_DEG, n: int = 6) -> pd.DataFrame:
    """The ``n`` lowest natural frequencies (Hz) at crank angles of AB (deg, from its start).

    Columns ``crank angle AB (deg)``, ``theta1 (deg)``, ``theta4 (deg)`` (the absolute crank
    angles of the default crank laws) and ``f1 (Hz)`` .. ``f<n> (Hz)`` (with the motors).
    """
    params = _params(params)
    phi = np.radians(array("angles_deg", angles_deg))
    n = number("n", n, integer=True, low=1)
    th1, _, _, th4, _, _ = crank_laws(params, phi / params.crank_speed)
    f = frequencies_along_cycle(params, phi, n=n)
    out = {"crank angle AB (deg)": np.degrees(phi), "theta1 (deg)": np.degrees(th1), "theta4 (deg)": np.degrees(th4)}
    out.update({f"f{k + 1} (Hz)": f[:, k] for k in range(f.shape[1])})
    return pd.DataFrame(out)


def resonance_speeds_table(params: Params) -> pd.DataFrame:
    """Crank speeds (r/min) at which the conditions of section 3 hold exactly.

    :func:`fivebar.resonance.resonance_speeds` with its defaults (the paper's mean frequencies
    (3.3), three modes, ``params.fourier_terms`` harmonics).
    """
    from .resonance import resonance_speeds

    return resonance_speeds(_params(params)).reset_index(drop=True)


def sweep_table(params: Params, speeds_rpm=SWEEP_SPEEDS_RPM) -> pd.DataFrame:
    """Steady-state peak-to-peak midpoint amplitudes of L2, L3 over crank speeds.

    :func:`fivebar.sweep.speed_sweep` with its defaults (linear, with the motors, S = 100,
    generalised-alpha): the columns of :func:`fivebar.sweep.sweep_point`.
    """
    from concurrent.futures import ProcessPoolExecutor

    from .sweep import speed_sweep

    _params(params)
    with ProcessPoolExecutor(max_workers=2) as pool:  # as chapter 07 does
        return speed_sweep(params, speeds_rpm, executor=pool, progress=False, cache=False)


@dataclass(frozen=True)
class Dataset:
    """One CSV file of the book: its ``name`` (file stem), what it holds, the chapter that
    links it, the function that computes it and how it was computed (for the header)."""

    name: str
    title: str
    chapter: str
    compute: Callable[[Params], pd.DataFrame]
    how: str


#: The book's downloads, by file stem.
DATASETS: dict[str, Dataset] = {
    d.name: d
    for d in (
        Dataset("figure6_curves", "Figure 6: midpoint displacements of L2 and L3 over one period (µm)",
                "09_figure6", figure6_curves,
                f"fivebar.datasets.figure6_curves(params): steady_state(params, steps_per_period={FIGURE6_STEPS})"),
        Dataset("natural_frequencies", "Six lowest natural frequencies along the cycle (Hz), every degree",
                "05_modes", frequencies_table,
                "fivebar.datasets.frequencies_table(params): frequencies_along_cycle(params, 0..360 deg, n=6)"),
        Dataset("resonance_speeds", "Crank speeds at which the resonance conditions of section 3 hold",
                "07_excitation", resonance_speeds_table,
                "fivebar.datasets.resonance_speeds_table(params): resonance_speeds(params)"),
        Dataset("speed_sweep", "Steady-state midpoint amplitude of L2, L3 over 600-3300 r/min",
                "07_excitation", sweep_table,
                "fivebar.datasets.sweep_table(params): speed_sweep(params, linspace(600, 3300, 120))"),
    )
}


def source_hash(params_path: str | Path = DEFAULT_PARAMS_PATH) -> str:
    """SHA-256 of the parameter file, the library's version and every library source file.

    The library's sources are hashed, not only its version string, because results change
    with the code long before the version is bumped.
    """
    from . import __version__

    h = hashlib.sha256()
    h.update(_file("params_path", params_path).read_bytes())
    h.update(__version__.encode())
    for src in sorted(Path(__file__).resolve().parent.glob("*.py")):
        h.update(src.name.encode())
        h.update(src.read_bytes())
    return h.hexdigest()


def _provenance(ds: Dataset, params_path: Path, digest: str) -> str:
    from . import __version__

    par = hashlib.sha256(params_path.read_bytes()).hexdigest()[:12]
    return (f"# fivebar {__version__} | parameters {params_path.name} sha256 {par} | "
            f"{ds.how} | {ds.title} | source {digest[:16]}\n")


def _is_fresh(path: Path, digest: str) -> bool:
    if not path.is_file():
        return False
    with open(path, encoding="utf-8") as fh:
        return fh.readline().rstrip("\n").endswith(f"| source {digest[:16]}")


def write_datasets(
    outdir: str | Path,
    params_path: str | Path = DEFAULT_PARAMS_PATH,
    names: list[str] | None = None,
    force: bool = False,
) -> dict[str, float]:
    """Write the CSV files of :data:`DATASETS` into ``outdir``; return seconds spent per file.

    A file whose provenance line carries the current :func:`source_hash` (parameter file and
    library sources unchanged) is kept (0 s), unless ``force``.  ``names`` restricts the files
    (default: all).
    """
    outdir, params_path = Path(outdir), _file("params_path", params_path)
    if isinstance(names, str):
        raise InputError(f"names = {names!r} is not allowed: give a list of dataset names, "
                         f"e.g. [{names!r}], from {list(DATASETS)}")
    names = list(DATASETS) if names is None else list(names)
    bad = [n for n in names if n not in DATASETS]
    if bad:
        raise InputError(f"names = {bad!r} are not datasets: use some of {list(DATASETS)}")
    if outdir.exists() and not outdir.is_dir():
        raise InputError(f"outdir = {str(outdir)!r} is not allowed: it is a file; give a directory")
    digest = source_hash(params_path)
    outdir.mkdir(parents=True, exist_ok=True)
    params = None
    cost = {}
    for n in names:
        path = outdir / f"{n}.csv"
        if not force and _is_fresh(path, digest):
            cost[n] = 0.0
            continue
        t0 = time.perf_counter()
        params = load_params(params_path) if params is None else params
        ds = DATASETS[n]
        df = ds.compute(params)
        tmp = path.with_suffix(".csv.tmp")
        with open(tmp, "w", encoding="utf-8", newline="") as fh:
            fh.write(_provenance(ds, params_path, digest))
            df.to_csv(fh, index=False, float_format="%.9g", lineterminator="\n")
        tmp.replace(path)
        cost[n] = time.perf_counter() - t0
    return cost


def read_dataset(path: str | Path) -> tuple[str, pd.DataFrame]:
    """The provenance line and the table of a CSV written by :func:`write_datasets`."""
    path = _file("path", path)
    with open(path, encoding="utf-8") as fh:
        first = fh.readline().rstrip("\n")
    if not first.startswith("# fivebar "):
        raise InputError(f"{path} has no provenance line (expected '# fivebar ...' first)")
    return first, pd.read_csv(path, comment="#")
