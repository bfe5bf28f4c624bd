#!/usr/bin/env bash
# Load time of a report.html in headless Chromium: the time from navigation
# start to the page's `load` event (performance.now() in a load handler),
# median of RUNS runs (default 5), in milliseconds. A measurement, not a test.
#
#   scripts/html_load_time.sh reports/grid-192/report.html
#
# The page is loaded from a copy with one inline script appended that writes
# the time into the DOM, which `--dump-dom` prints. Needs `chromium`
# (Debian package; scripts/test.sh installs it).
set -euo pipefail
html="${1:?usage: $0 REPORT.html [RUNS]}"
runs="${2:-5}"
[ -f "$html" ] || { echo "error: no such file: $html" >&2; exit 2; }
command -v chromium >/dev/null || { echo "error: chromium not found (apt-get install chromium)" >&2; exit 2; }

work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
probe='<script>addEventListener("load", function () { document.documentElement.setAttribute("data-load-ms", performance.now().toFixed(1)); var n = performance.getEntriesByType("navigation")[0]; document.documentElement.setAttribute("data-dcl-ms", n ? n.domContentLoadedEventEnd.toFixed(1) : "?"); });</script>'
# Same directory as the original, so relative links (charts/, traces/) resolve.
copy="$(dirname "$html")/.load-time-probe.html"
trap 'rm -rf "$work" "$copy"' EXIT
sed "s#</body>#${probe}</body>#" "$html" > "$copy"
grep -q 'data-load-ms' "$copy" || { echo "error: $html has no </body>" >&2; exit 2; }

times=()
for i in $(seq 1 "$runs"); do
    dom="$(chromium --headless --no-sandbox --disable-gpu --disable-quic --no-first-run \
        --disable-background-networking --disable-component-update --disable-sync \
        --user-data-dir="$work/profile-$i" --window-size=1200,2400 \
        --dump-dom "file://$(realpath "$copy")" 2>/dev/null)"
    ms="$(printf '%s' "$dom" | grep -o 'data-load-ms="[0-9.]*"' | head -1 | grep -o '[0-9.]*' || true)"
    dcl="$(printf '%s' "$dom" | grep -o 'data-dcl-ms="[0-9.?]*"' | head -1 | cut -d'"' -f2 || true)"
    [ -n "$ms" ] || { echo "error: run $i: no load time in the dumped DOM" >&2; exit 3; }
    echo "run $i: load ${ms} ms (DOMContentLoaded ${dcl} ms)" >&2
    times+=("$ms")
done
median="$(printf '%s\n' "${times[@]}" | sort -n | awk '{a[NR]=$1} END {print (NR % 2) ? a[(NR+1)/2] : (a[NR/2] + a[NR/2+1]) / 2}')"
echo "$html: $(stat -c %s "$html") bytes; load event at ${median} ms (median of $runs runs)"
