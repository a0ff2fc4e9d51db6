//! What a release publishes of a scene, by its split: one rule, read by the manifest's file
//! list and by the sequence archives alike, so an archive can never hold a file the
//! manifest leaves out.
//!
//! A val scene is open: every file of its sequences, its prompt and its questions. A test
//! scene publishes its colour and depth frames with the files that describe the camera and
//! its path, and nothing that tells its semantics or its answers: no semantic (or other
//! label) frame, no prompt or spec, no questions.

use std::path::Path;

use osmab_evaluator::Result;
use osmab_evaluator::scores::Split;
use osmab_evaluator::submission::archive::list_tree;

/// Ground truth: the val scenes' is public (listed in the manifest, so teams score val
/// offline); the test scenes' stays with the server, with the full quality report.
pub const GROUND_TRUTH: &str = "ground_truth";

/// Whether `relative` (a path inside a sequence folder, `results/frame000000.jpg`) of a
/// scene of `split` is public. Of a test sequence's `results/`, an allow-list: only colour
/// and depth frames, whatever else a renderer wrote beside them (semantic, instance or
/// label images).
pub fn is_public_in_sequence(split: Split, relative: &str) -> bool {
    match (split, relative.split_once('/')) {
        (Split::Val, _) => true,
        (Split::Test, Some(("results", name))) => !name.contains('/') && (name.starts_with("frame") || name.starts_with("depth")),
        (Split::Test, _) => true,
    }
}

/// The public files of the sequence folder `dir` of a scene of `split`, sorted, relative
/// to `dir` with '/' separators: what its archive holds.
pub fn public_sequence_files(split: Split, dir: &Path) -> Result<Vec<String>> {
    Ok(list_tree(dir)?.into_iter().filter(|name| is_public_in_sequence(split, name)).collect())
}

/// Whether a scene of `split` publishes its prompt (`scenes/<scene>/prompt.json`, the
/// manifest's `prompt`) and its questions (`questions/<scene>.json`): only val scenes do.
/// A test scene's prompt tells its prompt-grounded answers, and its questions are answered
/// by the server from a submission's scene graph.
pub fn publishes_prompt_and_questions(split: Split) -> bool {
    split == Split::Val
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_test_sequence_publishes_colour_depth_and_camera_files_only() {
        for public in [
            "results/frame000000.jpg",
            "results/depth000012.png",
            "traj.txt",
            "camera_params.yaml",
            "embed_semseg_classes.json",
            "configs/lighting/light_settings.json",
        ] {
            assert!(is_public_in_sequence(Split::Test, public), "{public}");
        }
        for hidden in ["results/semantic000000.png", "results/instance000000.png", "results/labels.npy", "results/frame/semantic000000.png"] {
            assert!(!is_public_in_sequence(Split::Test, hidden), "{hidden}");
            assert!(is_public_in_sequence(Split::Val, hidden), "{hidden}: val is open");
        }
    }

    #[test]
    fn the_archive_list_follows_the_rule() {
        let dir = tempfile::tempdir().unwrap();
        for name in ["results/frame000000.jpg", "results/depth000000.png", "results/semantic000000.png", "traj.txt"] {
            let path = dir.path().join(name);
            std::fs::create_dir_all(path.parent().unwrap()).unwrap();
            std::fs::write(path, b"x").unwrap();
        }
        assert_eq!(public_sequence_files(Split::Test, dir.path()).unwrap(), ["results/depth000000.png", "results/frame000000.jpg", "traj.txt"]);
        assert_eq!(public_sequence_files(Split::Val, dir.path()).unwrap().len(), 4);
        assert!(!publishes_prompt_and_questions(Split::Test) && publishes_prompt_and_questions(Split::Val));
    }
}
