"""The figures of a tuning study (tune/study.py): its trials counted by state, the best so far,
and what pruning saved."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from boxbox.tune.objective import RESULT_ATTR


def counts(study: Any) -> dict[str, int]:
    out: dict[str, int] = {}
    for t in study.get_trials(deepcopy=False):
        out[t.state.name] = out.get(t.state.name, 0) + 1
    return out


@dataclass
class Progress:
    finished: int
    complete: int
    pruned: int
    failed: int
    running: int
    best_value: float | None
    best_params: dict


def progress(study: Any) -> Progress:
    import optuna

    c = counts(study)
    try:
        best = study.best_trial
        value, params = best.value, best.params
    except (ValueError, optuna.exceptions.OptunaError):
        value, params = None, {}
    return Progress(finished=c.get("COMPLETE", 0) + c.get("PRUNED", 0), complete=c.get("COMPLETE", 0),
                    pruned=c.get("PRUNED", 0), failed=c.get("FAIL", 0), running=c.get("RUNNING", 0),
                    best_value=value, best_params=params)


def pruning_savings(study: Any, n_tracks: int) -> tuple[int, int, float]:
    """(races skipped by pruning, races run, an estimate of the wall time saved: the skipped races
    at the mean wall time of a race)."""
    import optuna

    skipped = run = 0
    walls = []
    for t in study.get_trials(deepcopy=False, states=(optuna.trial.TrialState.COMPLETE,
                                                      optuna.trial.TrialState.PRUNED)):
        result = t.user_attrs.get(RESULT_ATTR, {})
        races = result.get("races", [])
        run += len(races)
        walls += [r.get("wall_s", 0.0) for r in races]
        skipped += int(result.get("races_skipped", 0))
    mean = sum(walls) / len(walls) if walls else 0.0
    return skipped, run, skipped * mean
