"""The pages in a real headless Chromium (Debian's, scripts/ensure_browser.sh), driven by Playwright: the phone page
streams synthetic DeviceMotion events, its own labels and warnings equal the server's, it resends a backlog longer
than the burst allowance after being offline and nothing is lost; a simulated sudden stop lights the rider's
warning banner and the operator view lists the event and draws the track."""

import math
import os
import shutil
import tempfile
import threading
import time
from pathlib import Path

import numpy as np
import pytest

playwright_api = pytest.importorskip("playwright.sync_api")
uvicorn = pytest.importorskip("uvicorn")

from classify_fixtures import rides, truth_model  # noqa: E402
from service_fixtures import served  # noqa: E402
from spotfree.ride.api import create_app  # noqa: E402
from spotfree.ride.records import SAMPLE_COLUMNS  # noqa: E402
from spotfree.ride.service import RideService  # noqa: E402
from spotfree.ride.sources import recording_rows  # noqa: E402
from spotfree.ride.store import RideStore  # noqa: E402

pytestmark = [pytest.mark.browser,
              pytest.mark.skipif(shutil.which("chromium") is None, reason="run scripts/ensure_browser.sh")]
SHOTS = Path(os.environ.get("SPOTFREE_SCREENSHOTS") or tempfile.mkdtemp(prefix="spotfree-shots-"))
"""Where the views' screenshots go: ``SPOTFREE_SCREENSHOTS=docs/img`` refreshes the README's; a temporary folder
otherwise, so that a test run leaves the checkout as it was."""


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    raw = rides(seed=1, repeats=2)
    service = RideService(truth_model(raw.select_experiment(1)),
                          RideStore(tmp_path_factory.mktemp("db") / "rides.db", synchronous="normal"))
    service.operator_token = service.new_operator_token()
    with served(create_app(service)) as url:
        yield url, service, recording_rows(raw.select_experiment(2))


@pytest.fixture(scope="module")
def browser():
    with playwright_api.sync_playwright() as p:
        b = p.chromium.launch(executable_path=shutil.which("chromium"), args=["--no-sandbox"])
        yield b
        b.close()


MOTION = """([rows, t0]) => {
  for (const r of rows) {
    const ev = new DeviceMotionEvent('devicemotion', {
      accelerationIncludingGravity: {x: r[1], y: r[2], z: r[3]},
      rotationRate: {alpha: r[6] * 180 / Math.PI, beta: r[4] * 180 / Math.PI, gamma: r[5] * 180 / Math.PI},
      interval: 50});
    Object.defineProperty(ev, 'timeStamp', {value: (t0 + r[0]) * 1000});
    if (r[7] !== null) window.spotfree.state.fix = {lat: r[7], lon: r[8], speed: r[9]};
    window.dispatchEvent(ev);
  }
}"""


def _rows_js(rows):
    return [[None if math.isnan(v) else float(v) for v in r] for r in rows]


def _started_phone(opener, url, service, **page_args):
    """The phone page opened by ``opener`` (a browser or a context), its pipeline loaded, enrolled with a code
    the operator issued and Start tapped."""
    page = opener.new_page(**page_args)
    page.goto(url + "/")
    page.wait_for_function("() => window.spotfree && window.spotfree.state.pipeline !== null")
    page.fill("#code", service.issue_enrolment()[0])
    page.click("#start")
    page.wait_for_function("() => window.spotfree.state.online")
    return page


def _mid_slot(rows):
    """The rows 10 ms later: every sample lands mid-slot, so the page's 20 Hz grid keeps each one."""
    shifted = rows.copy()
    shifted[:, 0] += 0.01
    return shifted


