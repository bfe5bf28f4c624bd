#!/bin/sh
# A simulated camera for a [recorder] (docs/lab.md), looking at the SCPI
# instrument simulator's output instead of an LED:
#
#   sim-recorder.sh OUT_DIR DURATION_S FPS [INSTRUMENT_LOG]
#
# INSTRUMENT_LOG defaults to $LEDFLICKER_INSTRUMENT_LOG (the file given to
# `ledflicker rig simulate --log`), as test-plans/bench-example.toml runs it.
# It "records" for DURATION_S seconds, as a camera started by ledflicker
# would, then reads from INSTRUMENT_LOG (the simulator's log: Unix time,
# connection, line) what the instrument was told while it recorded: when
# the output went on and off, and the square wave's frequency and duty.
# From those times and settings it renders the frames the camera would
# have seen with the simulator (`ledflicker render`, the camera of
# test-plans/bench-example.toml), dark while the output was off, into OUT_DIR.
# Nothing comes from the case's plan values: a wrong line sent to the
# instrument gives wrong frames. Reads the Keysight 33500B template's
# lines on channel 1.
set -eu
out="$1" duration="$2" fps="$3" log="${4:-${LEDFLICKER_INSTRUMENT_LOG:-}}"
if [ -z "$log" ]; then
    echo "sim-recorder.sh: no instrument log: set LEDFLICKER_INSTRUMENT_LOG to the file of \`ledflicker rig simulate --log\` (scripts/lab-sim.sh does)" >&2
    exit 2
fi
exe="${LEDFLICKER_EXE:-ledflicker}"
start=$(date +%s.%N)
sleep "$duration"
if [ ! -f "$log" ]; then
    echo "sim-recorder.sh: the instrument log $log does not exist: is \`ledflicker rig simulate --log $log\` the instrument?" >&2
    exit 2
fi
steps=$(awk -v t0="$start" -v t1="$(date +%s.%N)" '
    $1 < t0 { next }
    { line = $0; sub(/^[^ ]+ [^ ]+ /, "", line) }
    line ~ /^SOUR1:FREQ / { freq = substr(line, 12) }
    line ~ /^SOUR1:FUNC:SQU:DCYC / { duty = substr(line, 21) / 100 }
    line == "OUTP1 ON" { ons++; if (ons == 1) t_on = $1; else if (ons == 2) t_pwm = $1 }
    line == "OUTP1 OFF" && ons == 1 && t_off == "" { t_off = $1 }
    line == "OUTP1 OFF" && ons == 2 && t_end == "" { t_end = $1 }
    END {
        if (t_pwm == "" || freq == "" || duty == "") {
            print "the instrument log shows no ON, OFF and PWM steps while recording" > "/dev/stderr"
            exit 1
        }
        if (t_end == "") t_end = t1
        printf "%.6f %.6f %.6f %.6f %s %s\n", t_on - t0, t_off - t_on, t_pwm - t_off, t_end - t_pwm, freq, duty
    }
' "$log")
set -- $steps
lead="$1" on="$2" off="$3" pwm="$4" freq="$5" duty="$6"
work="$out.render"
"$exe" render \
    --frequency-hz "$freq" --duty "$duty" --fps "$fps" \
    --exposure-ms 11.111 --shutter rolling --line-time-us 14.565 \
    --on-s "$on" --off-s "$off" --pwm-s "$pwm" \
    --width 64 --height 48 --out "$work" 2>/dev/null
# A frame inside the OFF segment stands for every dark frame: before ON
# (the lead-in) and after the end, up to the recording's length.
frames=$(awk -v d="$duration" -v f="$fps" 'BEGIN { printf "%d", d * f + 0.5 }')
lead=$(awk -v l="$lead" -v f="$fps" 'BEGIN { printf "%d", l * f + 0.5 }')
dark=$(awk -v o="$on" -v f="$fps" 'BEGIN { printf "%d", o * f + 2.5 }')
cp "$(printf '%s/frame_%06d.png' "$work" "$dark")" "$out.dark.png"
dark="$out.dark.png"
i=0
while [ "$i" -lt "$lead" ]; do
    cp "$dark" "$(printf '%s/a_%06d.png' "$out" "$i")"
    i=$((i + 1))
done
for f in "$work"/frame_*.png; do
    mv "$f" "$out/b_${f##*/}"
    i=$((i + 1))
done
while [ "$i" -lt "$frames" ]; do
    cp "$dark" "$(printf '%s/c_%06d.png' "$out" "$i")"
    i=$((i + 1))
done
