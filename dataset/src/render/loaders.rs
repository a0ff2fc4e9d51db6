//! Configs that ConceptGraphs' and BBQ's own dataset loaders read, written beside
//! `camera_params.yaml` in every sequence so a participant points the loaders at the
//! release without editing anything (checked against the loaders' code by
//! `bench/loaders_check.py`; docs/participants.md has the commands):
//!
//! - `conceptgraphs_dataconfig.yaml`: ConceptGraphs' `dataset_config=` — `dataset_name:
//!   replica` (the Replica loader reads HaDaGe's layout; OSMa-Bench's fork accepts it
//!   too) and the camera;
//! - `bbq_config.yaml`: BBQ's `main.py --config_path` — its `dataset:` section (loader
//!   `Replica`, this sequence under `base_dir: sequences`, the native image size,
//!   `relative_pose: False`: BBQ builds objects with the poses of `dataset[i]` but
//!   projects them with `dataset.poses`, which are always `traj.txt`'s) and the
//!   `nodes_constructor:` section `main.py` requires, as BBQ's Replica example has it,
//!   with the image-size-dependent values set for this camera.

use std::path::Path;

use osmab_evaluator::formats::camera::CameraParams;
use osmab_evaluator::{InputError, Result};

/// ConceptGraphs' dataconfig beside `camera_params.yaml`.
pub const CONCEPTGRAPHS_CONFIG: &str = "conceptgraphs_dataconfig.yaml";
/// BBQ's config beside `camera_params.yaml`.
pub const BBQ_CONFIG: &str = "bbq_config.yaml";

/// The image area BBQ's pixel-count thresholds were tuned for (1200 × 680).
const BBQ_TUNED_AREA: f64 = 1200.0 * 680.0;

/// The camera block both loaders read, indented by `indent`.
fn camera_block(params: &CameraParams, indent: &str) -> String {
    format!(
        "{indent}image_height: {}\n{indent}image_width: {}\n{indent}fx: {:?}\n{indent}fy: {:?}\n{indent}cx: {:?}\n{indent}cy: {:?}\n{indent}png_depth_scale: {:?}\n{indent}crop_edge: 0\n",
        params.image_height, params.image_width, params.fx, params.fy, params.cx, params.cy, params.png_depth_scale
    )
}

/// ConceptGraphs' dataconfig for a sequence with `params`.
pub fn conceptgraphs_config(params: &CameraParams) -> String {
    format!(
        "# ConceptGraphs dataconfig of this sequence (osmab). Pass it as dataset_config=<this file> with\n\
         # dataset_root=<release>/sequences and scene_id=<lighting>/<scene> (absolute paths: Hydra changes directory).\n\
         dataset_name: replica\ncamera_params:\n{}",
        camera_block(params, "  ")
    )
}

/// BBQ's config for the sequence `lighting`/`scene` with `params`.
pub fn bbq_config(params: &CameraParams, lighting: &str, scene: &str) -> String {
    let area = params.image_width as f64 * params.image_height as f64;
    let scaled = |tuned: f64| ((tuned * area / BBQ_TUNED_AREA).round() as u64).max(1);
    format!(
        r#"# BeyondBareQueries config of sequences/{lighting}/{scene} (osmab). Run from the release directory
# (the one holding sequences/), or make base_dir absolute:
#   python <BeyondBareQueries>/main.py --config_path sequences/{lighting}/{scene}/bbq_config.yaml
# relative_pose must stay False: main.py builds objects with the poses of dataset[i] but projects them
# with dataset.poses (always traj.txt); True would also put the map in the first camera's frame, which
# the submission check refuses. mask_area_threshold and min_points_threshold are BBQ's values for
# 1200x680 scaled to this image's area.
dataset:
  name: "Replica"
  base_dir: "sequences"
  sequence: "{lighting}/{scene}"
  start: 0
  end: -1
  stride: 5
  desired_height: {height}
  desired_width: {width}
  camera_params:
{camera}  relative_pose: False
  device: "cpu"

nodes_constructor:
  mask_generator:
    model: "MobileSAM"
    weights_path: "/home/docker_user/bbq_weights/mobilesamv2/weight"
  dino_generator:
    model: "dinov2_vits14_reg_lc"
    load_size: 448
    stride: 7
    facet: "value"
    num_patches_h: 63
    num_patches_w: 113
  detections_assembler:
    mask_conf_threshold: 0.95
    mask_area_threshold: {mask_area}
    max_bbox_area_ratio: 0.75
    min_points_threshold: {min_points}
    downsample_voxel_size: 0.025
    dbscan_remove_noise: True
    dbscan_eps: 0.05
    dbscan_min_points: 10
    image_area: {area} # desired_height * desired_width
  objects_associator:
    merge_det_obj_spatial_sim_thresh: 0.01
    merge_det_obj_visual_sim_thresh: 0.5
    downsample_voxel_size: 0.025
    merge_interval: 20
    merge_objects_overlap_thresh: 0.7
    merge_objects_visual_sim_thresh: 0.4
  projector:
    num_views: 5
    top_k: 1
    desired_height: {height}
    desired_width: {width}
  postprocessing:
    obj_min_points: 150
    obj_min_detections: 3
  output_path: "bbq_output/{lighting}"
  output_name_nodes: "{scene}.json"
  output_name_objects: "{scene}_objects.pkl.gz"
"#,
        height = params.image_height,
        width = params.image_width,
        camera = camera_block(params, "    "),
        mask_area = scaled(500.0),
        min_points = scaled(150.0),
        area = params.image_width as u64 * params.image_height as u64,
    )
}

