#!/usr/bin/env bash
# Installs Debian's Chromium (if missing) and runs the HTML report's browser test: the page opened
# headless, no console errors, every image decoded, key presses, clicks and sorting work, and a
# screenshot (its path is printed). Without a browser `cargo test` skips that test with a message.
set -euo pipefail
cd "$(dirname "$0")/../.."
if ! command -v chromium >/dev/null; then
    if [ "$(id -u)" -eq 0 ]; then apt-get install -y chromium; else sudo apt-get install -y chromium; fi
fi
cargo test -p lightlab-experiments --test report -- --nocapture
