"""The base of every error the library raises.

``except fivebar.FivebarError`` catches all of them.  Each library exception also keeps its
standard base (:class:`ValueError` for bad input, :class:`RuntimeError` for a computation that
failed), so ``except ValueError`` written before this base existed still works.

This module imports nothing of the linkage: the generic solvers (``schemes``, ``systems``, ``newmark``, ``multiscale``)
derive their errors from it too.  It also holds the one validation helper of every argument
(:func:`number`, with :func:`flag`, :func:`choice`, :func:`array` and the memory check
:func:`memory`), so that NumPy scalars are accepted everywhere a number is and every message
names the argument, the value and what is allowed; and the one validation layer of the public
entry points, :func:`checked` (which :func:`fivebar.description.setup.analysis` applies to every analysis):
it checks every argument by its annotation and name, so that a new argument gets the same
checks without new code.

:class:`ValidityWarning` is here too: a result (or a parameter set) outside the model's range
of validity, from any layer.
"""

from __future__ import annotations

import functools
import inspect
import math
import os
import typing
from collections.abc import Callable
from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = ["COMPLEX", "ComputationError", "FivebarError", "InputError", "InputTypeError", "ParameterError", "RANGES",
           "ResourceError", "ValidityWarning", "array", "available_memory", "checked", "checker", "choice", "flag",
           "memory", "number", "plain", "read_toml"]


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


class ValidityWarning(UserWarning):
    """A result lies outside the model's range of validity (stress above yield, deflection past
    the small-deflection range, a step too coarse for the accuracy it reports), or a parameter
    set whose numbers the model cannot resolve (a crank angle so large that a double does not
    resolve its change over a step)."""


# --- validation: one helper for every argument of the library --------------------------------
def read_toml(path: Any, what: str, error: type[FivebarError] = InputError) -> dict[str, Any]:
    """The TOML document at ``path``, the library's one reader of its data files (parameter
    files, ranges, errata): a missing file, one that cannot be read, invalid TOML or text that
    is not UTF-8 raises ``error``, naming ``what`` ("parameter file path", ...) and the path."""
    import tomllib

    try:
        with open(path, "rb") as fh:
            return tomllib.load(fh)
    except FileNotFoundError:
        raise error(f"{what} = {str(path)!r} does not exist") from None
    except OSError as exc:  # a directory, no permission, ...
        raise error(f"{what} = {str(path)!r} cannot be read: {exc.strerror or exc}") from None
    except tomllib.TOMLDecodeError as exc:
        raise error(f"{what} = {str(path)!r} is not valid TOML: {exc}") from None
    except UnicodeDecodeError as exc:
        raise error(f"{what} = {str(path)!r} is not valid UTF-8 (a TOML file is UTF-8 text): "
                    f"byte {exc.object[exc.start:exc.start + 1]!r} at offset {exc.start}") from None


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


# --- the validation layer of the public entry points -----------------------------------------
#: Ranges of the arguments by name, the same wherever the name is an argument of a checked
#: entry point (:func:`checked`): keyword arguments of :func:`number`.  A name ending in
#: ``_rpm`` is a speed, > 0.  A function's own narrower range stays in the function.
RANGES: dict[str, dict[str, Any]] = {
    **{name: dict(low=0.0, low_open=True) for name in (
        "tol", "rtol", "atol", "ds", "ds_min", "ds_max", "p_scale", "locate_tol", "critical_tol", "dp",
        "state_weight", "window", "interval_ms")},
    **{name: dict(integer=True, low=1) for name in (
        "max_iter", "max_newton", "max_periods", "periods", "n_modes", "samples", "dpi")},
    "max_points": dict(integer=True, low=2),
    "points": dict(integer=True, low=2),
    "frames": dict(integer=True, low=2),
    "transient": dict(integer=True, low=0),
    "detuning": dict(low=0.0),
    "prominence": dict(low=0.0),
}

#: Array arguments whose entries may be complex (the slow flow's complex amplitudes); every
#: other array argument of a checked entry point holds real numbers.
COMPLEX = frozenset({"guess"})

_NUMBER_TYPES = {"float", "int"}
_ARRAY_TYPES = {"ArrayLike", "NDArray", "Array", "NDArray[np.float64]", "np.ndarray"}


def _range(name: str) -> dict[str, Any]:
    if name in RANGES:
        return RANGES[name]
    if name.endswith("_rpm"):
        return dict(low=0.0, low_open=True, unit="r/min")
    return {}


def _has_bool(value: Any) -> bool:
    """True if ``value`` is a boolean, or a list, tuple or array that holds one."""
    if isinstance(value, (bool, np.bool_)):
        return True
    if isinstance(value, np.ndarray):
        return value.dtype.kind == "b" or (value.dtype.kind == "O" and any(_has_bool(v) for v in value.flat))
    if isinstance(value, (list, tuple)):
        return any(_has_bool(v) for v in value)
    return False


