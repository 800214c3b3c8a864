"""alpha-Rank: exact cases by hand, and agreement with OpenSpiel's implementation."""

import warnings

import numpy as np
import pytest

from arena_league.rating import (
    PairCounts,
    ReducibleChainError,
    alpha_rank,
    alpha_rank_intervals,
    alpha_rank_sweep,
    fixation_probability,
)

RPS = np.array([[0.0, -1.0, 1.0], [1.0, 0.0, -1.0], [-1.0, 1.0, 0.0]])
BIASED_RPS = np.array([[0.0, -0.5, 1.0], [0.5, 0.0, -0.1], [-1.0, 0.1, 0.0]])


def transitive_win_rates(n):
    r = np.arange(n, dtype=float)
    return 1.0 / (1.0 + np.exp(-(r[:, None] - r[None, :])))


def random_symmetric_win_rates(rng, n):
    W = rng.random((n, n))
    return (W + 1.0 - W.T) / 2.0


def test_rock_paper_scissors_is_uniform():
    for alpha in (0.1, 1.0, 100.0):
        np.testing.assert_allclose(alpha_rank([RPS], alpha=alpha), [1 / 3] * 3, atol=1e-12)
    np.testing.assert_allclose(alpha_rank(RPS, use_inf_alpha=True), [1 / 3] * 3, atol=1e-12)


def test_transitive_game_ranks_the_top_strategy_first():
    pi = alpha_rank([transitive_win_rates(5)], alpha=100.0)
    assert pi[4] == pytest.approx(1.0)
    # the bare response graph (eps = 0) has one sink: the top strategy
    np.testing.assert_allclose(alpha_rank([transitive_win_rates(5)], use_inf_alpha=True, inf_alpha_eps=0.0),
                               [0, 0, 0, 0, 1])


def test_two_strategies_by_hand():
    # one population, two strategies: pi_1 / pi_0 = rho(0 -> 1) / rho(1 -> 0) = e^{(m-1) u}
    M = np.array([[0.5, 0.4], [0.6, 0.5]])
    alpha, m = 2.0, 10
    u = alpha * (M[1, 0] - M[0, 1])
    ratio = fixation_probability(u, m) / fixation_probability(-u, m)
    assert ratio == pytest.approx(np.exp((m - 1) * u))
    pi = alpha_rank([M], alpha=alpha, m=m)
    assert pi[1] / pi[0] == pytest.approx(ratio)


def test_fixation_probability_is_stable():
    assert fixation_probability(0.0, 50) == pytest.approx(1 / 50)
    assert fixation_probability(1e-9, 50) == pytest.approx(1 / 50, rel=1e-6)
    assert fixation_probability(1e4, 50) == pytest.approx(1.0)
    assert fixation_probability(-1e4, 50) == 0.0
    assert np.isfinite(fixation_probability(np.array([-800.0, 800.0]), 50)).all()


def test_multi_population_profiles_in_c_order():
    # a 2-population game where population 0 wants strategy 1 and population 1 wants strategy 2
    shape = (2, 3)
    payoff_0 = np.zeros(shape)
    payoff_0[1, :] = 1.0
    payoff_1 = np.zeros(shape)
    payoff_1[:, 2] = 1.0
    pi = alpha_rank([payoff_0, payoff_1], alpha=50.0)
    assert pi.shape == (6,)
    assert np.argmax(pi) == np.ravel_multi_index((1, 2), shape) and pi.max() > 0.99


def test_reducible_chain_is_a_clean_error():
    coordination = np.array([[1.0, 0.0], [0.0, 1.0]])
    with pytest.raises(ReducibleChainError, match="closed classes"):
        alpha_rank([coordination, coordination], use_inf_alpha=True, inf_alpha_eps=0.0)
    # with noise the chain is irreducible and symmetric
    np.testing.assert_allclose(alpha_rank([coordination, coordination], use_inf_alpha=True),
                               [0.5, 0, 0, 0.5], atol=0.02)


