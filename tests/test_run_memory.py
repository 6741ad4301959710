"""Long runs in bounded memory: recording costs the stored arrays plus one chunk, ``sample_dt``
records less, a run that cannot fit is refused before it starts, and a run streamed to disk is
the run recorded in memory, bit for bit, with nothing left behind when it is interrupted.

Memory is measured, not estimated: ``tracemalloc`` sees every numpy allocation."""

from __future__ import annotations

import re
import tracemalloc
import zipfile
from pathlib import Path

import numpy as np
import pytest
from commandline import run_cli

import maniplab as ml
from maniplab.sim import budget, store, stream
from maniplab.sim.simulate import _Loop

s = ml.signals
INPUTS = {"q2": s.sine(0.2, frequency=0.2), "q1": s.step(0.1, t0=1.0)}

CHUNK_BYTES = 20_002 * (422 + 2 * 470) + 20_001 * 6 * 8
"""The recorder's fixed overhead on the erector, bytes: one chunk of the C loop's buffers (20,000
steps + 2 rows of 422 B: t, q, qd, 12 activations, ctrl, mode, friction, limit, ee_pos), that
chunk's signals (470 B a sample) and as much again for the temporaries that derive them, and the
chunk's inputs (6 joints). About 29 MB, whatever the run's duration; measured: 14 MB."""


def stored_bytes(run: ml.Run) -> int:
    return run.t.nbytes + sum(v.nbytes for v in run.signals.values())


def traced_run(**kwargs: object) -> tuple[ml.Run, int]:
    """An erector run and the peak of the memory numpy and Python allocated during it, bytes."""
    tracemalloc.start()
    try:
        run = ml.simulate("erector", inputs=INPUTS, initial={"dP": "gravity"}, **kwargs)
        return run, tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()


def assert_same_arrays(a: ml.Run, b: ml.Run) -> None:
    assert list(a.signals) == list(b.signals)
    assert a.t.tobytes() == b.t.tobytes()
    for name in a.signals:
        assert a[name].dtype == b[name].dtype and a[name].shape == b[name].shape, name
        assert a[name].tobytes() == b[name].tobytes(), name


# --- recording in memory --------------------------------------------------------------------------

def test_recording_costs_at_most_one_and_a_half_times_the_stored_arrays() -> None:
    ml.simulate("erector", duration=0.01)  # the plant's model and library built beforehand
    short, short_peak = traced_run(duration=30.0)
    run, peak = traced_run(duration=213.0)
    stored = stored_bytes(run)
    assert stored > 95e6  # 213,001 samples of 470 B: the arrays dominate
    assert peak <= 1.5 * stored + CHUNK_BYTES, (peak / 1e6, stored / 1e6)
    # the overhead is fixed: a run 7 times longer costs no more beyond its arrays
    assert peak - stored <= short_peak - stored_bytes(short) + 1e6


def test_saving_a_run_streams_its_arrays(tmp_path: Path) -> None:
    run, _ = traced_run(duration=60.0)
    stored = stored_bytes(run)
    tracemalloc.start()
    try:
        before = tracemalloc.get_traced_memory()[0]
        run.save(tmp_path / "run.npz")
        extra = tracemalloc.get_traced_memory()[1] - before
    finally:
        tracemalloc.stop()
    assert extra <= 0.25 * stored, (extra / 1e6, stored / 1e6)  # one signal at a time at most


# --- sample_dt ---------------------------------------------------------------------------------

@pytest.mark.parametrize("duration", [0.5, 0.505])
def test_sample_dt_on_the_command_line_is_the_full_rate_run_sliced(capsys, tmp_path: Path,
                                                                     duration: float) -> None:
    path = tmp_path / "coarse.npz"
    code, _, err = run_cli(capsys, "simulate", "erector", "--input", "q2=sine:0.2,2",
                           "--balanced", "--duration", str(duration), "--sample-dt", "0.01",
                           "-o", str(path))
    assert code == 0, err
    coarse = ml.Run.load(path)
    full = ml.simulate("erector", inputs={"q2": s.sine(0.2, frequency=2.0)},
                       initial={"dP": "gravity"}, duration=duration)
    steps = round(duration / 1e-3)
    rows = sorted(set(range(0, steps + 1, 10)) | {steps})  # every 10th step, and the last
    assert len(coarse.t) == len(rows) == steps // 10 + 1 + (steps % 10 > 0)
    assert coarse.meta["sample_dt"] == pytest.approx(0.01)
    assert coarse.t.tobytes() == full.t[rows].tobytes()
    for name in full.signals:
        assert coarse[name].tobytes() == full[name][rows].tobytes(), name


# --- refusing runs that do not fit -------------------------------------------------------------

