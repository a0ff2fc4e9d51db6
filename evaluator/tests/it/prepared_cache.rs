//! The node-local cache of ground truth prepared for scoring: an entry gives back exactly
//! what preparing gives, belongs to the files it was made from, and a damaged, foreign or
//! evicted entry is a miss, never a different score.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use osmab_evaluator::formats::classes::ClassList;
use osmab_evaluator::ground_truth::GroundTruth;
use osmab_evaluator::semseg::background_store::BackgroundStore;
use osmab_evaluator::semseg::prepared_cache::{CacheKey, PreparedCache};
use osmab_evaluator::semseg::{PreparedGroundTruth, score_prepared};
use osmab_evaluator::synthetic::{SceneSpec, SyntheticScene, generate};

const SPEC: SceneSpec = SceneSpec { gt_points: 30_000, map_points: 3_000, objects: 8, feature_dim: 8, seed: 11, map_covers_room: false };

/// A synthetic scene with its ground truth written to `dir/gt`.
fn scene_on_disk(dir: &Path) -> (SyntheticScene, PathBuf) {
    let scene = generate(SPEC);
    let gt_dir = dir.join("gt");
    scene.ground_truth.write(&gt_dir).unwrap();
    (scene, gt_dir)
}

fn prepare(gt_dir: &Path, classes: &ClassList) -> PreparedGroundTruth {
    PreparedGroundTruth::new(GroundTruth::read(gt_dir, classes).unwrap(), classes).unwrap()
}

fn entries(dir: &Path) -> Vec<PathBuf> {
    let mut found: Vec<PathBuf> = std::fs::read_dir(dir).unwrap().map(|e| e.unwrap().path()).collect();
    found.sort();
    found
}

#[test]
fn a_stored_ground_truth_comes_back_exactly_as_prepared_and_scores_alike() {
    let tmp = tempfile::tempdir().unwrap();
    let (scene, gt_dir) = scene_on_disk(tmp.path());
    let cache = PreparedCache::new(tmp.path().join("cache"), 1 << 30);
    let key = CacheKey::of(&gt_dir).unwrap();
    assert_eq!(cache.load(&key, &gt_dir, &scene.classes).err().unwrap().0, "not cached yet");

    let prepared = prepare(&gt_dir, &scene.classes);
    cache.store(&key, &prepared).unwrap();
    let loaded = cache.load(&key, &gt_dir, &scene.classes).unwrap();
    assert_eq!(loaded.points(), prepared.points());
    assert_eq!(loaded.labels(), prepared.labels());
    let map = scene.another_map(SPEC, &scene.text, 5);
    let fresh = score_prepared(&prepared, &map, &scene.classes, Some(&scene.text)).unwrap();
    let cached = score_prepared(&loaded, &map, &scene.classes, Some(&scene.text)).unwrap();
    assert_eq!(cached.confusion, fresh.confusion);
    // One entry, no temporary file left behind.
    let files = entries(&tmp.path().join("cache"));
    assert_eq!(files.len(), 1, "{files:?}");
    assert!(files[0].extension().unwrap() == "zgt", "{files:?}");
}

#[test]
fn a_ground_truth_read_into_the_memory_of_another_is_the_one_stored() {
    // A scorer reads each scene into the memory of the scene before: larger, smaller or
    // of the same size, what comes back is the entry, to the last point.
    let tmp = tempfile::tempdir().unwrap();
    let cache = PreparedCache::new(tmp.path().join("cache"), 1 << 30);
    let mut stored = Vec::new();
    for (name, gt_points) in [("large", 40_000), ("small", 7_000), ("middle", 20_000)] {
        let spec = SceneSpec { gt_points, seed: gt_points as u64, ..SPEC };
        let scene = generate(spec);
        let gt_dir = tmp.path().join(name);
        scene.ground_truth.write(&gt_dir).unwrap();
        let key = CacheKey::of(&gt_dir).unwrap();
        let prepared = prepare(&gt_dir, &scene.classes);
        cache.store(&key, &prepared).unwrap();
        stored.push((key, gt_dir, scene.classes, prepared));
    }
    let mut spare = None;
    for (key, gt_dir, classes, prepared) in stored.iter().chain(&stored) {
        let loaded = cache.load_reusing(key, gt_dir, classes, spare.take()).unwrap();
        assert_eq!(loaded.points(), prepared.points(), "{}", gt_dir.display());
        assert_eq!(loaded.labels(), prepared.labels(), "{}", gt_dir.display());
        spare = Some(loaded);
    }
}

