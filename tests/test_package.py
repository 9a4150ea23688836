"""An installable package: a wheel built from the repository works outside the checkout.

Builds the wheel (no network: ``pip wheel --no-deps --no-build-isolation``), installs it in a
fresh virtual environment that borrows the installed numpy/scipy (a path entry, so the editable
install of the checkout is not seen), and from another directory loads the default
parameters and the errata (package data), computes natural frequencies and a linear steady
state at small S.
"""

from __future__ import annotations

import subprocess
import pytest
import sys
import sysconfig
import textwrap
import venv
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

SCRIPT = textwrap.dedent(
    """
    import fivebar, fivebar.book.reporting as rep
    from pathlib import Path
    assert "site-packages" in fivebar.__file__ and "{root}" not in fivebar.__file__, fivebar.__file__
    p = fivebar.load_params()
    assert fivebar.DEFAULT_PARAMS_PATH.is_file() and p.steps_per_period > 0
    assert len(rep.errata_table()) > 20
    f = fivebar.natural_frequencies(p, 0.0, 0.0, n_modes=2)
    assert 20 < f[0] < 100, f
    r = fivebar.steady_state(fivebar.Setup(p, steps_per_period=60, nonlinear=False))
    assert r.stable and r.peak_to_peak_mm("L2") > 0
    print("OK", fivebar.__file__)
    """
)


@pytest.mark.slow
def test_wheel_installs_and_runs_outside_the_checkout(tmp_path):
    dist = tmp_path / "dist"
    subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "-q",
                    "-w", str(dist), str(ROOT)], check=True, cwd=tmp_path)
    wheel = next(dist.glob("fivebar-*.whl"))
    env = tmp_path / "env"
    venv.create(env, with_pip=False)
    py = env / "bin" / "python"
    site = subprocess.run([py, "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                          check=True, capture_output=True, text=True).stdout.strip()
    # borrow numpy, scipy, ... of the test environment, but not its editable fivebar
    Path(site, "borrowed.pth").write_text(sysconfig.get_paths()["purelib"] + "\n")
    subprocess.run([sys.executable, "-m", "pip", "install", "--no-deps", "-q", "--target", site, str(wheel)],
                   check=True, cwd=tmp_path)
    run = tmp_path / "elsewhere"
    run.mkdir()
    out = subprocess.run([py, "-c", SCRIPT.replace("{root}", str(ROOT))], cwd=run, capture_output=True, text=True)
    assert out.returncode == 0, out.stderr[-3000:]
    assert out.stdout.startswith("OK")
