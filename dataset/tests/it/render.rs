//! The CPU renderer: depth, semantics and shading of known geometry.

use nalgebra::Matrix4;
use osmab_dataset::convert::habitat::{ConvertOptions, write_habitat_scene};
use osmab_dataset::convert::scene::load_scene;
use osmab_dataset::render::mesh::{Surface, Triangle, World};
use osmab_dataset::render::raster::{AMBIENT, Camera, Frame, Light, Shading, render, render_visibility};

const QUANTUM: f32 = 1.0 / 6553.5;

fn camera(pose: Matrix4<f64>) -> Camera {
    Camera { width: 160, height: 120, fx: 80.0, fy: 80.0, cx: 79.5, cy: 59.5, pose }
}

/// Two triangles making the rectangle [x0, x1] × [y0, y1] at depth z (camera = world).
fn quad(x0: f32, x1: f32, y0: f32, y1: f32, z: f32, surface: u32, class_id: u16) -> [Triangle; 2] {
    let n = [[0.0, 0.0, -1.0]; 3];
    let tri = |p: [[f32; 3]; 3]| Triangle { positions: p, normals: n, uvs: [[0.0; 2]; 3], surface, class_id, instance_id: class_id };
    [tri([[x0, y0, z], [x1, y0, z], [x1, y1, z]]), tri([[x0, y0, z], [x1, y1, z], [x0, y1, z]])]
}

fn world(triangles: Vec<Triangle>) -> World {
    World::new(
        triangles,
        vec![
            Surface { color: [0.5, 0.25, 1.0], texture: None, occlusion_in_alpha: false },
            Surface { color: [0.2, 0.8, 0.4], texture: None, occlusion_in_alpha: false },
        ],
    )
}

#[test]
fn a_plane_facing_the_camera_has_its_depth_everywhere() {
    let w = world(quad(-10.0, 10.0, -10.0, 10.0, 2.0, 0, 7).to_vec());
    let mut frame = Frame::default();
    render(&w, &camera(Matrix4::identity()), &Shading::Flat, &mut frame);
    assert!(frame.depth.iter().all(|&z| (z - 2.0).abs() < QUANTUM), "planar depth, not ray length");
    assert!(frame.semantic.iter().all(|&s| s == 7));
}

#[test]
fn a_tilted_plane_has_the_planar_depth_of_each_pixel() {
    // The plane z = 3 + 0.5 x, seen by the identity camera: at pixel u, x = (u − cx)/fx · z.
    let (x0, x1) = (-3.0f32, 7.0f32);
    let z = |x: f32| 3.0 + 0.5 * x;
    let n = [[0.0, 0.0, -1.0]; 3];
    let tri = |p: [[f32; 3]; 3]| Triangle { positions: p, normals: n, uvs: [[0.0; 2]; 3], surface: 0, class_id: 1, instance_id: 1 };
    let w = world(vec![tri([[x0, -6.0, z(x0)], [x1, -6.0, z(x1)], [x1, 6.0, z(x1)]]), tri([[x0, -6.0, z(x0)], [x1, 6.0, z(x1)], [x0, 6.0, z(x0)]])]);
    let mut frame = Frame::default();
    let cam = camera(Matrix4::identity());
    render(&w, &cam, &Shading::Flat, &mut frame);
    for (i, &d) in frame.depth.iter().enumerate() {
        let u = (i % 160) as f64;
        // Solve z = 3 + 0.5 · (u − cx)/fx · z.
        let expected = 3.0 / (1.0 - 0.5 * (u - cam.cx) / cam.fx);
        assert!((d as f64 - expected).abs() < QUANTUM as f64, "pixel {i}: {d} vs {expected}");
    }
}

