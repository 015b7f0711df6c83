"""Pit stops as an action (placeholder, filled in below)."""

from __future__ import annotations

from boxbox.model import Car, PitOrder, State, Track


class PitStop:
    phase: str | None = None

    @classmethod
    def for_car(cls, track: Track, car: Car) -> PitStop | None:
        return None

    def request(self) -> None: ...
    def reset(self) -> None: ...
    def active(self, s: State) -> bool:
        return False

    def controls(self, s: State) -> tuple:
        raise NotImplementedError

    def order(self, s: State, fuel_l: float | None, repair: float | None) -> PitOrder:
        return PitOrder()
