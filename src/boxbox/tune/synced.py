"""The sampler and the pruner of a study, reading the study's trials once per trial.

Optuna reads every trial of the study (new and unfinished ones: its cache keeps the finished)
when asked for them; on a database each read is 7 SQL statements.  Optuna itself keeps one read
per trial for its samplers (Study._get_trials with use_cache: made at the trial's first sampling,
dropped by ask and tell); these wrappers hand that read to TPE's constant liar and to the pruner
too, which would otherwise read again, three times a trial of three tracks.
"""

from __future__ import annotations

from typing import Any

from optuna.pruners import BasePruner
from optuna.samplers import BaseSampler


class _AsSynced:
    """A study whose trials are its trial's one read of them: Optuna's per-trial copy (Study._get_trials
    with use_cache, made at the trial's first sampling, dropped by ask and tell)."""

    def __init__(self, study: Any) -> None:
        self._study = study

    def get_trials(self, deepcopy: bool = True, states: Any = None) -> list:
        return self._study._get_trials(deepcopy, states, use_cache=True)

    def _get_trials(self, deepcopy: bool = True, states: Any = None, use_cache: bool = False) -> list:
        return self._study._get_trials(deepcopy, states, use_cache=True)

    def __getattr__(self, name: str) -> Any:
        return getattr(self._study, name)


class SyncedSampler(BaseSampler):
    """A sampler that sees the study as read once for the trial.  TPE's constant liar (running trials
    count as bad values, so parallel workers spread out) otherwise reads every trial again right
    after that read, only to see the same running trials: 7 SQL statements on a database."""

    def __init__(self, inner: Any) -> None:
        self.inner = inner

    def before_trial(self, study: Any, trial: Any) -> None:
        self.inner.before_trial(study, trial)

    def infer_relative_search_space(self, study: Any, trial: Any) -> Any:
        return self.inner.infer_relative_search_space(_AsSynced(study), trial)

    def sample_relative(self, study: Any, trial: Any, search_space: Any) -> Any:
        return self.inner.sample_relative(_AsSynced(study), trial, search_space)

    def sample_independent(self, study: Any, trial: Any, name: str, distribution: Any) -> Any:
        return self.inner.sample_independent(_AsSynced(study), trial, name, distribution)

    def after_trial(self, study: Any, trial: Any, state: Any, values: Any) -> None:
        self.inner.after_trial(study, trial, state, values)

    def reseed_rng(self) -> None:
        self.inner.reseed_rng()


class SyncedPruner(BasePruner):
    """A pruner that compares a trial with the study as it was when the trial was sampled, instead
    of reading every trial from the storage again at each report (7 SQL statements a read on a
    database).  Trials that finish while this one races count from the next trial on."""

    def __init__(self, inner: Any) -> None:
        self.inner = inner

    def prune(self, study: Any, trial: Any) -> bool:
        return bool(self.inner.prune(_AsSynced(study), trial))
