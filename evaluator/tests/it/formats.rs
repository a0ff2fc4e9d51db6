//! Every reader accepts what the reference writes and rejects bad input with an
//! error that names the file, the field and the expectation.

use std::path::Path;

use osmab_evaluator::InputError;
use osmab_evaluator::formats::camera::CameraParams;
use osmab_evaluator::formats::classes::ClassList;
use osmab_evaluator::formats::map::{FeatureMatrix, MapSemantics, PredictedMap};
use osmab_evaluator::formats::npy::{NpyArray, ReadLimits};
use osmab_evaluator::formats::npz::write_npz;
use osmab_evaluator::formats::pcd::{PointCloud, read_pcd, write_pcd};
use osmab_evaluator::formats::ply::{SemanticMesh, read_semantic_mesh, write_semantic_mesh};
use osmab_evaluator::formats::trajectory::Trajectory;
use osmab_evaluator::ground_truth::GroundTruth;

use crate::common::classes;

fn write_arrays(path: &Path, arrays: &[(&str, NpyArray)]) {
    let refs: Vec<(&str, &NpyArray)> = arrays.iter().map(|(k, v)| (*k, v)).collect();
    write_npz(path, &refs, true).unwrap();
}

fn points(n: usize) -> NpyArray {
    NpyArray::from_f32_matrix(n, 3, (0..n * 3).map(|i| i as f32 * 0.1).collect())
}

fn read_map(path: &Path) -> Result<PredictedMap, InputError> {
    PredictedMap::read(path, ReadLimits::default())
}

#[test]
fn maps_survive_a_write_and_read_in_every_form() {
    let dir = tempfile::tempdir().unwrap();
    let forms = [
        MapSemantics::ObjectLabels { object_ids: vec![0, 1, 1], labels: vec![3, 4] },
        MapSemantics::ObjectFeatures { object_ids: vec![1, 0, 1], features: FeatureMatrix { rows: 2, dim: 2, values: vec![1.0, 0.0, 0.5, 0.5] } },
        MapSemantics::PointFeatures(FeatureMatrix { rows: 3, dim: 1, values: vec![1.0, 2.0, 3.0] }),
    ];
    for (i, semantics) in forms.into_iter().enumerate() {
        let path = dir.path().join(format!("map{i}.npz"));
        let map = PredictedMap { source: path.clone(), points: vec![[0.0, 1.0, 2.0], [3.0, 4.0, 5.0], [6.0, 7.0, 8.5]], semantics };
        map.write(&path, i % 2 == 0).unwrap();
        assert_eq!(read_map(&path).unwrap(), map);
    }
}

#[test]
fn float64_points_are_accepted() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("m.npz");
    let pts = NpyArray { shape: vec![2, 3], data: osmab_evaluator::formats::npy::NpyData::F64(vec![0.5, 1.0, 1.5, 2.0, 2.5, 3.0]) };
    write_arrays(&path, &[("points", pts), ("object_ids", NpyArray::from_i64(vec![0, 0])), ("labels", NpyArray::from_i64(vec![1]))]);
    assert_eq!(read_map(&path).unwrap().points, vec![[0.5, 1.0, 1.5], [2.0, 2.5, 3.0]]);
}

