"""The fixtures of the project tests: pyright, the type checker of VS Code's Python, as an outside author runs it.

Installed once per virtualenv from ``pyright/package.json`` (again when it changes), with node and
npm (``./run`` installs them); a heavy check, run once, on the default Python.
"""

from __future__ import annotations

import fcntl
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

TOOL = Path(__file__).parent / "pyright"
#: Where pyright is installed, once per virtualenv.
HOME = Path(sys.prefix) / "pyright-tool"


@pytest.fixture(scope="session")
def pyright_tool() -> Path:
    """The ``pyright`` command of ``pyright/package.json``, installed (exact version, no lock file)."""
    if os.environ.get("AIOGENOMIX_HEAVY") == "0":
        pytest.skip("heavy: run once, on the default Python")
    if shutil.which("npm") is None or shutil.which("node") is None:
        pytest.skip("needs node and npm (./run test installs them)")
    wanted = (TOOL / "package.json").read_text(encoding="utf-8")
    installed = HOME / ".installed"   # the package.json of the last install that ended well
    # Two test files use it, perhaps on two workers at once: one installs, the other waits for it.
    with open(Path(sys.prefix) / "pyright-tool.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if not installed.exists() or installed.read_text(encoding="utf-8") != wanted:
            shutil.rmtree(HOME, ignore_errors=True)
            HOME.mkdir(parents=True)
            (HOME / "package.json").write_text(wanted, encoding="utf-8")
            done = subprocess.run(["npm", "install", "--no-package-lock", "--no-audit", "--no-fund", "--silent"],
                                  cwd=HOME, capture_output=True, text=True, timeout=600, stdin=subprocess.DEVNULL)
            assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
            installed.write_text(wanted, encoding="utf-8")
    return HOME / "node_modules" / ".bin" / "pyright"