#[test]
fn labels_beyond_32_bits_are_kept_exactly() {
    let tmp = tempfile::tempdir().unwrap();
    let mut scene = generate(SPEC);
    let big = 5_000_000_000i64;
    let mut entries: Vec<_> = scene.classes.entries().to_vec();
    entries.push(osmab_evaluator::formats::classes::ClassEntry { name: "big".into(), id: big });
    scene.classes = ClassList::new(entries).unwrap();
    scene.ground_truth.labels[3] = big;
    let gt_dir = tmp.path().join("gt");
    scene.ground_truth.write(&gt_dir).unwrap();
    let cache = PreparedCache::new(tmp.path().join("cache"), 1 << 30);
    let key = CacheKey::of(&gt_dir).unwrap();
    let prepared = prepare(&gt_dir, &scene.classes);
    cache.store(&key, &prepared).unwrap();
    let loaded = cache.load(&key, &gt_dir, &scene.classes).unwrap();
    assert_eq!(loaded.labels(), prepared.labels());
    assert!(loaded.labels().contains(&big));
}

#[test]
fn rewritten_ground_truth_files_are_not_served_from_an_old_entry() {
    let tmp = tempfile::tempdir().unwrap();
    let (mut scene, gt_dir) = scene_on_disk(tmp.path());
    let cache = PreparedCache::new(tmp.path().join("cache"), 1 << 30);
    let key = CacheKey::of(&gt_dir).unwrap();
    cache.store(&key, &prepare(&gt_dir, &scene.classes)).unwrap();
    // The same files again, one label changed: another size or modification time, another key.
    scene.ground_truth.labels.pop();
    scene.ground_truth.points.pop();
    scene.ground_truth.colors.as_mut().map(Vec::pop);
    scene.ground_truth.write(&gt_dir).unwrap();
    let new_key = CacheKey::of(&gt_dir).unwrap();
    assert_ne!(new_key, key);
    assert_eq!(cache.load(&new_key, &gt_dir, &scene.classes).err().unwrap().0, "not cached yet");
}

#[test]
fn a_damaged_or_truncated_entry_is_a_miss_not_a_score() {
    let tmp = tempfile::tempdir().unwrap();
    let (scene, gt_dir) = scene_on_disk(tmp.path());
    let cache_dir = tmp.path().join("cache");
    let cache = PreparedCache::new(&cache_dir, 1 << 30);
    let key = CacheKey::of(&gt_dir).unwrap();
    cache.store(&key, &prepare(&gt_dir, &scene.classes)).unwrap();
    let entry = entries(&cache_dir).remove(0);
    let good = std::fs::read(&entry).unwrap();

    let mut flipped = good.clone();
    let last = flipped.len() - 1;
    flipped[last] ^= 0x40;
    std::fs::write(&entry, &flipped).unwrap();
    let why = cache.load(&key, &gt_dir, &scene.classes).err().unwrap().0;
    assert!(why.contains("damaged (CRC-32 mismatch)"), "{why}");

    std::fs::write(&entry, &good[..good.len() - 5]).unwrap();
    let why = cache.load(&key, &gt_dir, &scene.classes).err().unwrap().0;
    assert!(why.contains("payload bytes for 30000 points"), "{why}");

    std::fs::write(&entry, b"OSMAB").unwrap();
    let why = cache.load(&key, &gt_dir, &scene.classes).err().unwrap().0;
    assert!(why.contains("truncated at byte 0"), "{why}");

    // Storing again repairs it.
    cache.store(&key, &prepare(&gt_dir, &scene.classes)).unwrap();
    assert!(cache.load(&key, &gt_dir, &scene.classes).is_ok());
}

