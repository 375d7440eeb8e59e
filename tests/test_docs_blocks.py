"""The docs say what the code does now: every command output they show, and the README's Python.

- Every ``.. code-block:: console`` of ``docs/*.rst`` (and every ```` ```console ```` block of
  README.md) whose commands show their output is run as written (``$ skin-indent ...`` lines,
  ``$ cd DIR`` and ``$ echo $?``), from a scratch folder laid out like a clone, and each line it
  shows must be a line the command prints: the same words, and every number the printed one
  (a count exactly; a decimal within one unit of its last shown digit or 0.2 %: a fit on another
  CPU may move the last digit, 121 -> 118 does not pass). ``...`` stands for anything: a line of
  it for lines left out, inside a line for the part left out (times, iteration counts, hashes).
  A block that becomes stale fails here with the line no longer printed and the nearest printed.
- The blocks run on the coarse surfaces the suite builds once per run (``coarse_unit_surfaces``,
  ``diagnosis_surfaces`` in conftest.py, the gallery cache); blocks that need finite elements in
  the loop (two curves of one sample, the plan of the forearm-like curve: minutes on 2 cores) are
  marked ``slow`` (``python -m pytest -m slow tests/test_docs_blocks.py``).
- Every ``skin-indent`` command of README.md's code blocks parses with today's parser and
  names files that exist (an option that no longer exists is a defect of the README), and so
  does every command of the docs' console blocks; the docs' Python blocks compile.
- README.md's Python block runs as written and shows the package's progress messages.
"""

from __future__ import annotations

import importlib.util
import os
import re
import shlex
import shutil
import subprocess
import sys
import textwrap
from dataclasses import dataclass, field
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
README = ROOT / "README.md"

#: a number as the package prints it (an integer, a decimal, a float with exponent)
NUMBER = r"[-+]?(?:\d+\.\d*|\.\d+|\d+)(?:[eE][-+]?\d+)?"
#: blocks that need finite elements in the loop (minutes on 2 cores): a text of their first command
SLOW = ("forearm_like_R3.11mm.csv --sample", "plan src/skin_indent/data/forearm_like.csv")
#: blocks that read files only afmformats reads: a text of their first command
NEEDS_AFMFORMATS = (".jpk-force",)


@dataclass
class Command:
    line: str  # as written, without the prompt
    expected: list[str] = field(default_factory=list)


@dataclass
class Block:
    where: str  # file:line
    commands: list[Command]

    @property
    def shows_output(self) -> bool:
        return any(c.expected for c in self.commands)


def _console_blocks(path: Path) -> list[Block]:
    """The console blocks of an .rst (``.. code-block:: console``) or .md (```` ```console ````) file."""
    lines = path.read_text().splitlines()
    blocks, i = [], 0
    while i < len(lines):
        start = i
        if lines[i].strip() == ".. code-block:: console":
            i += 1
            body = []
            while i < len(lines) and (not lines[i].strip() or lines[i].startswith(" ")):
                body.append(lines[i])
                i += 1
            body = [b[3:] if b.startswith("   ") else b.strip() for b in body]
        elif lines[i].strip() == "```console":
            i += 1
            body = []
            while i < len(lines) and lines[i].strip() != "```":
                body.append(lines[i])
                i += 1
        else:
            i += 1
            continue
        commands: list[Command] = []
        for text in body:
            if text.startswith("$ "):
                commands.append(Command(text[2:].strip()))
            elif text.strip() and commands:
                commands[-1].expected.append(text.rstrip())
        blocks.append(Block(f"{path.relative_to(ROOT)}:{start + 1}", commands))
    return blocks


def _all_blocks() -> list[Block]:
    paths = [README, *sorted(DOCS.glob("*.rst"))]
    return [b for p in paths for b in _console_blocks(p) if b.shows_output]


def _params():
    out = []
    for block in _all_blocks():
        first = block.commands[0].line
        marks = [pytest.mark.slow] if any(s in c.line for c in block.commands for s in SLOW) else []
        if any(s in c.line for c in block.commands for s in NEEDS_AFMFORMATS):
            marks.append(pytest.mark.skipif(importlib.util.find_spec("afmformats") is None,
                                            reason="afmformats is not installed (pip install -e '.[test]')"))
        out.append(pytest.param(block, id=f"{block.where} {first[:60]}", marks=marks))
    return out


# ----------------------------------------------------------------------------- comparing lines
def _pattern(expected: str) -> re.Pattern:
    """A regex of a shown line: its words as they are, its numbers captured, ``...`` as anything."""
    parts = []
    for k, piece in enumerate(" ".join(expected.split()).split("...")):
        if k:
            parts.append(r".*?")
        for m, chunk in enumerate(re.split(f"({NUMBER})", piece)):
            parts.append(f"({NUMBER})" if m % 2 else re.escape(chunk))
    return re.compile("".join(parts))


