"""Seat-keeping outcome counts, Bradley-Terry with a seat term, and placement that holds it fixed."""

import json
import math

import numpy as np
import pytest
from scipy.optimize import minimize

from arena_league.rating import (
    AdaptivePlacement,
    OutcomeTable,
    PairCounts,
    SeatCounts,
    SeatTerm,
    bootstrap_ratings,
    fit_bradley_terry,
    place_entrant,
)

POINTS = 400.0 / math.log(10.0)  # rating points per unit of log-strength


def simulate_seated_league(rng, ratings, seat_edge, matches_per_ordered_pair, n_sides=2, draw_rate=0.0):
    """Every ordered pair (i, j) plays ``matches_per_ordered_pair`` matches at random distinct
    sides; side s carries ``seat_edge[s]`` rating points; a share of matches is drawn."""
    n = len(ratings)
    i, j = np.nonzero(~np.eye(n, dtype=bool))
    first = np.repeat(i, matches_per_ordered_pair)
    second = np.repeat(j, matches_per_ordered_pair)
    first_side = rng.integers(n_sides, size=first.size)
    second_side = (first_side + rng.integers(1, n_sides, size=first.size)) % n_sides
    gap = ratings[first] + seat_edge[first_side] - ratings[second] - seat_edge[second_side]
    p_first = 1.0 / (1.0 + 10.0 ** (-gap / 400.0))
    decided = rng.random(first.size) >= draw_rate
    score = np.where(decided, (rng.random(first.size) < p_first).astype(float), 0.5)
    return SeatCounts.from_results(first, second, first_side, second_side, score, n, n_sides)


def reference_fit(counts, draw_model, prior_sd):
    """Maximum a posteriori by BFGS on the negative log-likelihood written cell by cell, with the
    Gaussian prior (sd ``prior_sd`` rating points) on each rating and each side's advantage (h_0 =
    0), and Davidson's log nu under N(0, 10^2)."""
    n, n_sides = counts.n_agents, counts.n_sides
    a, b = np.triu_indices(n_sides, 1)
    davidson = draw_model == "davidson"
    precision = (POINTS / prior_sd) ** 2

    def nll(params):
        theta = params[:n]
        h = np.r_[0.0, params[n:n + n_sides - 1]]
        total = 0.5 * precision * (params[:n + n_sides - 1] ** 2).sum()
        for k in range(a.size):
            d = theta[:, None] - theta[None, :] + h[a[k]] - h[b[k]]
            won, lost, drawn = counts.won[k], counts.lost[k], counts.drawn[k]
            if davidson:
                nu = np.exp(params[-1])
                log_norm = np.log(np.exp(d / 2) + np.exp(-d / 2) + nu)
                total -= (won * (d / 2 - log_norm) + lost * (-d / 2 - log_norm)
                          + drawn * (np.log(nu) - log_norm)).sum()
            else:
                total += ((won + drawn / 2) * np.logaddexp(0.0, -d) + (lost + drawn / 2) * np.logaddexp(0.0, d)).sum()
        if davidson:
            total += 0.5 * 1e-2 * params[-1] ** 2
        return total

    start = np.zeros(n + n_sides - 1 + davidson)
    params = minimize(nll, start, method="BFGS", options={"gtol": 1e-9, "maxiter": 10000}).x
    ratings = POINTS * params[:n]
    return ratings - ratings.mean() + 1000.0, POINTS * np.r_[0.0, params[n:n + n_sides - 1]]


@pytest.mark.parametrize(("draw_model", "n_sides"), [("half", 2), ("davidson", 2), ("half", 3), ("davidson", 3)])
def test_fit_agrees_with_a_reference_maximum_likelihood(draw_model, n_sides):
    rng = np.random.default_rng(10 + n_sides)
    truth = rng.normal(0.0, 200.0, 6)
    counts = simulate_seated_league(rng, truth, np.array([60.0, -20.0, 0.0][:n_sides]), 6, n_sides, draw_rate=0.2)
    # a strong prior, so that the comparison checks it too
    fit = fit_bradley_terry(counts, draw_model=draw_model, prior_sd=150.0)
    ratings, seats = reference_fit(counts, draw_model, 150.0)
    # within 1e-3 rating points (1e-6 relative to ratings near 1000)
    np.testing.assert_allclose(fit.ratings, ratings, rtol=0, atol=1e-3)
    assert fit.seat_advantage[0] == 0.0 and fit.seat_advantage.shape == (n_sides,)
    np.testing.assert_allclose(fit.seat_advantage, seats, rtol=0, atol=1e-3)
    assert (fit.draw_nu is None) == (draw_model == "half")


