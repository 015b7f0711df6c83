"""Plain typed data shared by every part of boxbox: Track, Car, State, Controls, PitOrder, CarSetup."""

from boxbox.model.car import Car
from boxbox.model.car_setup import CarSetup
from boxbox.model.controls import Controls, PitOrder
from boxbox.model.state import Opponent, State
from boxbox.model.track import PitLane, Track

__all__ = ["Car", "CarSetup", "Controls", "Opponent", "PitLane", "PitOrder", "State", "Track"]
