#!/usr/bin/env bash
# Debian's Chromium, for the demonstration page's browser test (tests/integration/test_demo_ui.py
# drives it headless with Playwright; Playwright's own browser download is not used). Run as
# root (or with sudo) on Debian or Ubuntu. Idempotent.
set -euo pipefail

if command -v chromium >/dev/null 2>&1; then
    echo "install-chromium: $(chromium --version 2>/dev/null || echo chromium) already installed"
    exit 0
fi
apt-get update
DEBIAN_FRONTEND=noninteractive apt-get install -y --no-install-recommends chromium
echo "install-chromium: $(chromium --version 2>/dev/null) installed"
