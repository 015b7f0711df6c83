"""TORCS's skill levels: what each one changes in the simulation.

A car's level comes from its robot's driver file (`skill level` per robot index; TORCS's race
manager gives semi-pro to a robot that names none, raceinit.cpp). The simulation (simuv2,
categories.cpp) then scales two things by it: the tyre force at high slip, force x (1 + slip x
skid factor) with the slip capped at 1.5 (wheel.cpp), and the damage from every hit (collide.cpp).
"""

from __future__ import annotations

from enum import IntEnum


class SkillLevel(IntEnum):
    """The level's number is TORCS's `_skillLevel`; `.torcs_name` is how driver files spell it."""

    ROOKIE = 0
    AMATEUR = 1
    SEMI_PRO = 2
    PRO = 3

    @property
    def torcs_name(self) -> str:
        return self.name.lower().replace("_", "-")

    @property
    def skid_factor(self) -> float:
        """Extra tyre force per unit of slip (simuv2's simSkidFactor)."""
        return (0.40, 0.35, 0.30, 0.0)[self]

    @property
    def damage_factor(self) -> float:
        """Share of a hit's damage the car takes (simuv2's simDammageFactor)."""
        return (0.0, 0.5, 0.8, 1.0)[self]

    @classmethod
    def parse(cls, text: str) -> SkillLevel:
        """'semi-pro' -> SEMI_PRO; a ValueError naming the valid spellings otherwise."""
        for level in cls:
            if level.torcs_name == text:
                return level
        raise ValueError(f"unknown skill level {text!r}; use one of {', '.join(lv.torcs_name for lv in cls)}")


DEFAULT_SKILL_LEVEL = SkillLevel.SEMI_PRO  # what TORCS gives its own robots