def _number_rule(name: str, integer: bool):
    rng = dict(_range(name))
    rng["integer"] = integer or rng.get("integer", False)

    def rule(label: str, value: Any) -> Any:
        x = number(label, value, **rng)
        # a Python number is passed on as given (an int stays an int); a NumPy number or a
        # size-one array as the Python number
        if type(value) in (int, float) and not (rng["integer"] and isinstance(value, float)):
            return value
        return x
    return rule


def _flag_rule(label: str, value: Any) -> bool:
    return flag(label, value)


def _str_rule(label: str, value: Any) -> str:
    if not isinstance(value, str):
        raise InputTypeError(f"{label} = {_short(value)} ({type(value).__name__}) is not allowed: give a string")
    return value


def _array_rule(name: str):
    rng = _range(name)
    kinds = "iufc" if name in COMPLEX else "iuf"

    def rule(label: str, value: Any) -> Any:
        if _has_bool(value):
            raise InputError(f"{label} = {_short(value)} is not allowed: give numbers (True and False are not "
                             "numbers here)")
        try:
            a = np.asarray(value)
        except (TypeError, ValueError):
            a = np.asarray([None], dtype=object)
        if a.dtype.kind not in kinds:
            raise InputError(f"{label} = {_short(value)} is not allowed: give a {'number' if kinds == 'iufc' else 'real number'} "
                             f"or an array of {'numbers' if kinds == 'iufc' else 'real numbers'}")
        if not np.all(np.isfinite(a)):
            raise InputError(f"{label} = {_short(value)} is not allowed: every entry must be finite "
                             f"({int(a.size - np.isfinite(a).sum())} are nan or inf)")
        if rng.get("low") is not None and a.dtype.kind != "c" and a.size and (
                a.min() <= rng["low"] if rng.get("low_open") else a.min() < rng["low"]):
            raise InputError(f"{label} = {_short(value)} is not allowed: every entry must be "
                             f"{'>' if rng.get('low_open') else '>='} {_text(rng['low'])}"
                             + (f" ({rng['unit']})" if rng.get("unit") else ""))
        return plain(value) if a.ndim == 0 else value
    return rule


def _class_rule(classes: tuple[type, ...]):
    names = " or ".join(f"a {c.__module__.split('.')[0]}.{c.__name__}" for c in classes)

    def rule(label: str, value: Any) -> Any:
        if not isinstance(value, classes):
            raise InputTypeError(f"{label} = {_short(value)} ({type(value).__name__}) is not allowed: give {names}")
        return value
    return rule


def _split_union(text: str) -> list[str]:
    """The members of an annotation ``A | B[C, D] | None`` (top-level ``|`` only)."""
    parts, depth, cur = [], 0, ""
    for ch in text:
        depth += ch in "[("
        depth -= ch in "])"
        if ch == "|" and depth == 0:
            parts.append(cur.strip())
            cur = ""
        else:
            cur += ch
    parts.append(cur.strip())
    return parts


def _rule(name: str, annotation: Any, namespace: dict):
    """The check of an argument from its annotation (a string: ``from __future__ import
    annotations``) and name, or None (an argument the layer does not check)."""
    if annotation is inspect.Parameter.empty:
        return None, False
    text = annotation if isinstance(annotation, str) else getattr(annotation, "__name__", str(annotation))
    members = [p.strip("'\"") for p in _split_union(text)]  # (a quoted forward reference too)
    parts = [p for p in members if p not in ("None", "NoneType")]
    none_ok = len(parts) < len(members)
    if not parts:
        return None, True
    if set(parts) <= _NUMBER_TYPES:
        return _number_rule(name, parts == ["int"]), none_ok
    if parts == ["bool"]:
        return _flag_rule, none_ok
    if parts == ["str"]:
        return _str_rule, none_ok
    if set(parts) <= _ARRAY_TYPES:
        return _array_rule(name), none_ok
    if len(parts) == 1 and parts[0].startswith(("Literal[", "typing.Literal[")):
        try:
            allowed = typing.get_args(eval(parts[0], namespace))  # noqa: S307 - the function's own annotation
        except Exception:  # noqa: BLE001 - an annotation the layer cannot read is not checked
            return None, none_ok
        return (lambda label, value: choice(label, value, allowed)), none_ok
    classes = []
    for part in parts:
        try:
            obj = eval(part, namespace)  # noqa: S307 - the function's own annotation
        except Exception:  # noqa: BLE001
            return None, none_ok
        if not isinstance(obj, type) or not obj.__module__.startswith("fivebar"):
            return None, none_ok  # a type of another package: duck typing is its own business
        classes.append(obj)
    protocols = [c for c in classes if getattr(c, "_is_protocol", False)]
    if protocols:
        if len(protocols) < len(classes) or not all(_protocol_test(c) for c in protocols):
            return None, none_ok  # a protocol the layer cannot test, or mixed with classes
        return _protocol_rule(tuple(protocols)), none_ok
    return _class_rule(tuple(classes)), none_ok