def test_bad_tables_are_rejected():
    with pytest.raises(ValueError, match="square"):
        alpha_rank([np.zeros((2, 3))])
    with pytest.raises(ValueError, match="K tables of K dimensions"):
        alpha_rank([np.zeros((2, 3)), np.zeros((3, 2))])
    with pytest.raises(ValueError, match="NaN"):
        alpha_rank([np.array([[0.5, np.nan], [np.nan, 0.5]])])


def test_sweep_settles_on_a_large_alpha():
    sweep = alpha_rank_sweep([BIASED_RPS])
    assert sweep.alpha > 1.0 and sweep.pis.shape == (sweep.alphas.size, 3)
    np.testing.assert_allclose(sweep.pi, alpha_rank([BIASED_RPS], alpha=sweep.alpha))
    np.testing.assert_allclose(sweep.pis[-1], sweep.pis[-2], rtol=1e-5, atol=1e-8)


def test_alpha_rank_mass_intervals():
    rng = np.random.default_rng(0)
    games = 100
    wins = rng.binomial(games, transitive_win_rates(4) * 0.5 + 0.25)
    wins = np.triu(wins, 1) + np.triu(games - wins, 1).T
    result = alpha_rank_intervals(PairCounts.from_matrices(wins), alpha=10.0, rounds=30)
    assert result.samples.shape == (30, 4)
    np.testing.assert_allclose(result.samples.sum(1), 1.0)
    assert np.argmax(result.point) == 3 and result.lower[3] > result.upper[0]


# --- agreement with OpenSpiel (dev dependency open-spiel) -------------------------------------

def openspiel_pi(tables, **kwargs):
    alpharank = pytest.importorskip(
        "open_spiel.python.egt.alpharank",
        reason="open-spiel is not installed (pip install open-spiel); OpenSpiel comparison skipped")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # OpenSpiel overflows in exp for strong selection
        return alpharank.compute([np.asarray(t, dtype=float) for t in tables], **kwargs)[2]


def agree(tables, **kwargs):
    ours = alpha_rank(tables, **kwargs)
    theirs = openspiel_pi(tables, **kwargs)
    np.testing.assert_allclose(ours, theirs, atol=1e-6, rtol=0)


@pytest.mark.parametrize("alpha", [0.1, 1.0, 10.0, 100.0])
@pytest.mark.parametrize("game", ["rps", "biased_rps", "transitive"])
def test_agrees_with_openspiel_on_classic_games(game, alpha):
    table = {"rps": RPS, "biased_rps": BIASED_RPS, "transitive": transitive_win_rates(6)}[game]
    agree([table], alpha=alpha, m=50)


@pytest.mark.parametrize("seed", range(5))
def test_agrees_with_openspiel_on_random_symmetric_games(seed):
    rng = np.random.default_rng(seed)
    n = int(rng.integers(3, 12))
    win_rates = random_symmetric_win_rates(rng, n)
    general = rng.random((n, n))
    for alpha in (0.5, 5.0, 50.0):
        agree([win_rates], alpha=alpha, m=int(rng.integers(5, 60)))
        agree([general], alpha=alpha)
    agree([general], use_inf_alpha=True, inf_alpha_eps=0.05)
    # the Moran process over population states (OpenSpiel's use_local_selection_model=False)
    agree([win_rates], alpha=2.0, use_local_selection_model=False)
    agree([general], alpha=0.5, use_local_selection_model=False)


@pytest.mark.parametrize("seed", range(3))
def test_agrees_with_openspiel_on_random_multi_population_games(seed):
    rng = np.random.default_rng(100 + seed)
    n0, n1 = rng.integers(2, 7, size=2)
    tables = [rng.random((n0, n1)), rng.random((n0, n1))]
    # (OpenSpiel's eigen-solver finds spurious second unit eigenvalues under strong selection here)
    for alpha in (0.1, 0.5, 1.0):
        agree(tables, alpha=alpha)
    agree(tables, use_inf_alpha=True, inf_alpha_eps=0.1)
    three = [rng.random((2, 3, 2)) for _ in range(3)]
    agree(three, alpha=0.5)
