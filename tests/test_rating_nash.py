"""Nash averaging and population measures (Balduzzi et al. 2018, 2019)."""

import time

import numpy as np
import pytest

from arena_league.rating import (
    PairCounts,
    bootstrap_statistic,
    effective_diversity,
    intransitivity,
    nash_averaging,
    nash_intervals,
    population_performance,
    population_vs_population,
)

RPS = np.array([[0.0, -1.0, 1.0], [1.0, 0.0, -1.0], [-1.0, 1.0, 0.0]])


def random_antisymmetric(rng, n, transitive=0.0):
    X = rng.normal(size=(n, n))
    r = rng.normal(size=n) * transitive
    return X - X.T + r[:, None] - r[None, :]


def logistic_win_rate(A):
    return 1.0 / (1.0 + np.exp(-A))


def test_rock_paper_scissors_is_uniform_with_zero_scores():
    p, scores = nash_averaging(RPS)
    np.testing.assert_allclose(p, [1 / 3] * 3, atol=1e-12)
    np.testing.assert_allclose(scores, 0.0, atol=1e-12)


def test_cyclic_game_gives_uniform_equilibrium():
    # div(A) = 0 (every row sums to zero) <=> the maxent Nash is uniform (Balduzzi 2018, Prop. 1)
    rng = np.random.default_rng(0)
    X = random_antisymmetric(rng, 7)
    A = intransitivity(X).cyclic
    p, _ = nash_averaging(A)
    np.testing.assert_allclose(p, 1 / 7, atol=1e-9)


def test_transitive_game_puts_all_mass_on_the_top_agents():
    r = np.array([0.2, 1.5, -0.3, 1.5, 0.9])
    p, scores = nash_averaging(r[:, None] - r[None, :])
    np.testing.assert_allclose(p, [0, 0.5, 0, 0.5, 0], atol=1e-12)
    np.testing.assert_allclose(scores, r - 1.5, atol=1e-12)


def test_copies_change_no_score_but_change_mean_win_rate():
    rng = np.random.default_rng(1)
    A = random_antisymmetric(rng, 8, transitive=0.5)
    p, scores = nash_averaging(A)
    copies = [*range(8), 2, 2, 2, 5]
    A_copied = A[np.ix_(copies, copies)]
    p_copied, scores_copied = nash_averaging(A_copied)
    np.testing.assert_allclose(scores_copied[:8], scores, atol=1e-9)
    np.testing.assert_allclose(scores_copied[8:], scores[[2, 2, 2, 5]], atol=1e-9)
    # the copies share the original's mass
    merged = np.bincount(copies, weights=p_copied, minlength=8)
    np.testing.assert_allclose(merged, p, atol=1e-9)
    # mean win rate is not invariant: copies of agent 2 move everyone's average
    before = population_performance(logistic_win_rate(A))
    after = population_performance(logistic_win_rate(A_copied))[:8]
    assert np.abs(after - before).max() > 0.01


def test_perturbed_equilibrium_is_an_eps_equilibrium():
    # Balduzzi 2018, Theorem 1 (continuity): Nash of A + E with |E| <= eps scores <= eps under A
    rng = np.random.default_rng(2)
    for trial in range(20):
        A = random_antisymmetric(rng, 12, transitive=0.3 * trial)
        eps = 0.05
        E = rng.uniform(-eps, eps, size=A.shape)
        E = np.triu(E, 1) - np.triu(E, 1).T
        p_perturbed, _ = nash_averaging(A + E)
        assert (A @ p_perturbed).max() <= eps + 1e-9


def test_scores_are_non_positive_and_zero_on_the_support():
    rng = np.random.default_rng(3)
    for n in (2, 5, 30, 80):
        A = random_antisymmetric(rng, n, transitive=0.5)
        p, scores = nash_averaging(A)
        assert p.sum() == pytest.approx(1.0) and (p >= 0).all()
        assert scores.max() <= 1e-9
        np.testing.assert_allclose(scores[p > 1e-9], 0.0, atol=1e-9)


def test_rejects_a_non_antisymmetric_matrix():
    with pytest.raises(ValueError, match="antisymmetric"):
        nash_averaging(np.array([[0.0, 0.7], [0.3, 0.0]]))
    with pytest.raises(ValueError, match="pseudo-count"):
        nash_averaging(np.array([[0.0, np.inf], [-np.inf, 0.0]]))


