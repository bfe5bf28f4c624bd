#!/bin/sh
# Camera stand-in for a plan with a [source] light source (docs/lab.md).
# ledflicker starts this command, then plays the case's sequence on the
# light source: a dark lead-in of $LEDFLICKER_LEAD_IN_S seconds, ON, OFF,
# PWM. A real recorder would grab the camera for that long into
# $LEDFLICKER_OUT_DIR (e.g. with gst-launch-1.0); this one makes the frames
# a camera would have recorded with the simulator (`ledflicker render`),
# the lead-in as dark frames, so the run can be tried without a camera.
set -eu
exe="${LEDFLICKER_EXE:-ledflicker}"
work="$LEDFLICKER_OUT_DIR.render"
"$exe" render \
    --frequency-hz "$LEDFLICKER_FREQUENCY_HZ" \
    --duty "$LEDFLICKER_DUTY" \
    --fps "$LEDFLICKER_FRAME_RATE_FPS" \
    --exposure-ms 11.111 \
    --shutter rolling --line-time-us 14.565 \
    --on-s "$LEDFLICKER_ON_S" --off-s "$LEDFLICKER_OFF_S" --pwm-s "$LEDFLICKER_PWM_S" \
    --width 64 --height 48 \
    --out "$work" >/dev/null
# A frame well inside the OFF segment stands for the dark lead-in.
lead=$(awk -v l="$LEDFLICKER_LEAD_IN_S" -v f="$LEDFLICKER_FRAME_RATE_FPS" 'BEGIN { printf "%d", l * f + 0.5 }')
dark=$(awk -v o="$LEDFLICKER_ON_S" -v f="$LEDFLICKER_FRAME_RATE_FPS" 'BEGIN { printf "%d", o * f + 2.5 }')
dark=$(printf '%s/frame_%06d.png' "$work" "$dark")
i=0
while [ "$i" -lt "$lead" ]; do
    cp "$dark" "$(printf '%s/a_%06d.png' "$LEDFLICKER_OUT_DIR" "$i")"
    i=$((i + 1))
done
for f in "$work"/frame_*.png; do
    mv "$f" "$LEDFLICKER_OUT_DIR/b_${f##*/}"
done