def _protocol_test(protocol: type) -> Callable[[Any], bool] | None:
    """How a value is tested against a protocol of fivebar: a callable protocol (a period map)
    by ``callable``, a ``runtime_checkable`` one by ``isinstance``; None if neither."""
    if "__call__" in getattr(protocol, "__protocol_attrs__", ()) or (
            "__call__" in protocol.__dict__):
        return callable
    if getattr(protocol, "_is_runtime_protocol", False):
        return lambda value: isinstance(value, protocol)
    return None


def _protocol_rule(protocols: tuple[type, ...]):
    tests = [_protocol_test(p) for p in protocols]
    names = " or ".join(f"a {p.__name__} ({p.__doc__.strip().splitlines()[0][:-1].lower() if p.__doc__ else 'a protocol'})"
                        for p in protocols)

    def rule(label: str, value: Any) -> Any:
        if not any(test(value) for test in tests):
            raise InputTypeError(f"{label} = {_short(value)} ({type(value).__name__}) is not allowed: give {names}")
        return value
    return rule


def _close_names(word: str, names: list[str]) -> str:
    import difflib

    near = difflib.get_close_matches(word, names, n=1)
    return f" (did you mean {near[0]!r}?)" if near else ""


def checked(fn: Callable) -> Callable:
    """The validation layer of a public entry point: check each argument from its annotation
    and name before ``fn`` runs, so that a new argument gets the same checks without new code.

    ``@checked`` over ``def f(x: float, n: int = 3, flag: bool = False, a: ArrayLike = None,
    s: str = "x", setup: Setup | Params = ...)``.  By annotation: ``float``/``int`` a finite
    number (not a bool, a string or a complex number; an ``int`` integral), ``bool`` True or
    False (not a string), ``str`` a string, ``ArrayLike`` real numbers (complex ones for the names in :data:`COMPLEX`; no bool, no NaN or inf),
    ``Literal[...]`` one of its values, a class of fivebar an instance of it, a protocol of
    fivebar (a period map) a callable; ``| None`` also None.  By name: the ranges of
    :data:`RANGES` (``tol`` > 0, ``max_points`` an integer >= 2, ...) and ``*_rpm`` > 0.
    NumPy numbers and size-one arrays are accepted as numbers and passed on as Python numbers;
    an argument left at its default is not checked.  A call that does not match the signature
    (an unknown keyword, a missing argument) raises :class:`InputTypeError` with the nearest
    name.  Every error derives from :class:`FivebarError` and names the argument, its value
    and what is allowed.
    """
    check = checker(fn)

    @functools.wraps(fn)
    def wrapper(*args, **kwargs):
        args, kwargs = check(args, kwargs)
        return fn(*args, **kwargs)

    wrapper.__checked__ = True
    return wrapper


def checker(fn: Callable) -> Callable[[tuple, dict], tuple[tuple, dict]]:
    """The check of :func:`checked` as a function ``(args, kwargs) -> (args, kwargs)`` (the
    arguments to call ``fn`` with), for a wrapper of ``fn`` that does more
    (:func:`fivebar.description.setup.analysis`) and runs it in its own frame: a warning's ``stacklevel``
    counts the frames between the library and the caller."""
    sig = inspect.signature(fn)
    target = inspect.unwrap(fn)
    rules: dict[str, Any] | None = None

    def resolve() -> dict[str, Any]:
        out = {}
        for name, par in sig.parameters.items():
            if par.kind is inspect.Parameter.VAR_KEYWORD:
                continue
            rule, none_ok = _rule(name, par.annotation, target.__globals__)
            if rule is not None:
                out[name] = (rule, none_ok or par.default is None, par.default,
                             par.kind is inspect.Parameter.VAR_POSITIONAL)
        return out

    def check(args: tuple, kwargs: dict) -> tuple[tuple, dict]:
        nonlocal rules
        if rules is None:
            rules = resolve()
        try:
            bound = sig.bind(*args, **kwargs)
        except TypeError as exc:
            names = list(sig.parameters)
            hint = ""
            unknown = [k for k in kwargs if k not in sig.parameters]
            if unknown:
                hint = _close_names(unknown[0], names)
            raise InputTypeError(f"{fn.__name__}(): {exc}{hint}; its arguments are ({', '.join(names)})") from None
        changed = False
        for name, value in bound.arguments.items():
            entry = rules.get(name)
            if entry is None:
                continue
            rule, none_ok, default, star = entry
            if star:
                new = tuple(rule(f"{name}[{i}]", v) for i, v in enumerate(value))
                if any(a is not b for a, b in zip(new, value)):
                    bound.arguments[name], changed = new, True
                continue
            if value is default or (value is None and none_ok):
                continue
            new = rule(name, value)
            if new is not value:
                bound.arguments[name], changed = new, True
        if changed:
            return bound.args, bound.kwargs
        return args, kwargs

    return check
