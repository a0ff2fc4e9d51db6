//! Meshes for SDF primitives (box, cylinder, sphere), in the visual's own frame
//! (Drake axes: the cylinder runs along z), written as OBJ with a diffuse colour.

use std::f64::consts::TAU;
use std::fmt::Write as _;

/// Triangles with per-face normals folded into vertices (flat shading).
pub struct PrimitiveMesh {
    pub positions: Vec<[f64; 3]>,
    pub triangles: Vec<[usize; 3]>,
}

/// A box of `size` centred on the origin.
pub fn box_mesh(size: [f64; 3]) -> PrimitiveMesh {
    let h = size.map(|s| s / 2.0);
    let positions: Vec<[f64; 3]> =
        (0..8).map(|i| [if i & 1 == 0 { -h[0] } else { h[0] }, if i & 2 == 0 { -h[1] } else { h[1] }, if i & 4 == 0 { -h[2] } else { h[2] }]).collect();
    // Counter-clockwise seen from outside.
    let faces = [[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]];
    let triangles = faces.iter().flat_map(|f| [[f[0], f[1], f[2]], [f[0], f[2], f[3]]]).collect();
    PrimitiveMesh { positions, triangles }
}

/// A closed cylinder of `radius` and `length` along z.
pub fn cylinder_mesh(radius: f64, length: f64, segments: usize) -> PrimitiveMesh {
    let mut positions = vec![[0.0, 0.0, -length / 2.0], [0.0, 0.0, length / 2.0]];
    for i in 0..segments {
        let a = TAU * i as f64 / segments as f64;
        positions.push([radius * a.cos(), radius * a.sin(), -length / 2.0]);
        positions.push([radius * a.cos(), radius * a.sin(), length / 2.0]);
    }
    let mut triangles = Vec::new();
    for i in 0..segments {
        let (b0, t0) = (2 + 2 * i, 3 + 2 * i);
        let (b1, t1) = (2 + 2 * ((i + 1) % segments), 3 + 2 * ((i + 1) % segments));
        triangles.extend([[b0, b1, t1], [b0, t1, t0], [0, b1, b0], [1, t0, t1]]);
    }
    PrimitiveMesh { positions, triangles }
}

/// A UV sphere.
pub fn sphere_mesh(radius: f64, rings: usize, segments: usize) -> PrimitiveMesh {
    let mut positions = Vec::new();
    for r in 0..=rings {
        let phi = std::f64::consts::PI * r as f64 / rings as f64;
        for s in 0..segments {
            let theta = TAU * s as f64 / segments as f64;
            positions.push([radius * phi.sin() * theta.cos(), radius * phi.sin() * theta.sin(), radius * phi.cos()]);
        }
    }
    let mut triangles = Vec::new();
    for r in 0..rings {
        for s in 0..segments {
            let (a, b) = (r * segments + s, r * segments + (s + 1) % segments);
            let (c, d) = (a + segments, b + segments);
            triangles.extend([[a, c, b], [b, c, d]]);
        }
    }
    PrimitiveMesh { positions, triangles }
}

impl PrimitiveMesh {
    /// OBJ text referencing material `material` of `mtl_file`.
    pub fn to_obj(&self, mtl_file: &str, material: &str) -> String {
        let mut out = format!("mtllib {mtl_file}\nusemtl {material}\n");
        for p in &self.positions {
            let _ = writeln!(out, "v {} {} {}", p[0], p[1], p[2]);
        }
        for t in &self.triangles {
            let _ = writeln!(out, "f {} {} {}", t[0] + 1, t[1] + 1, t[2] + 1);
        }
        out
    }

    /// Axis-aligned bounds.
    pub fn bounds(&self) -> ([f64; 3], [f64; 3]) {
        self.positions.iter().fold(([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]), |(lo, hi), p| {
            (std::array::from_fn(|a| lo[a].min(p[a])), std::array::from_fn(|a| hi[a].max(p[a])))
        })
    }
}

/// An MTL file with one diffuse material.
pub fn mtl(material: &str, rgb: [f64; 3]) -> String {
    format!("newmtl {material}\nKa {r} {g} {b}\nKd {r} {g} {b}\nKs 0 0 0\nNs 10\nillum 1\n", r = rgb[0], g = rgb[1], b = rgb[2])
}
