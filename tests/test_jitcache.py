"""The compile cache heals (fivebar.numerics._jitcache): damaged files are discarded and rebuilt with one
warning, a read-only cache is read as it is, a temporary cache is removed at exit.

Every case runs in a subprocess on a cache of its own (a small module of two compiled
functions in a temporary directory, or the real kernels under a NUMBA_CACHE_DIR of the test's
own), so the worktree's cache is never touched while other tests run.  The reference is the
function's value computed by hand, and numba's own counters (cache hits and misses) say whether
the function was loaded or compiled.
"""

from __future__ import annotations

import glob
import json
import os
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

LIB = str(Path(__file__).resolve().parents[1] / "lib")

TINY = textwrap.dedent("""
    from numba import njit

    @njit(cache=True)
    def inner(x):
        return 2.0 * x

    @njit(cache=True)
    def f(x):
        return inner(x) + 1.0
""")

RUN = textwrap.dedent("""
    import json, sys, warnings
    sys.path[:0] = [sys.argv[1], sys.argv[2]]
    warnings.simplefilter("always")
    with warnings.catch_warnings(record=True) as w:
        from fivebar.numerics._jitcache import import_cached
        import fivebar.numerics._jitcache as jc
        m = import_cached("tiny")
        value = m.f(1.5)
    s = m.f.stats
    print(json.dumps({"value": value, "hits": sum(s.cache_hits.values()),
                      "misses": sum(s.cache_misses.values()), "path": s.cache_path,
                      "temp": jc._TEMP_DIR,
                      "warnings": [(x.category.__name__, str(x.message)) for x in w]}))
""")


pytestmark = pytest.mark.slow  # subprocesses and signals: make test runs them, make check does not


def _env(tmp_path: Path) -> dict:
    env = dict(os.environ)
    env.pop("NUMBA_CACHE_DIR", None)
    env.pop("NUMBA_CACHE_LOCATOR_CLASSES", None)
    env["XDG_CACHE_HOME"] = str(tmp_path / "user-cache")  # never the user's real cache
    return env


def _run(src: Path, env: dict, prefix: tuple[str, ...] = ()) -> dict:
    cmd = [*prefix, sys.executable, "-c", RUN, str(src), LIB]
    r = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=300)
    assert r.returncode == 0, r.stderr
    return json.loads(r.stdout.strip().splitlines()[-1])


@pytest.fixture
def tiny(tmp_path):
    src = tmp_path / "src"
    src.mkdir()
    (src / "tiny.py").write_text(TINY)
    return src


