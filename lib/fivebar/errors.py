"""The base of every error the library raises.

``except fivebar.FivebarError`` catches all of them.  Each library exception also keeps its
standard base (:class:`ValueError` for bad input, :class:`RuntimeError` for a computation that
failed), so ``except ValueError`` written before this base existed still works.

This module imports nothing of the linkage: the generic solvers (``schemes``, ``systems``, ``newmark``, ``multiscale``)
derive their errors from it too.  It also holds the one validation helper of every argument
(:func:`number`, with :func:`flag`, :func:`choice`, :func:`array` and the memory check
:func:`memory`), so that NumPy scalars are accepted everywhere a number is and every message
names the argument, the value and what is allowed.
"""

from __future__ import annotations

import math
import os
from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = ["ComputationError", "FivebarError", "InputError", "InputTypeError", "ParameterError", "ResourceError",
           "array", "available_memory", "choice", "flag", "memory", "number", "plain"]


class FivebarError(Exception):
    """Base of every exception raised by fivebar."""


class InputError(FivebarError, ValueError):
    """A bad argument: the message names the value and what is allowed."""


class ParameterError(FivebarError, ValueError):
    """A parameter file or override holds a missing, unknown or invalid entry."""


class InputTypeError(FivebarError, TypeError):
    """An argument of the wrong type: the message names the type given and the one expected."""


class ComputationError(FivebarError, RuntimeError):
    """A computation could not produce its result (the message says which and why)."""


class ResourceError(FivebarError, MemoryError):
    """A computation would need more memory than the machine has (found before allocating)."""


# --- validation: one helper for every argument of the library --------------------------------
def _text(x: float) -> str:
    return f"{x:g}" if isinstance(x, float) else str(x)


def plain(value: Any) -> Any:
    """A NumPy integer or float scalar, or a size-one array of one, as the Python number; any
    other value as it is."""
    if isinstance(value, np.ndarray) and value.size == 1 and value.dtype.kind in "iuf":
        return value.reshape(()).item()
    if isinstance(value, np.generic) and value.dtype.kind in "iuf":
        return value.item()
    return value


def number(name: str, value: Any, *, integer: bool = False, low: float | None = None,
           high: float | None = None, low_open: bool = False, high_open: bool = False,
           unit: str = "", error: type[FivebarError] = InputError) -> Any:
    """``value`` as a Python ``float`` (or ``int`` with ``integer=True``), checked.

    ``n = number("steps_per_period", S, integer=True, low=21)``.  Accepted: Python and NumPy
    numbers and NumPy arrays of size one (not ``bool``, strings or complex numbers); the value
    must be finite and within ``low``/``high`` (inclusive unless ``low_open``/``high_open``);
    an integer must be integral (``400.0`` is accepted as 400).  Otherwise ``error`` (an
    :class:`InputError` by default) names the argument, the value and what is allowed.
    """
    allowed = "an integer" if integer else "a finite number"
    if low is not None:
        allowed += f" {'>' if low_open else '>='} {_text(low)}"
    if high is not None:
        allowed += f"{' and' if low is not None else ''} {'<' if high_open else '<='} {_text(high)}"
    if unit:
        allowed += f" ({unit})"
    x = plain(value)
    bad = error(f"{name} = {value!r} is not allowed: give {allowed}")
    if isinstance(x, bool) or not isinstance(x, (int, float)):
        raise bad
    if not math.isfinite(x):
        raise bad
    if integer:
        if x != int(x):
            raise bad
        x = int(x)
    else:
        x = float(x)
    if low is not None and (x <= low if low_open else x < low):
        raise bad
    if high is not None and (x >= high if high_open else x > high):
        raise bad
    return x


def flag(name: str, value: Any) -> bool:
    """``value`` as a ``bool``: True, False or their NumPy forms; else an :class:`InputError`."""
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    raise InputError(f"{name} = {value!r} is not allowed: give True or False")


def choice(name: str, value: Any, allowed: Any) -> Any:
    """``value`` if it is one of ``allowed``; else an :class:`InputError` listing them."""
    try:
        ok = value in allowed
    except TypeError:
        ok = False
    if not ok or isinstance(value, (list, dict, set)):
        raise InputError(f"{name} = {value!r} is not allowed: use one of {list(allowed)}")
    return value


def array(name: str, value: Any, shape: tuple[int | None, ...] | None = None,
          finite: bool = True) -> NDArray[np.float64]:
    """``value`` as a float array, with its shape (``None`` in ``shape`` is any size) and
    finiteness checked; else an :class:`InputError` naming the argument."""
    try:
        a = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"{name} = {_short(value)} is not allowed: give an array of numbers"
                         + (f" of shape {_shape_text(shape)}" if shape is not None else "")) from None
    if shape is not None and (a.ndim != len(shape)
                              or any(s is not None and s != k for s, k in zip(shape, a.shape))):
        raise InputError(f"{name} has shape {a.shape}: expected {_shape_text(shape)}")
    if finite and not np.all(np.isfinite(a)):
        raise InputError(f"{name} = {_short(value)} is not allowed: every entry must be finite "
                         f"({int(np.size(a) - np.isfinite(a).sum())} are nan or inf)")
    return a


def _short(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 120 else text[:117] + "..."


def _shape_text(shape: tuple[int | None, ...]) -> str:
    return "(" + ", ".join("any" if s is None else str(s) for s in shape) + ("," if len(shape) == 1 else "") + ")"


def available_memory() -> int:
    """Bytes this process can still allocate: the system's available memory (``MemAvailable``
    of ``/proc/meminfo``, else free pages), bounded by the address-space limit if one is set."""
    avail = None
    try:
        with open("/proc/meminfo") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    avail = int(line.split()[1]) * 1024
                    break
    except OSError:
        pass
    if avail is None:
        try:
            avail = os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
        except (ValueError, OSError, AttributeError):
            return 2**62
    try:
        import resource

        soft = resource.getrlimit(resource.RLIMIT_AS)[0]
        if soft != resource.RLIM_INFINITY:
            avail = min(avail, soft)
    except (ImportError, OSError, ValueError):
        pass
    return avail


#: Allocations below this many bytes (64 MiB) are not checked against the available memory.
CHECKED_BYTES = 2**26


def memory(nbytes: float, what: str, remedy: str) -> None:
    """Raise a :class:`ResourceError` if ``nbytes`` would not fit in :func:`available_memory`.

    ``what`` says what would be allocated and from which arguments (``"the step matrices,
    steps_per_period = 10**9 x 22 x 22 doubles"``), ``remedy`` what to change.  Below
    ``CHECKED_BYTES`` nothing is checked: reading the system's memory costs about 0.1 ms,
    which every period of a continuation would pay for a few kilobytes.
    """
    if nbytes < CHECKED_BYTES:
        return
    avail = available_memory()
    if nbytes > avail:
        raise ResourceError(f"{what} need about {nbytes / 2**30:.3g} GiB, more than the "
                            f"{avail / 2**30:.3g} GiB of memory available: {remedy}")
