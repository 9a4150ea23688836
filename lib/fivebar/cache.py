"""The one in-memory store of what the library computes once and reuses.

Everything the library keeps between calls lives in :data:`STORE`: the sampled matrices of a
linkage (M, C, K and F at the S step times, owned by
:class:`fivebar.model.dynamics.LinkageDynamics`), the model and the built
:class:`~fivebar.model.dynamics.LinkageDynamics` of a set-up (two equal
:class:`fivebar.description.setup.Setup` share one), the remembered orbits of
``steady_state(..., tol=...)``, the points of a speed sweep, the modal data of the resonance
tables and the small tables of the elements (Gauss-Legendre nodes, element integrals).  The
per-result values of a :class:`fivebar.analyses.response.Response` (its element displacements, its
stresses) belong to that result, and the LU factors of a step's tangent to its
:class:`fivebar.numerics.systems.PeriodicStepData`: they go with their object (a stored
:class:`~fivebar.model.dynamics.LinkageDynamics` carries its step data, so they count here).

The store forgets the least recently used entry first, while it holds more than
``max_entries`` entries or more than ``max_bytes`` bytes (the newest entry always stays).  The
bytes are those of the NumPy arrays' buffers reachable from the keys and values (each buffer
once, however many entries reach it: the samples and the dynamics built on them share their
arrays), plus ``sys.getsizeof`` of every container and every instance of the library's classes
reachable (each once; Python's numbers and strings are not counted).  An entry is measured
when it is stored: what grows later is stored as entries of its own (the LU factors of a step
data object).  A key that cannot be hashed (a parameter set holding a list) is computed each
time, not stored.

``fivebar.clear_cache()`` empties it; :func:`cache_size` reads it.  A worker process of a sweep
has its own store (its copy from a fork, then its own entries); the store's lock is made anew
in a forked child.
"""

from __future__ import annotations

import collections
import functools
import os
import sys
import threading
import types
import weakref
from collections import OrderedDict
from collections.abc import Callable, Hashable
from typing import Any, NamedTuple

import numpy as np

from .errors import number

__all__ = ["MAX_BYTES", "MAX_ENTRIES", "STORE", "CacheSize", "Store", "cache_size", "clear_cache", "memoised"]

#: The store's default byte budget: 1 GiB.  The largest entries are the samples of one set-up
#: with its LU factors (about 4 S n^2 doubles: 35 MB at S = 1600 with the paper's mesh, n = 26;
#: 280 MB at S = 12800, the finest ``steady_state(..., tol=...)`` tries), so a doubling
#: sequence up to S = 6400 and the set-ups of a sweep fit at once, while a sweep's parent and
#: its two worker processes (one per core of the project's 2-core, 24 GiB machines) hold at
#: most 3 GiB.  (Before one store: 512 MiB for the samples and as much for the nonlinear
#: geometry, the dynamics of a set-up and the sweep points unbounded.)
MAX_BYTES = 2**30
#: The store's default bound on entries: every point of a sweep of a few thousand speeds stays.
MAX_ENTRIES = 4096

def _root(a: np.ndarray) -> np.ndarray:
    """The array that owns the memory of ``a`` (a view keeps its base alive)."""
    while isinstance(a.base, np.ndarray):
        a = a.base
    return a


#: what the count passes over: Python's numbers and strings (a few dozen bytes each; the entry
#: bound covers them), and what is not held for the store (a class, a module)
_SKIPPED = (str, bytes, int, float, complex, bool, type(None), type, types.ModuleType)
# the kinds of object the walk of :func:`_parts` tells apart
_ARRAY, _SEQUENCE, _MAPPING, _FUNCTION, _INSTANCE, _FROZEN, _LEAF, _SKIP = range(8)


def _kind(t: type) -> int:
    if issubclass(t, _SKIPPED):
        return _SKIP
    if issubclass(t, np.ndarray):
        return _ARRAY
    if issubclass(t, (tuple, list, set, frozenset)):
        return _SEQUENCE
    if issubclass(t, dict):
        return _MAPPING
    if t is types.FunctionType:
        return _FUNCTION
    if _ours(t.__module__):
        params = getattr(t, "__dataclass_params__", None)
        return _FROZEN if params is not None and params.frozen else _INSTANCE
    return _LEAF


