"""maniplab's C code under AddressSanitizer and UBSan, briefly (``make sanitize`` runs it all).

A sanitized child process (``MANIPLAB_NATIVE_SANITIZE=1``, the ASan runtime preloaded) runs a
short, fixed fuzz of tests/sanitize/ (``run.py --quick``): the plant's API, the plugins' configs,
the compiled cascade (with separate controllers in four threads) and an FMU's C functions, each
with a derandomized sequence of hypothesis examples. The child must exit clean: no sanitizer
report, every fuzz test passed."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

RUN = Path(__file__).parent / "sanitize" / "run.py"


def test_quick_fuzz_under_sanitizers_is_clean() -> None:
    try:
        proc = subprocess.run(["gcc", "-print-file-name=libasan.so"], capture_output=True,
                              text=True, check=True)
    except (OSError, subprocess.CalledProcessError):
        pytest.skip("no gcc with its ASan runtime")
    if not Path(proc.stdout.strip()).is_absolute():
        pytest.skip("gcc has no ASan runtime (libasan.so)")
    proc = subprocess.run([sys.executable, str(RUN), "--quick"], capture_output=True, text=True,
                          timeout=900, check=False)
    assert proc.returncode == 0, proc.stdout[-6000:] + proc.stderr[-3000:]
    assert "clean" in proc.stdout