/// Each malformed map and the field its error must name.
#[test]
fn malformed_maps_get_their_own_clear_error() {
    let dir = tempfile::tempdir().unwrap();
    let ids = |v: Vec<i64>| NpyArray::from_i64(v);
    let cases: Vec<(&str, Vec<(&str, NpyArray)>, &str, &str)> = vec![
        ("wrong point shape", vec![("points", NpyArray::from_f32_matrix(2, 2, vec![0.0; 4]))], "points", "expected an (N, 3)"),
        ("no points", vec![("points", points(0)), ("object_ids", ids(vec![])), ("labels", ids(vec![1]))], "points", "no points"),
        (
            "nan point",
            vec![("points", NpyArray::from_f32_matrix(1, 3, vec![0.0, f32::NAN, 0.0])), ("object_ids", ids(vec![0])), ("labels", ids(vec![1]))],
            "points",
            "row 0, column 1 is NaN",
        ),
        ("missing object ids", vec![("points", points(2)), ("labels", ids(vec![1]))], "object_ids", "missing"),
        (
            "short object ids",
            vec![("points", points(3)), ("object_ids", ids(vec![0, 0])), ("labels", ids(vec![1]))],
            "object_ids",
            "one object id per point (3), found 2",
        ),
        (
            "object id out of range",
            vec![("points", points(2)), ("object_ids", ids(vec![0, 5])), ("labels", ids(vec![1, 2]))],
            "object_ids",
            "point 1 has object id 5",
        ),
        ("negative object id", vec![("points", points(1)), ("object_ids", ids(vec![-1])), ("labels", ids(vec![1]))], "object_ids", "object id -1"),
        (
            "labels and features",
            vec![("points", points(1)), ("object_ids", ids(vec![0])), ("labels", ids(vec![1])), ("features", NpyArray::from_f32_matrix(1, 2, vec![1.0, 0.0]))],
            "labels",
            "both",
        ),
        (
            "float labels",
            vec![("points", points(1)), ("object_ids", ids(vec![0])), ("labels", NpyArray::from_f32_matrix(1, 1, vec![1.0]))],
            "labels",
            "1-D integer",
        ),
        (
            "nan feature",
            vec![("points", points(1)), ("object_ids", ids(vec![0])), ("features", NpyArray::from_f32_matrix(1, 2, vec![f32::INFINITY, 0.0]))],
            "features",
            "finite",
        ),
        (
            "point features of wrong length",
            vec![("points", points(3)), ("point_features", NpyArray::from_f32_matrix(2, 4, vec![1.0; 8]))],
            "point_features",
            "one row per point (3), found 2",
        ),
        (
            "point features and objects",
            vec![("points", points(1)), ("point_features", NpyArray::from_f32_matrix(1, 1, vec![1.0])), ("object_ids", ids(vec![0]))],
            "point_features",
            "both",
        ),
        (
            "huge feature dimension",
            vec![("points", points(1)), ("object_ids", ids(vec![0])), ("features", NpyArray::from_f32_matrix(1, 10_000, vec![1.0; 10_000]))],
            "features",
            "1..=8192 dimensions",
        ),
        (
            "float64 beyond float32",
            vec![
                ("points", NpyArray { shape: vec![1, 3], data: osmab_evaluator::formats::npy::NpyData::F64(vec![0.0, 1e300, 0.0]) }),
                ("object_ids", ids(vec![0])),
                ("labels", ids(vec![1])),
            ],
            "points",
            "outside the float32 range",
        ),
    ];
    for (name, arrays, field, needle) in cases {
        let path = dir.path().join(format!("{}.npz", name.replace(' ', "_")));
        write_arrays(&path, &arrays);
        let err = read_map(&path).expect_err(name);
        assert_eq!(err.field, field, "{name}: {err}");
        assert!(err.message.contains(needle), "{name}: '{needle}' not in: {err}");
        assert!(err.file.ends_with(".npz"), "{name}: the file is named: {err}");
    }
}

#[test]
fn truncated_and_foreign_archives_are_rejected() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("map.npz");
    write_arrays(&path, &[("points", points(100)), ("object_ids", NpyArray::from_i64(vec![0; 100])), ("labels", NpyArray::from_i64(vec![1]))]);
    let bytes = std::fs::read(&path).unwrap();
    std::fs::write(&path, &bytes[..bytes.len() / 2]).unwrap();
    let err = read_map(&path).unwrap_err();
    assert!(err.message.contains("not a readable .npz"), "{err}");
    std::fs::write(&path, b"PK\x03\x04 this is not really a zip").unwrap();
    assert!(read_map(&path).unwrap_err().message.contains("not a readable .npz"));
    let err = read_map(&dir.path().join("absent.npz")).unwrap_err();
    assert_eq!(err.message, "file not found");
}