def test_a_run_too_large_for_the_memory_is_refused_at_once(capsys, tmp_path: Path) -> None:
    path = tmp_path / "huge.npz"
    ml.simulate("erector", duration=0.01)
    tracemalloc.start()
    try:
        code, _, err = run_cli(capsys, "simulate", "erector", "--duration", "1e9", "-o", str(path))
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert code == 2
    assert len(err.strip().splitlines()) == 1
    assert "run would store" in err and "TB" in err and "--sample-dt" in err and "--stream" in err
    assert peak < 20e6  # the model only: none of the 470 TB
    assert not path.exists() and not list(tmp_path.iterdir())
    with pytest.raises(ml.InputError) as caught:
        ml.simulate("erector", duration=1e9)
    available = re.compile(r"but \S+ \S+ is available")  # the figure may change meanwhile
    assert available.sub("", err.strip()) == available.sub("", f"maniplab simulate: {caught.value}")


def test_the_refusal_names_a_sample_dt_that_fits(monkeypatch) -> None:
    monkeypatch.setattr(budget, "available_memory", lambda: 60_000_000)
    with pytest.raises(ml.InputError, match=r"^run would store 28 MB \(60 s at 1 kHz, 470 B per "
                                            r"sample\) but 60 MB is available") as caught:
        ml.simulate("erector", inputs=INPUTS, duration=60.0)
    suggested = float(re.search(r"--sample-dt (\S+) \(sample_dt=\1\)", str(caught.value)).group(1))
    run = ml.simulate("erector", inputs=INPUTS, duration=60.0, sample_dt=suggested)
    assert stored_bytes(run) <= 0.8 * 60e6 and len(run.t) == round(60.0 / suggested) + 1


def test_a_streamed_run_too_large_for_the_disk_is_refused(monkeypatch, tmp_path: Path) -> None:
    monkeypatch.setattr(budget, "free_disk", lambda path: 1_000_000)
    path = tmp_path / "runs" / "long.npz"
    with pytest.raises(ml.InputError, match=rf"^{re.escape(str(path))}: run would write 2.8 MB "
                                            r".* but 1 MB is free there: record less with "
                                            r"--sample-dt"):
        ml.simulate("erector", duration=6.0, stream=path)
    assert not path.parent.exists() or not list(path.parent.iterdir())


# --- streaming to disk ---------------------------------------------------------------------------

@pytest.fixture
def small_chunks(monkeypatch) -> int:
    """Chunks of 997 steps, so that a short run streams through many of them."""
    monkeypatch.setattr(_Loop, "CHUNK", 997)
    return 997


def test_a_streamed_run_is_the_run_in_memory_bit_for_bit(small_chunks, tmp_path: Path) -> None:
    path = tmp_path / "streamed.npz"
    args = {"inputs": INPUTS, "initial": {"dP": "gravity"}, "duration": 7.0, "sample_dt": 0.003}
    streamed = ml.simulate("erector", stream=path, **args)
    in_memory = ml.simulate("erector", **args)
    assert len(in_memory.t) == 7000 // 3 + 2  # samples in 8 chunks, the last not on the grid
    assert_same_arrays(streamed, in_memory)
    loaded = ml.Run.load(path)  # the content hash checked
    assert_same_arrays(loaded, in_memory)
    assert store.read_header(path)["hash"] == store.header_of(in_memory)["hash"]
    assert loaded.meta == in_memory.meta
    with zipfile.ZipFile(path) as archive:
        assert archive.testzip() is None  # every member's CRC
        assert all(i.compress_type == zipfile.ZIP_STORED for i in archive.infolist())
    with np.load(path) as plain:  # any numpy reads it, without maniplab
        assert plain["signal/dP"].tobytes() == in_memory["dP"].tobytes()
    assert not list(tmp_path.glob(".*"))


def test_streaming_does_not_change_the_run(small_chunks, tmp_path: Path, monkeypatch) -> None:
    """Chunked recording against the run recorded in one piece (chunks longer than the run)."""
    streamed = ml.simulate("erector", inputs=INPUTS, duration=3.0, stream=tmp_path / "s.npz")
    monkeypatch.setattr(_Loop, "CHUNK", 10_000)
    assert_same_arrays(streamed, ml.simulate("erector", inputs=INPUTS, duration=3.0))


def test_a_streamed_run_takes_one_chunk_of_memory(tmp_path: Path) -> None:
    ml.simulate("erector", duration=0.01)
    _, short_peak = traced_run(duration=30.0, stream=tmp_path / "short.npz")
    run, peak = traced_run(duration=120.0, stream=tmp_path / "long.npz")
    assert stored_bytes(run) > 55e6 and peak <= CHUNK_BYTES, peak / 1e6
    assert peak <= short_peak + 1e6  # 4 times the samples, no more memory