#[test]
fn a_box_in_front_of_a_wall_covers_exactly_its_projection() {
    let mut triangles = quad(-10.0, 10.0, -10.0, 10.0, 4.0, 0, 2).to_vec();
    triangles.extend(quad(-0.5, 0.5, -0.25, 0.25, 1.0, 1, 9));
    let w = world(triangles);
    let mut frame = Frame::default();
    render(&w, &camera(Matrix4::identity()), &Shading::Flat, &mut frame);
    for v in 0..120 {
        for u in 0..160 {
            let (x, y) = ((u as f32 - 79.5) / 80.0, (v as f32 - 59.5) / 80.0);
            let inside = x.abs() < 0.5 - 1e-3 && y.abs() < 0.25 - 1e-3;
            let outside = x.abs() > 0.5 + 1e-3 || y.abs() > 0.25 + 1e-3;
            let i = v * 160 + u;
            if inside {
                assert_eq!(frame.semantic[i], 9, "pixel ({u}, {v})");
                assert!((frame.depth[i] - 1.0).abs() < QUANTUM, "pixel ({u}, {v})");
            } else if outside {
                assert_eq!(frame.semantic[i], 2, "pixel ({u}, {v})");
                assert!((frame.depth[i] - 4.0).abs() < QUANTUM);
            }
        }
    }
    // Each pixel also knows its object instance; a visibility render (the planner's
    // probe) finds the same classes, instances and depths without drawing colour.
    assert!(frame.semantic.iter().zip(&frame.instance).all(|(c, i)| c == i), "the quads' instance ids are their classes here");
    let mut probe = Frame::default();
    render_visibility(&w, &camera(Matrix4::identity()), &mut probe);
    assert_eq!((&probe.semantic, &probe.instance, &probe.depth), (&frame.semantic, &frame.instance, &frame.depth));
    // Nothing behind the camera or outside the scene is drawn: depth 0, class 0.
    let empty = world(quad(-1.0, 1.0, -1.0, 1.0, -2.0, 0, 5).to_vec());
    render(&empty, &camera(Matrix4::identity()), &Shading::Flat, &mut frame);
    assert!(frame.depth.iter().all(|&d| d == 0.0) && frame.semantic.iter().all(|&s| s == 0) && frame.instance.iter().all(|&i| i == 0));
}

#[test]
fn flat_shading_is_the_albedo_and_lights_follow_habitats_model() {
    let w = world(quad(-10.0, 10.0, -10.0, 10.0, 2.0, 0, 1).to_vec());
    let mut frame = Frame::default();
    let cam = camera(Matrix4::identity());
    render(&w, &cam, &Shading::Flat, &mut frame);
    let centre = 3 * (60 * 160 + 80);
    assert_eq!(&frame.rgb[centre..centre + 3], &[128, 64, 255]);
    // A light behind the plane adds nothing: ambient 0.4 only.
    render(&w, &cam, &Shading::Lit(vec![Light { position: [0.0, 0.0, 10.0], color: [1.0; 3], attached_to_camera: false }]), &mut frame);
    let ambient = [0.5 * AMBIENT, 0.25 * AMBIENT, 1.0 * AMBIENT].map(|c| (c * 255.0).round() as u8);
    assert_eq!(&frame.rgb[centre..centre + 3], &ambient);
    // A camera light straight on, 2 m away: ambient + diffuse attenuated by 1/(1 + d²).
    render(&w, &cam, &Shading::Lit(vec![Light { position: [0.0; 3], color: [2.5; 3], attached_to_camera: true }]), &mut frame);
    // The centre pixel is a hair off the optical axis: the diffuse term is cos(0.00625 rad).
    let lit = [0.5 * 0.9, 0.25 * 0.9, 1.0f32 * 0.9].map(|c| c.min(1.0) * 255.0);
    for k in 0..3 {
        assert!((frame.rgb[centre + k] as f32 - lit[k]).abs() <= 1.0, "{:?} vs {lit:?}", &frame.rgb[centre..centre + 3]);
    }
    // A negative (darkening) light takes away from the ambient.
    render(&w, &cam, &Shading::Lit(vec![Light { position: [0.0; 3], color: [-0.035; 3], attached_to_camera: true }]), &mut frame);
    assert!(frame.rgb[centre] < ambient[0]);
}

