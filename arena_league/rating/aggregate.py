"""Aggregate statistics over training runs: IQM, optimality gap, probability of improvement,
performance profiles, and stratified bootstrap intervals for any of them.

After Agarwal, Schwarzer, Castro, Courville & Bellemare, "Deep Reinforcement Learning at the Edge
of the Statistical Precipice" (NeurIPS 2021; the ``rliable`` package) and the MARL protocol of
Gorsane, Mahjoub, de Kock, Dubb, Singh & Pretorius, "Towards a Standardised Performance Evaluation
Protocol for Cooperative MARL" (NeurIPS 2022).

Conventions
    ``scores`` is an array ``[runs, tasks]`` (one row per independent run, e.g. a seed; one column
    per task, e.g. a game or an evaluation setting), normalised so that larger is better. A
    one-dimensional array is one task. Every statistic also accepts leading batch axes
    (``[..., runs, tasks]``) and reduces only the last two, which is how the bootstrap evaluates
    all its resamples in one call.

Statistics
    :func:`iqm` the interquartile mean: the mean of the middle half of all ``runs * tasks``
    scores (``floor(n / 4)`` cut from each end, as ``scipy.stats.trim_mean(..., 0.25)``);
    :func:`optimality_gap` the mean shortfall below ``threshold``;
    :func:`probability_of_improvement` ``P(X > Y) + P(X = Y) / 2`` per task, the Mann-Whitney U
    statistic over ``n * m``, averaged over tasks;
    :func:`performance_profile` per threshold tau, the share of runs scoring above tau, averaged
    over tasks (``rliable``'s run-score distribution).

Intervals
    :func:`stratified_bootstrap_ci` resamples runs with replacement *within each task* (the tasks
    are the strata, kept whole), evaluates the statistic on every resample at once (vectorised
    over a leading axis, in chunks that bound memory), and returns the percentile interval or the
    BCa interval (Efron 1987: bias correction from the share of resamples below the point
    estimate, acceleration from a jackknife that leaves out one run at a time). Several score
    arrays (e.g. ``(x, y)`` for the probability of improvement) are resampled independently.
    Every draw comes from the one :class:`numpy.random.Generator` passed in (or made from an
    integer seed), so the same seed gives the same interval, bit for bit.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike
from scipy.special import ndtr, ndtri

__all__ = [
    "AggregateInterval",
    "iqm",
    "optimality_gap",
    "performance_profile",
    "probability_of_improvement",
    "probability_of_improvement_matrix",
    "stratified_bootstrap_ci",
]

#: Resampled score cells evaluated per chunk of the bootstrap (bounds its memory, ~64 MB of float64).
_CHUNK_CELLS = 8_000_000


@dataclass(frozen=True)
class AggregateInterval:
    """A statistic's point estimate and its bootstrap interval (arrays for vector statistics)."""

    point: np.ndarray | float
    lower: np.ndarray | float
    upper: np.ndarray | float
    level: float
    method: str
    reps: int

    def as_dict(self) -> dict[str, Any]:
        def plain(value: Any) -> Any:
            return np.asarray(value, dtype=float).tolist()

        return {"point": plain(self.point), "lower": plain(self.lower), "upper": plain(self.upper),
                "level": self.level, "method": self.method, "reps": self.reps}


def _scores(scores: ArrayLike, name: str = "scores") -> np.ndarray:
    """``scores`` as float64 ``[..., runs, tasks]`` (a 1-D array is one task), checked."""
    a = np.asarray(scores, dtype=np.float64)
    if a.ndim == 0:
        raise ValueError(f"{name} must be an array [runs, tasks] (or [runs] for one task), got a scalar")
    if a.ndim == 1:
        a = a[:, None]
    if a.shape[-2] < 1 or a.shape[-1] < 1:
        raise ValueError(f"{name} needs at least one run and one task, got shape {a.shape}")
    if not np.isfinite(a).all():
        raise ValueError(f"{name} holds NaN or infinite values; drop or fill those runs first")
    return a


