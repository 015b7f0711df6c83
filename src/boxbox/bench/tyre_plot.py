"""The skill level's tyre force against slip beside the force the robot's model plans on (docs/rules.md).

Per level: simuv2's magic formula with the level's skid factor (control/tyre.py), as a share of the
pro tyre's peak, and the model's grip (control/carmodel.py: the force at the pro peak's slip), held
flat up to that slip: the robot plans on it and, where the level's force falls past the peak (pro),
its traction control keeps the slip there.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from boxbox.control.tyre import MAX_SLIP, falls_past_peak, magic_formula, peak_slip, skid_grip_gain
from boxbox.model.skill import SkillLevel

CAR1_TRB1_TYRE = (20.0, 0.8, 0.7)  # stiffness, dynamic friction, elasticity (its car file)


def level_curves(shape: tuple[float, float, float] = CAR1_TRB1_TYRE, points: int = 301
                 ) -> dict[SkillLevel, tuple[np.ndarray, np.ndarray, float]]:
    """Per level: (slip, the tyre's force as a share of the pro peak, the model's planned share)."""
    slip = np.linspace(0.0, MAX_SLIP, points)
    pro_peak = float(magic_formula(slip, *shape).max())
    return {level: (slip, magic_formula(slip, *shape, level.skid_factor) / pro_peak,
                    skid_grip_gain(*shape, level.skid_factor) if level.skid_factor else 1.0)
            for level in SkillLevel}


def plot_level_curves(path: Path | str, shape: tuple[float, float, float] = CAR1_TRB1_TYRE) -> None:
    """The level's force curve (solid) and the model's planned force (dashed, to the slip it holds)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    held = peak_slip(*shape)
    fig, ax = plt.subplots(figsize=(8, 4.5))
    for level, (slip, force, model) in level_curves(shape).items():
        line, = ax.plot(slip, force, lw=1.5, label=f"{level.torcs_name}: tyre (skid factor {level.skid_factor})")
        note = ", slip held at the peak" if falls_past_peak(*shape, level.skid_factor) else ""
        ax.plot([0.0, held], [model, model], ls="--", color=line.get_color(),
                label=f"{level.torcs_name}: model {model:.3f}{note}")
    ax.axvline(held, color="grey", lw=0.8)
    ax.set_xlabel("combined slip")
    ax.set_ylabel("force / pro peak force")
    ax.set_title(f"tyre force by skill level (stiffness {shape[0]:g}, dynamic friction {shape[1]:g}, "
                 f"elasticity {shape[2]:g})", fontsize=10)
    ax.legend(fontsize=7, loc="lower right")
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
