#!/usr/bin/env bash
# The test command: installs what the tests need on a fresh machine, then
# runs the whole test suite. Used by the README and by .ci/run.
set -euo pipefail
cd "$(dirname "$0")/.."

# Snapshots never update silently in a test run; see README "Golden files".
export INSTA_UPDATE="${INSTA_UPDATE:-no}"

cargo test --all-targets "$@"
# Doc tests are not covered by --all-targets.
cargo test --doc "$@"
