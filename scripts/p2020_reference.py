#!/usr/bin/env python3
"""Independent reference values for test-plans/p2020-samples.toml.

Follows the pipeline of the IEEE P2020 reference implementation
(CARpublic/P2020-flicker, measure_flicker_demo.py + metrics/flicker.py),
re-written here from its description, not copied:

- decode each video with OpenCV (its bundled FFmpeg) to 8-bit BGR;
- grey = cv2.cvtColor(BGR2GRAY), i.e. BT.601 weights on full-range RGB;
- per ROI (integer x, y, w, h from rois.csv, in file order): mean grey;
- PWM segment = frames 100 .. end; OFF reference x_off = mean of frames 0..24;
- FMI = (max - min) / (max + min) over the PWM segment;
- FDI = share of PWM frames with (x - x_off) / x_off > 0.1;
- MMP = share of PWM frames with x_ref*(1-0.1) < x < x_ref*(1+0.1),
  x_ref = PWM-segment mean;
- saturation flag: some frame's ROI mean > 240.

One deliberate difference: upstream's matrix starts with an uninitialised
column (np.empty) and reads frame 0 only to draw the ROIs, so its row 0 is
not frame 0. Here row i is frame i for every i. Rows 0..24 are black in the
three samples, so x_off is unaffected within the tolerance.

Writes reference-data/p2020-flicker-videos/expected_p2020.csv (per video and
ROI: fmi, fdi, mmp, x_off, sat), expected_grey_<video>.csv (per-frame ROI
means, for decoder comparisons) and expected_tiff_rois.csv (ROI means of
test.tiff, an LZW-compressed RGB frame). Usage:
  pip install numpy 'opencv-python-headless<5'   # OpenCV 4's 14-bit grey weights
  python3 scripts/p2020_reference.py
"""
import csv
import os
import sys

import cv2
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
DATA = os.path.join(HERE, "..", "reference-data", "p2020-flicker-videos")
START = 100
OFF_FRAMES = START // 4  # 25, as upstream's start_index / 4
THRESHOLD = 0.1
DELTA = 0.1
SAT = 240


def rois():
    with open(os.path.join(DATA, "rois.csv")) as f:
        return [
            (int(r["x_int"]), int(r["y_int"]), int(r["w_int"]), int(r["h_int"]))
            for r in csv.DictReader(f)
        ]


def roi_means(video, boxes):
    cap = cv2.VideoCapture(video)
    if not cap.isOpened():
        sys.exit(f"cannot open {video}")
    rows = []
    while True:
        ok, frame = cap.read()
        if not ok:
            break
        grey = cv2.cvtColor(frame, cv2.COLOR_BGR2GRAY)
        rows.append([float(np.mean(grey[y : y + h, x : x + w])) for (x, y, w, h) in boxes])
    cap.release()
    return np.array(rows)


def metrics(x):
    pwm = x[START:]
    with np.errstate(divide="ignore", invalid="ignore"):
        fmi = (pwm.max(0) - pwm.min(0)) / (pwm.max(0) + pwm.min(0))
        x_off = x[:OFF_FRAMES].mean(0)
        fdi = (((pwm - x_off) / x_off) > THRESHOLD).sum(0) / pwm.shape[0]
    ref = pwm.mean(0)
    mmp = ((pwm > ref - DELTA * ref) & (pwm < ref + DELTA * ref)).sum(0) / pwm.shape[0]
    sat = (x > SAT).any(0)
    return fmi, fdi, mmp, x_off, sat


def main():
    boxes = rois()
    out = [["video", "roi", "fmi", "fdi_p2020", "mmp", "x_off", "saturated", "frames"]]
    for name in ["test_vid1", "test_vid2", "test_vid3"]:
        x = roi_means(os.path.join(DATA, name + ".mp4"), boxes)
        with open(os.path.join(DATA, f"expected_grey_{name}.csv"), "w", newline="") as f:
            w = csv.writer(f)
            w.writerow(["frame"] + [f"roi{i}" for i in range(len(boxes))])
            for i, row in enumerate(x):
                w.writerow([i] + [f"{v:.4f}" for v in row])
        fmi, fdi, mmp, x_off, sat = metrics(x)
        for i in range(len(boxes)):
            out.append([name, i, f"{fmi[i]:.6f}", f"{fdi[i]:.6f}", f"{mmp[i]:.6f}",
                        f"{x_off[i]:.6f}", int(sat[i]), x.shape[0]])
        print(name, x.shape, "fmi", fmi.min(), fmi.max(), "fdi", fdi.min(), fdi.max(),
              "mmp", mmp.min(), mmp.max(), "x_off max", x_off.max())
    with open(os.path.join(DATA, "expected_p2020.csv"), "w", newline="") as f:
        csv.writer(f).writerows(out)
    # The LZW-compressed RGB TIFF frame: ROI means of BT.601 grey and of R, G, B.
    img = cv2.imread(os.path.join(DATA, "test.tiff"), cv2.IMREAD_COLOR)
    grey = cv2.cvtColor(img, cv2.COLOR_BGR2GRAY)
    with open(os.path.join(DATA, "expected_tiff_rois.csv"), "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["roi", "grey", "r", "g", "b"])
        for i, (x, y, wd, h) in enumerate(boxes):
            bgr = img[y : y + h, x : x + wd].reshape(-1, 3).mean(0)
            w.writerow([i, f"{np.mean(grey[y:y + h, x:x + wd]):.4f}",
                        f"{bgr[2]:.4f}", f"{bgr[1]:.4f}", f"{bgr[0]:.4f}"])


if __name__ == "__main__":
    main()
