"""``.ci/install`` decides whether to rebuild from the sources' contents, without git.

A fresh Debian root has no git, and a source tarball no ``.git``: the old fingerprint (``git
ls-files``) was then empty and every run of ``.ci/install`` (so every ``.ci/test``) rebuilt
the package for minutes. Here the install script runs on a copy of the sources without
``.git``, against a stand-in virtual environment whose ``python`` only succeeds (no real
build): the second run must say "up to date", and an edited source must rebuild.
"""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


def _install(tree: Path) -> str:
    out = subprocess.run(["bash", ".ci/install"], cwd=tree, text=True, capture_output=True,
                         env={"PATH": "/usr/local/bin:/usr/bin:/bin", "VADSIM_VENV": "venv"},
                         timeout=120)
    assert out.returncode == 0, out.stderr
    return out.stdout


@pytest.mark.skipif(shutil.which("dpkg") is None, reason="the install script is for Debian")
def test_install_skips_an_unchanged_tree_without_git(tmp_path):
    tree = tmp_path / "src"
    for name in ("cpp", "python", ".ci"):
        shutil.copytree(ROOT / name, tree / name,
                        ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))
    for name in ("CMakeLists.txt", "pyproject.toml"):
        shutil.copy(ROOT / name, tree / name)
    python = tree / "venv" / "bin" / "python"
    python.parent.mkdir(parents=True)
    python.write_text("#!/bin/sh\nexit 0\n")   # stands in for pip and for `import vadsim._core`
    python.chmod(0o755)
    assert not (tree / ".git").exists()
    assert "building the Python package" in _install(tree)
    assert "up to date" in _install(tree)
    (tree / "python" / "vadsim" / "_version.py").write_text("# edited\n", encoding="utf-8")
    assert "building the Python package" in _install(tree)
    assert "up to date" in _install(tree)
