#!/usr/bin/env bash
# The test command: installs what the tests need on a fresh machine, then
# runs the whole test suite. Used by the README and by .ci/run.
set -euo pipefail
cd "$(dirname "$0")/.."

# The video tests decode H.264 with the `ffmpeg` and `ffprobe` binaries
# (Debian package `ffmpeg`); install them when they are missing. They fail,
# never skip, without them.
if ! command -v ffmpeg >/dev/null 2>&1 || ! command -v ffprobe >/dev/null 2>&1; then
    echo "--- installing ffmpeg (apt-get)"
    SUDO=""
    if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
    $SUDO apt-get update -qq
    DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends ffmpeg >/dev/null
fi

# The PDF tests read report.pdf with pdftotext, pdfinfo and pdfsig (Debian's
# poppler-utils); the sign-off tests check signatures with `openssl cms` and
# make PKCS#12 files with `openssl pkcs12` (Debian's openssl). Install them
# when missing and we may (root, e.g. in CI).
if ! command -v pdftotext >/dev/null || ! command -v pdfinfo >/dev/null || ! command -v pdfsig >/dev/null; then
    if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null; then
        apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq poppler-utils
    else
        echo "error: pdftotext/pdfinfo/pdfsig not found; install poppler-utils (e.g. sudo apt-get install poppler-utils)" >&2
        exit 2
    fi
fi
if ! command -v openssl >/dev/null; then
    if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null; then
        apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends openssl
    else
        echo "error: openssl not found; install it (e.g. sudo apt-get install openssl)" >&2
        exit 2
    fi
fi

# The visual tests (tests/integration/visual.rs) load report.html in headless
# Chromium (Debian package `chromium`) for a screenshot and its console.
if ! command -v chromium >/dev/null 2>&1; then
    if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null; then
        echo "--- installing chromium (apt-get)"
        apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends chromium >/dev/null
    else
        echo "error: chromium not found; install it (e.g. sudo apt-get install chromium)" >&2
        exit 2
    fi
fi

# The lab tests (tests/integration/lab_gst.rs) record through
# `gst-launch-1.0` (Debian's gstreamer1.0-tools, -plugins-base for
# videoconvert, -plugins-good for multifilesrc, pngdec and y4menc) and
# from Aravis' fake GigE Vision camera (aravis-tools:
# arv-fake-gv-camera-0.8, whose library libaravis-0.8-0 holds the
# `aravissrc` element; aravis-tools-cli: arv-tool-0.8). They fail, never
# skip, without them.
if ! command -v gst-launch-1.0 >/dev/null || ! command -v arv-fake-gv-camera-0.8 >/dev/null \
    || ! command -v arv-tool-0.8 >/dev/null \
    || ! gst-inspect-1.0 y4menc >/dev/null 2>&1 || ! gst-inspect-1.0 aravissrc >/dev/null 2>&1; then
    if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null; then
        echo "--- installing GStreamer and Aravis (apt-get)"
        apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends \
            gstreamer1.0-tools gstreamer1.0-plugins-base gstreamer1.0-plugins-good aravis-tools \
            aravis-tools-cli >/dev/null
    else
        echo "error: gst-launch-1.0, its y4menc or aravissrc element, arv-fake-gv-camera-0.8 or arv-tool-0.8 not found; install them (e.g. sudo apt-get install gstreamer1.0-tools gstreamer1.0-plugins-base gstreamer1.0-plugins-good aravis-tools aravis-tools-cli)" >&2
        exit 2
    fi
fi

# Snapshots never update silently in a test run; see README "Golden files".
export INSTA_UPDATE="${INSTA_UPDATE:-no}"

# --release: the tests share every dependency's build with the README's
# `cargo run --release` (see [profile.bench] in Cargo.toml). The tests of
# the results database on PostgreSQL (tests/integration/campaign_pg.rs)
# need a server: scripts/pg-test-server.sh starts a throwaway one (and
# installs Debian's postgresql when missing) for the length of the run.
scripts/pg-test-server.sh cargo test --release --workspace --all-targets "$@"
# Doc tests are not covered by --all-targets.
cargo test --release --workspace --doc "$@"
