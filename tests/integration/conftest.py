import pytest


@pytest.fixture(scope="session")
def overlay():
    """TORCS set up for boxbox (installs and builds on first use, like `./boxbox test` does)."""
    from boxbox.torcs import setup

    return setup.ensure_ready()


# chromium as root, headless, without anything that reaches out to the network
CHROMIUM_ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
                 "--disable-component-update", "--disable-sync", "--no-first-run"]


@pytest.fixture(scope="session")
def browser():
    """Debian's chromium (installed when missing), driven by Playwright, which never downloads a browser."""
    from boxbox.errors import BoxboxError
    from boxbox.torcs import setup

    try:
        chromium = setup.ensure_chromium()
    except BoxboxError as exc:
        pytest.skip(f"Debian's chromium cannot be installed here: {exc}")
    from playwright.sync_api import sync_playwright

    with sync_playwright() as pw:
        launched = pw.chromium.launch(executable_path=str(chromium), args=CHROMIUM_ARGS)
        yield launched
        launched.close()