def _parts(roots: list, frozen: dict[int, tuple[Any, dict]], kinds: dict[type, int]) -> dict[int, tuple[Any, int]]:
    """``id -> (object, bytes)`` of what the ``roots`` hold: the arrays' buffers (their owning
    arrays, ``nbytes``) and every other object reached through containers and the instances and
    closures of the library's own classes and functions (``sys.getsizeof``; each once).  What a
    frozen instance of the library (a dataclass: a parameter set, a set-up) holds is looked up
    in ``frozen`` (id -> (instance, its parts)), or walked once and kept there: a parameter set
    is reached from most entries.  ``kinds``: the kind of each type met (the store's: a type is
    classified once, not at every entry)."""
    seen: dict[int, tuple[Any, int]] = {}
    stack = list(roots)
    while stack:
        x = stack.pop()
        t = type(x)
        k = kinds.get(t)
        if k is None:
            k = kinds[t] = _kind(t)
        if k == _SKIP:
            continue
        if k == _ARRAY:
            x = _root(x)
            if id(x) not in seen:
                seen[id(x)] = (x, int(x.nbytes))
                if x.dtype.hasobject:
                    stack.extend(x.ravel().tolist())
            continue
        i = id(x)
        if i in seen:
            continue
        seen[i] = (x, sys.getsizeof(x))
        if k == _SEQUENCE:
            stack.extend(x)
        elif k == _MAPPING:
            # the keys unless all are strings (an instance's attribute names: not counted), read
            # at once (list() does not let another thread change the dictionary while it reads)
            keys = list(x)
            for key in keys:
                if type(key) is not str:
                    stack.extend(keys)
                    break
            stack.extend(x.values())
        elif k == _FUNCTION:
            if _ours(x.__module__) and x.__closure__:
                stack.extend(c.cell_contents for c in x.__closure__ if _filled(c))
        elif k == _INSTANCE:
            stack.extend(_members(x))
        elif k == _FROZEN:
            hit = frozen.get(i)
            if hit is None or hit[0] is not x:
                hit = frozen[i] = (x, _parts(_members(x), frozen, kinds))
            seen.update(hit[1])
    return seen


def _members(x: Any) -> list:
    """The instance dictionary (if any) and the slot values of ``x``."""
    d = getattr(x, "__dict__", None)
    out = [] if d is None else [d]
    for cls in type(x).__mro__:
        slots = getattr(cls, "__slots__", ())
        for name in (slots,) if isinstance(slots, str) else slots:
            if name not in ("__dict__", "__weakref__") and hasattr(x, name):
                out.append(getattr(x, name))
    return out


def _ours(module: str | None) -> bool:
    """Whether ``module`` is one of the library's."""
    return module is not None and (module == __package__ or module.startswith(__package__ + "."))


def _filled(cell) -> bool:
    try:
        cell.cell_contents
    except ValueError:  # an empty cell (a name not yet bound)
        return False
    return True


_MISSING = object()  # no entry (None can be a value)


def _hashable(key: Any) -> bool:
    try:
        hash(key)
    except TypeError:
        return False
    return True


class CacheSize(NamedTuple):
    """What the store holds: ``entries`` and ``bytes`` (as the bound counts them)."""

    entries: int
    bytes: int


