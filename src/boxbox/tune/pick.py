"""Which trial a study hands out as its best (the setup file, the comparison, the report).

`fastest`: the smallest total time, what Optuna calls the best trial.

`robust` (the default): a complete trial is a candidate when it has at least `min_neighbours`
trials around it (each searched number within `radius` of its range, the same choices; pruned
trials count with the tracks they raced) and it and all of them are at least as fast as the
robot's own values (the study's first trial) on every track they raced, with no more damage (a
lone trial is a single sample).  The candidate whose neighbourhood's worst track gains
most (relative to the robot's own time there) is handed out if that gain is above the study's noise
floor (noise_floor: how much the time of a track moves between trials within `radius` of each
other); else the robot's own values.  Why (docs/tuning.md, "The best trial" and
"Generalisation"): a total hides a loss on one track behind a gain on another, and an unseen track
is like one of the study's own with a slightly different grip, so the values must win on every
track, by more than a small change of the values moves the time, and their neighbours must not
lose or touch a wall (a threshold close by: mu_scale 1.055 chosen on three tracks gained 0.15 % or
more on each of them, under that study's floor of 0.18 %, and lost 8.9 s on g-track-1).  The robot's
own values are a neighbour like any other, with a gain of 0: values within `radius` of them are
never handed out (as far as the study can tell they are the same values).
"""

from __future__ import annotations

import math
import statistics
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:  # objective.py loads the racing side: the command line reads RADIUS without it
    from boxbox.tune.objective import TuneConfig

PICKS = ("robust", "fastest")
# the neighbourhood of a trial: each searched number within this share of its declared range (an
# unseen track's grip differs from the model's by a few percent: mu_scale 1.0 +- 0.036)
RADIUS = 0.03
MIN_PAIRS = 3  # the noise floor takes at least the 3 closest pairs of trials, near or not
# a trial with no other trial around it is a single sample: its gain may be the noise the floor,
# measured from a few pairs, understates (run 4: a lone 1.052 gained 0.14 % over a floor of 0.07 %
# made of two pairs, and lost 7.4 s on g-track-1)
MIN_NEIGHBOURS = 1


@dataclass
class Pick:
    trial: Any  # a complete FrozenTrial, or None (the study has none)
    is_defaults: bool  # the trial of the robot's own values
    why: str  # one line for the summary


@dataclass(frozen=True)
class PickRule:
    how: str = "robust"
    radius: float = RADIUS
    noise: bool = True  # ask for a gain above the study's noise floor
    min_neighbours: int = MIN_NEIGHBOURS

    def choose(self, study: Any, cfg: TuneConfig) -> Pick:
        return pick_best(study, cfg, self.how, self.radius, self.noise, self.min_neighbours)

    @property
    def label(self) -> str:
        return self.how if self.how == "fastest" else f"{self.how}, {100 * self.radius:g} % around"


# what bench-tune's generalisation compares: the default pick, the same without the trials around
# it (docs/tuning.md, runs 3 to 6: what the trials around a pick change), and the smallest total
GENERAL_PICKS = {"robust": PickRule(), "every track": PickRule("robust", 0.0, False, 0), "fastest": PickRule("fastest")}


@dataclass(frozen=True)
class Sample:
    """A finished trial as plain numbers: where it is (each searched number as a share of its range,
    choices as they are) and its races (track -> score_s, damage)."""

    number: int
    point: dict[str, Any]
    races: dict[str, dict]
    complete: bool


def unit_point(params: dict[str, Any], dists: dict[str, Any]) -> dict[str, Any]:
    """Each number as a share of its range (of its logarithm on a log scale); choices unchanged."""
    out: dict[str, Any] = {}
    for name, value in params.items():
        d = dists.get(name)
        if d is None or not hasattr(d, "low") or d.high <= d.low:
            out[name] = value
        elif d.log:
            out[name] = math.log(value / d.low) / math.log(d.high / d.low)
        else:
            out[name] = (value - d.low) / (d.high - d.low)
    return out


def near(a: dict[str, Any], b: dict[str, Any], radius: float) -> bool:
    """The same choices, and every number within `radius` (a share of its range)."""
    if a.keys() != b.keys():
        return False
    return all(abs(a[k] - b[k]) <= radius + 1e-12 if isinstance(a[k], float) and isinstance(b[k], float)
               else a[k] == b[k] for k in a)


def track_gains(races: dict[str, dict], ref: dict[str, dict], tracks: list[str]) -> dict[str, float] | None:
    """Time saved on each track raced, as a share of the robot's own time there; None when slower or
    with more damage than the robot's own values on one of them."""
    gains = {}
    for track in tracks:
        mine, theirs = races.get(track), ref.get(track)
        if mine is None or theirs is None:
            continue
        if mine["score_s"] > theirs["score_s"] or mine["damage"] > theirs["damage"]:
            return None
        gains[track] = 1.0 - mine["score_s"] / theirs["score_s"]
    return gains


def region_gain(center: Sample, samples: list[Sample], ref: dict[str, dict], tracks: list[str],
                radius: float) -> tuple[float, int] | None:
    """The worst gain over the tracks and the trials around `center` (itself included) and how many
    are around it; None when one of them lost to the robot's own values or took more damage."""
    members = [s for s in samples if s.number != center.number and near(center.point, s.point, radius)]
    worst = math.inf
    for s in [center, *members]:
        gains = track_gains(s.races, ref, tracks)
        if gains is None:
            return None
        worst = min(worst, *gains.values())
    return worst, len(members)


