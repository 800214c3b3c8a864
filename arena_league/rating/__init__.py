"""Rating engine of arena-league: pure numpy/scipy functions over outcome tables and payoff
matrices; ratings know nothing of games or SQL.

- :mod:`.outcomes`: per-seat match records, pairwise results, deduplicated win/draw counts (seat-blind,
  or keeping the side each agent held).
- :mod:`.elo`: classic online Elo.
- :mod:`.bradley_terry`: Bradley-Terry on the Elo scale (draws as halves, or Davidson), with an
  optional seat term.
- :mod:`.bootstrap`: bootstrap intervals for ratings, ranks, percentiles, Nash scores, alpha-Rank.
- :mod:`.teams`: OpenSkill (Plackett-Luce) for team games and free-for-all.
- :mod:`.nash`: Nash averaging (Balduzzi et al. 2018).
- :mod:`.alpharank`: alpha-Rank (Omidshafiei et al. 2019), OpenSpiel's payoff-table convention.
- :mod:`.population`: Arena's population performance, population vs population, effective
  diversity, intransitivity.
- :mod:`.ranks`: the one definition of a rank and its interval (competition ranking).
- :mod:`.placement`: placing an entrant against a frozen base population, adaptively.
- :mod:`.aggregate`: statistics over training runs (IQM, optimality gap, probability of
  improvement, performance profiles) with seeded stratified bootstrap intervals.
"""

from arena_league.rating.aggregate import (
    AggregateInterval,
    iqm,
    optimality_gap,
    performance_profile,
    probability_of_improvement,
    probability_of_improvement_matrix,
    stratified_bootstrap_ci,
)
from arena_league.rating.alpharank import (
    AlphaRankSweep,
    ReducibleChainError,
    alpha_rank,
    alpha_rank_sweep,
    fixation_probability,
)
from arena_league.rating.bootstrap import (
    BootstrapInterval,
    RatingIntervals,
    SeatTerm,
    alpha_rank_intervals,
    bootstrap_ratings,
    bootstrap_statistic,
    nash_intervals,
)
from arena_league.rating.bradley_terry import (
    DEFAULT_PRIOR_SD,
    ELO_BASE,
    ELO_SCALE,
    BradleyTerryFit,
    bradley_terry,
    fit_bradley_terry,
)
from arena_league.rating.elo import elo_expected_score, elo_online
from arena_league.rating.nash import check_antisymmetric, nash_averaging, zero_sum_value
from arena_league.rating.outcomes import (
    OUTCOME_PLACE,
    PSEUDO_COUNT,
    OutcomeTable,
    PairCounts,
    PairwiseResults,
    SeatCounts,
    SeatResult,
)
from arena_league.rating.placement import (
    MIN_PLACEMENT_MATCHES,
    PLACEMENT_PRIOR_SD,
    AdaptivePlacement,
    Placement,
    PlacementSimulation,
    place_entrant,
    simulate_placement,
)
from arena_league.rating.population import (
    Intransitivity,
    effective_diversity,
    intransitivity,
    population_performance,
    population_vs_population,
)
from arena_league.rating.ranks import Ranks, competition_ranks
from arena_league.rating.teams import SkillRatings, openskill_ratings

__all__ = [
    "DEFAULT_PRIOR_SD",
    "ELO_BASE",
    "ELO_SCALE",
    "MIN_PLACEMENT_MATCHES",
    "OUTCOME_PLACE",
    "PLACEMENT_PRIOR_SD",
    "PSEUDO_COUNT",
    "AdaptivePlacement",
    "AggregateInterval",
    "AlphaRankSweep",
    "BootstrapInterval",
    "BradleyTerryFit",
    "Intransitivity",
    "OutcomeTable",
    "PairCounts",
    "PairwiseResults",
    "Placement",
    "PlacementSimulation",
    "Ranks",
    "RatingIntervals",
    "ReducibleChainError",
    "SeatCounts",
    "SeatResult",
    "SeatTerm",
    "SkillRatings",
    "alpha_rank",
    "alpha_rank_intervals",
    "alpha_rank_sweep",
    "bootstrap_ratings",
    "bootstrap_statistic",
    "bradley_terry",
    "check_antisymmetric",
    "competition_ranks",
    "effective_diversity",
    "elo_expected_score",
    "elo_online",
    "fit_bradley_terry",
    "fixation_probability",
    "intransitivity",
    "iqm",
    "nash_averaging",
    "nash_intervals",
    "openskill_ratings",
    "optimality_gap",
    "performance_profile",
    "place_entrant",
    "population_performance",
    "population_vs_population",
    "probability_of_improvement",
    "probability_of_improvement_matrix",
    "simulate_placement",
    "stratified_bootstrap_ci",
    "zero_sum_value",
]
