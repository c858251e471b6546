"""The demo report in a real headless browser (Debian's chromium + chromedriver).

Serves the report folder over http on 127.0.0.1, opens it with selenium,
checks that every figure loaded (naturalWidth > 0) and that the console has
no SEVERE entry, and saves a screenshot to test-artifacts/report.png.
Chromium and chromedriver are required (`.ci/run` installs them): the test
fails, not skips, when they are missing.
"""

import functools
import http.server
import shutil
import threading
from pathlib import Path

import pytest
from typer.testing import CliRunner

from adaptid.cli._app import app

CHROMIUM = Path("/usr/bin/chromium")
CHROMEDRIVER = Path("/usr/bin/chromedriver")
ARTIFACTS = Path(__file__).resolve().parents[2] / "test-artifacts"


class _QuietHandler(http.server.SimpleHTTPRequestHandler):
    def log_message(self, *args):
        pass


@pytest.fixture(scope="module")
def served_report(tmp_path_factory):
    out = tmp_path_factory.mktemp("browser") / "report"
    res = CliRunner().invoke(app, ["demo", "--out", str(out), "--quiet"])
    assert res.exit_code == 0, res.output
    handler = functools.partial(_QuietHandler, directory=str(out))
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    try:
        yield f"http://127.0.0.1:{server.server_address[1]}/index.html", out
    finally:
        server.shutdown()
        server.server_close()
        thread.join(timeout=10)


@pytest.fixture
def driver(tmp_path):
    missing = [str(p) for p in (CHROMIUM, CHROMEDRIVER) if not p.exists()]
    if missing:
        pytest.fail(f"headless browser test needs Debian's chromium and chromium-driver "
                    f"(apt-get install chromium chromium-driver; .ci/run does it): missing "
                    f"{', '.join(missing)}")
    try:
        from selenium import webdriver
        from selenium.webdriver.chrome.service import Service
    except ImportError:
        pytest.fail("headless browser test needs selenium (pip install -e '.[test]')")
    opts = webdriver.ChromeOptions()
    opts.binary_location = str(CHROMIUM)
    for flag in ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage",
                 "--disable-background-networking", "--disable-component-update",
                 "--disable-sync", "--no-first-run", "--window-size=1280,2400",
                 f"--user-data-dir={tmp_path / 'chromium-profile'}"):
        opts.add_argument(flag)
    opts.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    drv = webdriver.Chrome(service=Service(executable_path=str(CHROMEDRIVER)), options=opts)
    drv.set_page_load_timeout(60)
    try:
        yield drv
    finally:
        drv.quit()


def test_report_in_headless_chromium(served_report, driver, tmp_path):
    url, folder = served_report
    driver.get(url)
    assert "adaptid demo" in driver.title
    images = driver.execute_script(
        "return Array.from(document.images).map(i => "
        "({src: i.getAttribute('src'), complete: i.complete, w: i.naturalWidth, h: i.naturalHeight}));")
    assert {im["src"] for im in images} >= {"tracks.png", "errors.png", "cusum.png"}
    for im in images:
        assert im["complete"] and im["w"] > 0 and im["h"] > 0, im
    # the CSV link resolves to the file written next to the page
    href = driver.execute_script("return document.querySelector('a[href=\"estimates.csv\"]') !== null;")
    assert href
    logs = driver.get_log("browser")
    severe = [e for e in logs if e.get("level") == "SEVERE"]
    assert not severe, severe
    # screenshot of the whole page as a test artifact
    height = driver.execute_script("return document.documentElement.scrollHeight;")
    driver.set_window_size(1280, min(max(int(height), 800), 8000))
    # let the resized page repaint before the capture
    driver.execute_async_script(
        "const done = arguments[arguments.length - 1];"
        "requestAnimationFrame(() => requestAnimationFrame(() => setTimeout(done, 300)));")
    shot = tmp_path / "report.png"
    assert driver.save_screenshot(str(shot))
    assert shot.stat().st_size > 10_000
    ARTIFACTS.mkdir(exist_ok=True)
    shutil.copyfile(shot, ARTIFACTS / "report.png")
