"""Bradley-Terry ratings, their bootstrap intervals, and online Elo."""

import math

import numpy as np
import pytest
from scipy.optimize import minimize

from arena_league.rating import (
    PairCounts,
    bootstrap_ratings,
    bradley_terry,
    elo_online,
    fit_bradley_terry,
)

LN10 = math.log(10.0)


def simulate_league(rng, ratings, n_matches, draw_rate=0.0):
    """Random pairings; Bradley-Terry outcomes on the Elo scale; a share of matches drawn."""
    n = len(ratings)
    first = rng.integers(n, size=n_matches)
    second = (first + rng.integers(1, n, size=n_matches)) % n
    p_first = 1.0 / (1.0 + 10.0 ** ((ratings[second] - ratings[first]) / 400.0))
    u = rng.random(n_matches)
    decided = rng.random(n_matches) >= draw_rate
    score = np.where(decided, (u < p_first).astype(float), 0.5)
    return PairCounts.from_results(first, second, score, n)


def plain_mle(wins, draws):
    """Reference: the unpenalised likelihood minimised by BFGS, mean 1000."""
    points = wins + 0.5 * draws

    def nll(theta):
        d = theta[:, None] - theta[None, :]
        return (points * np.logaddexp(0.0, -d)).sum()

    theta = minimize(nll, np.zeros(len(wins)), method="BFGS", options={"gtol": 1e-10}).x
    ratings = 400.0 / LN10 * theta
    return ratings - ratings.mean() + 1000.0


def test_matches_the_plain_maximum_likelihood():
    rng = np.random.default_rng(1)
    counts = simulate_league(rng, rng.normal(0, 200, 12), 3000, draw_rate=0.1)
    ours = bradley_terry(counts.wins, counts.draws, prior_sd=math.inf)
    np.testing.assert_allclose(ours, plain_mle(counts.wins, counts.draws), atol=1e-3)
    assert ours.mean() == pytest.approx(1000.0)
    # the default weak prior moves ratings by well under a point here
    assert np.abs(bradley_terry(counts.wins, counts.draws) - ours).max() < 1.0


def test_elo_scale_two_agents():
    # 10 wins to 1 is odds 10: a 400-point gap
    ratings = bradley_terry([[0, 10], [1, 0]], prior_sd=math.inf)
    assert ratings[0] - ratings[1] == pytest.approx(400.0)
    assert ratings.mean() == pytest.approx(1000.0)


def test_anchor_and_pin():
    rng = np.random.default_rng(2)
    counts = simulate_league(rng, rng.normal(0, 200, 6), 600)
    names = ["a", "b", "c", "d", "e", "f"]
    free = bradley_terry(counts.wins)
    pinned = bradley_terry(counts.wins, agents=names, pin="c")
    anchored = bradley_terry(counts.wins, agents=names, anchor=["a", "b"])
    assert pinned[2] == pytest.approx(1000.0)
    assert anchored[:2].mean() == pytest.approx(1000.0)
    # anchoring only shifts
    np.testing.assert_allclose(np.diff(pinned), np.diff(free), atol=1e-9)
    np.testing.assert_allclose(np.diff(anchored), np.diff(free), atol=1e-9)
    with pytest.raises(ValueError, match="unknown agent"):
        bradley_terry(counts.wins, agents=names, pin="zed")
    with pytest.raises(ValueError, match="not both"):
        bradley_terry(counts.wins, agents=names, pin="a", anchor=["b"])


def test_unbeaten_agent_is_finite_with_the_prior_and_an_error_without():
    wins = np.array([[0, 5, 5], [0, 0, 3], [0, 2, 0]], dtype=float)
    ratings = bradley_terry(wins)
    assert np.isfinite(ratings).all() and ratings[0] > ratings[1:].max() + 400
    with pytest.raises(ValueError, match="prior_sd"):
        bradley_terry(wins, prior_sd=math.inf)