#[test]
fn an_npz_with_data_before_it_or_inside_another_archive_is_refused_as_numpy_refuses_it() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("map.npz");
    write_arrays(&path, &[("points", points(100)), ("object_ids", NpyArray::from_i64(vec![0; 100])), ("labels", NpyArray::from_i64(vec![1]))]);
    let npz = std::fs::read(&path).unwrap();
    assert!(read_map(&path).is_ok());
    // 1 MB of random-looking bytes, then the archive: a zip reader searching from the end finds it.
    let mut polyglot: Vec<u8> = (0..1_000_000u32).map(|i| (i.wrapping_mul(2_654_435_761) >> 24) as u8).collect();
    polyglot.extend_from_slice(&npz);
    std::fs::write(&path, &polyglot).unwrap();
    let err = read_map(&path).unwrap_err();
    assert!(err.message.contains("must start with a zip signature") && err.message.contains("np.load"), "{err}");
    // The archive inside a tar.
    let mut tar = tar::Builder::new(Vec::new());
    let mut header = tar::Header::new_gnu();
    header.set_size(npz.len() as u64);
    header.set_mode(0o644);
    header.set_cksum();
    tar.append_data(&mut header, "map.npz", &npz[..]).unwrap();
    std::fs::write(&path, tar.into_inner().unwrap()).unwrap();
    assert!(read_map(&path).unwrap_err().message.contains("must start with a zip signature"));
    // A zip signature first, and the real archive after other bytes: refused by where it starts.
    let mut shifted = b"PK\x03\x04".to_vec();
    shifted.extend_from_slice(&[0u8; 4096]);
    shifted.extend_from_slice(&npz);
    std::fs::write(&path, &shifted).unwrap();
    assert!(read_map(&path).is_err());
}

#[test]
fn arrays_larger_than_the_limit_are_refused_before_reading() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("big.npz");
    write_arrays(&path, &[("points", points(1000)), ("object_ids", NpyArray::from_i64(vec![0; 1000])), ("labels", NpyArray::from_i64(vec![1]))]);
    let err = PredictedMap::read(&path, ReadLimits { max_array_bytes: 1000, ..ReadLimits::default() }).unwrap_err();
    assert!(err.message.contains("larger than the limit"), "{err}");
}

#[test]
fn archive_bombs_are_refused_before_decompression() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bomb.npz");
    // 40 MB of zeros deflate to a few tens of kilobytes.
    let zeros = NpyArray::from_f32_matrix(10_000_000 / 3, 3, vec![0.0; 10_000_000 / 3 * 3]);
    write_arrays(&path, &[("points", zeros)]);
    assert!(std::fs::metadata(&path).unwrap().len() < 1 << 20);
    let limits = ReadLimits { max_array_bytes: 1 << 20, max_archive_bytes: 2 << 20, ..ReadLimits::default() };
    // Refused from the headers, before anything is inflated.
    let err = PredictedMap::read(&path, limits).unwrap_err();
    assert!(err.message.contains("39999996 bytes once read, more than the limit of 2097152"), "{err}");
    assert!(err.file.ends_with("bomb.npz"), "{err}");
}

#[test]
fn the_archive_budget_covers_all_its_arrays_together() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("map.npz");
    write_arrays(&path, &[("points", points(1000)), ("object_ids", NpyArray::from_i64(vec![0; 1000])), ("labels", NpyArray::from_i64(vec![1]))]);
    // Each array fits on its own (12 kB and 8 kB), both together do not.
    let limits = ReadLimits { max_array_bytes: 16_000, max_archive_bytes: 16_000, ..ReadLimits::default() };
    let err = PredictedMap::read(&path, limits).unwrap_err();
    assert_eq!(err.field, "(archive)", "{err}");
    assert!(err.message.contains("20008 bytes once read"), "{err}");
}

#[test]
fn a_map_is_checked_from_its_headers_before_any_array_is_read() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("map.npz");
    // 4 M points of zeros: 48 MB once read, a few hundred kilobytes compressed.
    let n = 4_000_000;
    write_arrays(
        &path,
        &[
            ("points", NpyArray::from_f32_matrix(n, 3, vec![0.0; n * 3])),
            ("object_ids", NpyArray::from_i64(vec![0; n])),
            ("labels", NpyArray::from_i64(vec![1])),
        ],
    );
    assert!(std::fs::metadata(&path).unwrap().len() < 2 << 20);
    let err = PredictedMap::read(&path, ReadLimits { max_archive_bytes: 30_000_000, ..ReadLimits::default() }).unwrap_err();
    assert!(err.message.contains("once read") && err.message.contains("30000000"), "{err}");
    let err = PredictedMap::read(&path, ReadLimits { max_points: 1_000_000, ..ReadLimits::default() }).unwrap_err();
    assert!(err.message.contains("4000000 points") && err.message.contains("one per pixel"), "{err}");
    // Rows that disagree are named before the points are read.
    write_arrays(&path, &[("points", points(10)), ("object_ids", NpyArray::from_i64(vec![0; 9])), ("labels", NpyArray::from_i64(vec![1]))]);
    let err = PredictedMap::read(&path, ReadLimits::default()).unwrap_err();
    assert_eq!(err.field, "object_ids", "{err}");
    // More objects than points (a deflated 'labels' of millions of zeros, say).
    write_arrays(&path, &[("points", points(10)), ("object_ids", NpyArray::from_i64(vec![0; 10])), ("labels", NpyArray::from_i64(vec![1; 5_000_000]))]);
    let err = PredictedMap::read(&path, ReadLimits::default()).unwrap_err();
    assert!(err.field == "labels" && err.message.contains("5000000 objects for 10 points"), "{err}");
}

