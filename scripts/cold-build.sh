#!/usr/bin/env bash
# Cold release build of a fresh clone: what a new user pays on first build.
#
#   scripts/cold-build.sh [REV] [WORKDIR]
#   COLD_BUILD_ARGS=--no-default-features scripts/cold-build.sh [REV] [WORKDIR]
#
# COLD_BUILD_ARGS (default empty) is added to the cargo command, e.g. to
# measure the build without the PDF and the sign-off.
# Clones this repository at REV (default HEAD) into WORKDIR/src, then builds it
# with `cargo build --release --locked --timings` into an EMPTY target dir
# WORKDIR/target, under /usr/bin/time -v. Writes WORKDIR/summary.txt with:
# wall time, user+sys CPU time, peak RSS, the target dir size, the binary
# size, `uptime` load before and after (other builds on the machine inflate
# wall time, not CPU time much), and the slowest crates from cargo's
# --timings report (copied to WORKDIR/cargo-timing.html).
#
# Dependencies must already be in the cargo registry cache (~/.cargo); the
# script does not download anything beyond what `cargo build` fetches.
# WORKDIR must not exist yet (default: a new dir under ${TMPDIR:-/tmp}).
# Delete WORKDIR afterwards: the target dir is several GB.
set -euo pipefail
repo="$(cd "$(dirname "$0")/.." && pwd)"
rev="${1:-HEAD}"
work="${2:-}"
if [ -z "$work" ]; then
    work="$(mktemp -d "${TMPDIR:-/tmp}/cold-build.XXXXXX")"
    rmdir "$work"
fi
if [ -e "$work" ]; then
    echo "error: $work exists; give a new directory (the build must start cold)" >&2
    exit 2
fi
command -v /usr/bin/time >/dev/null || { echo "error: /usr/bin/time not found (Debian package 'time')" >&2; exit 2; }
mkdir -p "$work"
commit="$(git -C "$repo" rev-parse --verify "$rev^{commit}")"
git clone -q --no-local --no-checkout "$repo" "$work/src"
git -C "$work/src" checkout -q "$commit"

export CARGO_TARGET_DIR="$work/target"
load_before="$(uptime)"
start=$(date -u +%FT%TZ)
(cd "$work/src" && /usr/bin/time -v -o "$work/time.txt" \
    cargo build --release --locked --timings ${COLD_BUILD_ARGS:-}) 2>"$work/build.log"
load_after="$(uptime)"

field() { sed -n "s/^[[:space:]]*$1: //p" "$work/time.txt"; }
user=$(field 'User time (seconds)')
sys=$(field 'System time (seconds)')
wall=$(field 'Elapsed (wall clock) time (h:mm:ss or m:ss)')
rss_kb=$(field 'Maximum resident set size (kbytes)')
target_bytes=$(du -sb "$work/target" | cut -f1)
bin="$work/target/release/ledflicker"
bin_bytes=$(stat -c %s "$bin")
timing_html=$(ls -t "$work/target/cargo-timings"/cargo-timing-*.html | head -1)
cp "$timing_html" "$work/cargo-timing.html"

{
    echo "commit:        $commit"
    echo "started:       $start"
    echo "rustc:         $(rustc --version)"
    echo "cores:         $(nproc)"
    echo "command:       CARGO_TARGET_DIR=<empty> cargo build --release --locked --timings ${COLD_BUILD_ARGS:-}"
    echo "wall:          $wall"
    echo "cpu user+sys:  $(awk -v u="$user" -v s="$sys" 'BEGIN{printf "%.1f s (user %.1f, sys %.1f)", u+s, u, s}')"
    echo "peak rss:      $(awk -v k="$rss_kb" 'BEGIN{printf "%.0f MiB", k/1024}')"
    echo "target dir:    $(awk -v b="$target_bytes" 'BEGIN{printf "%.2f GiB (%d bytes)", b/2^30, b}')"
    echo "binary:        $(awk -v b="$bin_bytes" 'BEGIN{printf "%.1f MiB (%d bytes)", b/2^20, b}')"
    echo "crates built:  $(grep -c '^ *Compiling ' "$work/build.log" || true)"
    echo "load before:   $load_before"
    echo "load after:    $load_after"
    echo "slowest units (seconds, from cargo --timings):"
    # The timings page embeds `const UNIT_DATA = [...]` with one object per
    # compiled unit: name, version, target, duration.
    python3 - "$work/cargo-timing.html" <<'EOF'
import json, re, sys
html = open(sys.argv[1], encoding="utf-8").read()
m = re.search(r"const UNIT_DATA = (\[.*?\]);\s*\n", html, re.S)
units = json.loads(m.group(1)) if m else []
units.sort(key=lambda u: u.get("duration", 0), reverse=True)
for u in units[:15]:
    tgt = u.get("target", "").strip()
    print(f"  {u['duration']:7.1f}  {u['name']} {u['version']}{(' ' + tgt) if tgt else ''}")
EOF
} | tee "$work/summary.txt"
echo "(details: $work/summary.txt, $work/time.txt, $work/cargo-timing.html; delete $work when done)"
