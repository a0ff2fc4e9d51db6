//! Textured geometry of a synthesized scene: pack meshes at their instance's scale with
//! their texture in its look ([`super::recolour`]), and the room's floor and walls as tiled,
//! textured boxes. Written as glTF ([`super::gltf_out`]) with PNG or JPEG images beside.

use std::path::Path;

use osmab_evaluator::formats::image::{RgbImage, write_png_rgb};
use osmab_evaluator::{InputError, Result};

use super::artwork::printed;
use super::export::to_gltf;
use super::finishes::Look;
use super::gltf_out::{OutMaterial, OutPrimitive, write_gltf};
use super::library::PackMesh;
use super::recolour::{Print, painted, recolour, toned};
use super::source::ShellTexture;
use crate::classes::{Colouring, Finish, table};
use crate::convert::gltf::{TriangleMesh, read_gltf};

/// Write the pack mesh `mesh` of an instance of `category` as `dir/stem.gltf` (+ `.bin`
/// and one PNG per textured material).
pub fn write_pack_gltf(mesh: &PackMesh, category: &str, dir: &Path, stem: &str) -> Result<()> {
    let asset = read_gltf(&mesh.file)?;
    std::fs::create_dir_all(dir).map_err(|e| InputError::io(dir, &e))?;
    let scale = mesh.scale as f32;
    let positions: Vec<Vec<[f32; 3]>> = asset.meshes.iter().map(|m| m.positions.iter().map(|p| p.map(|v| v * scale)).collect()).collect();
    let class = table().class(category);
    let print = if class.is_some_and(|c| c.plain) { Print::Dropped } else { Print::Kept };
    // A picture's print is drawn anew; a book keeps its cover art, toned.
    let pictured = class.is_some_and(|c| c.colouring == Colouring::Print);
    let mut names = Vec::new();
    for (k, material) in asset.materials.iter().enumerate() {
        let Some(texture) = &material.texture else {
            names.push(None);
            continue;
        };
        let users: Vec<&TriangleMesh> = asset.meshes.iter().filter(|m| m.material == Some(k)).collect();
        let as_drawn = |pixels| RgbImage { width: texture.width, height: texture.height, pixels };
        let image = match mesh.look {
            Look::Finish(finish) => recolour(texture, &users, scale, finish, print),
            Look::Print { tone, art } if pictured => printed(texture, &users, tone, art),
            Look::Print { tone, .. } => as_drawn(toned(texture, tone)),
            Look::Own => as_drawn(texture.rgba.chunks_exact(4).flat_map(|p| [p[0], p[1], p[2]]).collect()),
        };
        let name = format!("{stem}_{k}.png");
        write_png_rgb(&dir.join(&name), &image)?;
        // The forge's ambient occlusion, as it is (a finish recolours, it does not relight).
        let occlusion = match &material.occlusion {
            Some(ao) => {
                let ao_name = format!("{stem}_{k}_ao.png");
                let grey: Vec<u8> = ao.rgba.chunks_exact(4).flat_map(|p| [p[0]; 3]).collect();
                write_png_rgb(&dir.join(&ao_name), &RgbImage { width: ao.width, height: ao.height, pixels: grey })?;
                Some(ao_name)
            }
            None => None,
        };
        names.push(Some((name, occlusion)));
    }
    let primitives: Vec<OutPrimitive> = asset
        .meshes
        .iter()
        .zip(&positions)
        .map(|(m, positions)| {
            let material = m.material.and_then(|k| asset.materials.get(k).map(|mat| (k, mat)));
            let texture = material.and_then(|(k, _)| names[k].as_ref()).map(|(t, _)| t.as_str());
            let occlusion = material.and_then(|(k, _)| names[k].as_ref()).and_then(|(_, o)| o.as_deref());
            OutPrimitive {
                positions,
                normals: &m.normals,
                uvs: m.uvs.as_deref().filter(|_| texture.is_some()),
                indices: &m.indices,
                material: OutMaterial {
                    name: material.map_or("default", |(_, mat)| mat.name.as_str()),
                    color: if texture.is_some() { [1.0; 4] } else { material.map_or([0.8, 0.8, 0.8, 1.0], |(_, mat)| mat.base_color) },
                    texture,
                    occlusion,
                },
            }
        })
        .collect();
    write_gltf(dir, stem, category, &format!("osmab from {} ({})", mesh.source, mesh.generator), &primitives)
}

/// A box of `size` (Drake axes, centred at the origin) as `dir/stem.gltf`, its faces
/// textured with `shell` tiled in world metres: floors and walls; with a `paint`, the
/// texture in that paint ([`painted`]).
pub fn write_shell_box(shell: &ShellTexture, paint: Option<&Finish>, size: [f64; 3], dir: &Path, stem: &str) -> Result<()> {
    std::fs::create_dir_all(dir).map_err(|e| InputError::io(dir, &e))?;
    let image = match paint {
        Some(paint) => {
            let image = format!("{}_{}_texture.png", shell.name, paint.name);
            let bytes = std::fs::read(&shell.file).map_err(|e| InputError::io(&shell.file, &e))?;
            let texture = crate::convert::gltf::decode_image(&bytes).map_err(|why| InputError::new(&shell.file, "image", why))?;
            write_png_rgb(&dir.join(&image), &RgbImage { width: texture.width, height: texture.height, pixels: painted(&texture, paint) })?;
            image
        }
        None => {
            let extension = shell.file.extension().and_then(|e| e.to_str()).unwrap_or("jpg").to_ascii_lowercase();
            let image = format!("{}_texture.{extension}", shell.name);
            std::fs::copy(&shell.file, dir.join(&image)).map_err(|e| InputError::io(&shell.file, &e))?;
            image
        }
    };
    let h = size.map(|v| v / 2.0);
    let (mut positions, mut normals, mut uvs, mut indices) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    // Each face: its normal axis and sign; texture axes are the other two, in metres / tile.
    for (axis, sign) in [(0, 1.0), (0, -1.0), (1, 1.0), (1, -1.0), (2, 1.0), (2, -1.0)] {
        let (u_axis, v_axis) = match axis {
            0 => (1, 2),
            1 => (0, 2),
            _ => (0, 1),
        };
        let base = positions.len() as u32;
        let corners = [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)];
        for (cu, cv) in corners {
            let mut p = [0.0; 3];
            p[axis] = sign * h[axis];
            p[u_axis] = cu * h[u_axis];
            p[v_axis] = cv * h[v_axis];
            let mut n = [0.0; 3];
            n[axis] = sign;
            positions.push(to_gltf(p));
            normals.push(to_gltf(n));
            uvs.push([(p[u_axis] / shell.tile) as f32, (-p[v_axis] / shell.tile) as f32]);
        }
        // Counter-clockwise seen from outside: flip the winding on faces whose corner order
        // runs clockwise about their normal.
        let clockwise = (sign < 0.0) ^ (axis == 1);
        indices.extend(if clockwise { [base, base + 2, base + 1, base, base + 3, base + 2] } else { [base, base + 1, base + 2, base, base + 2, base + 3] });
    }
    let primitive = OutPrimitive {
        positions: &positions,
        normals: &normals,
        uvs: Some(&uvs),
        indices: &indices,
        material: OutMaterial { name: &shell.name, color: [1.0; 4], texture: Some(&image), occlusion: None },
    };
    write_gltf(dir, stem, stem, "osmab room shell", &[primitive])
}
