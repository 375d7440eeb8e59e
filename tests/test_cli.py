"""The command-line interface: outputs, and one-line errors without tracebacks."""

import subprocess
import sys
from contextlib import nullcontext

import numpy as np
import pytest

from skin_indent.cli import main


def run_cli(*args):
    """Run ``python -m skin_indent ARGS`` as a user would; returns (code, stdout, stderr)."""
    p = subprocess.run([sys.executable, "-m", "skin_indent", *args], capture_output=True, text=True, timeout=300)
    return p.returncode, p.stdout, p.stderr


def test_simulate_writes_curve_and_fields(tmp_path):
    out, vtu = tmp_path / "curve.csv", tmp_path / "fields.vtu"
    code, stdout, stderr = run_cli("simulate", "--material", "neo-hooke", "--E", "10", "--nu", "0.4", "--radius",
                                   "6.22", "--depth", "0.6", "--points", "100", "--out", str(out), "--vtu", str(vtu),
                                   "--mesh", "coarse")
    assert code == 0, stderr
    assert out.read_text().splitlines()[0] == "depth_mm,force_mN"
    data = np.loadtxt(out, delimiter=",", skiprows=1)
    assert data.shape == (100, 2)
    assert np.allclose(data[:, 0], 0.006 * np.arange(1, 101))
    assert np.all(np.diff(data[:, 1]) > 0) and 15 < data[-1, 1] < 22  # ~ Hertz 18.6 mN minus ~2%
    assert vtu.stat().st_size > 1000
    assert str(out) in stdout and "mesh: coarse" in stdout


@pytest.mark.parametrize("args, message", [
    (["--E", "-1"], "E must be > 0"),
    (["--E", "nan"], "E must be a finite number"),
    (["--nu", "0.5"], "nu must lie in (-1, 0.5)"),
    (["--nu", "-1"], "nu must lie in (-1, 0.5)"),
    (["--depth", "0"], "depth must be a finite number > 0"),
    (["--depth", "nan"], "depth must be a finite number > 0"),
    (["--radius", "0"], "sphere radius must be a finite number > 0"),
    (["--points", "1"], "points must be an integer >= 2"),
    (["--mesh", "huge"], "unknown mesh"),
    (["--mesh", "missing.vtu"], "mesh file not found"),
    (["--out", "/no/such/folder/c.csv"], "output folder does not exist"),
    (["--E", "abc"], "invalid float value"),
])
def test_simulate_bad_input_gives_one_line_error(args, message, capsys):
    with pytest.raises(SystemExit) if "abc" in args else nullcontext():
        code = main(["simulate", "--points", "3", "--depth", "0.05", "--mesh", "coarse", *args])
        assert code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert message in err[-1]
    assert not any("Traceback" in line for line in err)
    if "abc" not in args:
        assert len(err) == 1


def test_cli_error_from_a_real_process_has_no_traceback():
    code, _, stderr = run_cli("simulate", "--nu", "0.7")
    assert code == 2
    assert stderr.strip() == "skin-indent simulate: error: nu must lie in (-1, 0.5), got 0.7"
