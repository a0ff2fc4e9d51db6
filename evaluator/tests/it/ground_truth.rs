//! Ground truth from a sequence, exactly as the reference's run_slam.py builds it.

use std::path::Path;

use nalgebra::Matrix4;
use osmab_evaluator::formats::camera::CameraParams;
use osmab_evaluator::formats::image::{GrayImage16, RgbImage, write_jpeg_rgb, write_png_gray16};
use osmab_evaluator::formats::sequence::{Sequence, frame_path};
use osmab_evaluator::formats::trajectory::Trajectory;
use osmab_evaluator::ground_truth::GroundTruth;

use crate::common::classes;

const W: u32 = 6;
const H: u32 = 4;

fn depth_of(frame: usize, u: u32, v: u32) -> u16 {
    // Some pixels have no depth; the rest vary by frame and position.
    if (u + v + frame as u32) % 4 == 0 { 0 } else { 1000 + 37 * frame as u16 + 11 * u as u16 + 5 * v as u16 }
}

fn pose_of(frame: usize) -> Matrix4<f64> {
    let (s, c) = (0.1 * frame as f64).sin_cos();
    Matrix4::new(c, 0.0, s, 0.25 * frame as f64, 0.0, 1.0, 0.0, 1.5, -s, 0.0, c, -0.125, 0.0, 0.0, 0.0, 1.0)
}

fn write_sequence(dir: &Path, frames: usize) {
    std::fs::create_dir_all(dir.join("results")).unwrap();
    let camera = CameraParams { image_width: W, image_height: H, fx: 3.0, fy: 3.5, cx: 2.5, cy: 1.5, png_depth_scale: 6553.5, crop_edge: 0 };
    camera.write(&dir.join("camera_params.yaml")).unwrap();
    classes(20).write(&dir.join("embed_semseg_classes.json")).unwrap();
    Trajectory { poses: (0..frames).map(pose_of).collect() }.write(&dir.join("traj.txt")).unwrap();
    for f in 0..frames {
        let depth = GrayImage16 { width: W, height: H, pixels: (0..H).flat_map(|v| (0..W).map(move |u| depth_of(f, u, v))).collect() };
        write_png_gray16(&frame_path(dir, "depth", f), &depth).unwrap();
        let semantic = GrayImage16 { width: W, height: H, pixels: (0..W * H).map(|i| ((i + f as u32) % 20) as u16).collect() };
        write_png_gray16(&frame_path(dir, "semantic", f), &semantic).unwrap();
        let color = RgbImage { width: W, height: H, pixels: vec![128; (W * H * 3) as usize] };
        write_jpeg_rgb(&frame_path(dir, "frame", f), &color, 95).unwrap();
    }
}

/// The reference, written plainly: frames 0, 5, ... before the last, row-major
/// pixels with depth > 0, Open3D's arithmetic, every 10th point of the concatenation.
fn expected(frames: usize) -> (Vec<[f32; 3]>, Vec<i64>) {
    let mut all = Vec::new();
    for f in (0..frames - 1).step_by(5) {
        let m = pose_of(f);
        for v in 0..H {
            for u in 0..W {
                let d = depth_of(f, u, v);
                if d == 0 {
                    continue;
                }
                let z = (d as f32 / 6553.5f32) as f64;
                let x = (u as f64 - 2.5) * z / 3.0;
                let y = (v as f64 - 1.5) * z / 3.5;
                let p: [f32; 3] = std::array::from_fn(|r| (m[(r, 0)] * x + m[(r, 1)] * y + m[(r, 2)] * z + m[(r, 3)]) as f32);
                all.push((p, ((v * W + u + f as u32) % 20) as i64));
            }
        }
    }
    all.into_iter().step_by(10).unzip()
}

#[test]
fn ground_truth_uses_every_fifth_frame_but_the_last_and_every_tenth_point() {
    for frames in [11, 12] {
        let dir = tempfile::tempdir().unwrap();
        write_sequence(dir.path(), frames);
        let gt = GroundTruth::build(&Sequence::open(dir.path()).unwrap()).unwrap();
        let (points, labels) = expected(frames);
        assert_eq!(gt.points, points, "{frames} frames");
        assert_eq!(gt.labels, labels, "{frames} frames");
    }
}

#[test]
fn ground_truth_survives_a_write_and_read() {
    let dir = tempfile::tempdir().unwrap();
    write_sequence(&dir.path().join("seq"), 7);
    let gt = GroundTruth::build(&Sequence::open(&dir.path().join("seq")).unwrap()).unwrap();
    gt.write(&dir.path().join("gt")).unwrap();
    let back = GroundTruth::read(&dir.path().join("gt"), &classes(20)).unwrap();
    assert_eq!((back.points, back.labels), (gt.points, gt.labels));
}

