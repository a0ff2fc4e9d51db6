//! Writing a placed layout exactly as SceneSmith writes a scene: `package.xml`, the
//! room geometry SDF (textured floor and walls with a pack), one SDF 1.7 + glTF per object under `room_main/generated_assets`,
//! `combined_house/house.dmd.yaml` (model directives with `!AngleAxis` rotations and
//! `package://scene/` paths) and `combined_house/house_state.json`.

use std::fmt::Write as _;
use std::path::Path;

use osmab_evaluator::numeric::python_repr;
use osmab_evaluator::{InputError, Result};
use serde_json::json;

use super::export::write_asset_gltf;
use super::placement::Layout;
use super::source::RoomShell;
use super::textured::{write_pack_gltf, write_shell_box};
use crate::convert::lighting::{FIXTURE_HEIGHT, ceiling_light_positions};
use crate::spec::{ObjectKind, SceneSpec};

fn write(path: &Path, text: impl AsRef<[u8]>) -> Result<()> {
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir).map_err(|e| InputError::io(dir, &e))?;
    }
    std::fs::write(path, text).map_err(|e| InputError::io(path, &e))
}

fn num(v: f64) -> String {
    python_repr((v * 1e6).round() / 1e6 + 0.0)
}

fn triple(v: [f64; 3]) -> String {
    format!("[{}, {}, {}]", num(v[0]), num(v[1]), num(v[2]))
}

fn title(category: &str) -> String {
    category
        .split(' ')
        .map(|w| {
            let mut c = w.chars();
            c.next().map(|f| f.to_uppercase().collect::<String>() + c.as_str()).unwrap_or_default()
        })
        .collect::<Vec<_>>()
        .join(" ")
}

/// Skirting boards: height and thickness, metres, and their paint.
const SKIRTING: (f64, f64) = (0.08, 0.015);
const SKIRTING_PAINT: [f64; 3] = [0.92, 0.91, 0.88];
/// A ceiling fixture's radius, metres, and its diffuser's colour.
const FIXTURE_RADIUS: f64 = 0.17;
const FIXTURE_WHITE: [f64; 3] = [0.97, 0.96, 0.93];

/// A room-geometry visual: its name (which decides its class), centre, and a box of a size,
/// or a vertical cylinder, with its own colour when it has no texture.
struct RoomPart {
    name: String,
    center: [f64; 3],
    shape: RoomShape,
    colour: Option<[f64; 3]>,
}

enum RoomShape {
    Box([f64; 3]),
    Cylinder { radius: f64, length: f64 },
}

/// The room's parts: floor, four walls, their skirting and (optionally) a ceiling with a
/// fixture where each ceiling light of the converter's grid shines from.
fn room_parts(layout: &Layout, ceiling: bool) -> Vec<RoomPart> {
    let (w, d, h, t) = (layout.width, layout.depth, layout.wall_height, 0.1);
    let part = |name: &str, center: [f64; 3], size: [f64; 3]| RoomPart { name: name.into(), center, shape: RoomShape::Box(size), colour: None };
    let mut parts = vec![part("floor", [0.0, 0.0, -0.05], [w, d, 0.1])];
    if ceiling {
        parts.push(part("ceiling", [0.0, 0.0, h + 0.05], [w, d, 0.1]));
    }
    parts.push(part("left_wall", [-w / 2.0, 0.0, h / 2.0], [t, d, h]));
    parts.push(part("right_wall", [w / 2.0, 0.0, h / 2.0], [t, d, h]));
    parts.push(part("back_wall", [0.0, -d / 2.0, h / 2.0], [w, t, h]));
    parts.push(part("front_wall", [0.0, d / 2.0, h / 2.0], [w, t, h]));
    // Skirting along each wall's inner face (named as walls: they are part of them).
    let (sh, st) = SKIRTING;
    let inner = t / 2.0 + st / 2.0;
    for (name, center, size) in [
        ("wall_skirting_left", [-w / 2.0 + inner, 0.0, sh / 2.0], [st, d - t, sh]),
        ("wall_skirting_right", [w / 2.0 - inner, 0.0, sh / 2.0], [st, d - t, sh]),
        ("wall_skirting_back", [0.0, -d / 2.0 + inner, sh / 2.0], [w - t - 2.0 * st, st, sh]),
        ("wall_skirting_front", [0.0, d / 2.0 - inner, sh / 2.0], [w - t - 2.0 * st, st, sh]),
    ] {
        parts.push(RoomPart { name: name.into(), center, shape: RoomShape::Box(size), colour: Some(SKIRTING_PAINT) });
    }
    if ceiling {
        // The converter lays its lights out on the floor's bounds in Habitat axes (x, y up, z = −y).
        let floor = ([-w / 2.0, -0.1, -d / 2.0], [w / 2.0, 0.0, d / 2.0]);
        for (k, p) in ceiling_light_positions(floor, h).into_iter().enumerate() {
            parts.push(RoomPart {
                name: format!("ceiling_light_{k}"),
                center: [p[0], -p[2], h - FIXTURE_HEIGHT / 2.0],
                shape: RoomShape::Cylinder { radius: FIXTURE_RADIUS, length: FIXTURE_HEIGHT },
                colour: Some(FIXTURE_WHITE),
            });
        }
    }
    parts
}