def test_phone_streams_and_labels_equal_server(server, browser):
    url, service, rows = server
    page = _started_phone(browser, url, service, viewport={"width": 420, "height": 860})
    shifted = _mid_slot(rows)
    for k in range(0, 800, 20):  # 40 s: the first sudden stop of this ride is at 36.7 s
        page.evaluate(MOTION, [_rows_js(shifted[k:k + 20]), 1000.0])
        page.wait_for_timeout(150)
    page.evaluate(MOTION, [_rows_js(shifted[800:801]), 1000.0])
    page.wait_for_function("() => window.spotfree.state.serverLabels.length >= 700", timeout=20000)
    remote = page.evaluate("window.spotfree.state.serverLabels")
    local = page.evaluate("window.spotfree.state.localLabels")[:len(remote)]
    assert local == remote
    assert {"cruising", "normal-braking"} <= set(filter(None, remote))
    ride_id = page.evaluate("window.spotfree.state.rideId")
    assert len(service.store.samples(ride_id)["time"]) == len(remote)
    # the page's own warnings (shown while offline) follow the server's debouncing
    warned = page.evaluate("window.spotfree.state.warnings")
    assert warned and [(w["kind"], w["time"]) for w in warned] == [
        (w["kind"], pytest.approx(w["time"])) for w in page.evaluate("window.spotfree.state.localWarnings")
        if w["time"] <= remote_time(page)]
    page.screenshot(path=str(SHOTS / "phone.png"))
    page.close()


def test_an_upright_phone_finds_its_mount_with_the_server(server, browser):
    """A phone standing upright in a holder: the page's mount tracker switches with the server's, so its labels
    stay the server's; the page says the mount is unusual and the ride record has it."""
    url, service, rows = server
    upright = _mid_slot(rows)
    q = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])
    upright[:, 1:4], upright[:, 4:7] = upright[:, 1:4] @ q.T, upright[:, 4:7] @ q.T
    page = _started_phone(browser, url, service)
    for k in range(0, 800, 40):
        page.evaluate(MOTION, [_rows_js(upright[k:k + 40]), 1000.0])
        page.wait_for_timeout(100)
    page.evaluate(MOTION, [_rows_js(upright[800:801]), 1000.0])
    page.wait_for_function("() => window.spotfree.state.serverLabels.length >= 790", timeout=20000)
    remote = page.evaluate("window.spotfree.state.serverLabels")
    assert page.evaluate("window.spotfree.state.localLabels")[:len(remote)] == remote
    assert len(set(filter(None, remote))) > 1
    assert page.evaluate("window.spotfree.state.pipeline.mount.stage") == "final"
    assert "unusual: features use it" in page.inner_text("#mount")
    kinds = [e.kind for e in service.store.events(page.evaluate("window.spotfree.state.rideId"))]
    assert kinds[:2] == ["unusual-mount", "unusual-mount"]
    page.close()


def test_the_sample_that_warns_is_sent_at_once(server, browser):
    url, service, rows = server
    page = _started_phone(browser, url, service)
    shifted = _mid_slot(rows)
    for k in range(0, 700, 20):
        page.evaluate(MOTION, [_rows_js(shifted[k:k + 20]), 1000.0])
        page.wait_for_timeout(100)
    for k in range(700, 801):  # one sample at a time, as a phone gives them, through the first sudden stop
        page.wait_for_function("() => window.spotfree.state.inFlight === null")
        page.evaluate(MOTION, [_rows_js(shifted[k:k + 1]), 1000.0])
    page.wait_for_function("() => window.spotfree.state.inFlight === null && window.spotfree.state.queue.length < 20")
    warned = [w["time"] for w in page.evaluate("window.spotfree.state.warnings")]
    ends = page.evaluate("window.spotfree.state.batchEnds")
    assert warned and all(any(abs(t - end) < 1e-9 for end in ends) for t in warned)
    # the other batches wait for a second of samples
    assert sum(1 for a, b in zip(ends, ends[1:]) if b - a < 0.95) <= len(warned)
    page.close()


def remote_time(page):
    """Time (s) of the last sample the server acknowledged to the page."""
    return page.evaluate("window.spotfree.state.times[window.spotfree.state.serverLabels.length - 1]")


