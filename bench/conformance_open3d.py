"""Check `osmab gt build` against the reference pipeline run with Open3D itself.

Usage (from the repo root, after `cargo build --release -p osmab`):
    bench/.venv/bin/pip install numpy open3d        # once; not needed by the tests
    bench/.venv/bin/python bench/conformance_open3d.py [--frames 23] [--width 160] [--height 120]

It writes a random HaDaGe-style sequence (uint16 depth with holes, uint16 semantic ids, JPEG colour, random rigid
poses), builds the ground truth the way OSMa-Bench's run_slam.py does (Open3D RGBDImage.create_from_color_and_depth
with depth_trunc=inf, PointCloud.create_from_rgbd_image, transform(pose), +=, uniform_down_sample(10),
write_point_cloud, semantic ids from the semantic cloud's colours), runs `osmab gt build` on the same sequence and
compares: the PCD header, every coordinate bit for bit, the colours, the semantic ids and the semantic.npy bytes.
"""
import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import open3d as o3d


def random_pose(rng):
    q = rng.normal(size=4)
    w, x, y, z = q / np.linalg.norm(q)
    r = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                  [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                  [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])
    pose = np.eye(4)
    pose[:3, :3] = r
    pose[:3, 3] = rng.uniform(-5, 5, size=3)
    return pose


def write_sequence(seq, frames, w, h, rng):
    (seq / "results").mkdir(parents=True)
    fx = fy = float((w / 2) / np.tan(np.radians(90) / 2))
    cx, cy = (w - 1) / 2, (h - 1) / 2
    (seq / "camera_params.yaml").write_text(
        f"camera_params:\n  crop_edge: 0\n  cx: {cx!r}\n  cy: {cy!r}\n  fx: {fx!r}\n  fy: {fy!r}\n"
        f"  image_height: {h}\n  image_width: {w}\n  png_depth_scale: 6553.5\n")
    (seq / "embed_semseg_classes.json").write_text(json.dumps(
        {"classes": [{"name": f"class_{i}", "id": i} for i in range(40)]}))
    poses = [random_pose(rng) for _ in range(frames)]
    with open(seq / "traj.txt", "w") as f:
        for p in poses:
            f.write("".join(f"{v:.18e} " for v in p.reshape(-1)) + "\n")
    for i in range(frames):
        depth = rng.integers(1, 65535, size=(h, w), dtype=np.uint16)
        depth[rng.random((h, w)) < 0.15] = 0
        o3d.io.write_image(str(seq / f"results/depth{i:06d}.png"), o3d.geometry.Image(depth))
        sem = rng.integers(0, 40, size=(h, w), dtype=np.uint16)
        o3d.io.write_image(str(seq / f"results/semantic{i:06d}.png"), o3d.geometry.Image(sem))
        rgb = rng.integers(0, 256, size=(h, w, 3), dtype=np.uint8)
        o3d.io.write_image(str(seq / f"results/frame{i:06d}.jpg"), o3d.geometry.Image(rgb), quality=90)
    return poses, o3d.camera.PinholeCameraIntrinsic(w, h, fx, fy, cx, cy)


def reference(seq, poses, intrinsic, out):
    """run_slam.py's ground truth with Open3D."""
    frames = sorted((seq / "results").glob("frame*.jpg"))
    depths = sorted((seq / "results").glob("depth*.png"))
    sems = sorted((seq / "results").glob("semantic*.png"))
    cloud, semantic = o3d.geometry.PointCloud(), o3d.geometry.PointCloud()
    for i in range(0, len(frames) - 1, 5):
        depth = o3d.io.read_image(str(depths[i]))
        rgbd = o3d.geometry.RGBDImage.create_from_color_and_depth(
            o3d.io.read_image(str(frames[i])), depth, depth_scale=6553.5, depth_trunc=np.inf,
            convert_rgb_to_intensity=False)
        pcd = o3d.geometry.PointCloud.create_from_rgbd_image(rgbd, intrinsic)
        pcd.transform(poses[i])
        cloud += pcd
        rgbd_s = o3d.geometry.RGBDImage.create_from_color_and_depth(
            o3d.io.read_image(str(sems[i])), depth, depth_scale=6553.5, depth_trunc=np.inf)
        pcd_s = o3d.geometry.PointCloud.create_from_rgbd_image(rgbd_s, intrinsic)
        pcd_s.transform(poses[i])
        semantic += pcd_s
    cloud = cloud.uniform_down_sample(every_k_points=10)
    semantic = semantic.uniform_down_sample(every_k_points=10)
    out.mkdir(parents=True)
    o3d.io.write_point_cloud(str(out / "pointcloud.pcd"), cloud)
    ids = np.asarray(semantic.colors).round().astype(int)
    assert (ids[:, 0] == ids[:, 1]).all() and (ids[:, 0] == ids[:, 2]).all()
    np.save(out / "semantic.npy", ids[:, 0].astype(np.int64))


