"""The library's one store (fivebar.cache): its order and bounds against a hand count, keys
that cannot be hashed, hits against fresh computations (the store emptied: an independent
path), results that do not depend on the budget, and no cache of the library outside it."""

from __future__ import annotations

import functools
import importlib
import inspect
import pkgutil
import sys
from collections import OrderedDict, deque

import numpy as np
import pandas as pd
import pytest

import fivebar
from fivebar import Setup, clear_cache, load_params, steady_state
from fivebar.cache import MAX_BYTES, MAX_ENTRIES, STORE, Store, cache_size, memoised
from fivebar.model.dynamics import LinkageDynamics, linkage_dynamics
from fivebar.errors import FivebarError

P = load_params()


@pytest.fixture
def budget():
    """Restores the library store's default bounds after the test."""
    yield STORE
    STORE.limit(MAX_BYTES, MAX_ENTRIES)


def _key_bytes(key) -> int:
    """What the store counts of a key of a name and a number: the tuple itself."""
    return sys.getsizeof(key)


def test_least_recently_used_goes_first_within_a_byte_bound_by_hand():
    a, b, c, d = (np.zeros(125) for _ in range(4))  # 1000 bytes each
    one = 1000 + _key_bytes(("t", 0))
    s = Store(max_bytes=3 * one, max_entries=10)
    for i, x in enumerate((a, b, c)):
        s.put(("t", i), x)
    assert s.size() == (3, 3 * one)
    assert s.get(("t", 0), lambda: pytest.fail("a hit must not compute")) is a  # a is now the newest
    s.put(("t", 3), d)  # 4 entries pass the bound: the least recently used (b) goes, not a
    assert s.keys("t") == [("t", 2), ("t", 0), ("t", 3)]
    assert s.size() == (3, 3 * one)
    assert s.lookup(("t", 2), touch=False) is c  # a look that is not a use: c stays the oldest
    # a second entry holding a's buffer (a view of it) adds only its own tuple: each buffer once
    s.put(("t", 4), (a[::2], a))
    assert s.keys("t") == [("t", 0), ("t", 3), ("t", 4)]  # c went (4 * one > the bound)
    assert s.size().bytes == 2 * one + _key_bytes(("t", 4)) + sys.getsizeof((a, a))
    s.pop(("t", 0))  # a's buffer is still held by ("t", 4)
    assert s.size().bytes == one + _key_bytes(("t", 4)) + sys.getsizeof((a, a)) + 1000
    s.limit(max_entries=1)  # the entry bound: the oldest go at once
    assert s.keys("t") == [("t", 4)] and s.size().bytes == _key_bytes(("t", 4)) + sys.getsizeof((a, a)) + 1000
    big = np.zeros(10_000)
    s.put(("t", 5), big)  # alone past the byte bound: the newest stays
    assert s.keys("t") == [("t", 5)] and s.size().bytes == 80_000 + _key_bytes(("t", 5))
    s.clear()
    assert s.size() == (0, 0)
    s.put(("t", 6), big)  # counted afresh after clear
    assert s.size() == (1, 80_000 + _key_bytes(("t", 6)))


def test_what_a_mapping_holds_is_counted_in_its_keys_too_unless_they_are_names():
    """A dictionary's values are counted; its keys too where one is not a string (a tuple key is
    a container; a string, like a number, is not counted, so a dictionary of names is walked by
    its values alone): the bytes a stored dictionary adds, by hand."""
    a, b = np.zeros(125), np.zeros(250)  # 1000 and 2000 bytes
    s = Store(max_bytes=10**6, max_entries=10)
    names = {"a": a, "b": b}
    s.put(("t", 0), names)
    assert s.size().bytes == _key_bytes(("t", 0)) + sys.getsizeof(names) + 3000
    tupled = {("a", 1): a, "b": b}  # a's buffer is held already: only the new containers add
    s.put(("t", 1), tupled)
    assert s.size().bytes == (_key_bytes(("t", 0)) + sys.getsizeof(names) + 3000 + _key_bytes(("t", 1))
                              + sys.getsizeof(tupled) + sys.getsizeof(("a", 1)))


def test_a_key_that_cannot_be_hashed_is_computed_each_time():
    s = Store()
    calls = []
    for _ in range(3):
        assert s.get(("k", [1, 2]), lambda: calls.append(1) or 7) == 7
    assert len(calls) == 3 and s.size() == (0, 0)
    s.put(("k", {}), 1)
    assert s.lookup(("k", {})) is None and s.pop(("k", {})) is None and s.size() == (0, 0)

    @memoised
    def twice(x):
        calls.append(x)
        return 2 * np.asarray(x)
    calls.clear()
    twice([1, 2]), twice([1, 2])  # a list: computed each time
    twice((1, 2)), twice((1, 2))  # a tuple: once
    assert calls == [[1, 2], [1, 2], (1, 2)]
    clear_cache()