def _numbers(expected: str) -> list[str]:
    return [n for piece in " ".join(expected.split()).split("...") for n in re.findall(NUMBER, piece)]


def _close(shown: str, printed: str) -> bool:
    """The printed number is the shown one.

    An integer below 1000 (a count) exactly; a decimal within one unit of its last shown digit
    (a value at a rounding boundary, or moved by round-off on another CPU) or 0.2 %.
    """
    a, b = float(shown), float(printed)
    if a == b:
        return True
    if abs(a) < 1e-9 and abs(b) < 1e-9:  # round-off zeros (a parameter at 0: 5e-16)
        return True
    mantissa, _, exponent = shown.lstrip("+-").lower().partition("e")
    if "." not in mantissa and not exponent:
        return abs(a) >= 1000 and abs(a - b) <= 2e-3 * abs(a)
    decimals = len(mantissa.partition(".")[2])
    unit = 10.0 ** (int(exponent or 0) - decimals)
    return abs(a - b) <= max(unit * (1 + 1e-9), 2e-3 * abs(a))


def _matches(expected: str, printed: str) -> bool:
    m = _pattern(expected).fullmatch(" ".join(printed.split()))
    return m is not None and all(_close(s, p) for s, p in zip(_numbers(expected), m.groups()))


def _check_output(command: Command, stdout: str, stderr: str) -> list[str]:
    """Lines shown but not printed (in order on stdout; anywhere on stderr), each with the nearest printed line."""
    out, err = stdout.splitlines(), stderr.splitlines()
    problems, at = [], 0
    for line in command.expected:
        if line.strip() == "...":
            continue
        found = next((k for k in range(at, len(out)) if _matches(line, out[k])), None)
        if found is not None:
            at = found + 1
            continue
        if any(_matches(line, e) for e in err):
            continue
        words = set(re.sub(NUMBER, " ", line).split())
        nearest = max(out + err, key=lambda p: len(words & set(re.sub(NUMBER, " ", p).split())), default="")
        problems.append(f"shown:   {line.strip()}\nprinted: {nearest.strip()}")
    return problems


# ----------------------------------------------------------------------------- running a block
def _scratch_clone(folder: Path) -> Path:
    """A folder laid out like a clone: src/ and tests/data/ (copied: blocks write next to the data)."""
    (folder / "tests").mkdir(parents=True)
    os.symlink(ROOT / "src", folder / "src")
    shutil.copytree(ROOT / "tests" / "data", folder / "tests" / "data")
    return folder


def _run_block(block: Block, folder: Path, cache: Path) -> list[str]:
    env = {**os.environ, "SKIN_INDENT_CACHE": str(cache), "PYTHONPATH": str(ROOT / "src")}
    cwd, last, problems = folder, None, []
    for command in block.commands:
        argv = shlex.split(command.line, comments=True)
        if argv[0] == "cd":
            cwd = cwd / argv[1]
            continue
        if argv == ["echo", "$?"]:
            shown = command.expected[0].strip() if command.expected else ""
            if str(last.returncode) != shown:
                problems.append(f"$ {command.line}: shown {shown}, the command exited {last.returncode}")
            continue
        assert argv[0] == "skin-indent", f"{block.where}: only skin-indent, cd and echo $? run here: {command.line}"
        last = subprocess.run([sys.executable, "-m", "skin_indent", *argv[1:]], cwd=cwd, env=env,
                              capture_output=True, text=True, timeout=3600)
        assert "Traceback" not in last.stderr, last.stderr[-3000:]
        problems += [f"$ {command.line}\n{p}" for p in _check_output(command, last.stdout, last.stderr)]
    return problems


@pytest.mark.parametrize("block", _params())
def test_console_block_is_what_the_code_prints(block, tmp_path, gallery_cache, coarse_unit_surfaces,
                                               diagnosis_surfaces):
    problems = _run_block(block, _scratch_clone(tmp_path / "clone"), gallery_cache)
    assert not problems, f"{block.where}: stale output block (update the docs):\n" + "\n\n".join(problems)


