"""Every code block of README.md runs, so that the page a user reads first cannot rot.

The first two blocks are the install-and-run and the test commands (checked for their form;
the install and the test command are what CI itself runs, so here the first one's job runs
without re-installing, and the second is not run from inside itself). Every other ``bash``
block runs line by line with the installed ``vadsim`` on the path, and the ``python`` blocks
run in order in one interpreter, as a reader pasting them would, in a scratch folder."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

README = Path(__file__).resolve().parents[2] / "README.md"
BLOCK = re.compile(r"^```(\w+)\n(.*?)^```", re.S | re.M)
HANG_S = 1800  # a hung block fails instead of stalling the suite; no time budget


def _blocks() -> list[tuple[str, str]]:
    return [(m.group(1), m.group(2)) for m in BLOCK.finditer(README.read_text())]


def _env() -> dict[str, str]:
    env = dict(os.environ, MPLBACKEND="Agg")
    env["PATH"] = f"{Path(sys.executable).parent}{os.pathsep}{env.get('PATH', '')}"
    return env


def _commands(block: str) -> list[str]:
    """Lines joined where they end in a backslash; comments and blank lines dropped."""
    joined = block.replace("\\\n", " ")
    return [line for line in joined.splitlines() if line.strip()
            and not line.lstrip().startswith("#")]


def test_readme_starts_with_the_install_and_the_test_command():
    (lang1, first), (lang2, second) = _blocks()[:2]
    assert lang1 == lang2 == "bash"
    assert README.read_text().lstrip().startswith("# vadsim\n\n```bash\n" + first)
    assert first.strip().startswith("bash .ci/install && .venv/bin/vadsim run 7in-cde ")
    assert second.strip() == "bash .ci/test"
    assert "bash .ci/test" in (README.parent / ".ci" / "run").read_text()


def test_the_main_job_of_the_first_command_runs(tmp_path):
    job = _blocks()[0][1].strip().split("&& ", 1)[1].replace(".venv/bin/", "")
    out = subprocess.run(job, shell=True, cwd=tmp_path, env=_env(), text=True,
                         capture_output=True, timeout=HANG_S)
    assert out.returncode == 0, out.stderr
    for flow in ("200", "350", "600"):
        assert flow in out.stdout


@pytest.mark.parametrize("index", [i for i, (lang, _) in enumerate(_blocks())
                                   if lang == "bash" and i >= 2])
def test_bash_block_runs(tmp_path, index):
    for cmd in _commands(_blocks()[index][1]):
        out = subprocess.run(cmd, shell=True, cwd=tmp_path, env=_env(), text=True,
                             capture_output=True, timeout=HANG_S)
        assert out.returncode == 0, f"{cmd}\n{out.stderr[-2000:]}"


def test_python_blocks_run_in_order(tmp_path):
    code = "\n\n".join(body for lang, body in _blocks() if lang == "python")
    assert code
    out = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, env=_env(),
                         text=True, capture_output=True, timeout=HANG_S)
    assert out.returncode == 0, out.stderr[-3000:]
    assert "missing physics: hydraulic_force" in out.stdout  # the diagnosis names it
    assert (tmp_path / "z.png").is_file() and (tmp_path / "report").is_dir()