def distance(a: dict[str, Any], b: dict[str, Any]) -> float:
    """The largest difference of a number (a share of its range); infinite when a choice differs."""
    if any(a[k] != b[k] for k in a if not isinstance(a[k], float)):
        return math.inf
    return max((abs(a[k] - b[k]) for k in a if isinstance(a[k], float)), default=0.0)


def noise_floor(samples: list[Sample], tracks: list[str], radius: float) -> float | None:
    """The median relative difference of a track's time between two trials within `radius` of each
    other (at least the MIN_PAIRS closest pairs: farther pairs add the slope, a higher floor);
    races with a problem left out; None without a pair."""
    pairs = sorted(((distance(a.point, b.point), a, b) for i, a in enumerate(samples) for b in samples[i + 1:]),
                   key=lambda p: p[0])
    close = [p for k, p in enumerate(pairs) if p[0] <= radius or (k < MIN_PAIRS and p[0] < math.inf)]
    diffs = [abs(a.races[t]["score_s"] - b.races[t]["score_s"]) / min(a.races[t]["score_s"], b.races[t]["score_s"])
             for _, a, b in close for t in tracks
             if t in a.races and t in b.races and not a.races[t].get("problem") and not b.races[t].get("problem")]
    return statistics.median(diffs) if diffs else None


def robust_choice(samples: list[Sample], ref: Sample, tracks: list[str], radius: float = RADIUS,
                  floor: float = 0.0, min_neighbours: int = MIN_NEIGHBOURS) -> tuple[Sample, float, int]:
    """The complete sample with `min_neighbours` or more around it whose region gains most on its
    worst track, more than `floor` (ties: the lower number), with that gain and its neighbours; the
    robot's own values (gain 0) when none."""
    best: tuple[Sample, float, int] = (ref, 0.0, 0)
    for s in samples:
        if not s.complete or s.number == ref.number or not set(tracks) <= set(s.races):
            continue
        scored = region_gain(s, samples, ref.races, tracks, radius)
        if scored is not None and scored[1] >= min_neighbours and scored[0] > max(floor, best[1]):
            best = (s, *scored)
    return best


def _races(trial: Any) -> dict[str, dict]:
    from boxbox.tune.objective import RESULT_ATTR

    return {r["track"]: r for r in trial.user_attrs.get(RESULT_ATTR, {}).get("races", [])}


def _same(a: dict, b: dict) -> bool:
    return a.keys() == b.keys() and all(
        math.isclose(a[k], b[k], rel_tol=1e-9) if isinstance(a[k], float) else a[k] == b[k] for k in a)


def _dists(cfg: TuneConfig) -> tuple[dict[str, Any], dict[str, Any]]:
    """The study's distributions and the robot's declared defaults in them."""
    from boxbox.robot.loader import load_robot_class
    from boxbox.tune.space import defaults_in_space, distributions, tune_space

    space = tune_space(load_robot_class(cfg.robot), cfg.car)
    dists = distributions(space, cfg.params)
    return dists, defaults_in_space(space, dists)


def samples(study: Any, dists: dict[str, Any]) -> list[Sample]:
    """The study's complete and pruned trials with their races, in order."""
    import optuna

    states = (optuna.trial.TrialState.COMPLETE, optuna.trial.TrialState.PRUNED)
    return [Sample(t.number, unit_point(t.params, dists), _races(t), t.state == optuna.trial.TrialState.COMPLETE)
            for t in sorted(study.get_trials(deepcopy=False, states=states), key=lambda t: t.number)]


def _rule_text(radius: float, floor: float | None, min_neighbours: int) -> str:
    text = "at least as fast as the robot's own values on every track without more damage"
    if radius > 0:
        text += f", as were the trials within {100 * radius:g} % of each range around it"
    if min_neighbours:
        text += f" ({min_neighbours} or more)"
    if floor is not None:
        text += f", by more than the study's noise floor ({100 * floor:.2f} %)"
    return text


def pick_best(study: Any, cfg: TuneConfig, how: str = "robust", radius: float = RADIUS, noise: bool = True,
              min_neighbours: int = MIN_NEIGHBOURS) -> Pick:
    import optuna

    complete = sorted(study.get_trials(deepcopy=False, states=(optuna.trial.TrialState.COMPLETE,)),
                      key=lambda t: t.number)
    if not complete:
        return Pick(None, False, "no complete trial yet")
    fastest = min(complete, key=lambda t: (t.value, t.number))
    dists, want = _dists(cfg)
    ref = next((t for t in complete if _same(t.params, want)), None)
    if how == "fastest" or ref is None:
        note = "" if how == "fastest" else " (the robot's own values have no complete trial to compare with)"
        return Pick(fastest, fastest is ref, f"the smallest total time{note}")
    found = samples(study, dists)
    floor = (noise_floor(found, cfg.tracks, radius) or 0.0) if noise else 0.0
    chosen, gain, around = robust_choice(found, next(s for s in found if s.number == ref.number), cfg.tracks,
                                         radius, floor, min_neighbours)
    rule = _rule_text(radius, floor if noise else None, min_neighbours)
    if chosen.number == ref.number:
        return Pick(ref, True, f"no trial was {rule}: they stay the best")
    best = next(t for t in complete if t.number == chosen.number)
    return Pick(best, False, f"{rule}; the worst track of it and its {around} neighbour(s) gained {100 * gain:.2f} %")
