"""boxbox's Gymnasium environment on stock TORCS: `boxbox/TORCS-v0` (see docs/gym.md).

Importing this package registers the id:

    import gymnasium, boxbox.gym
    env = gymnasium.make("boxbox/TORCS-v0", track="g-track-1", opponents=["bt:2"], laps=1)

(`gymnasium.make("boxbox.gym:boxbox/TORCS-v0", ...)` imports it on the way.)  Several learning cars in
one race, as PettingZoo's environments are made:

    env = boxbox.gym.parallel_env(cars=4, track="g-track-1")
"""

from __future__ import annotations

import gymnasium

ENV_ID = "boxbox/TORCS-v0"


def register() -> None:
    """Register `boxbox/TORCS-v0` with Gymnasium (done on import; harmless to repeat)."""
    if ENV_ID not in gymnasium.registry:
        gymnasium.register(id=ENV_ID, entry_point="boxbox.gym.env:TorcsEnv")


register()

from boxbox.gym.env import TorcsEnv  # noqa: E402  (after the registration, which must not need it)
from boxbox.gym.parallel import TorcsParallelEnv, parallel_env  # noqa: E402  (several learning cars, PettingZoo)

__all__ = ["ENV_ID", "TorcsEnv", "TorcsParallelEnv", "parallel_env", "register"]