def test_bootstrap_intervals_cover_the_true_seat_advantage_and_ratings():
    """200 leagues of 8 agents, each ordered pair 12 matches at random sides, side 0 worth +80
    Elo: the 95% intervals hold the true advantage and the true ratings (mean 1000) in 90-99% of
    cases. (With 4 matches per ordered pair the percentile bootstrap under-covers, seat term or
    not: about 0.92 for the ratings.)"""
    rng = np.random.default_rng(20)
    seat_hits, rating_hits = [], []
    for league in range(200):
        truth = rng.normal(0.0, 200.0, 8)
        truth = truth - truth.mean() + 1000.0
        counts = simulate_seated_league(rng, truth, np.array([80.0, 0.0]), 12)
        intervals = bootstrap_ratings(counts, rounds=200, seed=league)
        seats = intervals.seats
        edge_lower, edge_upper = -seats.upper[1], -seats.lower[1]  # side 0 over side 1
        seat_hits.append(edge_lower <= 80.0 <= edge_upper)
        rating_hits.append((intervals.lower <= truth) & (truth <= intervals.upper))
    assert 0.90 <= np.mean(seat_hits) <= 0.99, np.mean(seat_hits)
    assert 0.90 <= np.mean(rating_hits) <= 0.99, np.mean(rating_hits)


def test_seat_term_report():
    rng = np.random.default_rng(21)
    counts = simulate_seated_league(rng, np.linspace(800, 1200, 6), np.array([100.0, 0.0]), 30, draw_rate=0.1)
    for draw_model in ("half", "davidson"):
        intervals = bootstrap_ratings(counts, rounds=50, draw_model=draw_model)
        seats = intervals.seats
        assert isinstance(seats, SeatTerm)
        assert seats.advantage[0] == seats.lower[0] == seats.upper[0] == 0.0
        assert seats.lower[1] < seats.advantage[1] < seats.upper[1] < 0.0
        assert 0.5 < seats.first_share_lower < seats.first_share < seats.first_share_upper < 1.0
        fit = fit_bradley_terry(counts, draw_model=draw_model)
        np.testing.assert_allclose(seats.advantage, fit.seat_advantage)
        np.testing.assert_allclose(intervals.rating, fit.ratings)
        edge = -seats.advantage[1]
        if draw_model == "half":
            assert seats.first_share == pytest.approx(1.0 / (1.0 + 10.0 ** (-edge / 400.0)))
        else:
            d, nu = edge / POINTS, fit.draw_nu
            expected = (np.exp(d / 2) + nu / 2) / (np.exp(d / 2) + np.exp(-d / 2) + nu)
            assert seats.first_share == pytest.approx(expected)
        assert json.loads(json.dumps(seats.to_dict()))["advantage"] == list(seats.advantage)
        text = seats.describe()
        assert text.startswith(f"the first seat wins {100 * seats.first_share:.0f}% [")
        assert f"({edge:+.0f} Elo [{-seats.upper[1]:.0f}, {-seats.lower[1]:.0f}])" in text


def test_balanced_seats_leave_ratings_close_and_one_sided_seats_stay_finite():
    rng = np.random.default_rng(22)
    truth = np.linspace(700, 1300, 6)
    counts = simulate_seated_league(rng, truth, np.array([0.0, 0.0]), 40)
    with_seats = fit_bradley_terry(counts).ratings
    without = fit_bradley_terry(counts.pair_counts()).ratings
    assert np.abs(with_seats - without).max() < 5.0
    # side 0 always wins: the advantage is large but finite under the prior, and an error without it
    n = 4
    won = np.zeros((1, n, n))
    lost = np.zeros((1, n, n))
    won[0] = 3.0 * (1 - np.eye(n))
    one_sided = SeatCounts([str(i) for i in range(n)], 2, won, lost, np.zeros((1, n, n)))
    fit = fit_bradley_terry(one_sided)
    assert np.isfinite(fit.seat_advantage).all() and fit.seat_advantage[1] < -400
    np.testing.assert_allclose(fit.ratings, 1000.0, atol=1e-9)
    with pytest.raises(ValueError, match="prior_sd"):
        fit_bradley_terry(one_sided, prior_sd=math.inf)
    # with both outcomes at both sides the plain maximum likelihood exists
    fine = simulate_seated_league(rng, truth, np.array([50.0, 0.0]), 20)
    assert np.isfinite(fit_bradley_terry(fine, prior_sd=math.inf).seat_advantage).all()


def test_pair_counts_path_is_seat_blind():
    rng = np.random.default_rng(23)
    counts = simulate_seated_league(rng, np.linspace(800, 1200, 5), np.array([80.0, 0.0]), 10).pair_counts()
    assert isinstance(counts, PairCounts)
    assert fit_bradley_terry(counts).seat_advantage is None
    assert bootstrap_ratings(counts, rounds=10).seats is None