class Store:
    """A store of computed values bounded by entries and bytes, least recently used out first.

    ``store.get(key, make)`` is ``make()`` the first time and the stored value after;
    ``lookup``, ``put`` and ``pop`` reach an entry without computing it.  Keys are tuples whose
    first item names what is stored (``("dynamics.samples", ...)``), so that the users of the
    one store cannot collide.  An entry put with an ``owner`` is forgotten when the owner is
    (the LU factors of a step data object).  Thread-safe: ``make()`` runs outside the lock (two
    threads may compute the same value; the first stored is kept and returned to both).
    """

    def __init__(self, max_bytes: int = MAX_BYTES, max_entries: int = MAX_ENTRIES) -> None:
        self._lock = threading.RLock()
        #: key -> (value, ids of what it holds, weak reference to its owner or None), oldest first
        self._data: OrderedDict[Hashable, tuple[Any, tuple[int, ...], Any]] = OrderedDict()
        self._held: dict[int, list] = {}  # id -> [object, bytes, entries holding it]
        self._frozen: dict[int, tuple[Any, dict]] = {}  # id -> (frozen instance held, its parts)
        self._kinds: dict[type, int] = {}  # the walk's kind of each type met (see _parts)
        self._owned: dict[Any, Hashable] = {}  # weak reference to an owner -> its entry's key
        self._dead: collections.deque = collections.deque()  # references whose owner is gone
        self._bytes = 0
        self.max_bytes = self.max_entries = 0
        self.limit(max_bytes, max_entries)

    # --- the bounds ------------------------------------------------------------------------
    def limit(self, max_bytes: int | None = None, max_entries: int | None = None) -> None:
        """Set the bounds (``None`` keeps one); the oldest entries go at once if they are exceeded."""
        with self._lock:
            if max_bytes is not None:
                self.max_bytes = number("max_bytes", max_bytes, integer=True, low=0, unit="bytes")
            if max_entries is not None:
                self.max_entries = number("max_entries", max_entries, integer=True, low=1)
            self._evict()

    def size(self) -> CacheSize:
        """Entries and bytes held now."""
        with self._lock:
            self._bury()
            return CacheSize(len(self._data), self._bytes)

    def clear(self) -> None:
        """Forget every entry."""
        with self._lock:
            self._data.clear()
            self._held.clear()
            self._frozen.clear()
            self._owned.clear()
            self._dead.clear()
            self._bytes = 0

    # --- entries -------------------------------------------------------------------------------
    def get(self, key: Hashable, make: Callable[[], Any]) -> Any:
        """The value stored under ``key``, or ``make()`` stored under it (an unhashable key:
        ``make()``, not stored)."""
        hit = self._find(key, _MISSING, "touch")
        if hit is not _MISSING:
            return hit
        if not _hashable(key):
            return make()
        value = make()
        with self._lock:
            hit = self._data.get(key)
            if hit is not None:  # another thread stored it meanwhile
                self._data.move_to_end(key)
                return hit[0]
            self._add(key, value, None)
        return value

    def lookup(self, key: Hashable, default: Any = None, *, touch: bool = True) -> Any:
        """The value stored under ``key``, or ``default``; ``touch=False`` leaves its place in
        the order of use (a look that is not a use)."""
        return self._find(key, default, "touch" if touch else "look")

    def put(self, key: Hashable, value: Any, owner: Any = None) -> None:
        """Store ``value`` under ``key``, replacing what was there (an unhashable key: nothing);
        with an ``owner`` (an object that takes weak references) the entry is forgotten when the
        owner is, and its value must not refer to the owner."""
        if not _hashable(key):
            return
        with self._lock:
            self._bury()
            self._forget(key)
            self._add(key, value, None if owner is None else weakref.ref(owner, self._dead.append))

    def pop(self, key: Hashable, default: Any = None) -> Any:
        """Remove the entry of ``key`` and return its value (``default`` if there is none)."""
        return self._find(key, default, "pop")

    def keys(self, kind: str) -> list[Hashable]:
        """The keys whose first item is ``kind``, least recently used first."""
        with self._lock:
            self._bury()
            return [k for k in self._data if isinstance(k, tuple) and k and k[0] == kind]

    def _find(self, key, default, how: str):
        """The value of ``key`` (or ``default``, also for a key that cannot be hashed), and
        ``how``: "touch" makes it the newest, "pop" removes it, "look" leaves it.  (The key is
        hashed once: a parameter set is slow to hash.)"""
        with self._lock:
            self._bury()
            try:
                hit = self._data.get(key)
            except TypeError:  # a key that cannot be hashed: never stored
                return default
            if hit is None:
                return default
            if how == "pop":
                self._forget(key)
            elif how == "touch":
                self._data.move_to_end(key)
            return hit[0]

    # --- the count -----------------------------------------------------------------------------
    def _add(self, key, value, owner) -> None:
        """Count the new entry ``key -> value`` (what the key holds too), the last in the
        order, and forget the oldest while a bound is exceeded."""
        parts = _parts([key, value], self._frozen, self._kinds)
        for i, (obj, nbytes) in parts.items():
            h = self._held.get(i)
            if h is None:
                self._held[i] = [obj, nbytes, 1]
                self._bytes += nbytes
            else:
                h[2] += 1
        self._data[key] = (value, tuple(parts), owner)
        if owner is not None:
            self._owned[owner] = key
        self._evict()

    def _forget(self, key) -> None:
        old = self._data.pop(key, None)
        if old is None:
            return
        if old[2] is not None:
            self._owned.pop(old[2], None)
        for i in old[1]:
            h = self._held[i]
            h[2] -= 1
            if h[2] == 0:
                del self._held[i]
                self._frozen.pop(i, None)
                self._bytes -= h[1]

    def _evict(self) -> None:
        while len(self._data) > 1 and (len(self._data) > self.max_entries or self._bytes > self.max_bytes):
            self._forget(next(iter(self._data)))

    def _bury(self) -> None:
        """Forget the entries whose owner is gone (queued by the weak references' callbacks,
        which may run inside any operation: they only queue)."""
        while self._dead:
            ref = self._dead.popleft()
            key = self._owned.pop(ref, None)
            if key is not None and self._data.get(key, (None, None, None))[2] is ref:
                self._forget(key)

    def _after_fork(self) -> None:
        self._lock = threading.RLock()


#: The library's one store (:func:`clear_cache` empties it).
STORE = Store()
if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=STORE._after_fork)


def clear_cache() -> None:
    """Forget everything the library keeps between calls (``fivebar.clear_cache()``): the
    sampled matrices, models and dynamics, the remembered orbits, the sweep points, the modal
    data and the element tables.  Results do not change; the next calls compute afresh."""
    STORE.clear()


def cache_size() -> CacheSize:
    """Entries and bytes the library's store holds now (bounded by ``STORE.max_entries`` and
    ``STORE.max_bytes``, by default :data:`MAX_ENTRIES` and :data:`MAX_BYTES`)."""
    return STORE.size()


def memoised(fn: Callable) -> Callable:
    """``fn`` computed once per arguments (positional and keyword, hashable) and kept in
    :data:`STORE`; the value is shared, so ``fn`` returns what callers do not change (read-only
    arrays)."""
    kind = f"{fn.__module__}.{fn.__qualname__}"

    @functools.wraps(fn)
    def wrapper(*args, **kwargs):
        key = (kind, args, tuple(sorted(kwargs.items()))) if kwargs else (kind, args)
        return STORE.get(key, lambda: fn(*args, **kwargs))
    return wrapper
