"""Validating a controller in CI: assertions, pytest fixtures and a Monte-Carlo robustness study.

In a test file (pytest)::

    import maniplab as ml
    from maniplab.testing import assert_healthy, assert_tracks

    def test_my_controller_tracks(builtin_arm):          # once per built-in arm
        ...
        assert_tracks(result.run, final_mm=2.0, rms_mm=5.0)
        assert_healthy(result.run)

The fixtures come with ``pytest_plugins = ["maniplab.testing"]`` in your ``conftest.py``.
:func:`monte_carlo` samples parameter variations (payload, leakage, friction, bulk modulus...)
from distributions and reports the spread of the tracking metrics.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np

from maniplab.builtin import builtin_specs, resolve_spec
from maniplab.control.interface import TOLERANCES
from maniplab.control.move import ControllerFactory, MoveResult, run_move
from maniplab.errors import ManiplabError
from maniplab.model import AnalyticModel
from maniplab.sim import health
from maniplab.spec import ManipulatorSpec
from maniplab.workers import Threads

try:  # the fixtures need pytest; the assertions and the study do not
    import pytest
except ImportError:  # pragma: no cover - pytest is not a dependency of maniplab
    pytest = None  # type: ignore[assignment]


def tracking_errors(run: Any) -> tuple[float, float]:
    """(final, RMS over the move) position error of a run with a reference, mm: the end
    effector against ``p_ref`` (a controller that declares a reference records it)."""
    errors = health.tracking_errors(run)
    if errors is None:
        raise AssertionError("the run has no reference (p_ref): its controller declares none; "
                             "run it with run_move or give the controller a reference")
    return errors


def assert_tracks(run: Any, *, final_mm: float = TOLERANCES[0],
                  rms_mm: float = TOLERANCES[1]) -> None:
    """Fail (AssertionError, one line) unless the run ends within ``final_mm`` of its reference
    and its RMS error over the move is within ``rms_mm``."""
    final, rms = tracking_errors(run)
    misses = [f"final error {final:.3g} mm > {final_mm:g} mm"] if not final <= final_mm else []
    if not rms <= rms_mm:
        misses.append(f"RMS error {rms:.3g} mm > {rms_mm:g} mm")
    if misses:
        raise AssertionError(f"{run.label}: " + ", ".join(misses))


def assert_healthy(run: Any, *, warnings: bool = True) -> None:
    """Fail (AssertionError, the findings) when the run's health verdict is "failed" (or, with
    ``warnings=False``, anything but "ok")."""
    health = run.health
    if health.verdict == "failed" or (not warnings and health.verdict != "ok"):
        raise AssertionError(f"{run.label}: health {health.verdict}: " + "; ".join(health.lines()))


Distribution = Any
"""A scipy.stats frozen distribution (``scipy.stats.norm(4000, 400)``: anything with
``rvs(random_state=...)``), or a function ``rng -> value`` of a numpy Generator."""


@dataclasses.dataclass(frozen=True)
class MonteCarlo:
    """A Monte-Carlo study's samples and the spread of their metrics.

    Attributes:
        parameters: each sample's overrides (dotted path -> value).
        results: each sample's metrics: ``final_mm``, ``rms_mm``, ``max_mm``, ``peak_dP_MPa``,
            ``verdict`` (the run's health), ``error`` (one line, when the run failed outright).
    """

    parameters: tuple[dict[str, float], ...]
    results: tuple[dict[str, Any], ...]

    METRICS = ("final_mm", "rms_mm", "max_mm", "peak_dP_MPa")

    def spread(self) -> dict[str, dict[str, float]]:
        """metric -> {mean, std, min, p5, p50, p95, max} over the samples that ran."""
        out = {}
        for name in self.METRICS:
            values = np.array([r[name] for r in self.results if r.get("error") is None],
                              dtype=float)
            values = values[np.isfinite(values)]
            if values.size == 0:
                continue
            p5, p50, p95 = np.percentile(values, [5, 50, 95])
            out[name] = {"mean": float(values.mean()), "std": float(values.std(ddof=1))
                         if values.size > 1 else 0.0, "min": float(values.min()),
                         "p5": float(p5), "p50": float(p50), "p95": float(p95),
                         "max": float(values.max())}
        return out

    @property
    def failed(self) -> int:
        """Samples whose run failed its health check or did not complete."""
        return sum(r["verdict"] != "ok" and r["verdict"] != "warnings" for r in self.results)

    def table(self) -> str:
        """The spread as a Markdown table."""
        rows = ["| metric | mean | std | min | p5 | p50 | p95 | max |", "|---" * 8 + "|"]
        for name, s in self.spread().items():
            rows.append(f"| {name} | " + " | ".join(f"{s[k]:.3g}" for k in (
                "mean", "std", "min", "p5", "p50", "p95", "max")) + " |")
        rows.append(f"\n{len(self.results)} samples, {self.failed} failed")
        return "\n".join(rows)


def monte_carlo(spec: ManipulatorSpec | str, distributions: Mapping[str, Distribution], *,
                target: Sequence[float], start: Sequence[float] | None, duration: float,
                samples: int = 20, seed: int = 0, controller: ControllerFactory | None = None,
                mode: str = "cascade", settle: float = 1.0,
                tolerances: tuple[float, float] = TOLERANCES, threads: int = 2,
                sample_dt: float | None = 0.01) -> MonteCarlo:
    """Run a move on ``samples`` plants drawn from ``distributions``, the controller built for
    the nominal ``spec`` (the designer's estimate), and collect the metrics.

    Args:
        spec: the nominal arm (the controller's model).
        distributions: dotted path -> distribution of the plant's value (see ``Distribution``),
            e.g. ``{"end_effector.mass": scipy.stats.norm(4000, 400)}``.
        target: as for ``run_move``.
        start: as for ``run_move``.
        duration: as for ``run_move``.
        settle: as for ``run_move``.
        mode: as for ``run_move``.
        controller: as for ``run_move``.
        tolerances: as for ``run_move``.
        samples: how many plants.
        seed: the random seed: the same seed draws the same plants.
        threads: samples run at once (the plant's loop runs outside Python's lock).
        sample_dt: the runs' recording interval, s.

    Raises:
        ManiplabError: a distribution that is neither a scipy.stats one nor a function, or a
            drawn value that the spec refuses (naming the path and the value).
    """
    nominal = resolve_spec(spec)
    rng = np.random.default_rng(seed)
    drawn = [{path: _draw(path, dist, rng) for path, dist in distributions.items()}
             for _ in range(samples)]
    plants = [_plant(nominal, overrides) for overrides in drawn]
    model = AnalyticModel(nominal)

    def one(plant: ManipulatorSpec) -> dict[str, Any]:
        try:
            result = run_move(nominal, target, start=start, duration=duration, mode=mode,
                              settle=settle, model=model, controller=controller,
                              tolerances=tolerances, plant=plant, sample_dt=sample_dt)
        except ManiplabError as exc:
            return {"final_mm": math.nan, "rms_mm": math.nan, "max_mm": math.nan,
                    "peak_dP_MPa": math.nan, "verdict": "error", "error": str(exc)}
        return _metrics(result)

    with Threads(max(1, threads)) as pool:
        results = pool.map_results(one, [(plant,) for plant in plants])
    return MonteCarlo(tuple(drawn), tuple(results))


def _draw(path: str, dist: Distribution, rng: np.random.Generator) -> float:
    if hasattr(dist, "rvs"):
        return float(dist.rvs(random_state=rng))
    if callable(dist):
        return float(dist(rng))
    raise ManiplabError(f"distribution of {path!r}: expected a scipy.stats distribution or a "
                        f"function rng -> value, got {dist!r}")


def _plant(nominal: ManipulatorSpec, overrides: dict[str, float]) -> ManipulatorSpec:
    try:
        return nominal.with_overrides(overrides)
    except ManiplabError as exc:
        raise ManiplabError(f"a drawn plant was refused: {exc}") from None


def _metrics(result: MoveResult) -> dict[str, Any]:
    m = result.metrics
    return {"final_mm": m.final_error_mm, "rms_mm": m.rms_error_mm, "max_mm": m.max_error_mm,
            "peak_dP_MPa": m.peak_dP_MPa, "verdict": result.health.verdict, "error": None}


if pytest is not None:
    @pytest.fixture(params=builtin_specs())
    def builtin_arm(request: Any) -> ManipulatorSpec:
        """Each built-in arm in turn (the test runs once per arm)."""
        return resolve_spec(request.param)

    @pytest.fixture
    def move_runner() -> Callable[..., MoveResult]:
        """``run_move`` (plan a move, run it under a controller, measure it)."""
        return run_move