def test_phone_resends_a_long_backlog_after_being_offline(server, browser):
    """64 s offline (more than the 60 s the rate limit takes at once): the page sends the backlog in paced chunks,
    waits when refused for the rate, and every sample reaches the store in order."""
    url, service, rows = server
    context = browser.new_context()
    page = _started_phone(context, url, service)
    shifted = _mid_slot(rows)
    page.evaluate(MOTION, [_rows_js(shifted[:100]), 1000.0])
    page.wait_for_function("() => window.spotfree.state.serverLabels.length >= 99")
    context.set_offline(True)
    page.evaluate("window.spotfree.state.socket.close()")
    page.wait_for_function("() => !window.spotfree.state.online")
    for k in range(100, len(shifted), 200):
        page.evaluate(MOTION, [_rows_js(shifted[k:k + 200]), 1000.0])
    assert page.evaluate("window.spotfree.state.queue.length") > 60 * 20
    context.set_offline(False)
    page.wait_for_function("() => window.spotfree.state.queue.length <= 1", timeout=30000)
    remote = page.evaluate("window.spotfree.state.serverLabels")
    assert len(remote) == len(shifted) - 1  # the last 20 Hz slot waits for a later reading
    assert page.evaluate("window.spotfree.state.localLabels")[:len(remote)] == remote
    ride_id = page.evaluate("window.spotfree.state.rideId")
    stored = service.store.samples(ride_id)["time"]
    assert len(stored) == len(remote) and all(b > a for a, b in zip(stored, stored[1:]))
    assert "faster than" in page.locator("#status").inner_text()  # one chunk was refused for the rate, then resent
    context.close()


def test_rider_and_operator_views(server, browser):
    url, service, rows = server
    operator = browser.new_page(viewport={"width": 1280, "height": 820})
    rider = browser.new_page(viewport={"width": 420, "height": 760})
    _, token = service.register_device("replay")
    operator.goto(url + "/operator")
    operator.fill("#optoken", service.operator_token)
    operator.click("#signinbtn")
    # the rider view on the phone that rides: the phone page's device token lets it follow that device's rides
    rider.add_init_script(f"localStorage.setItem('spotfree-token', {token!r})")
    rider.goto(url + "/rider")
    operator.wait_for_timeout(500)
    ride_id = service.start_ride(token, "segway", "replay")
    warnings = []

    def stream():  # 45 s of the ride at 10 times real time, as the views would see a phone
        for k in range(0, 900, 20):
            batch = rows[k:k + 20]
            ack = service.ingest(token, ride_id, {name: [None if math.isnan(v) else float(v) for v in batch[:, j]]
                                                  for j, name in enumerate(SAMPLE_COLUMNS)}, check_rate=False)
            warnings.extend(ack["warnings"])
            time.sleep(0.1)

    streaming = threading.Thread(target=stream)
    streaming.start()
    rider.wait_for_selector("#banner.on", timeout=20000)
    assert rider.locator("#banner").inner_text() == "SUDDEN BRAKING"
    rider.screenshot(path=str(SHOTS / "rider.png"))
    streaming.join()
    assert warnings
    listed = operator.locator("#events li[data-kind='sudden-braking']")
    operator.wait_for_function(f"() => document.querySelectorAll('#events li').length >= {len(warnings)}")
    assert listed.count() == len(warnings)
    assert listed.last.inner_text().startswith(f"{warnings[0]['onset']:.1f} s sudden-braking")
    operator.wait_for_function("() => Number(document.getElementById('track').dataset.points || 0) > 5", timeout=10000)
    assert operator.locator("#scalebar text").text_content().endswith("m")
    assert rider.locator("#speed").inner_text() != "–"
    assert operator.locator("#signin").is_hidden()
    operator.click("#enrolbtn")
    operator.wait_for_function("() => document.getElementById('code').textContent.includes('one device')")
    operator.screenshot(path=str(SHOTS / "operator.png"))
    operator.close()
    rider.close()


def test_views_without_a_credential_show_nothing(server, browser):
    """A view opened without a credential is refused its data and says what to do; a wrong operator token is
    refused with the server's reason; the pages load under their Content-Security-Policy."""
    url, service, _ = server
    page = browser.new_page()
    violations = []
    page.on("console", lambda m: violations.append(m.text) if "Content Security Policy" in m.text else None)
    page.goto(url + "/rider")
    page.wait_for_selector("#nocredential", state="visible")
    page.goto(url + "/operator")
    page.fill("#optoken", "not-the-token")
    page.click("#signinbtn")
    page.wait_for_function("() => document.getElementById('signinmsg').textContent.includes('unknown token')")
    assert page.locator("#rides li").count() == 0
    assert not violations
    page.close()
