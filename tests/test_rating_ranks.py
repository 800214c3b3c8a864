"""The one definition of a rank: competition ranking among a reference set, with its interval."""

import numpy as np
import pytest

from arena_league.rating import competition_ranks, place_entrant


def test_equal_ratings_share_a_rank_and_the_rank_interval_counts_others_against_the_interval():
    rating = np.array([1200.0, 1100.0, 1100.0, 900.0])
    lower = np.array([1150.0, 1000.0, 1090.0, 700.0])
    upper = np.array([1250.0, 1210.0, 1110.0, 950.0])
    ranks = competition_ranks(rating, lower, upper)
    assert ranks.rank.tolist() == [1, 2, 2, 4]  # "1224": the two 1100s tie for second
    assert ranks.tied.tolist() == [False, True, True, False]
    # best place: 1 + others rated above the upper end; worst: 1 + others at or above the lower end
    assert ranks.rank_lower.tolist() == [1, 1, 2, 4]
    assert ranks.rank_upper.tolist() == [1, 3, 3, 4]
    # without an interval, a tie spans the places it shares
    plain = competition_ranks(rating)
    assert plain.rank.tolist() == [1, 2, 2, 4] and plain.rank_upper.tolist() == [1, 3, 3, 4]


def test_an_interval_that_misses_its_point_is_widened_to_hold_it():
    ranks = competition_ranks([3.0, 2.0, 1.0], lower=[3.5, 0.0, 0.0], upper=[4.0, 2.5, 1.5])
    assert ((ranks.rank_lower <= ranks.rank) & (ranks.rank <= ranks.rank_upper)).all()
    assert ranks.rank_upper[0] == 1


def test_ranks_against_a_reference_do_not_count_the_agent_itself_nor_other_entrants():
    members = np.array([1300.0, 1200.0, 1000.0])
    # two entrants and the three members, ranked among the members
    rating = np.array([1250.0, 1250.0, *members])
    ranks = competition_ranks(rating, rating - 60.0, rating + 60.0, reference=members,
                              self_index=[-1, -1, 0, 1, 2])
    assert ranks.rank.tolist() == [2, 2, 1, 2, 3]  # the entrants share the place of the member below them
    assert ranks.rank_lower.tolist() == [1, 1, 1, 2, 3]
    assert ranks.rank_upper.tolist() == [3, 3, 1, 2, 3]


def test_a_placement_reports_the_ranks_the_function_gives_against_its_base():
    base = np.linspace(600.0, 1400.0, 41)
    wins = (base < 1000.0).astype(float) * 3
    placement = place_entrant(base, wins, 3 - wins)
    ranks = competition_ranks([placement.rating], [placement.lower], [placement.upper], reference=base)
    assert (placement.rank, placement.rank_lower, placement.rank_upper) == (
        ranks.rank[0], ranks.rank_lower[0], ranks.rank_upper[0])
    assert placement.rank_lower < placement.rank < placement.rank_upper


def test_bad_input_is_refused():
    with pytest.raises(ValueError, match="NaN"):
        competition_ranks([1.0, np.nan])
    with pytest.raises(ValueError, match="one value per rating"):
        competition_ranks([1.0, 2.0], lower=[0.0])
    with pytest.raises(ValueError, match="self_index"):
        competition_ranks([1.0], reference=[2.0], self_index=[3])