#[test]
fn an_entry_is_checked_against_the_class_list_as_a_fresh_read_is() {
    let tmp = tempfile::tempdir().unwrap();
    let (scene, gt_dir) = scene_on_disk(tmp.path());
    let cache = PreparedCache::new(tmp.path().join("cache"), 1 << 30);
    let key = CacheKey::of(&gt_dir).unwrap();
    cache.store(&key, &prepare(&gt_dir, &scene.classes)).unwrap();
    let fewer = ClassList::new(scene.classes.entries()[..3].to_vec()).unwrap();
    let why = cache.load(&key, &gt_dir, &fewer).err().unwrap().0;
    let read = GroundTruth::read(&gt_dir, &fewer).err().unwrap().to_string();
    assert_eq!(why, read);
}

#[test]
fn the_cache_drops_the_entries_used_longest_ago_beyond_its_capacity() {
    let tmp = tempfile::tempdir().unwrap();
    let scenes: Vec<(SyntheticScene, PathBuf)> = (0..3)
        .map(|i| {
            let dir = tmp.path().join(format!("scene{i}"));
            scene_on_disk(&dir)
        })
        .collect();
    let prepared: Vec<PreparedGroundTruth> = scenes.iter().map(|(scene, gt)| prepare(gt, &scene.classes)).collect();
    let keys: Vec<CacheKey> = scenes.iter().map(|(_, gt)| CacheKey::of(gt).unwrap()).collect();
    // Room for two entries of 30,000 points (16 bytes each and a header), not three.
    let cache = PreparedCache::new(tmp.path().join("cache"), 2 * 30_000 * 16 + 4096);
    cache.store(&keys[0], &prepared[0]).unwrap();
    std::thread::sleep(std::time::Duration::from_millis(20));
    cache.store(&keys[1], &prepared[1]).unwrap();
    std::thread::sleep(std::time::Duration::from_millis(20));
    // Using the first entry makes the second the one used longest ago.
    cache.load(&keys[0], &scenes[0].1, &scenes[0].0.classes).unwrap();
    std::thread::sleep(std::time::Duration::from_millis(20));
    cache.store(&keys[2], &prepared[2]).unwrap();
    assert!(cache.load(&keys[0], &scenes[0].1, &scenes[0].0.classes).is_ok());
    assert_eq!(cache.load(&keys[1], &scenes[1].1, &scenes[1].0.classes).err().unwrap().0, "not cached yet");
    assert!(cache.load(&keys[2], &scenes[2].1, &scenes[2].0.classes).is_ok());
    // An entry larger than the whole cache is not kept.
    let tiny = PreparedCache::new(tmp.path().join("tiny"), 1000);
    let why = tiny.store(&keys[0], &prepared[0]).err().unwrap().0;
    assert!(why.contains("larger than the cache's capacity of 1000 bytes"), "{why}");
}

#[test]
fn an_entry_of_several_chunks_has_the_documented_layout() {
    // 200,000 points: four chunks of 65,536 points encoded one after another, the last one
    // partial; read back by four tasks.
    let spec = SceneSpec { gt_points: 200_000, ..SPEC };
    let tmp = tempfile::tempdir().unwrap();
    let scene = generate(spec);
    let gt_dir = tmp.path().join("gt");
    scene.ground_truth.write(&gt_dir).unwrap();
    let cache_dir = tmp.path().join("cache");
    let cache = PreparedCache::new(&cache_dir, 1 << 30);
    let key = CacheKey::of(&gt_dir).unwrap();
    let prepared = prepare(&gt_dir, &scene.classes);
    cache.store(&key, &prepared).unwrap();

    let bytes = std::fs::read(entries(&cache_dir).remove(0)).unwrap();
    assert_eq!(&bytes[..8], b"OSMABZG1");
    let identity_len = u32::from_le_bytes(bytes[8..12].try_into().unwrap()) as usize;
    let at = 12 + identity_len;
    let count = u64::from_le_bytes(bytes[at..at + 8].try_into().unwrap());
    assert_eq!(count, 200_000);
    assert_eq!(bytes[at + 8], 4, "every label fits in 32 bits");
    let crc = u32::from_le_bytes(bytes[at + 9..at + 13].try_into().unwrap());
    let payload = &bytes[at + 13..];
    assert_eq!(payload.len(), 200_000 * 16);
    let points: Vec<u8> = prepared.points().iter().flatten().flat_map(|c| c.to_le_bytes()).collect();
    let labels: Vec<u8> = prepared.labels().iter().flat_map(|&l| i32::try_from(l).unwrap().to_le_bytes()).collect();
    assert!(payload[..points.len()] == points[..], "the points, in Z-order, as little-endian f32");
    assert!(payload[points.len()..] == labels[..], "then the labels, as little-endian i32");
    let mut whole = flate2::Crc::new();
    whole.update(payload);
    assert_eq!(crc, whole.sum());
    let pool = rayon::ThreadPoolBuilder::new().num_threads(4).build().unwrap();
    let loaded = pool.install(|| cache.load(&key, &gt_dir, &scene.classes)).unwrap();
    assert_eq!(loaded.points(), prepared.points());
    assert_eq!(loaded.labels(), prepared.labels());
}