# ----------------------------------------------------------------------------- the matcher itself
def test_a_shown_line_matches_what_is_printed_and_nothing_else():
    shown = "     neo-hooke    RMS 0.316 mN  BIC    3271.4  structured  E_kPa = 5.139 +- 0.22, nu = 0.49"
    assert _matches(shown, "neo-hooke RMS 0.3161 mN BIC 3271.5 structured E_kPa = 5.139 +- 0.22, nu = 0.49")
    assert not _matches(shown, "neo-hooke RMS 0.316 mN BIC 3271.4 white E_kPa = 5.139 +- 0.22, nu = 0.49")
    assert not _matches(shown, "neo-hooke RMS 0.316 mN BIC 3271.4 structured E_kPa = 5.18 +- 0.22, nu = 0.49")
    # the stale numbers of issue 39: S 121 -> 118, E 16.54 -> 15.95
    assert not _matches("S = 121", "S = 118") and not _matches("E_kPa = 16.54", "E_kPa = 15.95")
    assert _matches("ready in ... s (surface.npz)", "ready in 12.3 s (surface.npz)")
    assert _matches("C20_kPa = 5.191e-16 +- 0.46", "C20_kPa = 1.2e-17 +- 0.46")
    assert not _matches("4 curves: 0 failed", "4 curves: 1 failed") and _matches("3981 points", "3982 points")
    problems = _check_output(Command("x", ["a = 1", "...", "b = 2"]), "a = 1\nc = 3\nb = 2.5\n", "")
    assert len(problems) == 1 and "b = 2.5" in problems[0]


def test_every_output_block_of_the_docs_is_checked():
    blocks = _all_blocks()
    assert len(blocks) >= 8  # the guide's fit, AFM, model, diagnosis, plan, sample, batch and commands
    assert any("--sample" in c.line for b in blocks for c in b.commands)
    # a block with output lines that are not of a command would be skipped silently
    for block in blocks:
        assert block.commands and all(c.line.split()[0] in ("skin-indent", "cd", "echo") for c in block.commands), \
            block.where


# ----------------------------------------------------------------------------- README.md
def _readme_code(language: str) -> list[str]:
    return re.findall(rf"```{language}\n(.*?)```", README.read_text(), flags=re.S)


def _parses(command: str, where: str):
    from skin_indent.cli import build_parser

    try:
        return build_parser().parse_args(shlex.split(command, comments=True)[1:])
    except SystemExit:
        pytest.fail(f"{where}: `{command}` does not parse with today's options")


def test_readme_commands_parse_and_name_files_that_exist():
    commands = [line.strip() for block in _readme_code("bash") for line in block.splitlines()
                if line.strip().startswith("skin-indent ")]
    assert len(commands) >= 3
    for command in commands:
        args = _parses(command, "README.md")
        for name in getattr(args, "data", []) or []:
            assert (ROOT / name).exists(), f"README: `{command}` names {name}, which does not exist"


def test_every_command_of_the_docs_parses():
    """Also the commands shown without their output (a cluster's, a Chiaro fit at another nu)."""
    commands = [(block.where, c.line) for path in sorted(DOCS.glob("*.rst")) for block in _console_blocks(path)
                for c in block.commands if c.line.startswith("skin-indent ")]
    assert len(commands) >= 15
    for where, command in commands:
        _parses(command, where)


def test_the_python_blocks_of_the_docs_compile():
    blocks = [(path.name, textwrap.dedent(m)) for path in sorted(DOCS.glob("*.rst"))
              for m in re.findall(r"\.\. code-block:: python\n\n((?:   .*\n|\n)+)", path.read_text())]
    assert len(blocks) >= 2
    for name, code in blocks:
        compile(code, name, "exec")


def test_readme_python_block_runs_and_shows_progress(tmp_path, gallery_cache):
    """The README's Python, as written, from another folder; its logging lines let the package's INFO through."""
    (code,) = _readme_code("python")
    assert "logging" in code
    # a probe: any INFO message of the package (a surface build says how many runs it makes) reaches stderr
    probe = '\nlogging.getLogger("skin_indent.response_surface").info("probe: progress is shown")\n'
    p = subprocess.run([sys.executable, "-c", code + probe], cwd=tmp_path, capture_output=True, text=True,
                       env={**os.environ, "SKIN_INDENT_CACHE": str(gallery_cache)}, timeout=1800)
    assert p.returncode == 0, p.stderr[-3000:]
    assert "E_kPa" in p.stdout and "[[Identification: ekf-paper]]" in p.stdout
    assert "probe: progress is shown" in p.stderr
    assert "Initializing" not in p.stderr  # scikit-fem's own INFO messages stay out


def test_the_readme_is_a_first_page():
    """Issue 39: at most 150 lines, the two set-up commands as CI runs them, three commands on bundled curves."""
    text = README.read_text()
    assert len(text.splitlines()) <= 150
    assert "python -m pip install . && skin-indent demo" in text
    assert 'python -m pip install -e ".[test,docs]" && python -m pytest' in text
    commands = [line for block in _readme_code("bash") for line in block.splitlines()
                if line.startswith(("skin-indent fit src/", "skin-indent diagnose src/"))]
    assert len(commands) >= 3 and any("--sample" in c for c in commands)
    assert (ROOT / "docs/_static/diagnose_ladder.png").is_file() and "docs/_static/diagnose_ladder.png" in text