def test_seat_counts_from_an_outcome_table():
    rows = [
        (1, 0, "a", 0, 0.0, "win"), (1, 1, "b", 1, 0.0, "loss"),     # a at side 0 beat b
        (2, 0, "b", 0, 0.0, "win"), (2, 1, "a", 1, 0.0, "loss"),     # b at side 0 beat a
        (3, 0, "c", 0, 0.0, "draw"), (3, 1, "a", 1, 0.0, "draw"),    # c at side 0 drew a
        (4, 0, "b", 0, 0.0, "loss"), (4, 1, "b", 1, 0.0, "win"),     # self-play: left out
        (5, 0, "c", 0, 0.0, "loss"), (5, 1, "c", 0, 0.0, "loss"),    # c (team 0, two seats) lost to a
        (5, 2, "a", 1, 0.0, "win"),
        (6, 0, "a", 0, 0.0, 1), (6, 1, "b", 1, 0.0, 0), (6, 2, "c", 2, 0.0, 1),  # three teams
    ]
    table = OutcomeTable.from_rows(rows)
    seats = table.seat_counts()
    assert seats.n_sides == 3 and seats.won.shape == (3, 3, 3)
    a, b, c = 0, 1, 2
    assert seats.won[0, a, b] == 1 and seats.won[0, b, a] == 1
    assert seats.drawn[0, c, a] == 1 and seats.lost[0, c, a] == 1
    assert seats.lost[0, a, b] == 1 and seats.drawn[1, a, c] == 1 and seats.won[2, b, c] == 1
    assert seats.n_matches == 7
    blind = table.pair_counts()
    np.testing.assert_array_equal(seats.pair_counts().wins, blind.wins)
    np.testing.assert_array_equal(seats.pair_counts().draws, blind.draws)
    results = table.pairwise()
    assert (results.first_team < results.second_team).all()


def test_seat_counts_from_results_orders_sides_and_resamples():
    counts = SeatCounts.from_results([0, 1, 2], [1, 0, 0], [1, 0, 1], [0, 1, 0], [1.0, 0.5, 0.0], ["x", "y", "z"])
    # x at side 1 beat y at side 0: y at side 0 lost to x
    assert counts.lost[0, 1, 0] == 1 and counts.drawn[0, 1, 0] == 1 and counts.won[0, 0, 2] == 1
    rng = np.random.default_rng(0)
    big = simulate_seated_league(rng, np.linspace(900, 1100, 4), np.array([50.0, 0.0]), 25, draw_rate=0.2)
    won, lost, drawn = big.resample(rng, 300)
    assert won.shape == (300, 1, 4, 4)
    np.testing.assert_array_equal(won.sum((1, 2, 3)) + lost.sum((1, 2, 3)) + drawn.sum((1, 2, 3)),
                                  np.full(300, big.n_matches))
    np.testing.assert_allclose(won.mean(0), big.won, rtol=0.2, atol=0.5)
    assert (drawn[:, :, big.drawn[0] == 0] == 0).all()


def test_bad_seat_counts_are_one_line_errors():
    z = np.zeros((1, 2, 2))
    with pytest.raises(ValueError, match="non-negative"):
        SeatCounts(["a", "b"], 2, -np.ones((1, 2, 2)) + np.eye(2), z, z)
    with pytest.raises(ValueError, match="zero the diagonal"):
        SeatCounts(["a", "b"], 2, np.eye(2)[None], z, z)
    with pytest.raises(ValueError, match=r"shape \(1, 2, 2\)"):
        SeatCounts(["a", "b"], 2, np.zeros((2, 2)), z, z)
    with pytest.raises(ValueError, match="at least 2"):
        SeatCounts(["a", "b"], 1, z, z, z)
    with pytest.raises(ValueError, match="same side"):
        SeatCounts.from_results([0], [1], [1], [1], [1.0], 2)
    with pytest.raises(ValueError, match=r"sides must lie in \[0, 2\)"):
        SeatCounts.from_results([0], [1], [0], [2], [1.0], 2)
    with pytest.raises(ValueError, match="scores must be"):
        SeatCounts.from_results([0], [1], [0], [1], [0.7], 2)
    with pytest.raises(ValueError, match="no matches"):
        SeatCounts(["a", "b"], 2, z, z, z).resample(np.random.default_rng(0), 5)
    with pytest.raises(ValueError) as error:
        SeatCounts(["a", "b"], 2, np.eye(2)[None], z, z)
    assert "\n" not in str(error.value)
    with pytest.raises(TypeError, match="PairCounts or SeatCounts"):
        fit_bradley_terry(np.zeros((2, 2)))


