"""OpenCV baseline for the centroiding benchmark (make bench-centroid).

Reads the frame and the C benchmark's timings from OUTDIR (written by
tests/bench/bench_centroid.c), times cv2.threshold + connectedComponentsWithStats
+ per-blob intensity moments on the same frame at the same threshold, reads the
callgrind instruction count of one full-frame call, and prints the ratios.
OpenCV runs single-threaded (cv2.setNumThreads(1)), as the flight code does,
with its faster (16-bit) label type. Frames are cache-warm for both sides.
"""

import sys
import time
from pathlib import Path

import cv2
import numpy as np


def read_kv(path: Path) -> dict[str, float]:
    out = {}
    for line in path.read_text().splitlines():
        key, value = line.split()
        out[key] = float(value)
    return out


def callgrind_instructions(path: Path) -> int | None:
    if not path.exists():
        return None
    for line in path.read_text().splitlines():
        if line.startswith("summary:") or line.startswith("totals:"):
            return int(line.split()[1])
    return None


def opencv_centroids(img: np.ndarray, threshold: int) -> list[tuple[float, float]]:
    """Pixels >= threshold, 8-connected components, intensity-weighted moments per blob."""
    _, binary = cv2.threshold(img, threshold - 1, 255, cv2.THRESH_BINARY)
    # 16-bit labels: faster than the default 32-bit ones here (fewer than 65535 blobs)
    n, labels, stats, _ = cv2.connectedComponentsWithStats(binary, connectivity=8, ltype=cv2.CV_16U)
    out = []
    for k in range(1, n):
        x, y, w, h, _area = stats[k]
        win = img[y : y + h, x : x + w]
        weights = np.where(labels[y : y + h, x : x + w] == k, win, 0).astype(np.float32)
        m = cv2.moments(weights)
        if m["m00"] > 0:
            out.append((x + m["m10"] / m["m00"], y + m["m01"] / m["m00"]))
    return out


def main() -> int:
    outdir = Path(sys.argv[1])
    c = read_kv(outdir / "centroid_c.txt")
    img = cv2.imread(str(outdir / "centroid_frame.pgm"), cv2.IMREAD_UNCHANGED)
    if img is None or img.shape != (int(c["height"]), int(c["width"])):
        print("bench_centroid_opencv: cannot read the frame", file=sys.stderr)
        return 1
    cv2.setNumThreads(1)
    threshold = int(c["threshold_dn"])
    blobs = opencv_centroids(img, threshold)
    times = []
    for _ in range(31):
        t0 = time.perf_counter()
        for _ in range(5):
            opencv_centroids(img, threshold)
        times.append((time.perf_counter() - t0) / 5)
    t_cv = float(np.median(times))
    mb = img.size / 1e6
    t_full, t_memcpy, t_roi = c["t_full_s"], c["t_memcpy_s"], c["t_roi_s"]
    instr = callgrind_instructions(outdir / "centroid.callgrind")
    what = f"threshold + connectedComponentsWithStats + moments, {len(blobs)} blobs"
    print(f"  OpenCV {cv2.__version__} ({what}):")
    print(f"                                    {1e3 * t_cv:8.3f} ms  {mb / t_cv:8.1f} MB/s")
    if instr is not None:
        px = img.size
        print(f"  callgrind, one full-frame call  : {instr} instructions ({instr / px:.3f} per pixel)")
    else:
        print("  callgrind: no count (valgrind missing or failed)")
    r_cv = t_cv / t_full
    r_mem = t_memcpy / t_full
    print("centroid bench ratios (full frame):")
    print(f"  ours / OpenCV   = {r_cv:6.2f}x  (target >= 3x: {'met' if r_cv >= 3 else 'NOT met'})")
    print(f"  ours / memcpy   = {r_mem:6.2f}   (target >= 0.50: {'met' if r_mem >= 0.5 else 'NOT met'})")
    print(f"  ROI mode / OpenCV full frame = {t_cv / t_roi:6.1f}x")
    return 0


if __name__ == "__main__":
    sys.exit(main())