fn cloud() -> PointCloud {
    PointCloud { points: vec![[0.5, -1.25, 3.0], [1e-3, 2.0, -7.5]], colors: Some(vec![[255, 0, 10], [1, 2, 3]]) }
}

#[test]
fn pcd_binary_as_open3d_writes_it_round_trips() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("pointcloud.pcd");
    write_pcd(&path, &cloud()).unwrap();
    let bytes = std::fs::read(&path).unwrap();
    let header = "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS x y z rgb\nSIZE 4 4 4 4\nTYPE F F F U\nCOUNT 1 1 1 1\nWIDTH 2\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 2\nDATA binary\n";
    assert!(bytes.starts_with(header.as_bytes()));
    assert_eq!(bytes.len(), header.len() + 2 * 16);
    // Colour bytes are B, G, R, 0 inside the rgb float.
    assert_eq!(&bytes[header.len() + 12..header.len() + 16], &[10, 0, 255, 0]);
    assert_eq!(read_pcd(&path).unwrap(), cloud());
}

#[test]
fn pcd_ascii_and_compressed_are_read() {
    let dir = tempfile::tempdir().unwrap();
    let ascii = dir.path().join("a.pcd");
    let packed = f32::from_le_bytes([10, 0, 255, 0]);
    std::fs::write(
        &ascii,
        format!("VERSION 0.7\nFIELDS x y z rgb\nSIZE 4 4 4 4\nTYPE F F F F\nCOUNT 1 1 1 1\nWIDTH 2\nHEIGHT 1\nPOINTS 2\nDATA ascii\n0.5 -1.25 3 {packed:e}\n0.001 2 -7.5 {:e}\n", f32::from_le_bytes([3, 2, 1, 0])),
    )
    .unwrap();
    assert_eq!(read_pcd(&ascii).unwrap(), cloud());
    // Open3D 0.20 writes rgb as an unsigned integer.
    std::fs::write(
        &ascii,
        format!(
            "FIELDS x y z rgb\nSIZE 4 4 4 4\nTYPE F F F U\nPOINTS 2\nDATA ascii\n0.5 -1.25 3 {}\n0.001 2 -7.5 {}\n",
            u32::from_le_bytes([10, 0, 255, 0]),
            u32::from_le_bytes([3, 2, 1, 0])
        ),
    )
    .unwrap();
    assert_eq!(read_pcd(&ascii).unwrap(), cloud());

    // binary_compressed with a literal-only LZF block holding x, y, z columns.
    let mut raw = Vec::new();
    for column in [[0.5f32, 1.0], [2.0, 3.0], [4.0, 5.0]] {
        for v in column {
            raw.extend_from_slice(&v.to_le_bytes());
        }
    }
    let mut lzf = vec![(raw.len() - 1) as u8];
    lzf.extend_from_slice(&raw);
    let compressed = dir.path().join("c.pcd");
    let mut bytes = b"FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 2\nHEIGHT 1\nPOINTS 2\nDATA binary_compressed\n".to_vec();
    bytes.extend_from_slice(&(lzf.len() as u32).to_le_bytes());
    bytes.extend_from_slice(&(raw.len() as u32).to_le_bytes());
    bytes.extend_from_slice(&lzf);
    std::fs::write(&compressed, bytes).unwrap();
    assert_eq!(read_pcd(&compressed).unwrap().points, vec![[0.5, 2.0, 4.0], [1.0, 3.0, 5.0]]);
}

