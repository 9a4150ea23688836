"""A disk cache of numba-compiled functions that heals, reads read-only copies and cleans up.

numba (0.68, pinned) caches ``cache=True`` functions as pickles: an index ``<name>.nbi`` and
one data file ``<name>.<k>.nbc`` per compiled signature.  Three of its behaviours matter to a
library that ships such functions (numba issue #10434; pull request #10656 proposes the same
cure and is not released):

* A truncated, empty or garbled cache file (a full disk, a killed process, a bad copy) makes
  every later call raise ``EOFError`` or ``pickle.UnpicklingError`` from inside numba, in every
  process, until someone deletes the file by hand.
* A cache directory that exists but is read-only (a system-wide install, a read-only mount) is
  ignored: numba only chooses a directory it can write, so every process compiles again; and
  a read-only cache whose entries are unreadable or stale cannot be healed in place, so every
  process compiles again too (26 s for the kernels), saying nothing.
* Where no writable location exists, numba raises ``RuntimeError`` when the module is imported.

:func:`import_cached` imports a module of compiled functions so that none of this happens: an
unreadable cache entry is discarded (removed where the directory allows) and the function
compiled again, with one :class:`CacheHealedWarning` naming the file and the error; a
read-only cache that holds entries of the module is read as it is; where it cannot serve a
function (an entry unreadable, stale or missing) and cannot be rewritten, the function is
compiled once and the healed copy kept in a temporary location of the user's own
(:func:`healed_cache_dir`), which the later processes read: one :class:`CacheHealedWarning`
per cache directory, in the process that heals it, names the files and the remedy; and with
nowhere to write, the cache lives in a temporary directory that is removed when the process
exits.  The order of the locations is numba's:
``NUMBA_CACHE_DIR`` if set, ``__pycache__`` beside the source if writable, then (new) that
``__pycache__`` read-only if it holds entries, then the user-wide cache directory, then (new)
the temporary directory.

This module knows nothing of the linkage; :func:`fivebar.numerics.newmark` loads its kernels with it.
"""

from __future__ import annotations

import atexit
import glob
import hashlib
import importlib
import os
import shutil
import stat
import tempfile
import threading
import warnings
from types import ModuleType

from numba.core import caching, config
from numba.core.registry import CPUDispatcher

__all__ = ["CacheHealedWarning", "healed_cache_dir", "import_cached", "temporary_cache_dir"]


class CacheHealedWarning(RuntimeWarning):
    """A compile-cache file was unreadable and has been discarded (the function recompiles)."""


_TEMP_DIR: str | None = None


def temporary_cache_dir() -> str:
    """The process's temporary cache directory (made on first use, removed at exit)."""
    global _TEMP_DIR
    if _TEMP_DIR is None:
        _TEMP_DIR = tempfile.mkdtemp(prefix="fivebar-numba-")
        atexit.register(shutil.rmtree, _TEMP_DIR, True)
        warnings.warn(
            "numba cannot cache the compiled kernels beside the package or in the user's cache "
            f"directory (neither is writable); caching in {_TEMP_DIR} for this process only "
            "(removed at exit). Set NUMBA_CACHE_DIR to a writable directory to keep the cache.",
            RuntimeWarning, stacklevel=4)
    return _TEMP_DIR


def healed_cache_dir(cache_path: str) -> str | None:
    """The temporary location of the healed copy of the read-only cache ``cache_path``:
    ``<tmp>/fivebar-numba-<uid>/<hash of cache_path>`` (kept across processes), or None where
    that directory cannot be made, or is not the user's own and private (another user's
    directory could hand this process pickles to load)."""
    uid = os.getuid() if hasattr(os, "getuid") else 0
    root = os.path.join(tempfile.gettempdir(), f"fivebar-numba-{uid}")
    try:
        os.makedirs(root, mode=0o700, exist_ok=True)
        st = os.lstat(root)
    except OSError:
        return None
    if not stat.S_ISDIR(st.st_mode) or (hasattr(os, "getuid") and st.st_uid != uid) or st.st_mode & 0o077:
        return None
    path = os.path.join(root, hashlib.sha256(os.path.abspath(cache_path).encode()).hexdigest()[:16])
    try:
        os.makedirs(path, mode=0o700, exist_ok=True)
    except OSError:
        return None
    return path


