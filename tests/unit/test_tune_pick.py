"""Which trial a study hands out (tune.pick), and the sampler and pruner that read the study once
per trial (tune.synced)."""

from __future__ import annotations

import optuna
import pytest

from boxbox.robot.params import TutorialParams
from boxbox.tune.objective import RESULT_ATTR, TuneConfig
from boxbox.tune.pick import pick_best
from boxbox.tune.synced import SyncedPruner, SyncedSampler

CFG = TuneConfig(study="pick", tracks=["a", "b"], params=["mu_scale", "brake_mu_scale"])
DISTS = {"mu_scale": optuna.distributions.FloatDistribution(0.3, 1.5),
         "brake_mu_scale": optuna.distributions.FloatDistribution(0.3, 1.5)}


MU, BRAKE = TutorialParams().mu_scale, TutorialParams().brake_mu_scale  # the robot's declared defaults


def add(study, mu: float, times: tuple[float, float], damage: tuple[int, int]) -> int:
    races = [{"track": t, "score_s": s, "damage": d} for t, s, d in zip(CFG.tracks, times, damage, strict=True)]
    study.add_trial(optuna.trial.create_trial(params={"mu_scale": mu, "brake_mu_scale": BRAKE}, distributions=DISTS,
                                              value=sum(times), user_attrs={RESULT_ATTR: {"races": races}}))
    return len(study.trials) - 1


@pytest.fixture
def study():
    optuna.logging.set_verbosity(optuna.logging.WARNING)
    s = optuna.create_study()
    add(s, MU, (100.0, 200.0), (0, 12))
    return s


def test_robust_pick_wants_every_track_and_no_more_damage(study):
    fastest = add(study, MU + 0.2, (95.0, 201.0), (0, 12))  # the smallest total, but slower on b
    add(study, MU + 0.15, (99.0, 199.0), (5, 12))  # faster on both, but touches a wall on a
    steady = add(study, MU + 0.1, (99.5, 199.5), (0, 12))  # 0.25 % on its worst track (b)
    add(study, MU + 0.08, (98.0, 199.9), (0, 10))  # more on a, only 0.05 % on b
    robust = pick_best(study, CFG)
    assert robust.trial.number == steady and not robust.is_defaults and "0.25 %" in robust.why
    assert pick_best(study, CFG, "fastest").trial.number == fastest


def test_robust_pick_keeps_the_defaults_when_nothing_beats_them_everywhere(study):
    add(study, MU + 0.2, (90.0, 200.5), (0, 12))
    add(study, MU - 0.05, (100.0, 199.0), (1, 12))
    chosen = pick_best(study, CFG)
    assert chosen.trial.number == 0 and chosen.is_defaults and "stay the best" in chosen.why


def test_no_complete_trial():
    assert pick_best(optuna.create_study(), CFG).trial is None


def test_pruner_and_sampler_read_the_study_once_a_trial():
    """MedianPruner through SyncedPruner still prunes a trial worse than the median, and neither it
    nor TPE's constant liar reads the storage again after the trial's first sampling."""
    optuna.logging.set_verbosity(optuna.logging.WARNING)
    study = optuna.create_study(sampler=SyncedSampler(optuna.samplers.TPESampler(seed=1, n_startup_trials=2)),
                                pruner=SyncedPruner(optuna.pruners.MedianPruner(n_startup_trials=3)))
    reads = []
    real = study._storage.get_all_trials
    study._storage.get_all_trials = lambda *a, **k: reads.append(1) or real(*a, **k)
    for value in (10.0, 11.0, 12.0):
        trial = study.ask()
        trial.suggest_float("x", 0.0, 1.0)
        trial.report(value, 0)
        assert not trial.should_prune()
        study.tell(trial, value)
    trial = study.ask()
    reads.clear()  # ask looks for queued trials: Optuna's own read
    trial.suggest_float("x", 0.0, 1.0)
    trial.report(100.0, 0)
    assert trial.should_prune()  # worse than the median of the three at step 0
    assert len(reads) == 1  # the sampling's; TPE's constant liar and the pruner would read once more each
    study.tell(trial, state=optuna.trial.TrialState.PRUNED)