def test_bad_bounds_are_refused_by_name():
    with pytest.raises(FivebarError, match="max_bytes"):
        Store(max_bytes=-1)
    with pytest.raises(FivebarError, match="max_entries"):
        Store(max_entries=0)


def test_an_entry_goes_with_its_owner():
    class Owner:
        pass
    s = Store()
    o = Owner()
    s.put(("lu", id(o)), np.zeros(8), owner=o)
    assert s.size().entries == 1
    del o
    assert s.size() == (0, 0)


def _arrays(d: LinkageDynamics) -> list[np.ndarray]:
    sd = d.step_data
    return [np.array(X) for X in (sd.M, sd.C, sd.K, sd.F)]


def _same_bits(xs, ys) -> bool:
    return all(x.shape == y.shape and x.tobytes() == y.tobytes() for x, y in zip(xs, ys))


def test_sampled_matrices_from_the_store_are_those_sampled_afresh(monkeypatch):
    """A hit, and the samples of S made from those of 2 S or S / 2, equal bit for bit the
    samples made with the store emptied; a hit shares the stored arrays (no copy)."""
    kw = dict(crank_speed_rpm=200, motors=False)
    clear_cache()
    fresh = _arrays(LinkageDynamics(Setup(P, steps_per_period=44, **kw)))
    calls = []
    real = LinkageDynamics._sample
    monkeypatch.setattr(LinkageDynamics, "_sample", lambda self, t, params=None, **kw: calls.append(np.size(t)) or real(self, t, params, **kw))
    for other, sampled in ((88, []), (22, [22])):  # from 2 S: none sampled; from S / 2: the S / 2 new ones (S = 44: S / 2 >= 2 m + 1)
        clear_cache()
        LinkageDynamics(Setup(P, steps_per_period=other, **kw))
        calls.clear()
        d = LinkageDynamics(Setup(P, steps_per_period=44, **kw))
        assert calls == sampled
        assert _same_bits(_arrays(d), fresh)
    calls.clear()
    again = LinkageDynamics(Setup(P, steps_per_period=44, **kw))
    assert calls == [] and _same_bits(_arrays(again), fresh)
    for name in "MCK":
        assert np.shares_memory(getattr(again.step_data, name), getattr(d.step_data, name))
    # another speed: M, C, K are the same arrays; F is the stored F / Omega^2 of the speed-free
    # set times the new Omega^2, the same bits as with the store emptied (what was sampled first
    # does not matter), and to rounding what sampling at that speed gives
    other = LinkageDynamics(Setup(P, steps_per_period=44, crank_speed_rpm=437, motors=False))
    assert calls == [] and _same_bits(_arrays(other)[:3], fresh[:3])
    clear_cache()
    direct = LinkageDynamics(Setup(P, steps_per_period=44, crank_speed_rpm=437, motors=False))
    F, G = _arrays(other)[3], _arrays(direct)[3]
    assert _same_bits([F], [G]) and not _same_bits([F], [fresh[3]])
    G = direct._sample(direct.t)[3]
    assert np.abs(F - G).max() <= 1e-14 * np.abs(G).max()


def test_equal_setups_share_one_dynamics():
    clear_cache()
    a = Setup(P, crank_speed_rpm=300, steps_per_period=60, nonlinear=False)
    b = Setup(P, crank_speed_rpm=300.0, steps_per_period=60, nonlinear=False, scheme=fivebar.PAPER_SCHEME)
    assert linkage_dynamics(a) is linkage_dynamics(b)  # the scheme is not the dynamics'
    assert linkage_dynamics(a.replace(steps_per_period=80)) is not linkage_dynamics(a)


def test_a_sweep_point_from_the_store_is_the_one_computed_afresh(monkeypatch):
    from fivebar.analyses import sweep

    speeds = [150.0, 420.0]
    first = dict(progress=False)
    second = dict(progress=False, links=("L2",), direction="chord")
    problem = Setup(P, steps_per_period=50, nonlinear=False)
    clear_cache()
    a = sweep.speed_sweep(problem, speeds, **first)
    b = sweep.speed_sweep(problem, speeds, **second)  # other options: other entries
    assert not np.array_equal(a["L2 p2p (mm)"], b["L2 p2p (mm)"])
    real = sweep.sweep_point
    monkeypatch.setattr(sweep, "sweep_point", lambda *a, **k: pytest.fail("a hit must not compute"))
    hit_a, hit_b = sweep.speed_sweep(problem, speeds, **first), sweep.speed_sweep(problem, speeds, **second)
    monkeypatch.setattr(sweep, "sweep_point", real)
    for hit, opts in ((hit_a, first), (hit_b, second)):
        clear_cache()
        pd.testing.assert_frame_equal(hit, sweep.speed_sweep(problem, speeds, **opts), check_exact=True)


