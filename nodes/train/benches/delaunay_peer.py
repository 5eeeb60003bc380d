"""Peer timing for the tetrahedralization: scipy.spatial.Delaunay (Qhull) on the
same kinds of clouds as examples/bench_connectivity.rs (fresh random draws of the
same distributions). Run with the shared peers venv: python delaunay_peer.py [--quick]"""
import sys
import time

import numpy as np
from scipy.spatial import Delaunay


def clouds(n, rng):
    cube = rng.random((n, 3))
    p = rng.normal(size=(n, 3))
    p /= np.linalg.norm(p, axis=1, keepdims=True)
    p *= 1.0 + 0.01 * (rng.random((n, 1)) * 2 - 1)
    return [("cube", cube), ("sphere", p)]


def main():
    quick = "--quick" in sys.argv
    sizes = [1000, 10_000] if quick else [1000, 10_000, 50_000, 200_000]
    rng = np.random.default_rng(1)
    print("| points | cloud | scipy Delaunay (s) | tets |")
    print("|---|---|---|---|")
    for n in sizes:
        for name, pts in clouds(n, rng):
            reps = 3 if n <= 10_000 else 1
            best, tets = float("inf"), 0
            for _ in range(reps):
                t = time.perf_counter()
                tri = Delaunay(pts)
                best = min(best, time.perf_counter() - t)
                tets = len(tri.simplices)
            print(f"| {n} | {name} | {best:.3f} | {tets} |")


if __name__ == "__main__":
    main()
