"""Which trial a study hands out (tune.pick), and the sampler and pruner that read the study once
per trial (tune.synced)."""

from __future__ import annotations

import optuna
import pytest

from boxbox.robot.params import TutorialParams
from boxbox.tune.objective import RESULT_ATTR, TuneConfig
from boxbox.tune.pick import Sample, near, noise_floor, pick_best, region_gain, robust_choice, unit_point
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
    robust = pick_best(study, CFG, radius=0.0, noise=False, min_neighbours=0)  # each trial on its own
    assert robust.trial.number == steady and not robust.is_defaults and "0.25 %" in robust.why
    assert pick_best(study, CFG, "fastest").trial.number == fastest


def test_robust_pick_keeps_the_defaults_when_nothing_beats_them_everywhere(study):
    add(study, MU + 0.2, (90.0, 200.5), (0, 12))
    add(study, MU - 0.05, (100.0, 199.0), (1, 12))
    chosen = pick_best(study, CFG, radius=0.0, noise=False, min_neighbours=0)
    assert chosen.trial.number == 0 and chosen.is_defaults and "stay the best" in chosen.why


def test_robust_pick_wants_the_trials_around_it_to_win_too(study):
    cliff = add(study, MU + 0.2, (98.0, 196.0), (0, 12))  # 2 %, but a neighbour lost on b: a threshold
    add(study, MU + 0.21, (98.2, 196.4), (0, 12))
    add(study, MU + 0.19, (98.0, 200.5), (0, 12))
    steady = add(study, MU + 0.1, (99.6, 199.2), (0, 12))  # 0.4 %; around it 0.3 % at worst
    add(study, MU + 0.11, (99.7, 199.0), (0, 12))
    chosen = pick_best(study, CFG, noise=False)  # within 3 % of the range (0.036 of mu_scale)
    assert chosen.trial.number == steady and "0.30 %" in chosen.why and "1 neighbour" in chosen.why
    assert pick_best(study, CFG, radius=0.0, noise=False, min_neighbours=0).trial.number == cliff


def test_robust_pick_wants_more_than_the_noise_of_near_trials(study):
    add(study, MU + 0.1, (99.8, 199.6), (0, 12))  # 0.2 % on both tracks
    add(study, MU + 0.11, (99.5, 199.0), (0, 12))  # 0.1 from the first: 0.3 % and 0.3 % apart
    kept = pick_best(study, CFG)  # the floor: 0.3 %, the best region's worst 0.2 %
    assert kept.trial.number == 0 and kept.is_defaults and "(0.30 %)" in kept.why
    far = add(study, MU + 0.3, (97.0, 194.0), (0, 12))  # 3 %
    assert pick_best(study, CFG).is_defaults  # but alone: a single sample
    add(study, MU + 0.31, (97.2, 194.2), (0, 12))
    assert pick_best(study, CFG).trial.number == far  # 2.9 % at worst with its neighbour, floor 0.25 %


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


def sample(number: int, point: dict, times: tuple[float, ...], damage: int = 0, complete: bool = True) -> Sample:
    return Sample(number, point, {t: {"score_s": s, "damage": damage} for t, s in zip("abc", times, strict=False)},
                  complete)


def test_unit_point_is_a_share_of_the_range():
    dists = {"x": optuna.distributions.FloatDistribution(0.5, 1.5),
             "k": optuna.distributions.FloatDistribution(0.01, 100.0, log=True),
             "mode": optuna.distributions.CategoricalDistribution(("calm", "wild"))}
    point = unit_point({"x": 0.8, "k": 1.0, "mode": "wild"}, dists)
    assert point["x"] == pytest.approx(0.3) and point["k"] == pytest.approx(0.5) and point["mode"] == "wild"


def test_near_wants_every_number_close_and_the_same_choices():
    assert near({"x": 0.50, "y": 0.20}, {"x": 0.53, "y": 0.18}, 0.03)
    assert not near({"x": 0.50, "y": 0.20}, {"x": 0.54, "y": 0.20}, 0.03)
    assert not near({"x": 0.5, "mode": "calm"}, {"x": 0.5, "mode": "wild"}, 0.03)


def test_a_pruned_neighbour_counts_with_the_tracks_it_raced():
    ref, center = sample(0, {"x": 0.0}, (100.0, 200.0)), sample(1, {"x": 0.5}, (99.0, 198.0))
    won = sample(2, {"x": 0.51}, (99.5,), complete=False)  # pruned after a: 0.5 % there
    assert region_gain(center, [ref, center, won], ref.races, ["a", "b"], 0.03) == pytest.approx((0.005, 1))
    lost = sample(3, {"x": 0.49}, (100.1,), complete=False)
    assert region_gain(center, [ref, center, won, lost], ref.races, ["a", "b"], 0.03) is None
    dented = sample(4, {"x": 0.52}, (99.0, 198.0), damage=3)  # faster, but touched a wall
    assert region_gain(center, [ref, center, dented], ref.races, ["a", "b"], 0.03) is None


def test_robust_choice_takes_the_best_worst_region_above_the_floor():
    ref = sample(0, {"x": 0.0}, (100.0, 200.0))
    lone = sample(1, {"x": 0.9}, (90.0, 180.0))  # 10 %
    good = [sample(2, {"x": 0.5}, (99.0, 198.0)), sample(3, {"x": 0.52}, (99.5, 199.0))]
    chosen, gain, around = robust_choice([ref, *good], ref, ["a", "b"], 0.03)
    assert chosen.number == 2 and gain == pytest.approx(0.005) and around == 1
    assert robust_choice([ref, *good], ref, ["a", "b"], 0.03, floor=0.006)[0] is ref  # under it
    assert robust_choice([ref, lone, *good], ref, ["a", "b"], 0.03, floor=0.02)[0] is ref  # lone: no neighbour
    assert robust_choice([ref, lone, *good], ref, ["a", "b"], 0.03, floor=0.02, min_neighbours=0)[0] is lone


def test_noise_floor_is_the_median_difference_of_near_trials():
    a, b = sample(1, {"x": 0.50}, (100.0, 200.0)), sample(2, {"x": 0.52}, (100.2, 201.0))  # 0.2 and 0.5 %
    c = sample(3, {"x": 0.51}, (100.1,), complete=False)  # pruned: 0.1 % from a, 0.1 % from b on a
    far = sample(4, {"x": 0.9}, (150.0, 300.0))
    assert noise_floor([a, b, c, far], ["a", "b"], 0.03) == pytest.approx(0.0015, rel=0.01)  # 0.1 .1 .2 .5
    assert noise_floor([a, far], ["a", "b"], 0.03) == pytest.approx(0.5)  # no near pair: the closest one
    crashed = Sample(5, {"x": 0.5}, {"a": {"score_s": 3000.0, "damage": 0, "problem": "did not finish"}}, True)
    assert noise_floor([a, crashed], ["a"], 0.03) is None


def test_values_next_to_the_robots_own_are_not_handed_out():
    ref = sample(0, {"x": 0.50}, (100.0, 200.0))
    close = sample(1, {"x": 0.52}, (95.0, 190.0))  # 5 %, but the robot's own values are around it
    assert robust_choice([ref, close], ref, ["a", "b"], 0.03)[0] is ref
    assert robust_choice([ref, close], ref, ["a", "b"], 0.01, min_neighbours=0)[0] is close
