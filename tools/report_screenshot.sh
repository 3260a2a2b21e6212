#!/bin/sh
# SPDX-License-Identifier: LGPL-2.1-or-later
# Screenshot of a deviation report in headless Chromium (for the README; not part of make test).
#   tools/report_screenshot.sh [REPORT_DIR] [OUT.png]
# Without REPORT_DIR it first writes the sample blade's report (robust rigid best fit).
# Needs Debian's chromium: sudo apt-get install chromium
set -e
dir=${1:-}
out=${2:-docs/screenshots/report_chromium_full.png}
if ! command -v chromium >/dev/null 2>&1; then
    echo "report_screenshot: chromium is not installed: sudo apt-get install chromium" >&2
    exit 2
fi
if [ -z "$dir" ]; then
    dir=$(mktemp -d)/report
    /usr/bin/python3 -m bladerecon deviation resources/sample/measured.csv \
        --nominal resources/sample/nominal.step --align rigid --robust --report "$dir" --quiet >/dev/null
fi
# --no-sandbox: Chromium refuses to run as root with its sandbox (CI containers run as root)
chromium --headless --no-sandbox --disable-gpu --hide-scrollbars --window-size=1400,5200 \
    --screenshot="$(realpath -m "$out")" "file://$(realpath "$dir")/report.html" 2>/dev/null
echo "report_screenshot: wrote $out from $dir/report.html"