def read_pcd(path):
    data = path.read_bytes()
    end = data.index(b"DATA binary\n") + len(b"DATA binary\n")
    header = data[:end].decode()
    n = int(header.split("POINTS ")[1].split()[0])
    rec = np.frombuffer(data[end:], dtype=[("xyz", "<f4", 3), ("rgb", "u1", 4)], count=n)
    return header, rec["xyz"], rec["rgb"]


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=23)
    ap.add_argument("--width", type=int, default=160)
    ap.add_argument("--height", type=int, default=120)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--write-fixture", type=Path,
                    help="write the sequence and Open3D's ground truth to this directory (for the Rust tests) and stop")
    args = ap.parse_args()
    rng = np.random.default_rng(args.seed)
    if args.write_fixture:
        out = args.write_fixture
        poses, intrinsic = write_sequence(out / "sequence", args.frames, args.width, args.height, rng)
        reference(out / "sequence", poses, intrinsic, out / "open3d")
        (out / "README.md").write_text(
            "Written by `bench/conformance_open3d.py --write-fixture` with Open3D "
            f"{o3d.__version__}: `sequence/` is a random HaDaGe-style sequence, `open3d/` the ground truth that "
            "OSMa-Bench's run_slam.py procedure gives for it when run with Open3D itself.\n")
        return
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        poses, intrinsic = write_sequence(tmp / "seq", args.frames, args.width, args.height, rng)
        reference(tmp / "seq", poses, intrinsic, tmp / "open3d")
        subprocess.run(["target/release/osmab", "gt", "build", str(tmp / "seq"), "--out", str(tmp / "osmab")],
                       check=True, stdout=subprocess.DEVNULL)
        h_ref, xyz_ref, rgb_ref = read_pcd(tmp / "open3d/pointcloud.pcd")
        h_our, xyz_our, rgb_our = read_pcd(tmp / "osmab/pointcloud.pcd")
        report = {
            "open3d": o3d.__version__, "points": len(xyz_ref), "same_point_count": len(xyz_ref) == len(xyz_our),
            "header_identical": h_ref == h_our,
        }
        if report["same_point_count"]:
            diff = xyz_ref.view(np.uint32) != xyz_our.view(np.uint32)
            report["coordinates_differing_bits"] = int(diff.sum())
            report["max_abs_coordinate_diff"] = float(np.abs(xyz_ref - xyz_our).max())
            report["colour_channels_differing"] = int((rgb_ref != rgb_our).sum())
            report["max_colour_diff"] = int(np.abs(rgb_ref.astype(int) - rgb_our.astype(int)).max())
        sem_ref, sem_our = np.load(tmp / "open3d/semantic.npy"), np.load(tmp / "osmab/semantic.npy")
        report["semantic_identical"] = bool(np.array_equal(sem_ref, sem_our))
        report["semantic_npy_bytes_identical"] = (tmp / "open3d/semantic.npy").read_bytes() == (tmp / "osmab/semantic.npy").read_bytes()
        if not report["header_identical"]:
            report["header_open3d"], report["header_osmab"] = h_ref, h_our
        print(json.dumps(report, indent=2))
        ok = report["same_point_count"] and report["semantic_identical"] and report.get("coordinates_differing_bits") == 0
        sys.exit(0 if ok else 1)


if __name__ == "__main__":
    main()
