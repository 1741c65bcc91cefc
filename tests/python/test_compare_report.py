"""`antumbra compare`'s report.html in a real headless browser (Debian's Chromium through
chromedriver): it loads with no console error, every plot is drawn and every difference image
decodes; the answer (what to use) opens the page and the wide work tables open on a click.
Also writes the screenshot of the report's top, docs/compare-report.png, when
ANTUMBRA_SCREENSHOT is set."""

import os
import subprocess
from pathlib import Path

import pytest
from selenium import webdriver
from selenium.webdriver.chrome.options import Options
from selenium.webdriver.chrome.service import Service

import antumbra

PLOTS = ["shadow_nb", "frame_ms", "time_parts", "pareto"]
REPO = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def report(antumbra_bin, tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("compare")
    run = subprocess.run(
        [
            str(antumbra_bin),
            "compare",
            "--scene",
            "bedroom",
            "--triangles",
            "3000",
            "--frames",
            "1-2",
            "--size",
            "48x36",
            "--repeat",
            "1",
            "--out",
            str(out),
        ],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert run.returncode == 0, run.stderr
    return out / "report.html"


@pytest.fixture(scope="module")
def browser():
    options = Options()
    options.binary_location = "/usr/bin/chromium"
    # As root, without the machine's closed network calling out (see the env notes).
    for flag in [
        "--headless",
        "--no-sandbox",
        "--disable-gpu",
        "--disable-quic",
        "--no-first-run",
        "--disable-background-networking",
        "--disable-component-update",
        "--disable-sync",
        "--window-size=1400,1000",
    ]:
        options.add_argument(flag)
    options.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    driver = webdriver.Chrome(service=Service("/usr/bin/chromedriver"), options=options)
    yield driver
    driver.quit()


def test_report_loads_with_every_plot_and_image(report, browser):
    browser.get(report.as_uri())
    assert browser.execute_script("return document.readyState") == "complete"
    errors = [e for e in browser.get_log("browser") if e["level"] in ("SEVERE", "WARNING")]
    assert errors == []
    # Each plot is an inline SVG with drawn marks and its title.
    for name in PLOTS:
        marks = browser.execute_script(
            "const f = document.getElementById(arguments[0]);"
            "if (!f) return -1;"
            "const svg = f.querySelector('svg');"
            "if (!svg || svg.getBoundingClientRect().width < 100) return -2;"
            "return svg.querySelectorAll('polyline, path, rect, circle').length;",
            f"plot-{name}",
        )
        assert marks > 5, f"plot {name}: {marks}"
    # Every difference image decoded (naturalWidth is 0 for a broken image).
    sizes = browser.execute_script(
        "return [...document.querySelectorAll('img.diff')]"
        ".map(i => [i.complete, i.naturalWidth, i.naturalHeight]);"
    )
    # Every method besides the baseline x 2 frames.
    assert len(sizes) == (len(antumbra.DEFAULT_METHODS) - 1) * 2
    assert all(c and w == 48 and h == 36 for c, w, h in sizes), sizes
    verdict = browser.find_element("id", "verdict")
    assert "bit for bit" in verdict.text
    tables = browser.execute_script("return document.querySelectorAll('table').length")
    assert tables >= 5
    # The answer opens the page, above the verdict and every table, in plain words.
    answer = browser.find_element("id", "answer")
    assert answer.text.startswith("What to use\nUse "), answer.text
    first_table = browser.find_element("css selector", "table")
    assert answer.location["y"] < verdict.location["y"] < first_table.location["y"]
    # The 16-column work tables are folded: shown on a click.
    shadow = browser.execute_script(
        "return [...document.querySelectorAll('details.table')]"
        ".find(d => d.querySelector('h2').textContent === 'Shadow rays');"
    )
    assert shadow is not None and not shadow.find_element("css selector", "table").is_displayed()
    shadow.find_element("css selector", "summary").click()
    assert shadow.find_element("css selector", "table").is_displayed()
    if os.environ.get("ANTUMBRA_SCREENSHOT"):
        # The top of the report: the answer, the verdict and the key table.
        shadow.find_element("css selector", "summary").click()
        browser.set_window_size(1400, 900)
        browser.execute_script("window.scrollTo(0, 0)")
        browser.save_screenshot(str(REPO / "docs" / "compare-report.png"))