/// Write both loaders' configs into the sequence `dir` (`…/<lighting>/<scene>`).
pub fn write_loader_configs(dir: &Path, params: &CameraParams) -> Result<()> {
    let name = |d: Option<&Path>| d.and_then(Path::file_name).map(|n| n.to_string_lossy().to_string()).unwrap_or_default();
    let (scene, lighting) = (name(Some(dir)), name(dir.parent()));
    for (file, text) in [(CONCEPTGRAPHS_CONFIG, conceptgraphs_config(params)), (BBQ_CONFIG, bbq_config(params, &lighting, &scene))] {
        let path = dir.join(file);
        std::fs::write(&path, text).map_err(|e| InputError::io(&path, &e))?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_yaml_ng::Value;

    fn camera(width: u32, height: u32) -> CameraParams {
        CameraParams::from_hfov(width, height, 90.0, 6553.5)
    }

    /// The camera block must carry what ConceptGraphs' and BBQ's loaders read, equal to
    /// camera_params.yaml's values.
    fn assert_camera(block: &Value, params: &CameraParams) {
        for key in ["image_height", "image_width", "fx", "fy", "cx", "cy", "png_depth_scale"] {
            assert!(block.get(key).is_some(), "camera_params.{key} is required");
        }
        assert_eq!(block["fx"].as_f64(), Some(params.fx), "fx to the last bit");
        assert_eq!(block["fy"].as_f64(), Some(params.fy));
        assert_eq!(block["cx"].as_f64(), Some(params.cx));
        assert_eq!(block["cy"].as_f64(), Some(params.cy));
        assert_eq!(block["png_depth_scale"].as_f64(), Some(6553.5));
        assert_eq!(block["image_width"].as_u64(), Some(params.image_width as u64));
        assert_eq!(block["image_height"].as_u64(), Some(params.image_height as u64));
    }

    #[test]
    fn conceptgraphs_reads_a_replica_dataconfig_with_the_exact_camera() {
        let params = camera(1200, 680);
        let config: Value = serde_yaml_ng::from_str(&conceptgraphs_config(&params)).unwrap();
        assert_eq!(config["dataset_name"].as_str(), Some("replica"), "the loader ConceptGraphs picks by name");
        assert_camera(&config["camera_params"], &params);
        assert!(config.get("inherit_from").is_none(), "resolved against the working directory: never shipped");
    }

    #[test]
    fn bbq_reads_its_replica_loader_with_absolute_poses_at_the_native_size() {
        let params = camera(320, 180);
        let config: Value = serde_yaml_ng::from_str(&bbq_config(&params, "dynamic_lights", "scene_002")).unwrap();
        let dataset = &config["dataset"];
        assert_eq!(dataset["name"].as_str(), Some("Replica"));
        assert_eq!((dataset["base_dir"].as_str(), dataset["sequence"].as_str()), (Some("sequences"), Some("dynamic_lights/scene_002")));
        assert_eq!(dataset["relative_pose"].as_bool(), Some(false), "maps in the release's world frame");
        assert_eq!((dataset["desired_height"].as_u64(), dataset["desired_width"].as_u64()), (Some(180), Some(320)), "not BBQ's 480x640 default");
        assert_camera(&dataset["camera_params"], &params);
        let nodes = &config["nodes_constructor"];
        for section in ["mask_generator", "dino_generator", "detections_assembler", "objects_associator", "projector", "postprocessing"] {
            assert!(nodes.get(section).is_some(), "main.py reads nodes_constructor.{section}");
        }
        assert_eq!(nodes["detections_assembler"]["image_area"].as_u64(), Some(57_600));
        assert_eq!(nodes["detections_assembler"]["mask_area_threshold"].as_u64(), Some(35), "500 px at 1200x680, scaled");
        assert_eq!(nodes["projector"]["desired_width"].as_u64(), Some(320));
        let full: Value = serde_yaml_ng::from_str(&bbq_config(&camera(1200, 680), "baseline", "scene_000")).unwrap();
        assert_eq!(full["nodes_constructor"]["detections_assembler"]["mask_area_threshold"].as_u64(), Some(500), "BBQ's own value");
    }
}
