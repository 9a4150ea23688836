"""Results are pure functions of their inputs (issue 30, point 2).

The same call gives the same answer, to the last bit, whatever was computed before in the
process: the library's store keeps finished results only (the samples of a set-up, a sweep's
points, the dynamics), never a predictor that an earlier call left behind, and a warm start is
an explicit argument (``steady_state(..., start=)``).

Reference: the call made first in a fresh process (one that has imported the library and computed
nothing; forked from the process that did the imports).  Each public analysis is computed in one
such process, and in another process after every other analysis (in the reverse
order, with a few speeds of the same problems computed first, as a reader's session would);
the digests of their numbers must agree bit for bit.  The known history dependences this
catches (before stop 38): the cached step data scaled the load from the speed that sampled the
set-up first (a difference in the last digits of F, and of every result on it), and
``steady_state(..., tol=...)`` started a new speed from the orbits remembered from the last
one (differences of 1e-9 relative in the orbit).
"""

from __future__ import annotations

import json
import os
import pytest
import subprocess
import sys
import textwrap

SCRIPT = textwrap.dedent(r'''
    import hashlib, json, os, sys, traceback, warnings
    import numpy as np
    import pandas as pd
    import fivebar
    from fivebar.analyses.branches import follow

    warnings.simplefilter("ignore")
    P = fivebar.load_params()
    FLEX = P.replace(bending_depth=0.002, damping_model="stiffness")

    def digest(*xs):
        h = hashlib.sha256()
        for x in xs:
            if isinstance(x, pd.DataFrame):
                x = x.select_dtypes("number").to_numpy()
            h.update(np.ascontiguousarray(np.asarray(x, dtype=complex if np.iscomplexobj(x) else float)).tobytes())
        return h.hexdigest()

    def steady(st):
        return digest(st.u, st.v, np.abs(st.floquet_multipliers) if st.method == "shooting" else [])

    ANALYSES = {
        "steady shooting": lambda: steady(fivebar.steady_state(fivebar.Setup(P, crank_speed_rpm=250.0,
                                                                            steps_per_period=60))),
        "steady shooting nonlinear, motors off": lambda: steady(fivebar.steady_state(
            fivebar.Setup(P, crank_speed_rpm=300.0, motors=False, steps_per_period=80))),
        "steady march": lambda: steady(fivebar.steady_state(
            fivebar.Setup(P, crank_speed_rpm=120.0, motors=False, nonlinear=False, steps_per_period=40),
            method="march")),
        "steady tol": lambda: steady(fivebar.steady_state(fivebar.Setup(P, crank_speed_rpm=300.0, motors=False),
                                                          tol=0.01)),
        "steady tol flexible": lambda: steady(fivebar.steady_state(
            fivebar.Setup(FLEX, crank_speed_rpm=60.0, motors=False), tol=0.05)),
        "sweep up": lambda: digest(fivebar.speed_sweep(fivebar.Setup(P, steps_per_period=40, nonlinear=False),
                                                       [100.0, 180.0, 260.0], progress=False)),
        "sweep down": lambda: digest(fivebar.speed_sweep(fivebar.Setup(P, steps_per_period=40, nonlinear=False),
                                                         [260.0, 180.0, 100.0], progress=False)),
        "follow": lambda: (lambda br: digest(br.p, br.branch.x, np.abs(br.branch.multipliers)))(
            follow(fivebar.Setup(FLEX, crank_speed_rpm=100.0, motors=False, steps_per_period=200), 110.0, points=6)),
        "resonance": lambda: digest(fivebar.resonance_table(fivebar.Setup(P, crank_speed_rpm=300.0,
                                                                          steps_per_period=24))),
        "frequencies": lambda: digest(fivebar.natural_frequencies(fivebar.Setup(P), 0.3, 1.1)),
        "control": lambda: (lambda s: digest(s.A, s.B, s.C, s.D))(fivebar.linear_model(P, 0.3, 1.1, n_modes=4)),
        "multiple scales": lambda: digest(fivebar.multiple_scales(
            fivebar.Setup(P, crank_speed_rpm=200.0, motors=False)).peak_to_peak_mm("L2")),
    }
    def run(order, first):
        for rpm in first:  # other speeds of the same problems, computed before
            fivebar.steady_state(fivebar.Setup(P, crank_speed_rpm=rpm, motors=False), tol=0.01)
            fivebar.steady_state(fivebar.Setup(P, crank_speed_rpm=rpm, steps_per_period=60))
            fivebar.steady_state(fivebar.Setup(FLEX, crank_speed_rpm=rpm / 5, motors=False), tol=0.05)
        return {name: ANALYSES[name]() for name in order}

    # Each run in a process of its own, forked from this one, which has imported the library
    # (the public functions' modules are loaded on first access) and computed nothing: its first
    # computation is the run's, and the imports are not repeated for every run.
    for public in ("steady_state", "speed_sweep", "resonance_table", "natural_frequencies",
                   "linear_model", "multiple_scales"):
        getattr(fivebar, public)
    results = []
    for order, first in json.loads(sys.argv[1]):
        r, w = os.pipe()
        pid = os.fork()
        if pid == 0:
            os.close(r)
            status = 1
            try:
                data = json.dumps(run(order, first)).encode()
                while data:
                    data = data[os.write(w, data):]
                status = 0
            except BaseException:
                traceback.print_exc()
            finally:
                sys.stdout.flush(); sys.stderr.flush()
                os._exit(status)
        os.close(w)
        chunks = []
        while chunk := os.read(r, 65536):
            chunks.append(chunk)
        os.close(r)
        _, status = os.waitpid(pid, 0)
        if status != 0:
            sys.exit(f"the run {order} after {first} failed (wait status {status})")
        results.append(json.loads(b"".join(chunks)))
    print(json.dumps(results))
''')


def _run(runs):
    """The digests of each run (order, first) of ``runs``, each in a fresh process."""
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1", MKL_NUM_THREADS="1")
    out = subprocess.run([sys.executable, "-c", SCRIPT, json.dumps(runs)],
                         capture_output=True, text=True, timeout=1200, env=env)
    assert out.returncode == 0, out.stderr[-3000:]
    return json.loads(out.stdout.strip().splitlines()[-1])


@pytest.mark.slow
def test_every_public_analysis_gives_the_same_bits_alone_and_after_others():
    names = ["steady shooting", "steady shooting nonlinear, motors off", "steady march", "steady tol",
             "steady tol flexible", "sweep up", "sweep down", "follow", "resonance", "frequencies", "control",
             "multiple scales"]
    # each the first computation of its process, then all of them after others in one process
    *single, after = _run([[[name], []] for name in names] + [[names[::-1], [333.0, 450.0, 270.0]]])
    alone = {k: v for d in single for k, v in d.items()}
    differ = [name for name in names if alone[name] != after[name]]
    assert not differ, f"results that depend on what was computed before: {differ}"
