"""Progress in a log (stderr not a terminal): one line per stage that lasts, nothing for short work."""

from __future__ import annotations

import io
import time
from pathlib import Path
from typing import Any

import pytest

import maniplab as ml
from maniplab import progress
from maniplab.model import build
from maniplab.progress import Progress


def test_a_lasting_stage_is_announced_and_its_end_written() -> None:
    log = io.StringIO()
    bar = Progress(2, "job", stream=log)
    bar.start("compiling")
    time.sleep(progress.LINE_AFTER + 0.5)
    bar.step("compiled")
    bar.start("linking")
    bar.step("linked")  # short: no line
    bar.close()
    lines = log.getvalue().splitlines()
    assert lines[0] == "job: compiling ..."
    assert lines[1].startswith("job: compiled (") and lines[1].endswith(" s)")
    assert len(lines) == 2


def test_short_work_prints_nothing_and_a_forced_bar_no_lines() -> None:
    log = io.StringIO()
    bar = Progress(3, "job", stream=log)
    for _ in range(3):
        bar.start("a")
        bar.step("b")
    bar.close()
    assert log.getvalue() == ""
    quiet = io.StringIO()
    off = Progress(1, "job", enabled=False, stream=quiet)
    off.start("compiling")
    time.sleep(progress.LINE_AFTER + 0.3)
    off.step("done")
    off.close()
    assert quiet.getvalue() == ""


def test_model_generation_logs_its_stages(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                          capsys: pytest.CaptureFixture[str]) -> None:
    """A cold model while stderr is not a terminal, with a compiler that takes its time: the
    compile stage is announced and its end written."""
    real = build.compile_objects

    def slow(*args: Any, **kwargs: Any) -> Any:
        time.sleep(progress.LINE_AFTER + 0.5)
        return real(*args, **kwargs)

    monkeypatch.setattr(build, "compile_objects", slow)
    monkeypatch.setenv("MANIPLAB_CACHE", str(tmp_path))
    ml.AnalyticModel(ml.builtin_spec("planar2"), backend="c", cache=False)
    lines = capsys.readouterr().err.splitlines()
    label = "maniplab: generating the planar2 model: "
    assert any(line.startswith(label + "compiling") and line.endswith("...") for line in lines)
    assert lines[-1].startswith(label + "compiled ("), lines