#[test]
fn malformed_pcd_files_are_rejected() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bad.pcd");
    write_pcd(&path, &cloud()).unwrap();
    let bytes = std::fs::read(&path).unwrap();
    std::fs::write(&path, &bytes[..bytes.len() - 5]).unwrap();
    let err = read_pcd(&path).unwrap_err();
    assert!(err.message.contains("truncated"), "{err}");

    let cases = [
        ("FIELDS x y\nSIZE 4 4\nTYPE F F\nCOUNT 1 1\nPOINTS 0\nDATA binary\n", "missing field 'z'"),
        ("FIELDS x y z\nSIZE 4 4\nTYPE F F F\nPOINTS 0\nDATA binary\n", "same number"),
        ("FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nPOINTS 1\nDATA lzma\n", "expected ascii, binary"),
        ("FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 2\nHEIGHT 2\nPOINTS 3\nDATA binary\n", "disagrees"),
        ("FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nPOINTS 1\nDATA ascii\nnan 0 0\n", "non-finite"),
    ];
    for (text, needle) in cases {
        std::fs::write(&path, text).unwrap();
        let err = read_pcd(&path).unwrap_err();
        assert!(err.to_string().contains(needle), "'{needle}' not in: {err}");
    }
}

#[test]
fn hostile_pcd_headers_are_refused_before_allocating() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("hostile.pcd");
    let cases = [
        // A million-wide padding field would need a 64 GB read buffer.
        (&b"FIELDS x y z pad\nSIZE 4 4 4 1\nTYPE F F F U\nCOUNT 1 1 1 1000000\nPOINTS 1\nDATA binary\n"[..], "counts 1..=4096"),
        (&b"FIELDS x y z a b c d e f g h i j k l m n o p q r s\nSIZE 4 4 4 8 8 8 8 8 8 8 8 8 8 8 8 8 8 8 8 8 8 8\nTYPE F F F F F F F F F F F F F F F F F F F F F F\nCOUNT 1 1 1 4096 4096 4096 1 1 1 1 1 1 1 1 1 1 1 1 1 1 1 1\nPOINTS 1\nDATA binary\n"[..], "larger than 65536"),
        // A compressed block claiming 4 GB from a few bytes.
        (&b"FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nPOINTS 357913941\nDATA binary_compressed\n\x04\x00\x00\x00\xfc\xff\xff\xffabcd"[..], "corrupt"),
        // Far more points declared than the file holds.
        (&b"FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nPOINTS 4000000000\nDATA binary\n\x00\x00\x00\x00"[..], "truncated"),
    ];
    for (text, needle) in cases {
        std::fs::write(&path, text).unwrap();
        let err = read_pcd(&path).unwrap_err();
        assert!(err.to_string().contains(needle), "'{needle}' not in: {err}");
    }
}

#[test]
fn hostile_ply_headers_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("hostile.ply");
    let cases = [
        ("ply\nformat binary_little_endian 1.0\nelement nothing 10000000000000\nend_header\n", "no properties"),
        ("ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n", "end_header"),
        ("ply\nformat ascii 1.0\nelement vertex 1\nproperty quaternion x\nend_header\n", "unknown type"),
        ("plx\nend_header\n", "not a PLY file"),
    ];
    for (text, needle) in cases {
        std::fs::write(&path, text).unwrap();
        let err = read_semantic_mesh(&path).unwrap_err();
        assert!(err.to_string().contains(needle), "'{needle}' not in: {err}");
    }
}

fn write_gt(dir: &Path, labels: Vec<i64>) {
    write_pcd(&dir.join("pointcloud.pcd"), &cloud()).unwrap();
    osmab_evaluator::formats::npy::write_npy_file(&dir.join("semantic.npy"), &NpyArray::from_i64(labels)).unwrap();
}

#[test]
fn ground_truth_must_align_with_its_cloud_and_classes() {
    let dir = tempfile::tempdir().unwrap();
    write_gt(dir.path(), vec![1, 2]);
    assert_eq!(GroundTruth::read(dir.path(), &classes(3)).unwrap().labels, vec![1, 2]);
    write_gt(dir.path(), vec![1, 2, 3]);
    let err = GroundTruth::read(dir.path(), &classes(3)).unwrap_err();
    assert!(err.message.contains("one label per point") && err.file.ends_with("semantic.npy"), "{err}");
    write_gt(dir.path(), vec![1, 42]);
    let err = GroundTruth::read(dir.path(), &classes(3)).unwrap_err();
    assert!(err.message.contains("42"), "{err}");
}

