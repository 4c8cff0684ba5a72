"""`wbpower report sample_logs/` opened in a real browser (headless Chromium driven by
selenium through the system chromedriver), offline, in one short session (issue 28):

- nothing is fetched: the page's only resource is itself;
- the runs table lists every run of sample_logs/, sorts by energy, and its energies are
  the runs' energies as wbpower's reader gives them;
- the trace view zooms (a mouse wheel over the trace narrows the visible range), and a
  selection made by dragging shows its energy, which matches the energy of that span
  integrated here from the log's samples (each sample's power held over its period, the
  rectangle rule of paper Eq. 1) within the bound the page shows.

Skipped, saying why, where selenium or Chromium is missing; `make test` installs both where
it can (root and apt: Debian's chromium and chromium-driver). Screenshots go to
$WBPOWER_SCREENSHOTS when set (`make docs-figures`: docs/figures/), else to a temporary
folder.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

SAMPLE_LOGS = Path(__file__).resolve().parents[1] / "sample_logs"
CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
CHROMEDRIVER = shutil.which("chromedriver")

try:
    import selenium  # noqa: F401
except ImportError:
    HAVE_SELENIUM = False
else:
    HAVE_SELENIUM = True

pytestmark = [
    pytest.mark.slow,
    pytest.mark.skipif(
        not HAVE_SELENIUM,
        reason="selenium is not installed (pip install 'wbpower[browser]'; make test does)",
    ),
    pytest.mark.skipif(
        CHROMIUM is None or CHROMEDRIVER is None,
        reason="chromium and chromedriver are not on PATH (Debian: apt-get install chromium "
        "chromium-driver; make test installs them where it runs as root with apt)",
    ),
]


def span_energy_J(power_W: np.ndarray, period_s: float, t0_s: float, t1_s: float) -> float:
    """The energy [J] of [t0, t1] of a trace whose sample i holds power_W[i] over
    [i dt, (i + 1) dt): the overlap of each sample's period with the span times its power."""
    starts = np.arange(power_W.size) * period_s
    overlap = np.clip(np.minimum(starts + period_s, t1_s) - np.maximum(starts, t0_s), 0, None)
    return float(np.sum(power_W * overlap))


