"""Choices a race offers beyond its track, car and robots, shared by the command line and the benches.

Each choice is a Literal (click shows its values; mypy checks them), with its values in a tuple.
"""

from __future__ import annotations

from typing import Literal, get_args

PitMode = Literal["constant-decel", "bang-bang"]  # how the robot brakes into its pit box
PIT_MODES: tuple[PitMode, ...] = get_args(PitMode)

# on: the shared learning store; off: none; fresh: a new empty store in the race's run dir
# (torcs/raceprep.py: learning_store, one per skill level)
LearningMode = Literal["on", "off", "fresh"]
LEARNING_MODES: tuple[LearningMode, ...] = get_args(LearningMode)


# how far a car may go past the track's edge: TORCS's own limit, or the painted edge (control/trackwidth.py)
TrackLimits = Literal["torcs", "strict"]
TRACK_LIMITS: tuple[TrackLimits, ...] = get_args(TrackLimits)
