"""The run page's pin deck in a real browser: Debian's Chromium driven by Playwright, against
the service in a thread of this process (uvicorn on loopback), with the network cut off.

An archive that does not keep a run's pins (format before 2.2) gets the pin run in the
server's replay cache, as loading it would give it; with pins in the archive nothing is
seeded. Skips (with the reason) when no Chromium can be found (``BOWLREC_CHROMIUM`` names
another executable).
"""

from __future__ import annotations

import os
import shutil
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

pytest.importorskip("fastapi")
pytest.importorskip("jinja2")
pytest.importorskip("mujoco", reason="pin action needs the pins extra")
sync_api = pytest.importorskip("playwright.sync_api", reason="playwright is not installed")

from helpers.servers import ThreadServer  # noqa: E402
from test_pins_replay import pin_run, seed_pins  # noqa: E402

from bowlrec.api import simulate_into  # noqa: E402
from bowlrec.archive import Archive  # noqa: E402


def _chromium() -> str | None:
    given = os.environ.get("BOWLREC_CHROMIUM")
    if given:
        return given
    for name in ("chromium", "chromium-browser", "google-chrome"):
        found = shutil.which(name)
        if found:
            return found
    return None


CHROMIUM = _chromium()
pytestmark = [
    pytest.mark.browser,
    pytest.mark.skipif(
        CHROMIUM is None,
        reason="no Chromium found (apt-get install chromium, or set BOWLREC_CHROMIUM)",
    ),
]


@pytest.fixture(scope="module")
def site(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[ThreadServer, str]]:
    from bowlrec.service.app import create_app

    run = pin_run()
    root: Path = tmp_path_factory.mktemp("pins-browser") / "archive"
    archive = Archive(root)
    rid = simulate_into(archive, run.scene).run_id
    archive.close()
    app = create_app(root, None, warm_up=False)
    with ThreadServer(app, root) as server:
        seed_pins(app.state.bowlrec.replays, rid, run)
        yield server, rid


@pytest.fixture(scope="module")
def browser() -> Iterator[Any]:
    with sync_api.sync_playwright() as p:
        b = p.chromium.launch(
            executable_path=CHROMIUM,
            headless=True,
            args=["--enable-unsafe-swiftshader", "--use-angle=swiftshader"],
        )
        yield b
        b.close()


def test_the_deck_view_draws_ten_pins_and_the_leave(
    browser: Any, site: tuple[ThreadServer, str]
) -> None:
    server, rid = site
    context = browser.new_context(base_url=server.url, viewport={"width": 1400, "height": 1000})
    offsite: list[str] = []
    errors: list[str] = []

    def route(r: Any) -> None:
        url = r.request.url
        if url.startswith((server.url, "data:", "blob:")):
            r.continue_()
        else:
            offsite.append(url)
            r.abort()

    context.route("**/*", route)
    # the rerun viewer's iframe is another test's; keep it from compiling here (the route
    # registered last is tried first)
    context.route("**/viewer/**", lambda r: r.fulfill(status=204, body=""))
    page = context.new_page()
    page.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
    page.on("pageerror", lambda e: errors.append(f"page error: {e}"))
    page.goto(f"/ui/runs/{rid}")
    section = page.locator("#pin-deck")
    page.wait_for_selector("#pin-deck[data-ready='1']", timeout=60_000)
    section.scroll_into_view_if_needed()
    assert page.locator("#pin-leave").inner_text() == "strike"
    pins = page.locator("#deck-svg g.pin")
    assert pins.count() == 10
    assert sorted(int(p.get_attribute("data-pin")) for p in pins.all()) == list(range(1, 11))
    assert page.locator("#deck-svg .deck-spot").count() == 10
    assert page.locator("#deck-svg .deck-path").count() == 1
    result = page.locator("#pin-result").inner_text()
    assert "10 of 10" in result and "exit board" in result and "touched by the ball" in result
    # the final positions: every pin down (a strike), each drawn lying; the ball's centre
    last = int(page.locator("#deck-time").get_attribute("max"))
    assert last > 10 and section.get_attribute("data-frame") == str(last)
    assert section.get_attribute("data-standing") == "0"
    assert page.locator("#deck-svg g.pin.down").count() == 10
    assert page.locator("#deck-svg g.pin.touched").count() >= 3
    box = page.locator("#deck-svg").bounding_box()
    assert box is not None and box["width"] > 200 and box["height"] > 300
    # scrubbed to the hand-off: all ten standing on their spots
    page.locator("#deck-time").fill("0")
    assert section.get_attribute("data-frame") == "0"
    assert section.get_attribute("data-standing") == "10"
    assert page.locator("#deck-svg g.pin.standing").count() == 10
    assert "t = 0.000 s" in page.locator("#deck-clock").inner_text()
    # played from the start, it reaches the last sample and stops
    page.locator("#deck-play").click()
    page.wait_for_selector(f"#pin-deck[data-frame='{last}']", timeout=30_000)
    page.wait_for_selector("#deck-play:text-is('Play')", timeout=5_000)
    assert section.get_attribute("data-standing") == "0"
    context.close()
    assert not offsite, f"requests off the server: {offsite}"
    assert not errors, f"console errors: {errors}"