def _damage(path: str, how: str) -> None:
    data = Path(path).read_bytes()
    if how == "truncated":
        Path(path).write_bytes(data[: len(data) // 2])
    elif how == "empty":
        Path(path).write_bytes(b"")
    else:  # garbled: same length, other bytes
        Path(path).write_bytes(bytes((b * 7 + 13) % 256 for b in data))


@pytest.mark.parametrize("how", ["truncated", "empty", "garbled"])
@pytest.mark.parametrize("kind", ["nbi", "nbc"])
def test_a_damaged_cache_file_is_discarded_and_rebuilt(tiny, tmp_path, kind, how):
    env = _env(tmp_path)
    first = _run(tiny, env)
    assert first["value"] == 4.0 and first["misses"] == 1 and first["warnings"] == []
    cache = tiny / "__pycache__"
    (target,) = glob.glob(str(cache / f"tiny.f-*.{kind}"))
    _damage(target, how)
    second = _run(tiny, env)
    assert second["value"] == 4.0 and second["misses"] == 1
    healed = [m for c, m in second["warnings"] if c == "CacheHealedWarning"]
    assert len(healed) == 1 and len(second["warnings"]) == 1, second["warnings"]
    assert "tiny.f" in healed[0] and "unreadable" in healed[0] and "removed" in healed[0]
    third = _run(tiny, env)  # rebuilt: loaded again, silently
    assert third["value"] == 4.0 and third["hits"] == 1 and third["misses"] == 0
    assert third["warnings"] == []


def _read_only_prefix(directory: Path) -> tuple[str, ...] | None:
    """A command prefix under which ``directory`` is read-only (for root, a read-only bind
    mount in a mount namespace of the subprocess's own; otherwise chmod)."""
    if os.geteuid() != 0:
        for p in [directory, *directory.rglob("*")]:
            p.chmod(p.stat().st_mode & ~0o222)
        return ()
    unshare, mount = shutil.which("unshare"), shutil.which("mount")
    if not (unshare and mount):
        return None
    d = str(directory)
    probe = subprocess.run([unshare, "-m", "sh", "-c",
                            f"mount --bind -o ro '{d}' '{d}' && ! touch '{d}/probe' 2>/dev/null"],
                           capture_output=True)
    if probe.returncode != 0:
        return None
    return (unshare, "-m", "sh", "-c", f"mount --bind -o ro '{d}' '{d}' && exec \"$0\" \"$@\"")


def test_a_read_only_cache_is_used_as_it_is(tiny, tmp_path):
    env = _env(tmp_path)
    assert _run(tiny, env)["misses"] == 1
    before = sorted(os.listdir(tiny / "__pycache__"))
    prefix = _read_only_prefix(tiny)
    if prefix is None:
        pytest.skip("cannot make a directory read-only here (root without mount namespaces)")
    (tmp_path / "user-cache").mkdir(exist_ok=True)
    Path(tmp_path / "user-cache").chmod(0o555) if os.geteuid() != 0 else None
    r = _run(tiny, env, prefix)
    assert r["value"] == 4.0 and r["hits"] == 1 and r["misses"] == 0, r
    assert r["path"] == str(tiny / "__pycache__") and r["temp"] is None
    assert r["warnings"] == []
    assert sorted(os.listdir(tiny / "__pycache__")) == before


@pytest.mark.parametrize("how", ["garbled", "stale"])
def test_a_read_only_cache_that_cannot_serve_is_healed_once_into_a_temporary_location(tiny, tmp_path, how):
    """Issue 36: a read-only cache whose entry is unreadable (garbled) or out of date (the source
    changed after it was written) cannot be healed in place.  The first process compiles once,
    says so once (the remedy named) and keeps the healed copy in a temporary location of the
    user's own; the next process loads that copy (a cache hit, no compilation, no word), and the
    read-only cache is left as it is.  (Planted: with the healed copy not read, the second run
    compiles again, misses == 1; with the report per function, not per directory, and a second
    damaged function, two warnings.)"""
    env = _env(tmp_path)
    env["TMPDIR"] = str(tmp_path / "tmp")  # the healed copy's location: the test's own
    (tmp_path / "tmp").mkdir()
    assert _run(tiny, env)["misses"] == 1
    cache = tiny / "__pycache__"
    if how == "garbled":
        for f in glob.glob(str(cache / "tiny.*.nbi")):  # both functions: still one warning
            _damage(f, "garbled")
    else:
        with open(tiny / "tiny.py", "a") as fh:  # the source changed (numba stamps its hash)
            fh.write("# changed\n")
    before = {p: Path(p).read_bytes() for p in glob.glob(str(cache / "*"))}
    prefix = _read_only_prefix(tiny)
    if prefix is None:
        pytest.skip("cannot make a directory read-only here (root without mount namespaces)")
    (tmp_path / "user-cache").mkdir(exist_ok=True)
    Path(tmp_path / "user-cache").chmod(0o555) if os.geteuid() != 0 else None
    first = _run(tiny, env, prefix)
    assert first["value"] == 4.0 and first["misses"] == 1, first
    said = [m for c, m in first["warnings"] if c == "CacheHealedWarning"]
    assert len(said) == 1 and len(first["warnings"]) == 1, first["warnings"]
    assert str(cache) in said[0] and "read-only" in said[0] and "NUMBA_CACHE_DIR" in said[0]
    healed = glob.glob(str(tmp_path / "tmp" / "fivebar-numba-*" / "*"))
    assert len(healed) == 1 and healed[0] in said[0] and glob.glob(healed[0] + "/tiny.f-*.nbi")
    assert os.stat(Path(healed[0]).parent).st_mode & 0o077 == 0  # the user's own, private
    second = _run(tiny, env, prefix)
    assert second["value"] == 4.0 and second["hits"] >= 1 and second["misses"] == 0, second
    assert second["warnings"] == []
    assert {p: Path(p).read_bytes() for p in glob.glob(str(cache / "*"))} == before


def test_a_healed_copy_in_a_directory_of_another_user_is_not_read(tmp_path, monkeypatch):
    """The healed copy's location is refused unless it is the user's own and private: another
    user's directory in /tmp could hand this process pickles to load."""
    from fivebar.numerics._jitcache import healed_cache_dir

    monkeypatch.setenv("TMPDIR", str(tmp_path))
    import tempfile

    monkeypatch.setattr(tempfile, "tempdir", None)
    assert healed_cache_dir("/some/cache") is not None
    root = next(tmp_path.glob("fivebar-numba-*"))
    root.chmod(0o777)
    assert healed_cache_dir("/some/cache") is None


def test_with_nowhere_to_write_the_temporary_cache_is_removed_at_exit(tiny, tmp_path):
    """Neither beside the source nor in the user's cache: the functions compile into a temporary
    directory, with a warning naming NUMBA_CACHE_DIR, removed at exit.  (The kernels take the same
    path through import_cached; compiling them there cost 15 s of make test, so the small module
    stands for them.)"""
    env = _env(tmp_path)
    env["XDG_CACHE_HOME"] = "/dev/null/cannot-be-a-directory"
    prefix = _read_only_prefix(tiny)
    if prefix is None:
        pytest.skip("cannot make a directory read-only here (root without mount namespaces)")
    r = _run(tiny, env, prefix)
    assert r["value"] == 4.0 and r["misses"] == 1
    assert r["temp"] and r["path"].startswith(r["temp"])
    assert any("NUMBA_CACHE_DIR" in m for _, m in r["warnings"]), r["warnings"]
    assert not os.path.exists(r["temp"]), "the temporary cache directory was left behind"


KERNELS = textwrap.dedent("""
    import json, sys, warnings
    import numpy as np
    sys.path.insert(0, sys.argv[1])
    warnings.simplefilter("always")
    from fivebar.numerics.newmark import integrate
    from fivebar.numerics.systems import System
    import fivebar.numerics.newmark as nm
    # u'' + u = 0 from u = 1: u(t) = cos t (average acceleration: the phase error is O(dt^2))
    with warnings.catch_warnings(record=True) as w:
        r = integrate(System(np.eye(1), np.zeros((1, 1)), np.eye(1)), [1.0], [0.0], 0.0, 0.01,
                      100, a0=[-1.0])
    print(json.dumps({"u": float(r.u[-1, 0]), "compiled": nm._KERNELS is not False,
                      "warnings": [(x.category.__name__, str(x.message)) for x in w]}))
""")


def test_the_kernels_heal_a_truncated_cache(tmp_path):
    """The real kernels (one recompilation): the march's data file truncated in a cache of the
    test's own, a copy of the worktree's cache where one exists."""
    from numba.core import caching

    kern = Path(LIB) / "fivebar" / "numerics" / "_kernels.py"
    own = tmp_path / "numba"
    target = own / caching._CacheLocator.get_suitable_cache_subpath(str(kern))
    real = glob.glob(str(kern.parent / "__pycache__" / "_kernels.*.nb[ic]"))
    env = _env(tmp_path)
    env["NUMBA_CACHE_DIR"] = str(own)
    if real:
        target.mkdir(parents=True)
        for f in real:
            shutil.copy(f, target)
    cmd = [sys.executable, "-c", KERNELS, LIB]
    first = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=900)
    assert first.returncode == 0, first.stderr
    ref = json.loads(first.stdout.splitlines()[-1])
    assert abs(ref["u"] - __import__("math").cos(1.0)) < 1e-4
    data = sorted(glob.glob(str(target / "_kernels.march-*.nbc")))
    assert data, os.listdir(target)
    for f in data:
        _damage(f, "truncated")
    second = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=900)
    assert second.returncode == 0, second.stderr
    out = json.loads(second.stdout.splitlines()[-1])
    assert out["u"] == ref["u"]
    healed = [m for c, m in out["warnings"] if c == "CacheHealedWarning"]
    assert len(healed) == 1 and "_kernels.march" in healed[0], out["warnings"]


