import numpy as np
import pytest

from boxbox.bench.tyre_plot import level_curves, plot_level_curves
from boxbox.control.tyre import peak_slip
from boxbox.model.skill import SkillLevel


def test_the_model_plans_on_each_levels_force_at_the_pro_peaks_slip():
    curves = level_curves()
    held = peak_slip(20.0, 0.8, 0.7)
    for level, (slip, force, model) in curves.items():
        at_peak = float(np.interp(held, slip, force))
        assert model == pytest.approx(at_peak, abs=2e-3), level
    # pro: the model is the tyre's very peak, and the tyre gives less past it; below pro, more
    slip, force, model = curves[SkillLevel.PRO]
    assert model == 1.0 and force.max() == pytest.approx(1.0, abs=1e-4) and force[-1] < 0.95
    semi = curves[SkillLevel.SEMI_PRO]
    assert semi[2] == pytest.approx(1.079, abs=1e-3) and semi[1][-1] > 1.25
    assert curves[SkillLevel.ROOKIE][2] > curves[SkillLevel.AMATEUR][2] > semi[2] > 1.0


def test_the_plot_is_written(tmp_path):
    plot_level_curves(tmp_path / "t.png")
    assert (tmp_path / "t.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