def test_stream_on_the_command_line(capsys, tmp_path: Path) -> None:
    argv = ["simulate", "erector", "--input", "q2=step:0.2@0.1", "--balanced", "--duration", "1.5"]
    assert run_cli(capsys, *argv, "--stream", "-o", str(tmp_path / "s.npz"))[0] == 0
    assert run_cli(capsys, *argv, "-o", str(tmp_path / "m.npz"))[0] == 0
    assert_same_arrays(ml.Run.load(tmp_path / "s.npz"), ml.Run.load(tmp_path / "m.npz"))
    assert run_cli(capsys, *argv, "--compress", "-o", str(tmp_path / "c.npz"))[0] == 0
    assert_same_arrays(ml.Run.load(tmp_path / "c.npz"), ml.Run.load(tmp_path / "m.npz"))
    assert (tmp_path / "c.npz").stat().st_size < (tmp_path / "m.npz").stat().st_size
    code, _, err = run_cli(capsys, *argv, "--stream", "--compress", "-o", str(tmp_path / "x.npz"))
    assert code == 2 and "--compress and --stream" in err and err.count("\n") == 1
    assert not (tmp_path / "x.npz").exists()


def test_large_files_take_zip64_records(tmp_path: Path, monkeypatch) -> None:
    monkeypatch.setattr(stream, "ZIP64_AT", 1000)  # as for members and offsets beyond 4 GiB
    path = tmp_path / "z64.npz"
    streamed = ml.simulate("planar2", duration=1.0, stream=path)
    with zipfile.ZipFile(path) as archive:
        assert archive.testzip() is None
        assert all(i.extra[:2] == b"\x01\x00" for i in archive.infolist())  # ZIP64 extras
    assert_same_arrays(ml.Run.load(path), ml.simulate("planar2", duration=1.0))
    assert_same_arrays(streamed, ml.Run.load(path))


def test_load_can_memory_map_a_run(tmp_path: Path) -> None:
    run = ml.simulate("planar2", duration=1.0)
    run.save(tmp_path / "run.npz")
    mapped = ml.Run.load(tmp_path / "run.npz", mmap=True)
    assert_same_arrays(mapped, run)
    assert not mapped.q.flags.writeable and isinstance(mapped.q.base, np.memmap)


class Fails:
    """An input signal that raises once the run is past ``at`` seconds."""

    def __init__(self, at: float, error: type[BaseException]) -> None:
        self.at, self.error = at, error

    def __call__(self, t: float) -> float:
        if t > self.at:
            raise self.error("stop here")
        return 0.1


class FailingController:
    """A controller that raises once the run is past ``at`` seconds."""

    dt = 0.01

    def __init__(self, at: float, error: type[BaseException]) -> None:
        self.at, self.error = at, error

    def __call__(self, t: float, state: ml.PlantState) -> list[float]:
        if t > self.at:
            raise self.error("stop here")
        return [0.0] * 6


@pytest.mark.parametrize("error", [RuntimeError, KeyboardInterrupt])
@pytest.mark.parametrize("how", ["input", "controller"])
def test_an_interrupted_streamed_run_leaves_nothing(small_chunks, tmp_path: Path, how: str,
                                                   error: type[BaseException]) -> None:
    path = tmp_path / "run.npz"
    path.write_bytes(b"the earlier run")
    drive = ({"inputs": {"q2": Fails(2.5, error)}} if how == "input"
             else {"controller": FailingController(2.5, error)})
    with pytest.raises(error, match="stop here"):
        ml.simulate("erector", duration=5.0, stream=path, **drive)
    assert path.read_bytes() == b"the earlier run"  # kept, not half replaced
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run.npz"]  # no temporary file


def test_stream_refuses_what_is_no_file(tmp_path: Path) -> None:
    with pytest.raises(ml.ManiplabError, match="not a regular file"):
        ml.simulate("planar2", duration=0.1, stream=tmp_path)
    with pytest.raises(ml.InputError, match="stream must be the path of a run file"):
        ml.simulate("planar2", duration=0.1, stream=3)  # type: ignore[arg-type]


def test_stream_refuses_a_controller_that_annotates_the_run(tmp_path: Path) -> None:
    class Annotating(FailingController):
        def annotate(self, run: ml.Run) -> ml.Run:
            return run

    with pytest.raises(ml.InputError, match="annotate.*sample_dt="):
        ml.simulate("erector", duration=1.0, controller=Annotating(9.0, RuntimeError),
                    stream=tmp_path / "run.npz")
    assert not list(tmp_path.iterdir())
