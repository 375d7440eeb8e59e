"""The command-line interface: outputs, and one-line errors without tracebacks."""

import subprocess
import sys
from contextlib import nullcontext
from pathlib import Path

import numpy as np
import pytest

from skin_indent.cli import main


def _rows(path):
    """The header and the numbers of a CSV the CLI wrote, past its ``#`` provenance lines."""
    lines = [line for line in Path(path).read_text().splitlines() if not line.startswith("#")]
    return lines[0], np.loadtxt(lines[1:], delimiter=",", ndmin=2)


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
    header, data = _rows(out)
    assert header == "depth_mm,force_mN"
    assert data.shape == (100, 2)
    assert np.allclose(data[:, 0], 0.006 * np.arange(1, 101))
    assert np.all(np.diff(data[:, 1]) > 0) and 15 < data[-1, 1] < 22  # ~ Hertz 18.6 mN minus ~2%
    assert vtu.stat().st_size > 1000
    assert str(out) in stdout and "mesh: coarse" in stdout
    assert "peak force" in stdout


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


def test_simulate_effect_options(tmp_path):
    """Layers, viscoelastic loading-unloading and a contact offset from the command line."""
    layered, visco, shifted = (tmp_path / f"{n}.csv" for n in ("layered", "visco", "shifted"))
    common = ["--mesh", "coarse", "--points", "6", "--depth", "0.3"]
    assert main(["simulate", "--layer", "1,25,0.45", "--E", "4", "--nu", "0.45", "--out", str(layered), *common]) == 0
    assert main(["simulate", "--prony", "0.4,5", "--E", "10", "--nu", "0.45", "--unload", "--out", str(visco),
                 *common]) == 0
    assert main(["simulate", "--offset", "0.1", "--out", str(shifted), *common]) == 0
    t, d, F = _rows(visco)[1].T
    assert d.size == 12 and d.max() == pytest.approx(0.3) and F[-1] == 0.0  # contact lost at depth 0
    up, down = F[:5], F[6:11][::-1]  # the same depths 0.05 ... 0.25 mm on the way in and out
    assert np.all(down < up)  # viscoelastic hysteresis: less force on the way back
    d, F = _rows(shifted)[1].T
    assert np.all(F[d <= 0.1] == 0) and np.all(F[d > 0.1] > 0)


@pytest.mark.parametrize("args, message", [
    (["--rigid-base"], "--rigid-base needs at least one --layer"),
    (["--layer", "1,2"], "--layer THICKNESS_MM,E_KPA,NU must be 3 comma-separated numbers"),
    (["--layer=-1,2,0.3"], "layer thickness must be"),
    (["--prony", "1.2,5"], "Prony relative modulus g must lie in (0, 1)"),
    (["--prony", "0.3,0"], "time constant"),
    (["--C20", "3"], "--C20 needs --material neo-hooke-stiffening"),
    (["--material", "neo-hooke-stiffening", "--C20", "-3"], "C20 must be >= 0"),
    (["--offset", "nan"], "offset must be a finite number"),
    (["--protocol", "missing.csv"], "missing.csv"),
    (["--friction", "-0.2"], "friction"),
    (["--adhesion", "nan"], "adhesion"),
])
def test_simulate_effect_options_bad_input(args, message, capsys):
    assert main(["simulate", "--points", "3", "--depth", "0.05", "--mesh", "coarse", *args]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0], err


def test_surface_build_without_dask_says_how_to_install_it(monkeypatch, capsys):
    monkeypatch.setitem(sys.modules, "distributed", None)
    monkeypatch.setitem(sys.modules, "dask", None)
    code = main(["surface", "build", "--scheduler", "tcp://127.0.0.1:8786", "--nu", "0.3:0.4:2", "--points", "5"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and err == ["skin-indent surface: error: Dask is not installed: pip install 'skin_indent[dask]'"]


def test_a_missing_data_file_is_a_user_error(capsys, tmp_path):
    """Exit 2 (a user error, as every other), not 3 (a failed curve of a batch)."""
    assert main(["fit", str(tmp_path / "nope.csv")]) == 2
    err = capsys.readouterr().err.strip()
    assert err == f"skin-indent fit: error: no such file or folder: {tmp_path / 'nope.csv'}"
