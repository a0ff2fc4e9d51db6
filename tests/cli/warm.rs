//! A node made ready to score a release before any submission asks: every scene's ground
//! truth prepared and kept in the node's cache, and its box known to validation, so the
//! first submission is scored as fast as every later one.

use std::path::Path;

use osmab_evaluator::ground_truth::GroundTruth;
use osmab_evaluator::semseg::PreparedGroundTruth;
use osmab_evaluator::semseg::prepared_cache::{CacheKey, PreparedCache};
use osmab_evaluator::submission::extents::{ground_truth_extent, is_known};
use osmab_evaluator::submission::release::ReleaseIndex;
use osmab_evaluator::submission::warm::{Warmed, warm_release, warm_scene};
use osmab_evaluator::submission::{SubmissionLimits, score_submission_timed, validate};

use crate::service::{baseline_dir_of, test_release};

/// A copy of `from` at `to` (a release of its own: its files have other paths, so nothing
/// this process knows of the shared test release applies to it).
fn copy_tree(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for entry in std::fs::read_dir(from).unwrap() {
        let entry = entry.unwrap();
        let target = to.join(entry.file_name());
        if entry.file_type().unwrap().is_dir() {
            copy_tree(&entry.path(), &target);
        } else {
            std::fs::copy(entry.path(), &target).unwrap();
        }
    }
}

fn warm_all(index: &ReleaseIndex, cache: &PreparedCache) -> Vec<(String, Warmed)> {
    let mut seen = Vec::new();
    warm_release(index, cache, |scene, warmed| seen.push((scene.to_string(), warmed.clone()))).unwrap();
    seen
}

fn cache_entries(dir: &Path) -> Vec<std::path::PathBuf> {
    let mut found: Vec<_> = std::fs::read_dir(dir).unwrap().map(|e| e.unwrap().path()).filter(|p| p.extension().is_some_and(|x| x == "zgt")).collect();
    found.sort();
    found
}

#[test]
fn a_warmed_release_is_prepared_once_a_scene_known_to_validation_and_scored_from_the_cache() {
    let tmp = tempfile::tempdir().unwrap();
    let root = tmp.path().join("release");
    copy_tree(test_release(), &root);
    let index = ReleaseIndex::read(&root).unwrap();
    let scenes: Vec<String> = index.scenes.iter().map(|s| s.id.clone()).collect();
    assert_eq!(scenes, ["scene_000", "scene_001"]);
    let cache_dir = tmp.path().join("cache");
    let cache = PreparedCache::new(&cache_dir, 1 << 30);
    assert!(scenes.iter().all(|s| !is_known(&index, s)));

    let first = warm_all(&index, &cache);
    assert_eq!(first, scenes.iter().map(|s| (s.clone(), Warmed::Prepared)).collect::<Vec<_>>());
    assert_eq!(cache_entries(&cache_dir).len(), 2);
    for scene in &scenes {
        let dir = index.ground_truth_dir(scene);
        let classes = index.scene_classes(scene).unwrap();
        let read = GroundTruth::read(&dir, &classes).unwrap();
        // The box validation places maps in is the cloud's own, taken from the prepared points.
        assert!(is_known(&index, scene));
        let (lo, hi) = ground_truth_extent(&index, scene).unwrap();
        for a in 0..3 {
            assert_eq!(lo[a], read.points.iter().map(|p| p[a]).fold(f32::INFINITY, f32::min), "{scene} axis {a}");
            assert_eq!(hi[a], read.points.iter().map(|p| p[a]).fold(f32::NEG_INFINITY, f32::max), "{scene} axis {a}");
        }
        let prepared = PreparedGroundTruth::new(read, &classes).unwrap();
        let loaded = cache.load(&CacheKey::of(&dir).unwrap(), &dir, &classes).unwrap();
        assert_eq!(loaded.points(), prepared.points());
        assert_eq!(loaded.labels(), prepared.labels());
    }

    // Again: nothing left to do.
    let again = warm_all(&index, &cache);
    assert_eq!(again, scenes.iter().map(|s| (s.clone(), Warmed::AlreadyReady)).collect::<Vec<_>>());

    // The first submission takes every scene's ground truth from the cache.
    let oracle = baseline_dir_of(&root, "oracle");
    let limits = SubmissionLimits::for_release(&index, 1 << 32);
    let valid = validate(oracle.path(), &index, limits).unwrap();
    let (scores, timings) = score_submission_timed(&valid, &index, limits, Default::default(), Some(&cache), &|_, _| {}).unwrap();
    assert_eq!(timings.ground_truth_cached, 2, "{:?}", timings.cache_misses);
    assert_eq!(timings.prepare_ground_truth, std::time::Duration::ZERO);
    assert_eq!(scores.semseg[&osmab_evaluator::scores::Lighting::BASELINE].overall.miou, 1.0);

    // An entry gone, or cut short, is prepared again.
    let entries = cache_entries(&cache_dir);
    std::fs::remove_file(&entries[0]).unwrap();
    let bytes = std::fs::read(&entries[1]).unwrap();
    std::fs::write(&entries[1], &bytes[..bytes.len() - 16]).unwrap();
    let repaired = warm_all(&index, &cache);
    assert_eq!(repaired, scenes.iter().map(|s| (s.clone(), Warmed::Prepared)).collect::<Vec<_>>());

    // A scene whose ground truth is gone cannot be warmed, and says which file is missing.
    std::fs::remove_file(index.ground_truth_dir("scene_001").join("semantic.npy")).unwrap();
    let error = warm_scene(&index, "scene_001", &cache).unwrap_err().to_string();
    assert!(error.contains("scene_001/semantic.npy"), "{error}");
}
