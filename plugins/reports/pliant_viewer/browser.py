"""Headless Chromium for the viewer's tests and benchmark: Debian's ``chromium`` and ``chromium-driver`` through
selenium, with the flags that keep it off the network (no background networking, component updates or sync) and a
fresh profile.  selenium is told where chromedriver is, so selenium-manager never downloads anything.
"""

from __future__ import annotations

import shutil
import tempfile
from pathlib import Path

CHROMIUM = "/usr/bin/chromium"
CHROMEDRIVER = "/usr/bin/chromedriver"
FLAGS = ("--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync",
         "--disable-dev-shm-usage", "--use-gl=angle", "--use-angle=swiftshader", "--enable-unsafe-swiftshader")


def missing() -> str | None:
    """Why headless Chromium cannot run here, or ``None`` when it can."""
    for path in (CHROMIUM, CHROMEDRIVER):
        if not Path(path).exists():
            return f"{path} is not installed (Debian: apt-get install chromium chromium-driver; `make install`)"
    try:
        import selenium  # noqa: F401
    except ImportError:
        return "selenium is not installed (pip install selenium; it is in pliant's test extra)"
    return None


class Browser:
    """One headless Chromium window (``width`` x ``height``) driven by selenium; :meth:`quit` ends it and removes
    its profile."""

    def __init__(self, width: int = 1280, height: int = 800) -> None:
        from selenium import webdriver
        from selenium.webdriver.chrome.service import Service

        self.profile = tempfile.mkdtemp(prefix="pliant-chromium-")
        options = webdriver.ChromeOptions()
        options.binary_location = CHROMIUM
        for flag in FLAGS:
            options.add_argument(flag)
        options.add_argument(f"--user-data-dir={self.profile}")
        options.add_argument(f"--window-size={width},{height}")
        self.driver = webdriver.Chrome(service=Service(executable_path=CHROMEDRIVER), options=options)

    def quit(self) -> None:
        try:
            self.driver.quit()
        finally:
            shutil.rmtree(self.profile, ignore_errors=True)

    def __enter__(self) -> Browser:
        return self

    def __exit__(self, *exc) -> None:
        self.quit()

    def frames_per_second(self, seconds: float = 3.0) -> float:
        """Animation frames the page drew per second over ``seconds`` (``requestAnimationFrame`` callbacks; the
        viewer's canvas renders on each)."""
        script = """
            const done = arguments[arguments.length - 1];
            const seconds = arguments[0];
            let frames = 0; const t0 = performance.now();
            function tick(now) { frames++; if (now - t0 < seconds * 1000) requestAnimationFrame(tick);
                                 else done(frames / ((now - t0) / 1000)); }
            requestAnimationFrame(tick);"""
        self.driver.set_script_timeout(seconds + 30)
        return float(self.driver.execute_async_script(script, seconds))


def wait_for_text(driver, text: str, timeout: float = 60.0) -> float:
    """Seconds until ``text`` shows in the page's body (the viewer's summary arrives after the scene's nodes);
    raises ``TimeoutError``."""
    import time

    from selenium.common.exceptions import WebDriverException

    t0 = time.perf_counter()
    while time.perf_counter() - t0 < timeout:
        try:
            if text in driver.execute_script("return document.body ? document.body.innerText : ''"):
                return time.perf_counter() - t0
        except WebDriverException:
            pass
        time.sleep(0.02)
    raise TimeoutError(f"'{text}' did not appear in the page within {timeout} s")


def scene_tree(driver) -> list[str]:
    """The node names of the client's own scene tree (viser's scene-tree table: one "Edit props for NAME" button
    per node it holds, children listed once their parent is expanded)."""
    labels = driver.execute_script(
        "return Array.from(document.querySelectorAll('[aria-label^=\"Edit props for \"]'))"
        ".map(e => e.getAttribute('aria-label').slice('Edit props for '.length));")
    return list(labels)


def dismiss_notifications(driver) -> None:
    """Close viser's notices (e.g. "Software WebGL rendering detected") so that screenshots show the scene."""
    driver.execute_script(
        "document.querySelectorAll('.mantine-Notification-closeButton, [class*=Notification] button')"
        ".forEach(b => b.click());")
