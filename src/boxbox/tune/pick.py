"""Which trial a study hands out as its best (the setup file, the comparison, the report).

`fastest`: the smallest total time, what Optuna calls the best trial.

`robust` (the default): the trial that is at least as fast as the robot's own values (the study's
first trial) on every track and takes no more damage than they do on any, choosing among those
the one whose worst track gains most (relative to the robot's own time there); the robot's own
values when no trial qualifies.  Why (docs/tuning.md, "Generalisation"): a total hides a loss on
one track behind a gain on another, and the tracks a study never saw differ from its own as much
as these differ from each other, so the worst of its tracks is the fair forecast for an unseen
one; and damage above the robot's own is contact with a wall, the sign of more grip asked for
than the track gives, which on another track is a crash (mu_scale 1.158 chosen on three tracks
took 12 damage on g-track-1 where 1.05 took none, and crashed on e-track-4).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from boxbox.tune.objective import RESULT_ATTR, TuneConfig

PICKS = ("robust", "fastest")


@dataclass
class Pick:
    trial: Any  # a complete FrozenTrial, or None (the study has none)
    is_defaults: bool  # the trial of the robot's own values
    why: str  # one line for the summary


def _races(trial: Any) -> dict[str, dict]:
    return {r["track"]: r for r in trial.user_attrs.get(RESULT_ATTR, {}).get("races", [])}


def _same(a: dict, b: dict) -> bool:
    return a.keys() == b.keys() and all(
        math.isclose(a[k], b[k], rel_tol=1e-9) if isinstance(a[k], float) else a[k] == b[k] for k in a)


def defaults_trial(study: Any, cfg: TuneConfig, complete: list) -> Any:
    """The first complete trial of the robot's declared defaults (the study's first trial, or its retry)."""
    from boxbox.robot.loader import load_robot_class
    from boxbox.robot.tunable import param_space
    from boxbox.tune.space import defaults_in_space, distributions

    space = param_space(load_robot_class(cfg.robot))
    want = defaults_in_space(space, distributions(space, cfg.params))
    return next((t for t in complete if _same(t.params, want)), None)


def worst_gain(trial: Any, ref: dict[str, dict], tracks: list[str]) -> float | None:
    """The smallest relative gain over the tracks (time saved / the robot's own time), or None when
    the trial is slower or takes more damage than the robot's own values on some track."""
    races = _races(trial)
    gains = []
    for track in tracks:
        mine, theirs = races.get(track), ref.get(track)
        if mine is None or theirs is None:
            return None
        if mine["score_s"] > theirs["score_s"] or mine["damage"] > theirs["damage"]:
            return None
        gains.append(1.0 - mine["score_s"] / theirs["score_s"])
    return min(gains)


def pick_best(study: Any, cfg: TuneConfig, how: str = "robust") -> Pick:
    import optuna

    complete = sorted(study.get_trials(deepcopy=False, states=(optuna.trial.TrialState.COMPLETE,)),
                      key=lambda t: t.number)
    if not complete:
        return Pick(None, False, "no complete trial yet")
    fastest = min(complete, key=lambda t: (t.value, t.number))
    ref = defaults_trial(study, cfg, complete)
    if how == "fastest" or ref is None:
        note = "" if how == "fastest" else " (the robot's own values have no complete trial to compare with)"
        return Pick(fastest, fastest is ref, f"the smallest total time{note}")
    ref_races = _races(ref)
    scored = [(g, -t.value, -t.number, t) for t in complete
              if (g := worst_gain(t, ref_races, cfg.tracks)) is not None]
    gain, _, _, best = max(scored, key=lambda s: s[:3])  # ref itself scores 0: never empty
    if best is ref:
        return Pick(ref, True, "no trial was at least as fast as the robot's own values on every track "
                               "without more damage: they stay the best")
    return Pick(best, False, f"at least as fast as the robot's own values on every track without more damage, "
                             f"and the most gained on its worst track ({100 * gain:.2f} %)")
