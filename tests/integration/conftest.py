import pytest


@pytest.fixture(scope="session")
def overlay():
    """TORCS set up for boxbox (installs and builds on first use, like `./boxbox test` does)."""
    from boxbox.torcs import setup

    return setup.ensure_ready()