#[test]
fn a_converted_scene_renders_from_inside_the_room() {
    let out = tempfile::tempdir().unwrap();
    let fixture = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/fixtures/scenesmith/scene_000");
    let report = write_habitat_scene(&load_scene(&fixture).unwrap(), out.path(), &ConvertOptions::default()).unwrap();
    let w = World::load_habitat_scene(out.path(), "scene_000").unwrap();
    assert!(w.triangles().len() > 100_000, "real assets: {} triangles", w.triangles().len());
    // Stand at the room centre, 1 m up, looking at the bed (Habitat −z, OpenCV axes).
    let pose = Matrix4::new(1.0, 0.0, 0.0, 0.0, 0.0, -1.0, 0.0, 1.0, 0.0, 0.0, -1.0, 0.5, 0.0, 0.0, 0.0, 1.0);
    let mut frame = Frame::default();
    render(&w, &camera(pose), &Shading::Flat, &mut frame);
    let hit = frame.depth.iter().filter(|&&d| d > 0.0).count();
    assert!(hit as f64 > 0.6 * frame.depth.len() as f64, "walls and floor fill most of the view: {hit}");
    assert!(frame.depth.iter().all(|&d| d < 8.0));
    let bed = report.objects.iter().find(|o| o.class == "bed").unwrap().class_id as u16;
    assert!(frame.semantic.contains(&bed), "the bed is in view");
}

#[test]
fn a_box_seen_at_an_angle_has_the_ray_cast_depth() {
    // A 1 m cube centred 4 m ahead, turned 30° about the vertical; camera at the origin.
    let (c, s) = (30f32.to_radians().cos(), 30f32.to_radians().sin());
    let corner = |x: f32, y: f32, z: f32| [c * x + s * z, y, -s * x + c * z + 4.0];
    let mut triangles = Vec::new();
    let faces: [[(f32, f32, f32); 4]; 6] = [
        [(-0.5, -0.5, -0.5), (0.5, -0.5, -0.5), (0.5, 0.5, -0.5), (-0.5, 0.5, -0.5)],
        [(-0.5, -0.5, 0.5), (0.5, -0.5, 0.5), (0.5, 0.5, 0.5), (-0.5, 0.5, 0.5)],
        [(-0.5, -0.5, -0.5), (-0.5, 0.5, -0.5), (-0.5, 0.5, 0.5), (-0.5, -0.5, 0.5)],
        [(0.5, -0.5, -0.5), (0.5, 0.5, -0.5), (0.5, 0.5, 0.5), (0.5, -0.5, 0.5)],
        [(-0.5, -0.5, -0.5), (0.5, -0.5, -0.5), (0.5, -0.5, 0.5), (-0.5, -0.5, 0.5)],
        [(-0.5, 0.5, -0.5), (0.5, 0.5, -0.5), (0.5, 0.5, 0.5), (-0.5, 0.5, 0.5)],
    ];
    for f in faces {
        let p = f.map(|(x, y, z)| corner(x, y, z));
        let n = [[0.0, 0.0, -1.0]; 3];
        triangles.push(Triangle { positions: [p[0], p[1], p[2]], normals: n, uvs: [[0.0; 2]; 3], surface: 0, class_id: 3, instance_id: 7 });
        triangles.push(Triangle { positions: [p[0], p[2], p[3]], normals: n, uvs: [[0.0; 2]; 3], surface: 0, class_id: 3, instance_id: 7 });
    }
    let w = world(triangles);
    let mut frame = Frame::default();
    let cam = camera(Matrix4::identity());
    render(&w, &cam, &Shading::Flat, &mut frame);
    // Ray-cast each pixel against the cube in its own frame (slab test).
    let mut checked = 0;
    for v in 0..120 {
        for u in 0..160 {
            let d = [((u as f64) - cam.cx) / cam.fx, ((v as f64) - cam.cy) / cam.fy, 1.0];
            // Into the cube frame: undo the translation and the 30° turn.
            let (cd, sd) = (30f64.to_radians().cos(), 30f64.to_radians().sin());
            let to_local = |p: [f64; 3]| [cd * p[0] - sd * p[2], p[1], sd * p[0] + cd * p[2]];
            let o = to_local([0.0, 0.0, -4.0]);
            let dir = to_local(d);
            let (mut near, mut far) = (f64::NEG_INFINITY, f64::INFINITY);
            for a in 0..3 {
                let (t0, t1) = ((-0.5 - o[a]) / dir[a], (0.5 - o[a]) / dir[a]);
                near = near.max(t0.min(t1));
                far = far.min(t0.max(t1));
            }
            if near < far {
                // Stay away from the face's edges, where a pixel may go either way: the hit
                // point's distance to the nearest edge of the face it lies on.
                let edge = (0..3).map(|a| 0.5 - (o[a] + near * dir[a]).abs()).filter(|m| *m > 1e-6).fold(f64::INFINITY, f64::min);
                if edge > 0.02 {
                    let i = v * 160 + u;
                    assert_eq!(frame.semantic[i], 3);
                    // Planar depth is the ray parameter here (the ray's z component is 1).
                    assert!((frame.depth[i] as f64 - near).abs() < QUANTUM as f64, "pixel ({u}, {v}): {} vs {near}", frame.depth[i]);
                    checked += 1;
                }
            } else if frame.semantic[v * 160 + u] == 3 {
                // A miss may only be drawn right at the silhouette.
                assert!(far - near > -0.02, "pixel ({u}, {v}) drawn outside the cube");
            }
        }
    }
    assert!(checked > 300, "{checked} pixels checked");
}

