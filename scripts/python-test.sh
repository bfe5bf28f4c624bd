#!/usr/bin/env bash
# The Python package (python/, docs/python.md): builds its wheel once,
# installs it into a fresh virtual environment and runs its pytest suite
# (python/tests), whose reference is the command line of the same build
# (target/release/ledflicker), then the benchmark against the Rust calls
# (python/bench/bench_metrics.py). Used by .ci/run after scripts/test.sh.
#
# The wheel is built by maturin into the workspace's target/, with the
# release profile: it shares every dependency's build with `cargo build
# --release` and the README's test command, so only PyO3, rust-numpy and
# the package's own crate are compiled here (about 40 s).
set -euo pipefail
cd "$(dirname "$0")/.."
root="$PWD"

venv() {
    if ! python3 -m venv "$1" 2>/dev/null; then
        # Debian's python3 leaves venv to a package of its own.
        if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null; then
            apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq python3-venv >/dev/null
            python3 -m venv "$1"
        else
            echo "error: python3 -m venv failed; install python3-venv" >&2
            exit 2
        fi
    fi
}

# The reference binary, with the default features the wheel has.
test -x target/release/ledflicker || cargo build --release

work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
echo "--- maturin build --release (python/)"
venv "$work/build"
"$work/build/bin/pip" install -q "maturin>=1.9,<2"
rm -rf target/wheels
"$work/build/bin/maturin" build --release -m python/Cargo.toml -o target/wheels
echo "--- the wheel into a fresh virtual environment"
venv "$work/env"
# matplotlib for the plot of docs/python.md, whose examples are run.
"$work/env/bin/pip" install -q target/wheels/ledflicker-*.whl pytest pandas matplotlib
echo "--- pytest python/tests"
# From outside the source tree, so that the installed package is tested;
# the runs' folders in $work, removed on exit, not kept by pytest in /tmp.
(cd "$work" && LEDFLICKER_CLI="$root/target/release/ledflicker" \
    "$work/env/bin/pytest" "$root/python/tests" -q -p no:cacheprovider \
    --basetemp "$work/pytest" --durations 8 "$@")
echo "--- python/bench/bench_metrics.py"
(cd "$work" && "$work/env/bin/python" "$root/python/bench/bench_metrics.py" --reps 11)