TINY_SIGNED = TINY + textwrap.dedent("""
    __jit_signatures__ = {"f": ["float64(float64)"], "inner": ["float64(float64)"]}
""")

TWO_THREADS = textwrap.dedent("""
    import sys, threading
    sys.path[:0] = [sys.argv[1], sys.argv[2]]
    from fivebar.numerics._jitcache import import_cached
    go, out = threading.Barrier(4), []
    def first_use():
        go.wait()
        try:
            out.append(import_cached("tiny").f(1.5))
        except Exception as exc:
            out.append(repr(exc))
    threads = [threading.Thread(target=first_use) for _ in range(4)]
    [t.start() for t in threads]
    [t.join() for t in threads]
    print(out)
""")


def test_a_first_use_in_several_threads_at_once_compiles_once(tmp_path):
    # the continuation's second thread, or a thread pool, can be where the kernels are used
    # first: a thread that found the signatures half loaded by another used to raise
    # "compilation disabled" (planted: without the import lock, 3 of 4 threads raised so)
    src = tmp_path / "src"
    src.mkdir()
    (src / "tiny.py").write_text(TINY_SIGNED)
    for run in ("compiles", "loads the cache"):
        r = subprocess.run([sys.executable, "-c", TWO_THREADS, str(src), LIB], capture_output=True,
                           text=True, env=_env(tmp_path), timeout=300)
        assert r.returncode == 0, r.stderr
        assert r.stdout.strip() == "[4.0, 4.0, 4.0, 4.0]", (run, r.stdout)