def iqm(scores: ArrayLike) -> np.ndarray | float:
    """Interquartile mean of all ``runs * tasks`` scores (leading axes kept)."""
    a = _scores(scores)
    flat = np.sort(a.reshape(*a.shape[:-2], -1), axis=-1)
    n = flat.shape[-1]
    cut = n // 4
    out = flat[..., cut:n - cut].mean(axis=-1)
    return float(out) if out.ndim == 0 else out


def optimality_gap(scores: ArrayLike, threshold: float = 1.0) -> np.ndarray | float:
    """Mean of ``max(threshold - score, 0)`` over all runs and tasks (lower is better)."""
    a = _scores(scores)
    out = np.maximum(threshold - a, 0.0).mean(axis=(-2, -1))
    return float(out) if out.ndim == 0 else out


def probability_of_improvement(x: ArrayLike, y: ArrayLike) -> np.ndarray | float:
    """``P(X > Y)`` (ties counted half) per task between the runs of ``x`` ``[n, tasks]`` and of
    ``y`` ``[m, tasks]``, averaged over tasks: each task's Mann-Whitney U over ``n * m``."""
    a, b = _scores(x, "x"), _scores(y, "y")
    if a.shape[-1] != b.shape[-1]:
        raise ValueError(f"x and y must have the same tasks, got {a.shape[-1]} and {b.shape[-1]} columns")
    greater = (a[..., :, None, :] > b[..., None, :, :]).mean(axis=(-3, -2))
    equal = (a[..., :, None, :] == b[..., None, :, :]).mean(axis=(-3, -2))
    out = (greater + 0.5 * equal).mean(axis=-1)
    return float(out) if out.ndim == 0 else out


def probability_of_improvement_matrix(scores: Mapping[str, ArrayLike]) -> dict[str, dict[str, float]]:
    """``{a: {b: P(a > b)}}`` for every ordered pair of methods in ``scores`` (``P(a > a) = 0.5``)."""
    return {a: {b: float(probability_of_improvement(scores[a], scores[b])) for b in scores} for a in scores}


def performance_profile(scores: ArrayLike, taus: ArrayLike) -> np.ndarray:
    """For each threshold in ``taus``, the share of runs scoring above it, averaged over tasks:
    ``float[..., len(taus)]``."""
    a = _scores(scores)
    t = np.asarray(taus, dtype=np.float64).reshape(-1)
    return (a[..., None] > t).mean(axis=-3).mean(axis=-2)


