"""The book's results as CSV files a reader can plot in their own tools.

Four tables, each computed by the library (never copied from a notebook):

* :func:`figure6_curves`: the midpoint displacements of L2 and L3 over one steady period
  (Figure 6: transverse, longitudinal and chord deflection, µm, against the crank angle);
* :func:`frequencies_table`: the lowest natural frequencies along the cycle (Hz);
* :func:`resonance_speeds_table`: the crank speeds at which the resonance conditions of section 3
  hold, from :func:`fivebar.analyses.resonance.resonance_speeds`;
* :func:`sweep_table`: the steady-state midpoint amplitude over a range of crank speeds,
  from :func:`fivebar.analyses.sweep.speed_sweep`.

:func:`write_datasets` writes them with a provenance line at the top of each file
(``# fivebar <version> | parameters <file> sha256 <hash> | <how> | <title> | source <hash> |
rows <n> sha256 <hash of the table>``; read them with ``pandas.read_csv(path, comment="#")``)
and skips a file whose ``source`` hash (of the parameter file and the library's sources,
:func:`source_hash`) is current and whose table has the recorded row count and checksum (a
file cut short or altered is computed again).  Files are written atomically (a temporary file
renamed over the old one, removed if anything fails).  A sweep stopped by Ctrl-C or SIGTERM
stops its workers at once and leaves its finished rows in ``<name>.partial.csv``.
"""

from __future__ import annotations

import contextlib
import hashlib
import os
import re
import signal
import tempfile
import time
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np
import pandas as pd

from ..errors import InputError, InputTypeError, array, number
from ..model.kinematics import crank_laws
from ..analyses.modal import frequencies_along_cycle
from ..description.params import DEFAULT_PARAMS_PATH, Params, load_params
from ..analyses.sweep import SweepInterrupted

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


def figure6_curves(params: Params) -> pd.DataFrame:
    """Midpoint displacements (µm) of L2 and L3 over one steady period (Figure 6).

    Columns ``crank angle (deg)`` and ``<link> <direction> (um)`` for L2, L3 and the
    directions of :meth:`fivebar.analyses.response.Response.midpoint_mm` (transverse, longitudinal,
    chord).  The steady state is :func:`fivebar.analyses.branches.steady_state` of
    ``Setup(params, steps_per_period=FIGURE6_STEPS)`` (the data set's fine step).
    """
    from ..description.setup import Setup
    from ..analyses.branches import steady_state

    res = steady_state(Setup(_params(params), steps_per_period=FIGURE6_STEPS))
    out = {"crank angle (deg)": res.crank_angle_deg}
    for link in ("L2", "L3"):
        for direction in ("transverse", "longitudinal", "chord"):
            out[f"{link} {direction} (um)"] = 1e3 * res.midpoint_mm(link, direction)
    return pd.DataFrame(out)


def frequencies_table(params: Params, angles_deg=FREQUENCY_ANGLES_DEG, n_modes: int = 6) -> pd.DataFrame:
    """The ``n_modes`` lowest natural frequencies (Hz) at crank angles of AB (deg, from its start).

    Columns ``crank angle AB (deg)``, ``theta1 (deg)``, ``theta4 (deg)`` (the absolute crank
    angles of the default crank laws) and ``f1 (Hz)`` .. ``f<n_modes> (Hz)`` (with the motors).
    """
    params = _params(params)
    phi = np.radians(array("angles_deg", angles_deg))
    n = number("n_modes", n_modes, integer=True, low=1)
    th1, _, _, th4, _, _ = crank_laws(params, phi / params.crank_speed_rad_s)
    f = frequencies_along_cycle(params, phi, n_modes=n)
    out = {"crank angle AB (deg)": np.degrees(phi), "theta1 (deg)": np.degrees(th1), "theta4 (deg)": np.degrees(th4)}
    out.update({f"f{k + 1} (Hz)": f[:, k] for k in range(f.shape[1])})
    return pd.DataFrame(out)


def resonance_speeds_table(params: Params) -> pd.DataFrame:
    """Crank speeds (r/min) at which the conditions of section 3 hold exactly.

    :func:`fivebar.analyses.resonance.resonance_speeds` with its defaults (the paper's mean frequencies
    (3.3), three modes, ``params.fourier_terms`` harmonics).
    """
    from ..analyses.resonance import resonance_speeds

    return resonance_speeds(_params(params)).reset_index(drop=True)