#: the read-only cache directories whose healing this process has reported (one warning each)
_REPORTED: set[str] = set()


class _ReadOnlyInTreeLocator(caching.InTreeCacheLocator):
    """``__pycache__`` beside the source, read-only, chosen only if it holds entries of the
    module (an ``.nbi`` index of one of its functions)."""

    @classmethod
    def from_function(cls, py_func, py_file):
        self = cls(py_func, py_file)
        path = self.get_cache_path()
        stem = os.path.splitext(os.path.basename(py_file))[0]
        if not (os.access(path, os.R_OK | os.X_OK) and glob.glob(os.path.join(path, f"{stem}.*.nbi"))):
            return None
        return self

    def ensure_cache_path(self):  # nothing to create: the directory is read as it is
        pass


class _TemporaryLocator(caching.UserProvidedCacheLocator):
    """The last resort: a temporary directory of this process (removed at exit)."""

    def __init__(self, py_func, py_file):
        self._py_file = py_file
        self._lineno = py_func.__code__.co_firstlineno
        self._cache_path = os.path.join(temporary_cache_dir(),
                                        self.get_suitable_cache_subpath(py_file))

    @classmethod
    def from_function(cls, py_func, py_file):
        self = cls(py_func, py_file)
        try:
            self.ensure_cache_path()
        except OSError:
            return None
        return self


_LOCATORS = [caching.UserProvidedCacheLocator, caching.InTreeCacheLocator,
             _ReadOnlyInTreeLocator, caching.UserWideCacheLocator, _TemporaryLocator]
_LOCATOR_PATHS = ",".join(f"{c.__module__}.{c.__qualname__}" for c in _LOCATORS)
_TEMPORARY_PATH = f"{__name__}._TemporaryLocator"


class _Impl(caching.CompileResultCacheImpl):
    _locator_classes = _LOCATORS


class _HealingCache(caching.FunctionCache):
    """numba's function cache, but an unreadable entry is a miss (discarded, with a warning),
    and a cache that cannot be written is read as it is, its misses compiled once and kept
    healed in :func:`healed_cache_dir`."""

    _impl_class = _Impl
    #: the healed copy's cache file once this cache is redirected there (None: not redirected)
    _healed = None
    #: why the read-only cache could not serve (for the one warning), None if it served
    _why: str | None = None

    def load_overload(self, sig, target_context):
        if self._healed is not None:
            return self._load_healed(sig, target_context)
        try:
            data = super().load_overload(sig, target_context)
        except Exception as exc:  # any failure to read or rebuild an entry: treat as a miss
            if self._discard(exc):
                return self._load_healed(sig, target_context)
            return None
        if data is None and self._enabled and self._healed_copy(create=False):
            # a miss in a read-only cache (a stale entry): the healed copy if there is one
            data = self._load_healed(sig, target_context)
        return data

    def save_overload(self, sig, data):
        if self._healed is not None:
            return self._save_healed(sig, data)
        try:
            super().save_overload(sig, data)
        except OSError:  # a read-only cache: the compiled function kept healed elsewhere
            if self._healed_copy(create=True):
                self._why = self._why or "it has no readable entry for this signature (stale or missing)"
                self._save_healed(sig, data)

    def _healed_copy(self, create: bool) -> bool:
        """Redirect this cache to its healed copy; with ``create`` False only if the copy has
        an index of this function already.  False where no healed location is usable."""
        if self._healed is not None:
            return True
        path = healed_cache_dir(self._cache_path)
        if path is None:
            return False
        cf = caching.IndexDataCacheFile(cache_path=path, filename_base=self._impl.filename_base,
                                        source_stamp=self._impl.locator.get_source_stamp())
        if not create and not os.path.exists(cf._index_path):
            return False
        self._read_only_path, self._healed = self._cache_path, cf
        return True

    def _load_healed(self, sig, target_context):
        try:
            data = self._healed.load(self._index_key(sig, target_context.codegen()))
            return None if data is None else self._impl.rebuild(target_context, data)
        except Exception:  # noqa: BLE001 - a damaged healed copy is a miss; compiled and saved again
            return None

    def _save_healed(self, sig, data):
        if not self._impl.check_cachable(data):
            return
        key = self._index_key(sig, data.codegen)
        try:
            self._healed.save(key, self._impl.reduce(data))
        except OSError:
            return
        ro = self._read_only_path
        if ro in _REPORTED:
            return
        _REPORTED.add(ro)
        stem = os.path.basename(self._cache_file._index_path)[:-len(".nbi")]
        warnings.warn(
            f"the compile cache in {ro} cannot serve {self._py_func.__module__}.{self._py_func.__qualname__} "
            f"({self._why}) and cannot be rewritten (read-only): compiled again (tens of seconds), and "
            f"the healed copy kept in {self._healed._cache_path}, which later processes read. To heal the "
            f"cache itself, as a user who may write to {ro}: remove the damaged files ({stem}.nbi and "
            f"{stem}.*.nbc, or all of its .nbi and .nbc files) or run once with write access; or set "
            "NUMBA_CACHE_DIR to a writable directory.", CacheHealedWarning, stacklevel=2)

    def _discard(self, exc: BaseException) -> bool:
        """Remove the unreadable entry's files (one warning); where they cannot be removed,
        redirect to the healed copy (True: the caller reads it; warned when it is written)."""
        cf = self._cache_file
        index = cf._index_path
        stem = index[:-len(".nbi")]
        files = [index] + sorted(glob.glob(glob.escape(stem) + ".*.nbc"))
        removed, kept = [], []
        for f in files:
            if not os.path.exists(f):
                continue
            try:
                os.remove(f)
                removed.append(os.path.basename(f))
            except OSError:
                kept.append(os.path.basename(f))
        if kept:  # cannot remove them (read-only): the healed copy, or no cache in this process
            self._why = f"unreadable: {type(exc).__name__}: {exc}"
            if self._healed_copy(create=True):
                return True
            self.disable()
        what = (f"removed {', '.join(removed)}" if removed else
                f"could not remove {', '.join(kept)} (read-only): compiled in memory")
        warnings.warn(
            f"the compile cache of {self._py_func.__module__}.{self._py_func.__qualname__} in "
            f"{self._cache_path} is unreadable ({type(exc).__name__}: {exc}); {what}, "
            "recompiling (tens of seconds, once).", CacheHealedWarning, stacklevel=2)
        return False