#[test]
fn a_background_store_keeps_every_entry_handed_to_it_before_it_finishes_and_names_what_it_could_not_keep() {
    let tmp = tempfile::tempdir().unwrap();
    let scenes: Vec<(SyntheticScene, PathBuf)> = (0..3).map(|i| scene_on_disk(&tmp.path().join(format!("scene{i}")))).collect();
    let cache = PreparedCache::new(tmp.path().join("cache"), 1 << 30);
    let store = BackgroundStore::start(cache.clone());
    for (scene, gt_dir) in &scenes {
        store.keep(CacheKey::of(gt_dir).unwrap(), Arc::new(prepare(gt_dir, &scene.classes)));
    }
    let report = store.finish();
    assert_eq!((report.stored, report.misses.len()), (3, 0), "{report:?}");
    assert!(report.writing > std::time::Duration::ZERO);
    for (scene, gt_dir) in &scenes {
        let loaded = cache.load(&CacheKey::of(gt_dir).unwrap(), gt_dir, &scene.classes).unwrap();
        assert_eq!(loaded.points(), prepare(gt_dir, &scene.classes).points());
    }

    // A cache whose directory cannot be made (a file is in its place) keeps nothing, and says
    // which ground truth it did not keep.
    let blocked = tmp.path().join("blocked");
    std::fs::write(&blocked, b"a file").unwrap();
    let store = BackgroundStore::start(PreparedCache::new(&blocked, 1 << 30));
    let (scene, gt_dir) = &scenes[0];
    store.keep(CacheKey::of(gt_dir).unwrap(), Arc::new(prepare(gt_dir, &scene.classes)));
    let report = store.finish();
    assert_eq!(report.stored, 0);
    assert_eq!(report.misses.len(), 1);
    assert!(report.misses[0].starts_with(&format!("{}: not kept: creating {}", gt_dir.display(), blocked.display())), "{:?}", report.misses);

    // Dropped without finishing (a scoring that stopped early), it still writes what it was handed.
    let late = PreparedCache::new(tmp.path().join("late"), 1 << 30);
    let (scene, gt_dir) = &scenes[1];
    drop({
        let store = BackgroundStore::start(late.clone());
        store.keep(CacheKey::of(gt_dir).unwrap(), Arc::new(prepare(gt_dir, &scene.classes)));
        store
    });
    assert!(late.holds(&CacheKey::of(gt_dir).unwrap()));
}

#[test]
fn temporary_files_abandoned_an_hour_ago_are_removed_when_an_entry_is_stored() {
    let tmp = tempfile::tempdir().unwrap();
    let (scene, gt_dir) = scene_on_disk(tmp.path());
    let cache_dir = tmp.path().join("cache");
    std::fs::create_dir_all(&cache_dir).unwrap();
    let abandoned = cache_dir.join(".0123456789abcdef.zgt.999-0.tmp");
    let being_written = cache_dir.join(".0123456789abcdef.zgt.998-0.tmp");
    for path in [&abandoned, &being_written] {
        std::fs::write(path, b"half an entry").unwrap();
    }
    let two_hours_ago = std::time::SystemTime::now() - std::time::Duration::from_secs(7200);
    std::fs::File::options().append(true).open(&abandoned).unwrap().set_modified(two_hours_ago).unwrap();
    let cache = PreparedCache::new(&cache_dir, 1 << 30);
    cache.store(&CacheKey::of(&gt_dir).unwrap(), &prepare(&gt_dir, &scene.classes)).unwrap();
    assert!(!abandoned.exists(), "an hour old: abandoned");
    assert!(being_written.exists(), "fresh: another process may be writing it");
}