def sweep_table(params: Params, speeds_rpm=SWEEP_SPEEDS_RPM) -> pd.DataFrame:
    """Steady-state peak-to-peak midpoint amplitudes of L2, L3 over crank speeds.

    :func:`fivebar.analyses.sweep.speed_sweep` of ``Setup(params, nonlinear=False)`` (the linear model,
    with the motors, the parameter file's S and scheme): the columns of
    :func:`fivebar.analyses.sweep.sweep_point`, whose validity columns (``valid``, ``stress / yield``, ``deflection / length``) mark the rows outside the
    model's range (the sweep's warning is not repeated).
    """
    from concurrent.futures import ProcessPoolExecutor

    from ..description.setup import Setup
    from ..analyses.sweep import ignore_sigint, speed_sweep

    _params(params)
    from ..analyses.steady import ValidityWarning

    with ProcessPoolExecutor(max_workers=2, initializer=ignore_sigint) as pool:  # as chapter 07 does
        with warnings.catch_warnings():  # the table's columns 'valid', 'stress / yield', ... say it
            warnings.simplefilter("ignore", ValidityWarning)
            return speed_sweep(Setup(params, nonlinear=False), speeds_rpm, executor=pool, progress=False,
                               cache=False)


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
                f"fivebar.book.datasets.figure6_curves(params): steady_state(Setup(params, steps_per_period={FIGURE6_STEPS}))"),
        Dataset("natural_frequencies", "Six lowest natural frequencies along the cycle (Hz), every degree",
                "05_modes", frequencies_table,
                "fivebar.book.datasets.frequencies_table(params): frequencies_along_cycle(params, 0..360 deg, n_modes=6)"),
        Dataset("resonance_speeds", "Crank speeds at which the resonance conditions of section 3 hold",
                "07_excitation", resonance_speeds_table,
                "fivebar.book.datasets.resonance_speeds_table(params): resonance_speeds(params)"),
        Dataset("speed_sweep", "Steady-state midpoint amplitude of L2, L3 over 600-3300 r/min",
                "07_excitation", sweep_table,
                "fivebar.book.datasets.sweep_table(params): speed_sweep(Setup(params, nonlinear=False), linspace(600, 3300, 120))"),
    )
}


def source_hash(params_path: str | Path = DEFAULT_PARAMS_PATH) -> str:
    """SHA-256 of the parameter file, the library's version and every library source file.

    The library's sources are hashed, not only its version string, because results change
    with the code long before the version is bumped.
    """
    from .. import __version__

    h = hashlib.sha256()
    h.update(_file("params_path", params_path).read_bytes())
    h.update(__version__.encode())
    root = _library_root()
    for src in _library_sources():
        h.update(src.relative_to(root).as_posix().encode())
        h.update(src.read_bytes())
    return h.hexdigest()


def _library_root() -> Path:
    """The folder of the package ``fivebar`` (this module is in its subpackage ``book``)."""
    return Path(__file__).resolve().parents[1]


def _library_sources() -> list[Path]:
    """Every source file of the library, in every subpackage, in a fixed order."""
    return sorted(_library_root().rglob("*.py"))


def _provenance(ds: Dataset, params_path: Path, digest: str, body: bytes, partial: str = "") -> str:
    from .. import __version__

    par = hashlib.sha256(params_path.read_bytes()).hexdigest()[:12]
    rows = body.count(b"\n") - 1  # the column names' line
    return (f"# fivebar {__version__} | parameters {params_path.name} sha256 {par} | "
            f"{ds.how} | {ds.title}{partial} | source {digest[:16]} | rows {rows} sha256 "
            f"{hashlib.sha256(body).hexdigest()[:16]}\n")


def _check_file(path: Path) -> tuple[str, str | None]:
    """The provenance line of a written dataset and why the file is damaged (None if intact):
    the table after the line must have the row count and checksum the line records."""
    with open(path, "rb") as fh:
        first = fh.readline()
        body = fh.read()
    line = first.decode("utf-8", "replace").rstrip("\n")
    m = re.search(r"\| rows (\d+) sha256 ([0-9a-f]{16})$", line)
    if m is None:
        return line, "its provenance line records no row count and checksum (an older or foreign file)"
    rows = body.count(b"\n") - 1
    if rows != int(m.group(1)):
        return line, f"it has {rows} rows, its provenance line records {m.group(1)} (cut short?)"
    if hashlib.sha256(body).hexdigest()[:16] != m.group(2):
        return line, "its checksum does not match the one its provenance line records (altered?)"
    return line, None


def _is_fresh(path: Path, digest: str) -> bool:
    if not path.is_file():
        return False
    line, damage = _check_file(path)
    return damage is None and f"| source {digest[:16]} |" in line


def _write_atomic(path: Path, ds: Dataset, params_path: Path, digest: str, df: pd.DataFrame,
                  partial: str = "") -> None:
    """Write ``df`` with its provenance line to a temporary file beside ``path``, then rename it
    over ``path`` (readers see the old file or the new one, never half of one); the temporary
    file is removed whatever happens."""
    body = df.to_csv(index=False, float_format="%.9g", lineterminator="\n").encode("utf-8")
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(_provenance(ds, params_path, digest, body, partial).encode("utf-8"))
            fh.write(body)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.remove(tmp)
        raise


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
        partial = outdir / f"{n}.partial.csv"
        try:
            df = ds.compute(params)
        except SweepInterrupted as exc:  # keep the finished rows, apart from the dataset
            if len(exc.results):
                _write_atomic(partial, ds, params_path, digest, exc.results,
                              f" | PARTIAL: {len(exc.results)} rows finished before {signal.Signals(exc.signal).name}")
            raise
        _write_atomic(path, ds, params_path, digest, df)
        with contextlib.suppress(FileNotFoundError):
            partial.unlink()
        cost[n] = time.perf_counter() - t0
    return cost


def read_dataset(path: str | Path) -> tuple[str, pd.DataFrame]:
    """The provenance line and the table of a CSV written by :func:`write_datasets`."""
    path = _file("path", path)
    with open(path, encoding="utf-8", errors="replace") as fh:
        first = fh.readline().rstrip("\n")
    if not first.startswith("# fivebar "):
        raise InputError(f"path = {str(path)!r} has no provenance line (expected '# fivebar ...' first)")
    _, damage = _check_file(path)
    if damage is not None:
        raise InputError(f"path = {str(path)!r} is damaged: {damage}; write it again "
                         "(fivebar.book.datasets.write_datasets(..., force=True))")
    return first, pd.read_csv(path, comment="#")