def test_two_hundred_agents_in_under_a_second():
    A = random_antisymmetric(np.random.default_rng(4), 200, transitive=0.3)
    start = time.perf_counter()
    nash_averaging(A)
    assert time.perf_counter() - start < 2.0  # the benchmark holds the 1 s target on a quiet machine


def test_population_vs_population_is_antisymmetric():
    rng = np.random.default_rng(5)
    A = random_antisymmetric(rng, 10, transitive=1.0)
    P, Q = [0, 1, 2, 3], [4, 5, 6, 7, 8, 9]
    v = population_vs_population(A, P, Q)
    assert v == pytest.approx(-population_vs_population(A, Q, P), abs=1e-9)
    assert population_vs_population(A, P, P) == pytest.approx(0.0, abs=1e-9)
    # a population holding the strongest agent of a transitive game wins
    r = np.arange(6.0)
    T = r[:, None] - r[None, :]
    assert population_vs_population(T, [5, 0], [1, 2, 3]) == pytest.approx(2.0)


def test_effective_diversity():
    r = np.arange(5.0)
    assert effective_diversity(r[:, None] - r[None, :]) == pytest.approx(0.0, abs=1e-12)
    # RPS: uniform Nash, each agent beats one other by 1: 3 * (1/3)^2 * 1
    assert effective_diversity(RPS) == pytest.approx(1 / 3)
    assert effective_diversity(RPS, P=[0, 1]) == pytest.approx(0.0)


def test_intransitivity_decomposition():
    r = np.array([0.0, 1.0, 3.0])
    T = r[:, None] - r[None, :]
    pure = intransitivity(T)
    assert pure.cyclic_share == pytest.approx(0.0, abs=1e-12) and pure.cycle_strengths.size == 0
    cyclic = intransitivity(RPS)
    assert cyclic.cyclic_share == pytest.approx(1.0)
    assert cyclic.cycle_strengths == pytest.approx([np.sqrt(3.0)])
    mixed = intransitivity(T + RPS)
    np.testing.assert_allclose(mixed.transitive + mixed.cyclic, T + RPS)
    assert (mixed.transitive * mixed.cyclic).sum() == pytest.approx(0.0, abs=1e-12)  # orthogonal parts
    assert 0 < mixed.cyclic_share < 1 and mixed.transitive_share == pytest.approx(1 - mixed.cyclic_share)


def test_population_performance_over_a_base():
    W = np.array([[0.5, 0.8, 0.6], [0.2, 0.5, 0.4], [0.4, 0.6, 0.5]])
    np.testing.assert_allclose(population_performance(W), [0.7, 0.3, 0.5])
    np.testing.assert_allclose(population_performance(W, base=[1, 2]), [0.7, 0.4, 0.6])
    with pytest.raises(ValueError, match="never played"):
        population_performance(np.array([[0.5, np.nan], [np.nan, 0.5]]))


def test_nash_score_intervals():
    rng = np.random.default_rng(6)
    r = np.array([0.0, 0.5, 1.0, 1.5])
    games = 200
    wins = rng.binomial(games, 1 / (1 + np.exp(-(r[:, None] - r[None, :]))))
    wins = np.triu(wins, 1) + np.triu(games - wins, 1).T
    result = nash_intervals(PairCounts.from_matrices(wins), rounds=50)
    assert (result.lower <= result.point + 1e-12).all() and (result.point <= result.upper + 1e-12).all()
    assert result.point[3] == pytest.approx(0.0) and result.upper[0] < 0


def test_a_known_point_is_taken_as_given_and_the_interval_is_unchanged():
    wins = np.array([[0, 30, 25], [10, 0, 20], [15, 20, 0]])
    counts = PairCounts.from_matrices(wins)
    calls = []

    def scores(c):
        calls.append(c)
        return nash_averaging(c.logit_payoff())[1]

    fresh = bootstrap_statistic(counts, scores, rounds=20, seed=4)
    assert len(calls) == 21  # the point, then one per round
    calls.clear()
    known = bootstrap_statistic(counts, scores, rounds=20, seed=4, point=fresh.point)
    assert len(calls) == 20
    np.testing.assert_array_equal(known.point, fresh.point)
    np.testing.assert_array_equal(known.lower, fresh.lower)
    np.testing.assert_array_equal(known.upper, fresh.upper)
    via_nash = nash_intervals(counts, rounds=20, seed=4, point=fresh.point)
    np.testing.assert_array_equal(via_nash.samples, fresh.samples)
