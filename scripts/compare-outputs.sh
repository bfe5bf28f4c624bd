#!/usr/bin/env bash
# Runs every shipped plan (test-plans/*.toml) with a fixed report date and
# compares the whole output directories, byte for byte, with a baseline.
# For refactors that must change no number (docs/architecture.md).
#
#   scripts/compare-outputs.sh BIN OUT            # make a baseline in OUT
#   scripts/compare-outputs.sh BIN OUT BASELINE   # compare OUT with BASELINE
#
# BIN is a ledflicker binary (e.g. target/debug/ledflicker built from the
# commit before the change). Exit codes of the runs are kept in
# OUT/exits.txt and compared too. Exits 1 when anything differs.
set -u
if [ $# -lt 2 ]; then
  sed -n '2,11p' "$0"; exit 2
fi
bin=$(realpath "$1"); out=$2; base=${3:-}
cd "$(dirname "$0")/.."
case "$out" in /*) ;; *) out="$PWD/$out" ;; esac
rm -rf "$out"; mkdir -p "$out"
for p in test-plans/*.toml; do
  n=$(basename "$p" .toml)
  env -u SOURCE_DATE_EPOCH "$bin" plan "$p" --out "$out/$n" --date 2026-01-01 -q --threads 2 \
    >"$out/$n.stdout" 2>"$out/$n.stderr"
  echo "$n exit $?" >>"$out/exits.txt"
done
cat "$out/exits.txt"
[ -z "$base" ] && exit 0
if diff -r -q "$base" "$out"; then echo "IDENTICAL"; else echo "DIFFERENT"; exit 1; fi
