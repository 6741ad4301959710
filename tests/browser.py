"""Driving a page in Debian's headless chromium (selenium, the driver named explicitly so that
Selenium Manager never reaches for the network). ``make test`` installs chromium and its driver."""

from __future__ import annotations

import contextlib
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

from selenium import webdriver
from selenium.common.exceptions import StaleElementReferenceException, WebDriverException
from selenium.webdriver.chrome.service import Service
from selenium.webdriver.common.by import By
from selenium.webdriver.common.keys import Keys

CHROMIUM, DRIVER = "/usr/bin/chromium", "/usr/bin/chromedriver"
SHOTS = Path(__file__).resolve().parents[1] / "out" / "gui-screenshots"


@contextlib.contextmanager
def chromium(width: int = 1400, height: int = 900, offline: bool = False) -> Iterator[Any]:
    """A headless chromium with WebGL (SwiftShader); ``offline``: no network at all."""
    options = webdriver.ChromeOptions()
    options.binary_location = CHROMIUM
    for arg in ("--headless=new", "--no-sandbox", "--disable-dev-shm-usage",
                "--use-gl=swiftshader", "--enable-unsafe-swiftshader",
                f"--window-size={width},{height}"):
        options.add_argument(arg)
    if offline:  # every host name fails to resolve: only file:// pages load
        options.add_argument("--host-resolver-rules=MAP * ~NOTFOUND")
        options.add_argument("--proxy-server=127.0.0.1:9")
    driver = webdriver.Chrome(service=Service(executable_path=DRIVER), options=options)
    try:
        yield driver
    finally:
        driver.quit()


def wait(condition: Callable[[], Any], what: str, timeout: float = 60.0) -> Any:
    """Poll ``condition()`` until it returns something true; fail naming ``what``."""
    end = time.monotonic() + timeout
    while True:
        with contextlib.suppress(WebDriverException, StaleElementReferenceException):
            value = condition()
            if value:
                return value
        if time.monotonic() > end:
            raise AssertionError(f"timed out after {timeout:g} s waiting for {what}")
        time.sleep(0.2)


def visible(driver: Any, xpath: str) -> Any:
    """The first displayed element matching ``xpath``, or None."""
    return next((e for e in driver.find_elements(By.XPATH, xpath) if e.is_displayed()), None)


def _row(label: str) -> str:
    return (f"//label[normalize-space()={_quote(label)}]"
            "/ancestor::div[contains(@class,'mantine-Flex-root')][1]")


def field(driver: Any, label: str) -> Any:
    """The displayed input next to the label ``label``."""
    return wait(lambda: visible(driver, _row(label) + "//input"), f"the field '{label}'")


def type_into(driver: Any, label: str, text: str) -> None:
    """Replace the text of field ``label`` and leave it (the page sends the value)."""
    element = field(driver, label)
    element.click()
    element.send_keys(Keys.CONTROL, "a")
    element.send_keys(Keys.DELETE)
    element.send_keys(text)
    element.send_keys(Keys.ENTER)
    driver.execute_script("arguments[0].blur();", element)  # focus moves nowhere


def click(driver: Any, text: str) -> None:
    """Click the displayed button whose text is ``text``."""
    button = wait(lambda: visible(driver, f"//button[normalize-space()={_quote(text)}]"),
                  f"the button '{text}'")
    driver.execute_script("arguments[0].scrollIntoView({block: 'center'});", button)
    button.click()


def tick(driver: Any, label: str, on: bool = True) -> None:
    """Set the checkbox labelled ``label``."""
    box = wait(lambda: visible(driver, _row(label) + "//input[@type='checkbox']")
               or _hidden_checkbox(driver, label), f"the checkbox '{label}'")
    if box.is_selected() != on:
        driver.execute_script("arguments[0].click();", box)


def _hidden_checkbox(driver: Any, label: str) -> Any:
    boxes = driver.find_elements(By.XPATH, _row(label) + "//input[@type='checkbox']")
    return boxes[0] if boxes else None


def tab(driver: Any, name: str) -> None:
    """Open the tab ``name``."""
    element = wait(lambda: visible(driver, f"//*[@role='tab'][@title={_quote(name)}]"),
                   f"the tab '{name}'")
    driver.execute_script("arguments[0].scrollIntoView({block: 'center'});", element)
    element.click()


def text_shown(driver: Any, text: str, timeout: float = 60.0) -> None:
    """Wait until ``text`` is displayed on the page."""
    wait(lambda: visible(driver, f"//*[contains(normalize-space(text()), {_quote(text)})]"),
         f"the text '{text}'", timeout)


def shot(driver: Any, name: str) -> Path:
    """Save a screenshot as out/gui-screenshots/NAME.png."""
    SHOTS.mkdir(parents=True, exist_ok=True)
    path = SHOTS / f"{name}.png"
    driver.save_screenshot(str(path))
    return path


def _quote(text: str) -> str:
    return f'"{text}"' if '"' not in text else f"'{text}'"