def test_results_do_not_depend_on_the_budget_and_it_holds(budget):
    """With a budget of one byte every entry but the newest goes at once (the LU factors in the
    middle of a shooting, the dynamics of a set-up, the samples): the steady states are those
    of the default budget bit for bit (there S = 120 is made from the samples at 60 and the
    second S = 60 is a hit), and the store never holds more than its newest entry.  (One
    speed: F at another speed is scaled from the speed that sampled the set-up first, equal
    to rounding only.)"""
    def run():
        out = []
        for S in (60, 120, 60):
            res = steady_state(Setup(P, crank_speed_rpm=300.0, steps_per_period=S, nonlinear=False))
            out.append((res.u.copy(), res.v.copy(), res.floquet_multipliers.copy()))
            assert cache_size().bytes <= STORE.max_bytes or cache_size().entries == 1
        return out
    clear_cache()
    ample = run()
    clear_cache()
    budget.limit(max_bytes=1)
    tight = run()
    assert cache_size().entries == 1
    for x, y in zip(ample, tight):
        assert _same_bits(x, y)
    budget.limit(max_bytes=2 * 2**20)
    steady_state(Setup(P, crank_speed_rpm=400, steps_per_period=200, nonlinear=False))
    assert cache_size().bytes <= 2 * 2**20 or cache_size().entries == 1


def _library_modules():
    for m in pkgutil.walk_packages(fivebar.__path__, "fivebar."):
        yield importlib.import_module(m.name)


def _containers():
    """(module, name) -> the module-level dicts, lists, sets and deques of the library."""
    out = {}
    for mod in _library_modules():
        for name, value in vars(mod).items():
            if isinstance(value, (dict, OrderedDict, list, set, deque)):
                out[(mod.__name__, name)] = value
    return out


def _contents(x):
    """What a container holds, by identity."""
    return [(id(k), id(v)) for k, v in x.items()] if isinstance(x, dict) else [id(v) for v in x]


def test_no_cache_of_the_library_lives_outside_the_store():
    """No functools cache anywhere in the library, no module-level container that grows while
    the library computes (a dictionary kept outside the store), and clear_cache empties
    what the store holds."""
    wrappers = []
    for mod in _library_modules():
        for name, value in vars(mod).items():
            inner = [value] + ([v for v in vars(value).values()] if inspect.isclass(value) else [])
            for v in inner:
                v = getattr(v, "__func__", v)
                if isinstance(v, functools._lru_cache_wrapper):
                    wrappers.append(f"{mod.__name__}.{name}")
    assert not wrappers, f"caches outside fivebar.cache: {wrappers}"

    before = {k: (id(v), _contents(v)) for k, v in _containers().items()}
    clear_cache()
    from fivebar.model import elements
    from fivebar.analyses import resonance, response, sweep
    s = Setup(P, crank_speed_rpm=320, steps_per_period=50, nonlinear=False, motors=False)
    res = steady_state(s)
    res.bending_stress()
    steady_state(Setup(P, crank_speed_rpm=300, motors=False), tol=0.05)
    steady_state(Setup(P, crank_speed_rpm=310, motors=False), tol=0.05)
    sweep.speed_sweep(Setup(P, steps_per_period=50, nonlinear=False), [200.0], progress=False)
    resonance.linkage_frequencies(Setup(P, steps_per_period=24), n_modes=2)
    elements.gauss_points(4, 0.3)
    response.transient(s, 1)
    LinkageDynamics(Setup(P, steps_per_period=30, nonlinear=True)).nonlinear_geometry(0.0)
    grown = [k for k, v in _containers().items() if k not in before or before[k][0] != id(v)
             or _contents(v) != before[k][1]]
    assert not grown, f"module-level containers changed by computing (a cache outside fivebar.cache?): {grown}"
    kinds = {k[0] for k in STORE._data}
    assert {"dynamics.samples", "setup.dynamics", "sweep.point", "newmark.lu",
            "fivebar.analyses.resonance._modal_data", "fivebar.model.elements._legendre"} <= kinds, kinds
    assert cache_size().entries > 0 and cache_size().bytes > 0
    clear_cache()
    assert cache_size() == (0, 0)