def test_davidson_recovers_the_draw_rate():
    rng = np.random.default_rng(3)
    n, matches = 8, 20000
    strength = rng.normal(0, 0.5, n)
    nu = 0.6
    first = rng.integers(n, size=matches)
    second = (first + rng.integers(1, n, size=matches)) % n
    half_gap = 0.5 * (strength[first] - strength[second])
    weights = np.stack([np.exp(half_gap), np.full(matches, nu), np.exp(-half_gap)], axis=1)
    u = rng.random(matches)[:, None] * weights.sum(1, keepdims=True)
    outcome = (u > np.cumsum(weights, axis=1)).sum(1)  # 0 first wins, 1 draw, 2 second wins
    score = np.array([1.0, 0.5, 0.0])[outcome]
    fit = fit_bradley_terry(PairCounts.from_results(first, second, score, n), draw_model="davidson")
    assert fit.draw_nu == pytest.approx(nu, rel=0.05)
    truth = 400.0 / LN10 * strength
    np.testing.assert_allclose(fit.ratings - fit.ratings.mean(), truth - truth.mean(), atol=25.0)


def test_bootstrap_intervals_cover_the_truth_in_200_leagues():
    """Over 200 simulated leagues the 95% intervals hold the true rating 90-99% of the
    time (pooled over agents)."""
    rng = np.random.default_rng(4)
    hits = []
    for league in range(200):
        truth = rng.normal(0.0, 200.0, 8)
        truth = truth - truth.mean() + 1000.0
        counts = simulate_league(rng, truth, 400)
        intervals = bootstrap_ratings(counts, rounds=100, seed=league)
        hits.append((intervals.lower <= truth) & (truth <= intervals.upper))
    coverage = np.mean(hits)
    assert 0.90 <= coverage <= 0.99, coverage


def test_ranks_and_percentiles():
    rng = np.random.default_rng(5)
    counts = simulate_league(rng, np.array([0.0, 200.0, 400.0, 600.0]), 2000)
    result = bootstrap_ratings(counts, rounds=50)
    assert result.rank.tolist() == [4, 3, 2, 1]
    assert ((result.rank_lower <= result.rank) & (result.rank <= result.rank_upper)).all()
    assert result.percentile.tolist() == [0.0, 100 / 3, 200 / 3, 100.0]
    assert (result.percentile_lower <= result.percentile).all()
    assert (result.percentile <= result.percentile_upper).all()


def test_pinned_agent_has_zero_width_interval():
    rng = np.random.default_rng(6)
    counts = simulate_league(rng, rng.normal(0, 200, 5), 500)
    result = bootstrap_ratings(counts, rounds=30, pin=0)
    assert result.lower[0] == pytest.approx(1000.0) and result.upper[0] == pytest.approx(1000.0)
    assert (result.upper[1:] - result.lower[1:] > 10.0).all()


def test_bootstrap_is_seeded():
    rng = np.random.default_rng(7)
    counts = simulate_league(rng, rng.normal(0, 200, 5), 500)
    a, b = bootstrap_ratings(counts, rounds=20, seed=3), bootstrap_ratings(counts, rounds=20, seed=3)
    np.testing.assert_array_equal(a.samples, b.samples)


def test_elo_online():
    # equal ratings, one win: the winner gains K/2
    ratings = elo_online([0], [1], [1.0], 2, k=32)
    np.testing.assert_allclose(ratings, [1016.0, 984.0])
    # order matters: the same two results in the other order give other ratings
    forward = elo_online([0, 0], [1, 1], [1.0, 0.0], 2)
    backward = elo_online([0, 0], [1, 1], [0.0, 1.0], 2)
    assert forward[0] != backward[0]
    assert forward.sum() == pytest.approx(2000.0)
    # a long league tracks the Bradley-Terry order
    rng = np.random.default_rng(8)
    truth = np.linspace(600, 1400, 6)
    first = rng.integers(6, size=6000)
    second = (first + rng.integers(1, 6, size=6000)) % 6
    score = (rng.random(6000) < 1 / (1 + 10 ** ((truth[second] - truth[first]) / 400))).astype(float)
    assert np.argsort(elo_online(first, second, score, 6)).tolist() == list(range(6))
