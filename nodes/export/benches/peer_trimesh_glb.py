"""Peer timing for the export benchmark: trimesh writes the same scene as one .glb.

Reads the per-component PLYs that `examples/bench_export.rs` left in OUT_DIR/ply, builds a
trimesh Scene (one node per component, vertex colours) and exports GLB; prints the median of
5 runs of the export alone (loading is not timed).
Usage: python peer_trimesh_glb.py OUT_DIR
"""
import pathlib
import sys
import time

import trimesh


def main() -> None:
    out = pathlib.Path(sys.argv[1])
    scene = trimesh.Scene()
    for ply in sorted((out / "ply").glob("*.ply")):
        mesh = trimesh.load(ply, process=False)
        scene.add_geometry(mesh, node_name=ply.stem, geom_name=ply.stem)
    triangles = sum(len(g.faces) for g in scene.geometry.values())
    times = []
    for _ in range(5):
        start = time.perf_counter()
        data = scene.export(file_type="glb")
        (out / "peer_trimesh.glb").write_bytes(data)
        times.append(time.perf_counter() - start)
    times.sort()
    t = times[2]
    print(f"trimesh {trimesh.__version__} export glb: {t:.4f} s median of 5 ({triangles / t / 1e6:.1f} M tri/s)")


if __name__ == "__main__":
    main()