BASE = np.linspace(800.0, 1200.0, 20)
SEATS = np.array([0.0, -80.0])  # side 0 is worth 80 Elo over side 1


def entrant_results(rng, truth, matches, side_share):
    """Per-side results ``(2, n)`` of an entrant rated ``truth`` against every base agent; the
    entrant holds side 0 in a share ``side_share`` of its matches."""
    wins, losses = np.zeros((2, BASE.size)), np.zeros((2, BASE.size))
    for side in (0, 1):
        played = np.full(BASE.size, round(matches * (side_share if side == 0 else 1 - side_share)))
        edge = SEATS[side] - SEATS[1 - side]
        p = 1.0 / (1.0 + 10.0 ** ((BASE - truth - edge) / 400.0))
        wins[side] = rng.binomial(played, p)
        losses[side] = played - wins[side]
    return wins, losses


def test_placement_with_a_seat_term_recovers_the_entrant():
    rng = np.random.default_rng(30)
    truth = 1040.0
    # mostly at the favoured side: without the seat term the entrant looks stronger than it is
    wins, losses = entrant_results(rng, truth, 60, side_share=0.9)
    seated = place_entrant(BASE, wins, losses, seat_advantage=SEATS)
    blind = place_entrant(BASE, wins, losses)
    assert seated.lower <= truth <= seated.upper
    assert abs(seated.rating - truth) < 25
    assert blind.rating > seated.rating + 40
    assert seated.matches == blind.matches == wins.sum() + losses.sum()
    # results of length n carry no sides: the seat term is left out
    assert place_entrant(BASE, wins.sum(0), losses.sum(0), seat_advantage=SEATS) == blind


def test_adaptive_placement_with_a_seat_term():
    rng = np.random.default_rng(31)
    truth = 960.0
    chooser = AdaptivePlacement(BASE, target_half_width=2, budget=600, seat_advantage=SEATS)
    blind = AdaptivePlacement(BASE, target_half_width=2, budget=600)
    while not chooser.done:
        opponent = chooser.next_opponent()
        side = int(rng.random() < 0.85)  # mostly at the weaker side
        edge = SEATS[side] - SEATS[1 - side]
        score = float(rng.random() < 1.0 / (1.0 + 10.0 ** ((BASE[opponent] - truth - edge) / 400.0)))
        chooser.record(opponent, score, side=side)
        blind.record(opponent, score, side=side)
    assert chooser.placement.lower <= truth <= chooser.placement.upper
    assert blind.placement.rating < chooser.placement.rating - 30
    with pytest.raises(ValueError, match="side must be 0 or 1"):
        chooser.record(0, 1.0, side=2)


def test_zero_seat_advantage_gives_todays_placement():
    rng = np.random.default_rng(32)
    wins, losses = entrant_results(rng, 1000.0, 10, side_share=0.7)
    draws = np.ones_like(wins)
    today = place_entrant(BASE, wins.sum(0), losses.sum(0), draws.sum(0))
    for seats in (np.zeros(2), None):
        placed = place_entrant(BASE, wins, losses, draws, seat_advantage=seats)
        assert placed.rating == pytest.approx(today.rating, abs=1e-9)
        assert placed.lower == pytest.approx(today.lower, abs=1e-9)
        assert placed.upper == pytest.approx(today.upper, abs=1e-9)
        assert (placed.rank, placed.rank_lower, placed.rank_upper) == (today.rank, today.rank_lower,
                                                                       today.rank_upper)
    zero = AdaptivePlacement(BASE, budget=40, seat_advantage=np.zeros(2))
    plain = AdaptivePlacement(BASE, budget=40)
    for match in range(40):
        opponent = plain.next_opponent()
        assert zero.next_opponent() == opponent
        score = float(rng.random() < 0.5)
        plain.record(opponent, score)
        zero.record(opponent, score, side=match % 2)
    assert zero.placement.rating == pytest.approx(plain.placement.rating, abs=1e-9)
    assert zero.placement.rank == plain.placement.rank


def test_bad_placement_inputs_are_one_line_errors():
    wins = np.zeros((2, BASE.size))
    with pytest.raises(ValueError, match=r"shape \(2,\)"):
        place_entrant(BASE, wins, wins, seat_advantage=[0.0, -50.0, 10.0])
    with pytest.raises(ValueError, match="one row"):
        place_entrant(BASE, np.zeros((3, BASE.size)), np.zeros((3, BASE.size)), seat_advantage=SEATS)
    with pytest.raises(ValueError, match="finite"):
        AdaptivePlacement(BASE, seat_advantage=[0.0, math.nan])
