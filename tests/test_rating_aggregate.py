"""Aggregate statistics over runs: hand-worked cases, scipy and rliable cross-checks, seeded intervals."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from arena_league.rating.aggregate import (
    iqm,
    optimality_gap,
    performance_profile,
    probability_of_improvement,
    probability_of_improvement_matrix,
    stratified_bootstrap_ci,
)

EIGHT = np.arange(1.0, 9.0)[:, None]  # 8 runs of one task: 1 .. 8


def test_hand_worked_case() -> None:
    # IQM of 1..8: cut floor(8/4) = 2 from each end, the mean of 3, 4, 5, 6.
    assert iqm(EIGHT) == 4.5
    # Shortfalls below 4: 3, 2, 1, then zeros, over 8 scores.
    assert optimality_gap(EIGHT, threshold=4.0) == 0.75
    # x = 1, 2, 3 against y = 2: one greater, one tie (half), one smaller.
    assert probability_of_improvement([[1.0], [2.0], [3.0]], [[2.0]]) == 0.5
    # Two tasks: x beats y everywhere in task 0 and never in task 1: the mean of 1 and 0.
    assert probability_of_improvement([[5.0, 0.0], [6.0, 0.0]], [[1.0, 9.0]]) == 0.5
    assert performance_profile(EIGHT, [0.0, 4.5, 8.0]).tolist() == [1.0, 0.5, 0.0]


def test_against_scipy() -> None:
    rng = np.random.default_rng(3)
    x, y = rng.normal(size=(10, 6)), rng.normal(0.3, 1.0, size=(7, 6))
    assert iqm(x) == pytest.approx(stats.trim_mean(x.reshape(-1), 0.25))
    u = [stats.mannwhitneyu(x[:, t], y[:, t]).statistic / (10 * 7) for t in range(6)]
    assert probability_of_improvement(x, y) == pytest.approx(np.mean(u))
    matrix = probability_of_improvement_matrix({"a": x, "b": y})
    assert matrix["a"]["b"] + matrix["b"]["a"] == pytest.approx(1.0)
    assert matrix["a"]["a"] == 0.5


def test_against_rliable_point_estimates() -> None:
    metrics = pytest.importorskip("rliable.metrics", reason="the rliable package does not import here")
    rng = np.random.default_rng(5)
    x, y = rng.random((10, 8)), rng.random((9, 8))
    assert iqm(x) == pytest.approx(metrics.aggregate_iqm(x))
    assert optimality_gap(x, 0.8) == pytest.approx(metrics.aggregate_optimality_gap(x, 0.8))
    assert probability_of_improvement(x, y) == pytest.approx(metrics.probability_of_improvement(x, y))


def test_batched_statistics_equal_the_loop() -> None:
    rng = np.random.default_rng(1)
    batch = rng.random((4, 6, 3))
    assert np.allclose(iqm(batch), [iqm(b) for b in batch])
    assert np.allclose(optimality_gap(batch), [optimality_gap(b) for b in batch])
    assert np.allclose(performance_profile(batch, [0.2, 0.7]), [performance_profile(b, [0.2, 0.7]) for b in batch])


@pytest.mark.parametrize("method", ["percentile", "bca"])
def test_same_seed_same_interval(method: str) -> None:
    scores = np.random.default_rng(7).random((10, 8))
    first = stratified_bootstrap_ci(scores, iqm, reps=500, rng=11, method=method)
    again = stratified_bootstrap_ci(scores, iqm, reps=500, rng=np.random.default_rng(11), method=method)
    other = stratified_bootstrap_ci(scores, iqm, reps=500, rng=12, method=method)
    assert (first.lower, first.upper) == (again.lower, again.upper)
    assert (first.lower, first.upper) != (other.lower, other.upper)
    assert first.lower <= first.point <= first.upper
    assert first.point == iqm(scores)


def test_interval_covers_the_truth_and_resamples_within_tasks() -> None:
    # Tasks with very different levels: a resample that mixed tasks would wander far off.
    rng = np.random.default_rng(0)
    scores = np.stack([rng.normal(0.0, 1.0, 40), rng.normal(100.0, 1.0, 40)], axis=1)
    ci = stratified_bootstrap_ci(scores, lambda s: s.mean(axis=(-2, -1)), reps=400, rng=0)
    assert ci.upper - ci.lower < 1.0
    assert ci.lower < 50.0 < ci.upper
    # A normal mean with known sd: a 95% interval from 200 runs has half-width near 1.96 / sqrt(200).
    ci = stratified_bootstrap_ci(rng.normal(0.0, 1.0, (200, 1)), lambda s: s.mean(axis=(-2, -1)),
                                 reps=2000, rng=1, method="bca")
    assert (ci.upper - ci.lower) / 2 == pytest.approx(1.96 / np.sqrt(200), rel=0.15)


def test_pairs_and_vector_statistics() -> None:
    rng = np.random.default_rng(2)
    x, y = rng.normal(1.0, 1.0, (10, 4)), rng.normal(0.0, 1.0, (10, 4))
    ci = stratified_bootstrap_ci((x, y), probability_of_improvement, reps=300, rng=4, method="bca")
    assert 0.5 < ci.lower <= ci.point <= ci.upper <= 1.0
    taus = np.linspace(-2, 3, 6)
    profile = stratified_bootstrap_ci(x, lambda s: performance_profile(s, taus), reps=300, rng=4)
    assert profile.lower.shape == (6,) and np.all(profile.lower <= profile.upper)
    assert profile.as_dict()["point"] == performance_profile(x, taus).tolist()


@pytest.mark.parametrize("bad, message", [
    (np.array([[np.nan, 1.0]]), "NaN"),
    (np.zeros((0, 3)), "at least one run"),
    (3.0, "scalar"),
])
def test_bad_scores_are_named(bad, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        iqm(bad)


def test_bad_bootstrap_options_are_named() -> None:
    with pytest.raises(ValueError, match="level"):
        stratified_bootstrap_ci(EIGHT, iqm, level=1.5)
    with pytest.raises(ValueError, match="reps"):
        stratified_bootstrap_ci(EIGHT, iqm, reps=1)
    with pytest.raises(ValueError, match="method"):
        stratified_bootstrap_ci(EIGHT, iqm, method="basic")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="same tasks"):
        probability_of_improvement(np.zeros((3, 2)), np.zeros((3, 4)))
