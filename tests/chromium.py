"""Debian's Chromium, headless, driven by Debian's chromium-driver: nothing is downloaded."""

from __future__ import annotations

import os
import tempfile

from selenium import webdriver
from selenium.webdriver.chrome.service import Service

CHROMIUM = "/usr/bin/chromium"
CHROMEDRIVER = "/usr/bin/chromedriver"
FLAGS = (
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--no-first-run",
    "--window-size=1280,800",
)


def missing_browser() -> str:
    """What of Debian's Chromium and its driver this machine lacks, or "" when both are there."""
    absent = [path for path in (CHROMIUM, CHROMEDRIVER) if not os.access(path, os.X_OK)]
    return " and ".join(absent) + " not found" if absent else ""


def headless_chromium() -> webdriver.Chrome:
    """A fresh headless Chromium with its own profile folder; quit it when done."""
    options = webdriver.ChromeOptions()
    options.binary_location = CHROMIUM
    for flag in FLAGS:
        options.add_argument(flag)
    options.add_argument(f"--user-data-dir={tempfile.mkdtemp(prefix='seedtrack-chromium-')}")
    # Naming the driver's path keeps Selenium Manager from looking for (and fetching) one.
    return webdriver.Chrome(service=Service(executable_path=CHROMEDRIVER), options=options)
