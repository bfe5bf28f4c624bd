#!/bin/sh
# Example lab rig for `[dut] backend = "command"` (docs/command-backend.md).
# A real rig would set the PWM controller to $LEDFLICKER_FREQUENCY_HZ and
# $LEDFLICKER_DUTY, run the ON / OFF / PWM sequence and save the camera's
# frames into $LEDFLICKER_OUT_DIR. This one makes the frames with the
# simulator (`ledflicker render`): a rolling-shutter camera, 30 fps, 11.1 ms
# exposure, looking at a diffusely lit scene.
set -eu
# The case also arrives as JSON on stdin; a rig may parse it instead of the
# environment. This example keeps a copy next to the frames' directory.
cat > "$LEDFLICKER_OUT_DIR.json"
exe="${LEDFLICKER_EXE:-ledflicker}"
exec "$exe" render \
    --frequency-hz "$LEDFLICKER_FREQUENCY_HZ" \
    --duty "$LEDFLICKER_DUTY" \
    --fps "$LEDFLICKER_FRAME_RATE_FPS" \
    --exposure-ms "${RIG_EXPOSURE_MS:-11.111}" \
    --shutter rolling --line-time-us 14.565 \
    --on-s "$LEDFLICKER_ON_S" --off-s "$LEDFLICKER_OFF_S" --pwm-s "$LEDFLICKER_PWM_S" \
    --width 64 --height 48 \
    --out "$LEDFLICKER_OUT_DIR"