def import_cached(name: str) -> ModuleType:
    """Import the module ``name`` of ``@njit(cache=True)`` functions with the healing cache.

    Every numba dispatcher among the module's attributes gets the cache described in the
    module docstring (before its first call; a dispatcher already compiled keeps its code).
    The module's ``__jit_signatures__`` (a dict: function name -> signatures), if any, are
    then compiled (or loaded from the cache) and those functions compile nothing else: an
    explicit signature is what keeps the type of a first-class function argument the same
    from one process to the next (a function typed by the dispatcher it was given would be
    compiled again in every process).  Importing again returns the module as it is.  One
    thread at a time (a second waits for the first's compilation, then finds it done).
    """
    with _IMPORT_LOCK:
        return _import_cached(name)


#: import_cached runs in one thread at a time (a process's first periods may start in two)
_IMPORT_LOCK = threading.RLock()


def _import_cached(name: str) -> ModuleType:
    user = config.CACHE_LOCATOR_CLASSES
    # numba picks a location per function when the module is imported and again when the
    # cache is replaced below: give it ours (or the user's, with the temporary one last)
    config.CACHE_LOCATOR_CLASSES = (f"{user},{_TEMPORARY_PATH}" if user else _LOCATOR_PATHS)
    try:
        mod = importlib.import_module(name)
        for value in list(vars(mod).values()):
            if isinstance(value, CPUDispatcher) and isinstance(value._cache, caching.FunctionCache) \
                    and not isinstance(value._cache, _HealingCache):
                value._cache = _HealingCache(value.py_func)
    finally:
        config.CACHE_LOCATOR_CLASSES = user
    for fname, sigs in getattr(mod, "__jit_signatures__", {}).items():
        dispatcher = getattr(mod, fname)
        if not dispatcher._can_compile:  # done by an earlier import
            continue
        for sig in sigs:
            dispatcher.compile(sig)
        dispatcher.disable_compile()
    return mod
