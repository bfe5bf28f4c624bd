#!/usr/bin/env python3
"""The P2020 reference pipeline (OpenCV decode, BGR2GRAY, 36 ROI means) on the
three sample videos, timed; examples/capture_bench.rs runs it for comparison."""
import cv2, numpy as np, csv, time
import os
D=os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "reference-data/p2020-flicker-videos/")
boxes=[(int(r["x_int"]),int(r["y_int"]),int(r["w_int"]),int(r["h_int"])) for r in csv.DictReader(open(D+"rois.csv"))]
t=time.time(); n=0
for v in ["test_vid1","test_vid2","test_vid3"]:
    cap=cv2.VideoCapture(D+v+".mp4")
    while True:
        ok,fr=cap.read()
        if not ok: break
        g=cv2.cvtColor(fr,cv2.COLOR_BGR2GRAY)
        m=[np.mean(g[y:y+h,x:x+w]) for (x,y,w,h) in boxes]
        n+=1
dt=time.time()-t
print(f"opencv pipeline: {n} frames, {n/dt:.0f} frames/s")