#[test]
fn a_floor_reaching_behind_the_camera_keeps_its_depth_to_the_quantum() {
    // The floor y = 1.5 (OpenCV: y down) from 20 m behind to 20 m ahead, clipped at the near plane.
    let (w, h) = (1200usize, 680usize);
    let cam = Camera { width: w as u32, height: h as u32, fx: 600.0, fy: 600.0, cx: 599.5, cy: 339.5, pose: Matrix4::identity() };
    let n = [[0.0, -1.0, 0.0]; 3];
    let tri = |p: [[f32; 3]; 3]| Triangle { positions: p, normals: n, uvs: [[0.0; 2]; 3], surface: 0, class_id: 3, instance_id: 7 };
    let (y, e) = (1.5f32, 20.0f32);
    let floor = world(vec![tri([[-e, y, -e], [e, y, -e], [e, y, e]]), tri([[-e, y, -e], [e, y, e], [-e, y, e]])]);
    let mut frame = Frame::default();
    render(&floor, &cam, &Shading::Flat, &mut frame);
    let mut checked = 0;
    for v in 0..h {
        let expected = 1.5 * cam.fy / (v as f64 - cam.cy);
        if !(0.3..8.0).contains(&expected) {
            continue;
        }
        for u in 0..w {
            let d = frame.depth[v * w + u] as f64;
            let x = (u as f64 - cam.cx) / cam.fx * expected;
            if x.abs() > 19.0 {
                continue;
            }
            assert!((d - expected).abs() < QUANTUM as f64, "pixel ({u}, {v}): depth {d}, expected {expected}");
            checked += 1;
        }
    }
    assert!(checked > 100_000, "{checked} pixels checked");
}