#[test]
fn semantic_meshes_are_read_in_ascii_and_binary() {
    let dir = tempfile::tempdir().unwrap();
    let ascii = dir.path().join("mesh_semantic.ply");
    std::fs::write(
        &ascii,
        "ply\nformat ascii 1.0\ncomment test\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\nproperty uchar red\nelement face 2\nproperty list uchar int vertex_indices\nproperty int object_id\nend_header\n0 0 0 1\n1 0 0 1\n0 1 0 1\n5 5 5 1\n3 0 1 2 7\n3 0 2 1 7\n",
    )
    .unwrap();
    let mesh = read_semantic_mesh(&ascii).unwrap();
    assert_eq!(mesh.vertices.len(), 4);
    assert_eq!(mesh.face_objects, vec![7, 7]);

    let binary = dir.path().join("binary.ply");
    let mut bytes = b"ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nproperty int object_id\nend_header\n".to_vec();
    for v in [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0] {
        bytes.extend_from_slice(&v.to_le_bytes());
    }
    bytes.push(3);
    for i in [0i32, 1, 2, 9] {
        bytes.extend_from_slice(&i.to_le_bytes());
    }
    std::fs::write(&binary, &bytes).unwrap();
    let info = dir.path().join("info_semantic.json");
    std::fs::write(&info, r#"{"objects": [{"id": 9, "class_id": 2}], "classes": [{"id": 2, "name": "chair"}]}"#).unwrap();
    let gt = GroundTruth::read_mesh(&binary, &info).unwrap();
    assert_eq!(gt.labels, vec![2, 2, 2]);

    std::fs::write(&binary, &bytes[..bytes.len() - 2]).unwrap();
    assert!(read_semantic_mesh(&binary).unwrap_err().message.contains("truncated"));

    // What we write, we read back.
    let mesh = SemanticMesh {
        vertices: vec![[0.0, 1.0, 2.0], [3.0, 4.0, 5.0], [6.0, 7.0, 8.0]],
        face_vertices: vec![0, 1, 2],
        face_offsets: vec![0, 3],
        face_objects: vec![9],
    };
    let written = dir.path().join("written.ply");
    write_semantic_mesh(&written, &mesh).unwrap();
    assert_eq!(read_semantic_mesh(&written).unwrap(), mesh);

    // A face pointing past the vertices is named.
    let bad = dir.path().join("bad.ply");
    write_semantic_mesh(&bad, &SemanticMesh { face_vertices: vec![0, 1, 7], ..mesh }).unwrap();
    assert!(read_semantic_mesh(&bad).unwrap_err().message.contains("vertex index 7"));
}

#[test]
fn camera_params_and_trajectories_are_checked() {
    let dir = tempfile::tempdir().unwrap();
    let yaml = dir.path().join("camera_params.yaml");
    let params = CameraParams::from_hfov(1200, 680, 90.0, 6553.5);
    assert_eq!((params.fx, params.fy, params.cx, params.cy), (600.0000000000001, 600.0000000000001, 599.5, 339.5));
    params.write(&yaml).unwrap();
    assert_eq!(CameraParams::read(&yaml).unwrap(), params);
    std::fs::write(&yaml, "camera_params:\n  image_width: 10\n  image_height: 10\n  fx: -1\n  fy: 1\n  cx: 1\n  cy: 1\n  png_depth_scale: 1\n").unwrap();
    assert_eq!(CameraParams::read(&yaml).unwrap_err().field, "camera_params.fx");

    let traj = dir.path().join("traj.txt");
    std::fs::write(&traj, "1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1\n1 0 0\n").unwrap();
    let err = Trajectory::read(&traj).unwrap_err();
    assert_eq!((err.field.as_str(), err.message.contains("16 numbers")), ("line 2", true));
    std::fs::write(&traj, "1 0 0 0 0 1 0 0 0 0 1 0 0 0 2 1\n").unwrap();
    assert!(Trajectory::read(&traj).unwrap_err().message.contains("last row"));
}

#[test]
fn class_lists_reject_duplicates_and_accept_the_double_wrapped_variant() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("classes.json");
    std::fs::write(&path, r#"{"classes": {"classes": [{"name": "other", "id": 0}, {"name": "chair", "id": 3}]}}"#).unwrap();
    assert_eq!(ClassList::read(&path).unwrap().name(3), Some("chair"));
    std::fs::write(&path, r#"{"classes": [{"name": "a", "id": 1}, {"name": "b", "id": 1}]}"#).unwrap();
    assert!(ClassList::read(&path).unwrap_err().message.contains("listed twice"));
}
