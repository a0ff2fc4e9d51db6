//! What a world is made of: triangles with a surface (a colour, a texture with its
//! mipmaps) and a class and object each.

use crate::convert::gltf::Texture;

/// How a surface is coloured.
#[derive(Debug, Clone)]
pub struct Surface {
    /// Base colour (linear 0..1).
    pub color: [f32; 3],
    /// Base-colour texture, sampled with the vertices' UVs, with its mipmaps.
    pub texture: Option<std::sync::Arc<MipMaps>>,
    /// Whether the texture's alpha holds ambient occlusion: what of the ambient light
    /// reaches the surface past the object's own parts, baked by the forge.
    pub occlusion_in_alpha: bool,
}

/// A texture and its mipmaps: each level half the last (2 × 2 texels averaged), down to a
/// side of 4, so a far surface reads few, nearby texels (and does not shimmer).
#[derive(Debug, Clone, PartialEq)]
pub struct MipMaps {
    /// Level 0 is the texture itself.
    pub levels: Vec<Texture>,
}

impl MipMaps {
    /// `texture`'s mipmaps.
    pub fn of(texture: Texture) -> MipMaps {
        let mut levels = vec![texture];
        loop {
            let last = levels.last().expect("level 0");
            let (w, h) = (last.width as usize, last.height as usize);
            if w.min(h) < 8 {
                break;
            }
            let (nw, nh) = (w / 2, h / 2);
            let mut rgba = vec![0u8; nw * nh * 4];
            for y in 0..nh {
                for x in 0..nw {
                    for c in 0..4 {
                        let at = |xx: usize, yy: usize| last.rgba[4 * (yy * w + xx) + c] as u32;
                        let sum = at(2 * x, 2 * y) + at(2 * x + 1, 2 * y) + at(2 * x, 2 * y + 1) + at(2 * x + 1, 2 * y + 1);
                        rgba[4 * (y * nw + x) + c] = ((sum + 2) / 4) as u8;
                    }
                }
            }
            levels.push(Texture { width: nw as u32, height: nh as u32, rgba });
        }
        MipMaps { levels }
    }
}

/// One triangle.
#[derive(Debug, Clone, Copy)]
pub struct Triangle {
    pub positions: [[f32; 3]; 3],
    pub normals: [[f32; 3]; 3],
    pub uvs: [[f32; 2]; 3],
    /// Index into `World::surfaces`.
    pub surface: u32,
    /// Class id written to semantic images.
    pub class_id: u16,
    /// The object instance it belongs to (the template's `semantic_id`; 0 for none).
    pub instance_id: u16,
}