def stratified_bootstrap_ci(
    scores: ArrayLike | Sequence[ArrayLike],
    statistic: Callable[..., Any],
    *,
    reps: int = 2000,
    level: float = 0.95,
    rng: np.random.Generator | int | None = 0,
    method: Literal["percentile", "bca"] = "percentile",
) -> AggregateInterval:
    """The bootstrap interval of ``statistic(scores)`` (or ``statistic(*scores)`` for a tuple or
    list of score arrays, each resampled on its own), resampling runs within each task.

    Args:
        scores: ``[runs, tasks]``, or a tuple/list of such arrays (their tasks may differ).
        statistic: a function of the score array(s) that reduces their last two axes and keeps any
            leading ones (every function of this module does), returning a scalar or a vector.
        reps: bootstrap resamples.
        level: the interval's coverage, in (0, 1).
        rng: the generator every resample draws from, or an integer seed for a new one.
        method: ``"percentile"`` or ``"bca"`` (bias-corrected and accelerated).
    """
    if not 0.0 < level < 1.0:
        raise ValueError(f"level must lie in (0, 1), got {level}")
    if isinstance(reps, bool) or not isinstance(reps, (int, np.integer)) or reps < 2:
        raise ValueError(f"reps must be a whole number of resamples, at least 2 (2000 is usual), got {reps!r}")
    if method not in ("percentile", "bca"):
        raise ValueError(f"method must be 'percentile' or 'bca', got {method!r}")
    several = isinstance(scores, (tuple, list))
    arrays = [_scores(s, f"scores[{i}]") for i, s in enumerate(scores)] if several else [_scores(scores)]
    for i, a in enumerate(arrays):
        if a.ndim != 2:
            raise ValueError(f"scores[{i}] must be [runs, tasks] without batch axes, got shape {a.shape}")
    generator = rng if isinstance(rng, np.random.Generator) else np.random.default_rng(rng)
    point = np.asarray(statistic(*arrays), dtype=np.float64)
    cells = max(sum(a.size for a in arrays), 1)
    chunk = max(1, min(int(reps), _CHUNK_CELLS // cells))
    samples = []
    for start in range(0, int(reps), chunk):
        n = min(chunk, int(reps) - start)
        resampled = [np.take_along_axis(a[None], generator.integers(0, a.shape[0], size=(n, *a.shape)), axis=1)
                     for a in arrays]
        samples.append(np.asarray(statistic(*resampled), dtype=np.float64).reshape(n, *point.shape))
    boot = np.concatenate(samples, axis=0)
    alpha = (1.0 - level) / 2.0
    if method == "percentile":
        lower, upper = np.quantile(boot, [alpha, 1.0 - alpha], axis=0)
    else:
        lower, upper = _bca(boot, point, arrays, statistic, alpha)
    return AggregateInterval(_plain(point), _plain(lower), _plain(upper), float(level), method, int(reps))


def _bca(boot: np.ndarray, point: np.ndarray, arrays: list[np.ndarray], statistic: Callable[..., Any],
         alpha: float) -> tuple[np.ndarray, np.ndarray]:
    """BCa limits (Efron 1987) of ``boot`` ``[reps, ...]``; the acceleration's jackknife leaves out
    one run of one array at a time (every task of that run)."""
    share = (boot < point).mean(axis=0) + 0.5 * (boot == point).mean(axis=0)
    z0 = ndtri(np.clip(share, 1.0 / (len(boot) + 1), 1.0 - 1.0 / (len(boot) + 1)))
    influence = []
    for i, a in enumerate(arrays):
        if a.shape[0] < 2:
            continue
        keep = ~np.eye(a.shape[0], dtype=bool)
        left_out = np.stack([a[k] for k in keep])  # [runs, runs - 1, tasks]
        args = [left_out if j == i else np.broadcast_to(b, (a.shape[0], *b.shape)) for j, b in enumerate(arrays)]
        influence.append(np.asarray(statistic(*args), dtype=np.float64).reshape(a.shape[0], *point.shape))
    if influence:
        jack = np.concatenate(influence, axis=0)
        d = jack.mean(axis=0) - jack
        denominator = 6.0 * (d ** 2).sum(axis=0) ** 1.5
        accel = np.divide((d ** 3).sum(axis=0), denominator, out=np.zeros_like(denominator),
                          where=denominator > 0)
    else:
        accel = np.zeros_like(point)
    limits = []
    for q in (alpha, 1.0 - alpha):
        zq = ndtri(q)
        adjusted = ndtr(z0 + (z0 + zq) / (1.0 - accel * (z0 + zq)))
        limits.append(_quantile_per_cell(boot, adjusted))
    return limits[0], limits[1]


def _quantile_per_cell(boot: np.ndarray, q: np.ndarray) -> np.ndarray:
    """The ``q``-quantile of ``boot`` along axis 0, with its own ``q`` for every other cell."""
    flat_boot = boot.reshape(len(boot), -1)
    flat_q = np.broadcast_to(q, boot.shape[1:]).reshape(-1)
    out = np.array([np.quantile(flat_boot[:, k], flat_q[k]) for k in range(flat_boot.shape[1])])
    return out.reshape(boot.shape[1:])


def _plain(value: np.ndarray) -> np.ndarray | float:
    value = np.asarray(value, dtype=np.float64)
    return float(value) if value.ndim == 0 else value
