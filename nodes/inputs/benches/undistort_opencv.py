"""OpenCV's side of examples/bench_undistort.rs: the same camera, map and one frame.

    python3 undistort_opencv.py     (numpy, opencv-python-headless)

Prints the median of 7 runs of building the map (cv2.fisheye.initUndistortRectifyMap,
CV_16SC2 as cv2.fisheye.undistortImage uses) and of resampling one RGB frame (cv2.remap,
INTER_LINEAR), in milliseconds, with OpenCV's thread count.
"""
import time

import cv2
import numpy as np

W, H = 1752, 1168
K = np.array([[1150.0, 0, 876.0 - 0.5], [0, 1150.0, 584.0 - 0.5], [0, 0, 1]])
D = np.array([-0.03, -0.005, 0.0007, -0.0002])


def median_ms(f):
    times = []
    for _ in range(7):
        t = time.perf_counter()
        f()
        times.append((time.perf_counter() - t) * 1e3)
    return sorted(times)[3]


def main():
    # The pinhole camera bench_undistort prints (COLMAP's choice), principal point shifted
    # to OpenCV's pixel-centre convention.
    size = (2260, 1291)
    Knew = np.array([[1150.0, 0, 1130.0 - 0.5], [0, 1150.0, 645.5 - 0.5], [0, 0, 1]])
    y, x = np.mgrid[0:H, 0:W]
    img = np.stack([(x * 3 + y * 7 + c * 50) % 256 for c in range(3)], -1).astype(np.uint8)
    maps = {}

    def build():
        maps["m"] = cv2.fisheye.initUndistortRectifyMap(K, D, np.eye(3), Knew, size, cv2.CV_16SC2)

    build_ms = median_ms(build)
    m1, m2 = maps["m"]
    apply_ms = median_ms(lambda: cv2.remap(img, m1, m2, cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT))
    print(f"OpenCV {cv2.__version__}, {cv2.getNumThreads()} threads")
    print(f"build map: {build_ms:.1f} ms; resample one frame: {apply_ms:.1f} ms")


if __name__ == "__main__":
    main()