/// The room as SceneSmith's room-geometry SDF: boxes, or with a `shell` the floor and walls
/// as textured meshes of the same boxes written beside it (`room_geometry/<part>.gltf`).
/// SceneSmith itself writes no ceiling.
fn write_room(dir: &Path, layout: &Layout, ceiling: bool, shell: Option<&RoomShell>) -> Result<String> {
    let mut out =
        String::from("<sdf xmlns:drake=\"drake.mit.edu\" version=\"1.7\">\n  <model name=\"room_geometry\">\n    <link name=\"room_geometry_body_link\">\n");
    let box_geometry = |s: [f64; 3]| format!("<box>\n            <size>{} {} {}</size>\n          </box>", num(s[0]), num(s[1]), num(s[2]));
    for part in room_parts(layout, ceiling) {
        let name = part.name.as_str();
        let primitive = match part.shape {
            RoomShape::Box(s) => box_geometry(s),
            RoomShape::Cylinder { radius, length } => {
                format!("<cylinder>\n            <radius>{}</radius>\n            <length>{}</length>\n          </cylinder>", num(radius), num(length))
            }
        };
        let is_surface = matches!(name, "floor" | "left_wall" | "right_wall" | "back_wall" | "front_wall");
        let texture = shell.filter(|_| is_surface).map(|shell| if name == "floor" { (&shell.floor, shell.floor_dye) } else { (&shell.wall, shell.wall_paint) });
        let visual = match (texture, &part.shape) {
            (Some((texture, paint)), RoomShape::Box(s)) => {
                write_shell_box(texture, paint, *s, &dir.join("room_geometry"), name)?;
                format!("<mesh>\n            <uri>{name}.gltf</uri>\n          </mesh>")
            }
            _ => primitive.clone(),
        };
        let material = part.colour.map_or(String::new(), |c| {
            format!("        <material>\n          <diffuse>{} {} {} 1</diffuse>\n        </material>\n", num(c[0]), num(c[1]), num(c[2]))
        });
        let c = part.center;
        for (kind, geometry) in [("visual", &visual), ("collision", &primitive)] {
            let material = if kind == "visual" { material.as_str() } else { "" };
            let _ = write!(
                out,
                "      <{kind} name=\"{name}_{kind}\">\n        <geometry>\n          {geometry}\n        </geometry>\n{material}        <pose>{} {} {} 0 0 0</pose>\n      </{kind}>\n",
                num(c[0]),
                num(c[1]),
                num(c[2])
            );
        }
    }
    out.push_str("    </link>\n    <static>true</static>\n  </model>\n</sdf>\n");
    Ok(out)
}

/// An object's SDF as SceneSmith writes it: inertial, the glTF visual and a collision
/// (here the asset's bounding box; SceneSmith uses convex pieces).
fn object_sdf(name: &str, stem: &str, size: [f64; 3], mass: f64) -> String {
    let [w, d, h] = size;
    let (ixx, iyy, izz) = (mass * (d * d + h * h) / 12.0, mass * (w * w + h * h) / 12.0, mass * (w * w + d * d) / 12.0);
    format!(
        "<?xml version='1.0' encoding='utf-8'?>\n<sdf version=\"1.7\">\n  <model name=\"{name}\">\n    <link name=\"base_link\">\n      <inertial>\n        <mass>{mass:.6}</mass>\n        <pose>0 0 {cz:.6} 0 0 0</pose>\n        <inertia>\n          <ixx>{ixx:.6}</ixx>\n          <iyy>{iyy:.6}</iyy>\n          <izz>{izz:.6}</izz>\n          <ixy>0</ixy>\n          <ixz>0</ixz>\n          <iyz>0</iyz>\n        </inertia>\n      </inertial>\n      <visual name=\"visual\">\n        <geometry>\n          <mesh>\n            <uri>{stem}.gltf</uri>\n          </mesh>\n        </geometry>\n      </visual>\n      <collision name=\"collision_0\">\n        <pose>0 0 {cz:.6} 0 0 0</pose>\n        <geometry>\n          <box>\n            <size>{w:.6} {d:.6} {h:.6}</size>\n          </box>\n        </geometry>\n      </collision>\n    </link>\n  </model>\n</sdf>\n",
        cz = h / 2.0
    )
}

/// A plausible mass: a fraction of the bounding box filled with wood-like material.
fn mass_of(size: [f64; 3]) -> f64 {
    (size[0] * size[1] * size[2] * 600.0 * 0.2).clamp(0.05, 200.0)
}

