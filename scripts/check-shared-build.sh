#!/usr/bin/env bash
# Fails when a dev-dependency turns on a feature of a crate the product
# also builds. Cargo unifies features across what one command builds, so
# such a feature gives that crate, and every crate above it, a second build
# for `cargo test`: the README's test command would then compile Typst or
# the workspace's crates again instead of sharing `cargo run --release`'s
# artifacts (docs/building.md, "The test command shares the release build").
set -euo pipefail
cd "$(dirname "$0")/.."
tree() {
    cargo tree --workspace -e "$1" --prefix none -f '{p}|{f}' | sed 's/ (\*)//g' | grep -v '^$' | sort -u
}
product="$(mktemp)"; tests="$(mktemp)"
trap 'rm -f "$product" "$tests"' EXIT
tree normal,build >"$product"
# Only the crates the product builds: the dev-dependencies' own crates are
# built for the tests alone.
tree normal,build,dev | awk -F'|' 'NR == FNR { built[$1] = 1; next } $1 in built' "$product" - >"$tests"
if ! diff -u "$product" "$tests"; then
    echo "error: the tests build these crates with other features than the product (- product, + tests)" >&2
    echo "hint: find the dev-dependency with 'cargo tree --workspace -e features,normal,build,dev -i CRATE'" >&2
    exit 1
fi
echo "the tests share the product's build of all $(cut -d'|' -f1 "$product" | sort -u | wc -l) crates"