@pytest.fixture(scope="module")
def page(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("browser") / "report"
    done = subprocess.run(
        [sys.executable, "-m", "wifibot_power", "report", str(SAMPLE_LOGS), "-o", str(out)],
        capture_output=True,
        text=True,
        timeout=540,
    )
    assert done.returncode == 0, done.stderr[-2000:]
    return out / "report.html"


@pytest.fixture(scope="module")
def browser():
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    options = webdriver.ChromeOptions()
    options.binary_location = CHROMIUM
    for flag in (
        "--headless=new",
        "--no-sandbox",
        "--disable-gpu",
        "--disable-dev-shm-usage",
        "--disable-background-networking",
        "--disable-component-update",
        "--disable-sync",
        "--no-first-run",
        "--window-size=1280,900",
        "--hide-scrollbars",
    ):
        options.add_argument(flag)
    driver = webdriver.Chrome(service=Service(CHROMEDRIVER), options=options)
    try:
        yield driver
    finally:
        driver.quit()


def test_report_in_chromium_zooms_selects_and_lists_every_run(page: Path, browser) -> None:
    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.common.actions.wheel_input import ScrollOrigin
    from selenium.webdriver.common.by import By
    from selenium.webdriver.support.ui import WebDriverWait

    from wifibot_power.io import read_log

    shots = Path(os.environ.get("WBPOWER_SCREENSHOTS") or page.parent)
    shots.mkdir(parents=True, exist_ok=True)
    # offline: the browser has no network while it opens the page
    browser.execute_cdp_cmd("Network.enable", {})
    browser.execute_cdp_cmd(
        "Network.emulateNetworkConditions",
        {"offline": True, "latency": 0, "downloadThroughput": 0, "uploadThroughput": 0},
    )
    browser.get(page.resolve().as_uri())
    WebDriverWait(browser, 60).until(
        lambda d: d.find_element(By.TAG_NAME, "body").get_attribute("data-explorer") == "ready"
    )
    # nothing fetched: no resource loaded but the page; every embedded image decoded
    assert browser.execute_script("return performance.getEntriesByType('resource').length") == 0
    WebDriverWait(browser, 30).until(
        lambda d: d.find_element(By.TAG_NAME, "body").get_attribute("data-images-loaded")
    )
    loaded, total = (
        browser.find_element(By.TAG_NAME, "body").get_attribute("data-images-loaded").split("/")
    )
    assert loaded == total and int(total) >= 5

    # the runs table: every run of sample_logs, each with its energy
    logs = sorted(SAMPLE_LOGS.glob("*.csv.gz"))
    rows = browser.find_elements(By.CSS_SELECTOR, "#wb-runs tbody tr")
    ids = [r.find_element(By.CSS_SELECTOR, "td").text for r in rows]
    assert sorted(ids) == sorted(p.name.removesuffix(".csv.gz") for p in logs)
    assert len(ids) == 89
    energy_column = [th.text for th in browser.find_elements(By.CSS_SELECTOR, "#wb-runs th")]
    col = energy_column.index("energy J")
    browser.find_elements(By.CSS_SELECTOR, "#wb-runs th")[col].click()  # sort: ascending
    energies = [
        float(r.find_elements(By.TAG_NAME, "td")[col].get_attribute("data-v"))
        for r in browser.find_elements(By.CSS_SELECTOR, "#wb-runs tbody tr")
    ]
    assert energies == sorted(energies) and energies[0] < energies[-1]

    # one run: its energy in the table is its samples' (the reader's run, summed here)
    run_id = "v0.50_d10_s10_r1"
    run = read_log(SAMPLE_LOGS / f"{run_id}.csv.gz")
    run = run[0] if isinstance(run, list) else run
    power_W = np.asarray(run.power_W, np.float64)
    period_s = run.sample_period_s
    row = next(
        r
        for r in browser.find_elements(By.CSS_SELECTOR, "#wb-runs tbody tr")
        if r.find_element(By.TAG_NAME, "td").text == run_id
    )
    table_J = float(row.find_elements(By.TAG_NAME, "td")[col].get_attribute("data-v"))
    assert table_J == pytest.approx(float(np.sum(power_W)) * period_s, rel=1e-9)
    row.find_element(By.CSS_SELECTOR, "a").click()  # shows it in the trace view
    canvas = browser.find_element(By.ID, "wb-canvas")
    assert canvas.get_attribute("data-run") == run_id
    whole = float(canvas.get_attribute("data-x1")) - float(canvas.get_attribute("data-x0"))
    assert whole == pytest.approx(power_W.size * period_s, rel=1e-6)
    browser.save_screenshot(str(shots / "report_explorer_whole.png"))

    # zoom: the wheel over the trace narrows the visible range around the pointer
    ActionChains(browser).scroll_from_origin(ScrollOrigin.from_element(canvas), 0, -600).perform()
    WebDriverWait(browser, 10).until(
        lambda d: (
            float(canvas.get_attribute("data-x1")) - float(canvas.get_attribute("data-x0"))
            < 0.6 * whole
        )
    )
    x0, x1 = float(canvas.get_attribute("data-x0")), float(canvas.get_attribute("data-x1"))
    assert 0 <= x0 < x1 <= whole + 1e-6

    # select: drag across the middle of the visible range
    width = canvas.size["width"]
    drag = ActionChains(browser).move_to_element_with_offset(canvas, -width // 5, 0)
    drag.click_and_hold().move_by_offset(2 * width // 5, 0).release().perform()
    t0, t1 = float(canvas.get_attribute("data-sel-t0")), float(canvas.get_attribute("data-sel-t1"))
    assert x0 < t0 < t1 < x1
    shown_J = float(canvas.get_attribute("data-sel-energy-j"))
    bound_J = float(canvas.get_attribute("data-sel-bound-j"))
    expected_J = span_energy_J(power_W, period_s, t0, t1)
    assert abs(shown_J - expected_J) <= bound_J + 1e-9 * abs(expected_J)
    assert bound_J < 0.01 * expected_J  # a bound that says something
    readout = browser.find_element(By.ID, "wb-readout").text
    assert "energy" in readout and "mean power" in readout and "duration" in readout
    browser.save_screenshot(str(shots / "report_explorer_selection.png"))