/// Write `layout` for `spec` and `prompt` as a SceneSmith scene in `dir`, with the
/// relations of the spec it leaves `unmet`.
pub fn write_scenesmith_scene(
    dir: &Path,
    spec: &SceneSpec,
    prompt: &str,
    layout: &Layout,
    unmet: &[String],
    ceiling: bool,
    shell: Option<&RoomShell>,
) -> Result<()> {
    write(
        &dir.join("package.xml"),
        "<?xml version=\"1.0\"?>\n<package format=\"2\">\n  <name>scene</name>\n  <version>0.0.1</version>\n  <description>Procedural scene written by osmab.</description>\n  <maintainer email=\"none@example.com\">osmab</maintainer>\n  <license>CC-BY-4.0</license>\n</package>\n",
    )?;
    let room = write_room(dir, layout, ceiling, shell)?;
    write(&dir.join("room_geometry/room_geometry_main.sdf"), room)?;
    let mut dmd = String::from(
        "directives:\n- add_frame:\n    name: house_frame\n    X_PF:\n      base_frame: world\n      translation: [0.0, 0.0, 0.0]\n- add_frame:\n    name: room_main_frame\n    X_PF:\n      base_frame: house_frame\n      translation: [0.0, 0.0, 0.0]\n- add_model:\n    name: room_geometry_main\n    file: package://scene/room_geometry/room_geometry_main.sdf\n- add_weld:\n    parent: room_main_frame\n    child: room_geometry_main::room_geometry_body_link\n",
    );
    // SceneSmith also writes the variant with the furniture welded in place.
    let mut welded = dmd.clone();
    let mut objects = serde_json::Map::new();
    for o in &layout.objects {
        let agent = if o.kind == ObjectKind::Furniture { "furniture" } else { "manipuland" };
        let stem = o.category.replace(' ', "_");
        let rel_dir = format!("room_main/generated_assets/{agent}/sdf/{}", o.object_id);
        match &o.asset.mesh {
            Some(mesh) => write_pack_gltf(mesh, &o.category, &dir.join(&rel_dir), &stem)?,
            None => write_asset_gltf(&o.asset, &dir.join(&rel_dir), &stem)?,
        }
        write(&dir.join(&rel_dir).join(format!("{stem}.sdf")), object_sdf(&stem, &stem, o.asset.size, mass_of(o.asset.size)))?;
        if o.kind == ObjectKind::Furniture {
            let _ = write!(
                welded,
                "- add_model:\n    name: main_{}\n    file: package://scene/{rel_dir}/{stem}.sdf\n- add_weld:\n    parent: room_main_frame\n    child: main_{}::base_link\n    X_PC:\n      translation: {}\n      rotation: !AngleAxis\n        angle_deg: {}\n        axis: [0.0, 0.0, 1.0]\n",
                o.object_id,
                o.object_id,
                triple(o.position),
                num(o.yaw_deg)
            );
        }
        let _ = write!(
            dmd,
            "- add_model:\n    name: main_{}\n    file: package://scene/{rel_dir}/{stem}.sdf\n    default_free_body_pose:\n      base_link:\n        base_frame: room_main_frame\n        translation: {}\n        rotation: !AngleAxis\n          angle_deg: {}\n          axis: [0.0, 0.0, 1.0]\n",
            o.object_id,
            triple(o.position),
            num(o.yaw_deg)
        );
        let half = o.yaw_deg.to_radians() / 2.0;
        let s = o.asset.size;
        objects.insert(
            o.object_id.clone(),
            json!({
                "object_id": o.object_id,
                "object_type": agent,
                "name": title(&o.category),
                "description": o.asset.description,
                "transform": {"translation": o.position.map(|v| (v * 1e6).round() / 1e6 + 0.0), "rotation_wxyz": [half.cos(), 0.0, 0.0, half.sin()]},
                "geometry_path": format!("{rel_dir}/{stem}.gltf"),
                "sdf_path": format!("{rel_dir}/{stem}.sdf"),
                "image_path": null,
                "support_surfaces": o.asset.supports.iter().map(|s| json!({"height": s.height, "min": s.min, "max": s.max, "inside": s.inside})).collect::<Vec<_>>(),
                "placement_info": o.host.as_ref().map(|h| json!({"parent_object": h})),
                "metadata": {"asset_source": o.asset.mesh.as_ref().map_or("procedural", |m| m.source.as_str()), "category": o.category, "dressing": o.dressing},
                "bbox_min": [-s[0] / 2.0, -s[1] / 2.0, 0.0],
                "bbox_max": [s[0] / 2.0, s[1] / 2.0, s[2]],
                "immutable": false,
                "scale_factor": 1.0,
            }),
        );
    }
    write(&dir.join("combined_house/house.dmd.yaml"), dmd)?;
    write(&dir.join("combined_house/house_furniture_welded.dmd.yaml"), welded)?;
    let state = json!({
        "layout": {
            "house_prompt": prompt,
            "rooms": [{"id": "main", "type": spec.room, "prompt": prompt, "width": layout.width, "depth": layout.depth, "position": [-layout.width / 2.0, -layout.depth / 2.0]}],
            "wall_height": layout.wall_height,
        },
        "rooms": {"main": {"room_id": "main", "text_description": prompt, "objects": objects}},
        "spec": spec,
        "placement": {"unmet": unmet, "notes": layout.notes},
    });
    write(&dir.join("combined_house/house_state.json"), serde_json::to_string_pretty(&state).expect("serialisable") + "\n")
}