#[test]
fn obj_meshes_carry_their_materials_uvs_and_base_colour_textures() {
    use osmab_dataset::render::obj::read_obj;
    use osmab_evaluator::formats::image::{RgbImage, write_jpeg_rgb};
    let dir = tempfile::tempdir().unwrap();
    write_jpeg_rgb(&dir.path().join("red.jpg"), &RgbImage { width: 16, height: 16, pixels: [230u8, 20, 20].repeat(256) }, 95).unwrap();
    std::fs::write(
        dir.path().join("m.mtl"),
        "Kd 0 1 0\nnewmtl wood\nKd 0.5 0.25 0.125\nmap_Kd -s 1 1 1 red.jpg\nnewmtl paint\nKd 0.1 0.2 0.3\nnewmtl stolen\nmap_Kd ../../etc/passwd\n",
    )
    .unwrap();
    let obj = "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nusemtl wood\nf 1/1 2/2 3/3 4/4\nusemtl paint\nf -4 -2 -1\n";
    std::fs::write(dir.path().join("a.obj"), obj).unwrap();
    let mesh = read_obj(&dir.path().join("a.obj")).unwrap();
    let names: Vec<&str> = mesh.materials.iter().map(|m| m.name.as_str()).collect();
    assert_eq!(names, ["", "wood", "paint", "stolen"]);
    assert_eq!(mesh.materials[1].color, [0.5, 0.25, 0.125]);
    let texture = mesh.materials[1].texture.as_ref().expect("the wood texture");
    assert_eq!((texture.width, texture.height), (16, 16));
    assert!(texture.rgba[0] > 200 && texture.rgba[1] < 60, "red texels: {:?}", &texture.rgba[..4]);
    assert!(mesh.materials[3].texture.is_none(), "a texture outside the asset's folder is not read");
    // The quad is a fan of two triangles with wood; the last face uses paint and no UVs.
    assert_eq!(mesh.triangles.iter().map(|t| t.1).collect::<Vec<_>>(), [1, 1, 2]);
    assert_eq!(mesh.triangles[0].0, [(0, Some(0)), (1, Some(1)), (2, Some(2))]);
    assert_eq!(mesh.triangles[2].0, [(0, None), (2, None), (3, None)]);
    // OBJ's v points up, textures are sampled with v down.
    assert_eq!(mesh.uvs[0], [0.0, 1.0]);

    std::fs::write(dir.path().join("bad.obj"), "v 0 0 0\nvt 0 0\nf 1/1 1/2 1/1\n").unwrap();
    let err = read_obj(&dir.path().join("bad.obj")).unwrap_err();
    assert!(err.to_string().contains("bad.obj") && err.to_string().contains("line 3"), "{err}");
}

#[test]
fn triangles_at_the_image_edges_draw_their_pixels_and_those_beyond_draw_none() {
    // Triangles wholly beyond an edge are dropped before projection; those reaching a
    // pixel centre across the edge must still draw it. Camera 160×120, fx = fy = 80,
    // at z = 1: pixel column u = 80·x + 79.5, row v = 80·y + 59.5.
    let (x, y) = (|u: f32| (u - 79.5) / 80.0, |v: f32| (v - 59.5) / 80.0);
    let cam = camera(Matrix4::identity());
    let drawn = |triangles: Vec<Triangle>| {
        let mut frame = Frame::default();
        render(&world(triangles), &cam, &Shading::Flat, &mut frame);
        frame.semantic.iter().filter(|&&s| s == 5).count()
    };
    // Reaching a fifth of a pixel into the image: one column or row of pixels.
    assert_eq!(drawn(quad(x(-5.0), x(0.2), y(9.5), y(19.5), 1.0, 0, 5).to_vec()), 10, "left edge");
    assert_eq!(drawn(quad(x(158.8), x(165.0), y(9.5), y(19.5), 1.0, 0, 5).to_vec()), 10, "right edge");
    assert_eq!(drawn(quad(x(9.5), x(19.5), y(-5.0), y(0.2), 1.0, 0, 5).to_vec()), 10, "top edge");
    assert_eq!(drawn(quad(x(9.5), x(19.5), y(118.8), y(125.0), 1.0, 0, 5).to_vec()), 10, "bottom edge");
    // Stopping short of the first pixel centre, by less than a pixel and by far.
    for (u0, u1) in [(-5.0, -0.4), (-500.0, -300.0), (159.4, 165.0), (300.0, 500.0)] {
        assert_eq!(drawn(quad(x(u0), x(u1), y(9.5), y(19.5), 1.0, 0, 5).to_vec()), 0, "columns {u0}..{u1}");
    }
    for (v0, v1) in [(-5.0, -0.4), (-500.0, -300.0), (119.4, 125.0), (300.0, 500.0)] {
        assert_eq!(drawn(quad(x(9.5), x(19.5), y(v0), y(v1), 1.0, 0, 5).to_vec()), 0, "rows {v0}..{v1}");
    }
}
