#!/bin/sh
# Installs Debian's Chromium for the browser tests (pytest -m browser) when it is missing; the tests drive it with
# Playwright (pip install -e '.[test]') through executable_path, so no browser download is needed.
set -e
if ! command -v chromium >/dev/null 2>&1; then
    apt-get update -qq && apt-get install -y -qq chromium >/dev/null
fi
command -v chromium
