"""Run files: bit-for-bit round trips, corrupt and truncated files, atomic writes."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import maniplab as ml
from maniplab.sim import Run, RunFileError, store


def make_run(mass: float = 4000.0, seed: int = 0) -> Run:
    spec = ml.builtin_spec("erector").with_overrides({"end_effector.mass": mass})
    rng = np.random.default_rng(seed)
    t = np.linspace(0.0, 1.0, 101)
    dp = rng.normal(size=(101, 6)) * 1e6
    dp[:, 2] = np.nan  # a joint without the element
    signals = {"q": rng.normal(size=(101, 6)), "qd": rng.normal(size=(101, 6)), "dP": dp,
               "mode": rng.integers(0, 4, size=(101, 6)), "ee_pos": rng.normal(size=(101, 3))}
    return Run(t, signals, spec, {"label": "heavy", "overrides": {"end_effector.mass": mass},
                                  "inputs": {"q2": "step(1.5, t0=0.2)"}, "dt": 1e-3})


def test_round_trip_is_bit_for_bit(tmp_path: Path) -> None:
    run = make_run()
    run.save(tmp_path / "a.npz")
    back = Run.load(tmp_path / "a.npz")
    assert back.t.tobytes() == run.t.tobytes()
    assert set(back.signals) == set(run.signals)
    for name, values in run.signals.items():
        assert back[name].dtype == values.dtype
        assert back[name].tobytes() == values.tobytes(), name
    assert back.spec == run.spec
    assert back.spec.end_effector.mass == 4000.0
    assert back.meta == run.meta


def test_a_compressed_run_is_smaller_and_reads_back_bit_for_bit(tmp_path: Path) -> None:
    """A simulated run (smooth signals, not the noise of make_run) deflated: the file is smaller
    than the stored one, its members are deflated (zip's own record), and it reads back bit for
    bit, mapped or not, block by block too."""
    import zipfile

    spec = ml.builtin_spec("crane3")
    run = ml.simulate(spec, inputs={"luff": ml.signals.sine(0.3, 0.5)}, duration=2.0,
                      sample_dt=0.01)
    run.save(tmp_path / "plain.npz")
    run.save(tmp_path / "small.npz", compress=True)
    plain, small = ((tmp_path / n).stat().st_size for n in ("plain.npz", "small.npz"))
    assert small < 0.7 * plain, (small, plain)
    with zipfile.ZipFile(tmp_path / "small.npz") as archive:
        assert archive.getinfo("signal/q.npy").compress_type == zipfile.ZIP_DEFLATED
    for mmap in (False, True):
        back = Run.load(tmp_path / "small.npz", mmap=mmap)
        for name, values in run.signals.items():
            assert back[name].tobytes() == values.tobytes(), name
    blocks = list(store.blocks(tmp_path / "small.npz", "q", rows=64))
    assert np.concatenate(blocks).tobytes() == run.q.tobytes()


def test_header_records_units_versions_and_hash(tmp_path: Path) -> None:
    from importlib.metadata import version

    make_run().save(tmp_path / "a.npz")
    header = store.read_header(tmp_path / "a.npz")
    assert header["units"]["dP"] == "Pa" and header["units"]["q"] == "rad | m"
    assert header["versions"] == {"maniplab": version("maniplab"), "mujoco": version("mujoco")}
    assert len(header["hash"]) == 64
    assert header["hash"] != store.header_of(make_run(seed=1))["hash"]  # other data, other hash


def test_truncated_file_is_a_clear_error(tmp_path: Path) -> None:
    path = tmp_path / "a.npz"
    make_run().save(path)
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])
    with pytest.raises(RunFileError, match=r"a\.npz: not a readable maniplab run file"):
        Run.load(path)


def test_flipped_byte_is_detected(tmp_path: Path) -> None:
    path = tmp_path / "a.npz"
    run = make_run()
    run.save(path)
    data = bytearray(path.read_bytes())
    # flip one byte inside the q array's data (found by its exact bytes), keeping the zip valid
    # for stored (uncompressed) members; zip's CRC or the content hash must catch it
    offset = bytes(data).find(run.q.tobytes()[:64])
    assert offset > 0
    data[offset + 10] ^= 0xFF
    path.write_bytes(bytes(data))
    with pytest.raises(RunFileError, match="corrupt|not a readable"):
        Run.load(path)


def test_edited_header_fails_the_hash(tmp_path: Path) -> None:
    path = tmp_path / "a.npz"
    run = make_run()
    header = store.header_of(run)
    header["meta"]["label"] = "edited"
    arrays = {f"signal/{k}": v for k, v in run.signals.items()}
    np.savez(path, t=run.t, header=np.array(json.dumps(header)), **arrays)
    with pytest.raises(RunFileError, match="content hash mismatch"):
        Run.load(path)


@pytest.mark.parametrize("content", [b"", b"not a zip", b"PK\x03\x04garbage"])
def test_not_a_run_file(tmp_path: Path, content: bytes) -> None:
    path = tmp_path / "x.npz"
    path.write_bytes(content)
    with pytest.raises(RunFileError, match="x.npz"):
        Run.load(path)


def test_missing_file_and_foreign_npz(tmp_path: Path) -> None:
    with pytest.raises(RunFileError, match="no such run file"):
        Run.load(tmp_path / "nope.npz")
    np.savez(tmp_path / "foreign.npz", a=np.zeros(3))
    with pytest.raises(RunFileError, match="foreign.npz"):
        Run.load(tmp_path / "foreign.npz")


def test_interrupted_save_keeps_the_earlier_file(tmp_path: Path, monkeypatch) -> None:
    path = tmp_path / "a.npz"
    first = make_run(mass=3000.0)
    first.save(path)
    before = path.read_bytes()

    def explode(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(np, "savez", explode)
    with pytest.raises(KeyboardInterrupt):
        make_run(mass=5000.0).save(path)
    assert path.read_bytes() == before
    assert [p.name for p in tmp_path.iterdir()] == ["a.npz"]