#[test]
fn inconsistent_sequences_are_rejected() {
    let dir = tempfile::tempdir().unwrap();
    write_sequence(dir.path(), 6);
    std::fs::remove_file(frame_path(dir.path(), "depth", 3)).unwrap();
    let err = Sequence::open(dir.path()).unwrap_err();
    assert!(err.field == "depth*.png" && err.message.contains("found 5"), "{err}");

    let dir = tempfile::tempdir().unwrap();
    write_sequence(dir.path(), 6);
    Trajectory { poses: (0..4).map(pose_of).collect() }.write(&dir.path().join("traj.txt")).unwrap();
    assert!(Sequence::open(dir.path()).unwrap_err().message.contains("one pose per frame"));

    let dir = tempfile::tempdir().unwrap();
    write_sequence(dir.path(), 6);
    write_png_gray16(&frame_path(dir.path(), "depth", 0), &GrayImage16 { width: 2, height: 2, pixels: vec![1; 4] }).unwrap();
    let err = GroundTruth::build(&Sequence::open(dir.path()).unwrap()).unwrap_err();
    assert!(err.message.contains("expected 6x4 pixels"), "{err}");

    let dir = tempfile::tempdir().unwrap();
    write_sequence(dir.path(), 6);
    std::fs::write(frame_path(dir.path(), "semantic", 0), b"\x89PNG\r\n\x1a\ntruncated").unwrap();
    let err = GroundTruth::build(&Sequence::open(dir.path()).unwrap()).unwrap_err();
    assert!(err.file.ends_with("semantic000000.png"), "{err}");
}

#[test]
fn ground_truth_matches_open3d_bit_for_bit() {
    // A sequence with random rigid poses and the ground truth Open3D itself built from it
    // (bench/conformance_open3d.py --write-fixture).
    let fixture = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/open3d-gt");
    let gt = GroundTruth::build(&Sequence::open(&fixture.join("sequence")).unwrap()).unwrap();
    let out = tempfile::tempdir().unwrap();
    gt.write(out.path()).unwrap();
    let ours = std::fs::read(out.path().join("semantic.npy")).unwrap();
    assert_eq!(ours, std::fs::read(fixture.join("open3d/semantic.npy")).unwrap(), "semantic.npy is byte-identical");

    let reference = osmab_evaluator::formats::pcd::read_pcd(&fixture.join("open3d/pointcloud.pcd")).unwrap();
    assert_eq!(gt.points.len(), reference.points.len());
    for (i, (a, b)) in gt.points.iter().zip(&reference.points).enumerate() {
        assert_eq!(a.map(f32::to_bits), b.map(f32::to_bits), "point {i}: {a:?} vs Open3D {b:?}");
    }
    let header = |bytes: &[u8]| bytes[..bytes.windows(12).position(|w| w == b"DATA binary\n").unwrap()].to_vec();
    let theirs = std::fs::read(fixture.join("open3d/pointcloud.pcd")).unwrap();
    assert_eq!(header(&std::fs::read(out.path().join("pointcloud.pcd")).unwrap()), header(&theirs), "Open3D's PCD header");
    // Colours come from different JPEG decoders (libjpeg-turbo there); they are never scored.
    let colors = gt.colors.unwrap();
    let worst = colors.iter().zip(reference.colors.unwrap()).flat_map(|(a, b)| (0..3).map(move |c| a[c].abs_diff(b[c]))).max().unwrap();
    assert!(worst <= 4, "colours within a few levels of libjpeg-turbo's, worst {worst}");
}

#[test]
fn unsupported_camera_settings_are_named() {
    let dir = tempfile::tempdir().unwrap();
    write_sequence(dir.path(), 6);
    let yaml = dir.path().join("camera_params.yaml");
    let text = std::fs::read_to_string(&yaml).unwrap().replace("crop_edge: 0", "crop_edge: 8");
    std::fs::write(&yaml, text).unwrap();
    let err = GroundTruth::build(&Sequence::open(dir.path()).unwrap()).unwrap_err();
    assert_eq!(err.field, "camera_params.crop_edge");

    let dir = tempfile::tempdir().unwrap();
    write_sequence(dir.path(), 6);
    let yaml = dir.path().join("camera_params.yaml");
    let text = std::fs::read_to_string(&yaml).unwrap().replace("png_depth_scale: 6553.5", "png_depth_scale: 1e-60");
    std::fs::write(&yaml, text).unwrap();
    let err = GroundTruth::build(&Sequence::open(dir.path()).unwrap()).unwrap_err();
    assert_eq!(err.field, "camera_params.png_depth_scale");
}

#[test]
fn eight_bit_depth_images_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    write_sequence(dir.path(), 6);
    let path = frame_path(dir.path(), "depth", 0);
    let file = std::fs::File::create(&path).unwrap();
    let mut encoder = png::Encoder::new(file, W, H);
    encoder.set_color(png::ColorType::Grayscale);
    encoder.set_depth(png::BitDepth::Eight);
    encoder.write_header().unwrap().write_image_data(&vec![7u8; (W * H) as usize]).unwrap();
    let err = GroundTruth::build(&Sequence::open(dir.path()).unwrap()).unwrap_err();
    assert!(err.message.contains("expected a 16-bit grayscale PNG"), "{err}");
}
