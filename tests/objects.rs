//! Moving objects in the light field (issue 28) on the software adapter: an object inside a
//! closed furnace shows exactly rho * Le / (1 - rho_walls) plus its own emission (lit through
//! the irradiance probes), hides at run time, and is seen in a mirror where geometry puts its
//! reflection.

mod common;
use common::*;
use glam::DVec3;
use std::path::Path;
use vlf::display::frame::{FrameOfViews, Poses, Slots};
use vlf::display::DisplayConfig;
use vlf::progress::Silent;
use vlf::render::Frame;

/// A one-wall display looking along -z from a head at (0, 0, 0.35) through a 0.2 x 0.2 m wall at
/// z = 0.15, `pixels` square, with `objects` (TOML `[[object]]` tables) and small probes.
fn display(dir: &Path, pixels: u32, aa: u32, objects: &str) -> (std::path::PathBuf, DisplayConfig) {
    let text = format!(
        "name = \"objects test\"\nantialiasing = {aa}\n\n[tracking]\nsource = \"static\"\nhead = [0.0, 0.0, 0.35]\n\n\
         [probes]\nresolution = 6\nrays = 256\n\n\
         [[wall]]\nname = \"front\"\nlower_left = [-0.1, -0.1, 0.15]\nlower_right = [0.1, -0.1, 0.15]\n\
         upper_left = [-0.1, 0.1, 0.15]\npixels = [{pixels}, {pixels}]\noutput = {{ monitor = 0 }}\n\n{objects}"
    );
    let path = dir.join("display.toml");
    std::fs::write(&path, text).unwrap();
    let config = DisplayConfig::load(&path).unwrap();
    (path, config)
}

/// An OBJ cube of half-size `h` at `c` with one material, as `name`.obj + .mtl in `dir`.
fn cube_object(dir: &Path, name: &str, c: DVec3, h: f64, kd: f32, ke: f32) {
    let mut obj = ObjBuilder::default();
    obj.cube("thing", c, h, false);
    std::fs::write(
        dir.join(format!("{name}.obj")),
        obj.text(&format!("{name}.mtl")),
    )
    .unwrap();
    let mtl = format!("newmtl thing\nKd {kd} {kd} {kd}\nKe {ke} {ke} {ke}\nKs 0 0 0\n");
    std::fs::write(dir.join(format!("{name}.mtl")), mtl).unwrap();
}

fn object_table(name: &str, mesh: &str) -> String {
    format!("[[object]]\nname = \"{name}\"\nmesh = \"{mesh}\"\n\n")
}

/// Every view of the display drawn once from its static head, read back.
fn draw(
    lf: &vlf::lightfield::LightField,
    resident: &vlf::lightfield::ResidentLightField,
    (path, config): (&Path, &DisplayConfig),
    hide: Option<&str>,
) -> Frame {
    let poses = config.pose_source(path).unwrap();
    let mut frame =
        FrameOfViews::cave((lf, resident), config, path, &poses, Slots::PerWall).unwrap();
    if let Some(name) = hide {
        frame
            .objects_mut()
            .unwrap()
            .set_visible(name, false)
            .unwrap();
    }
    let pose = poses.at(0.0);
    let tracked = Poses::Tracked {
        pose: &pose,
        wand: None,
        arrived: None,
    };
    frame.read_back(tracked).unwrap().remove(0).0
}

fn pixel(f: &Frame, x: u32, y: u32) -> [f32; 4] {
    f.pixels[(y * f.width + x) as usize]
}

/// The furnace: a closed box of side 1 whose walls emit Le = 1 with albedo 0.5 holds radiance
/// 2 everywhere; a cube of albedo 0.6 in it receives pi * 2 from every side and shows 1.2, and
/// one that also emits 0.3 shows 1.5. The probes' spherical harmonics hold a uniform field
/// exactly, so what is left is the light field's own convergence (draft settings, tolerance
/// 1e-2 with the geometric tail: measured within 0.02%; asserted within 0.2%).
#[test]
fn an_object_in_a_closed_furnace_shows_rho_le_over_one_minus_rho_plus_its_emission() {
    let dir = tempfile::tempdir().unwrap();
    let mut obj = ObjBuilder::default();
    obj.cube("wall", DVec3::ZERO, 0.5, true);
    let walls = [Mat {
        name: "wall",
        kd: [0.5; 3],
        ke: [1.0; 3],
    }];
    let scene = load_scene(dir.path(), &obj, &walls, "");
    let (lf, resident, _) =
        vlf::propagate::propagate(gpu(), &scene, &draft_params(), &Silent).unwrap();
    cube_object(
        dir.path(),
        "grey",
        DVec3::new(-0.06, 0.0, -0.1),
        0.04,
        0.6,
        0.0,
    );
    cube_object(
        dir.path(),
        "glowing",
        DVec3::new(0.06, 0.0, -0.1),
        0.04,
        0.6,
        0.3,
    );
    let objects = object_table("grey", "grey.obj") + &object_table("glowing", "glowing.obj");
    let (path, config) = display(dir.path(), 32, 4, &objects);
    let image = draw(&lf, &resident, (&path, &config), None);
    let wall = pixel(&image, 16, 2)[0] as f64;
    let grey = pixel(&image, 10, 16)[0] as f64;
    let glowing = pixel(&image, 22, 16)[0] as f64;
    let within = |v: f64, want: f64| (v - want).abs() / want;
    eprintln!("wall {wall:.4} (2), grey {grey:.4} (1.2), glowing {glowing:.4} (1.5)");
    assert!(
        within(wall, 2.0) < 0.01,
        "the walls show {wall}, not Le / (1 - rho) = 2"
    );
    assert!(
        within(grey, 1.2) < 0.01,
        "the grey cube shows {grey}, not 0.6 * 2 = 1.2"
    );
    assert!(
        within(glowing, 1.5) < 0.01,
        "the glowing cube shows {glowing}, not 1.5"
    );
    // hidden, the cube leaves the wall behind it
    let hidden = draw(&lf, &resident, (&path, &config), Some("grey"));
    let behind = pixel(&hidden, 10, 16)[0] as f64;
    assert!(
        within(behind, 2.0) < 0.01,
        "the hidden cube still shows: {behind}"
    );
    assert!(
        within(pixel(&hidden, 22, 16)[0] as f64, 1.5) < 0.01,
        "the other one went too"
    );
}

/// Where a row's radiance first falls below `threshold` from the left, in pixels (sub-pixel:
/// an edge pixel's value is the mix of the two sides by the share of the pixel each covers).
fn first_edge(f: &Frame, y: u32, from: u32, bright: f64, dark: f64) -> f64 {
    let threshold = 0.5 * (bright + dark);
    for x in from..f.width {
        let v = pixel(f, x, y)[0] as f64;
        if v < threshold {
            let previous = pixel(f, x - 1, y)[0] as f64;
            // the pixel before the crossing holds part of the edge where it is between the two
            let (c, v) = if previous < bright * 0.98 {
                (x - 1, previous)
            } else {
                (x, v)
            };
            return c as f64 + ((v - dark) / (bright - dark)).clamp(0.0, 1.0);
        }
    }
    panic!("no edge in row {y} from column {from}");
}

/// A mirror for the back wall of the furnace (z = -0.5, reflectance 0.9) and a dark cube in
/// front of it: its reflection's left edge lands where the mirror image of the cube projects,
/// and the cube seen directly where it projects (measured within 0.05 pixel at 16 eye rays per
/// pixel; asserted within a quarter, the issue asks for one).
#[test]
fn an_object_is_seen_in_a_mirror_where_geometry_puts_its_reflection() {
    let dir = tempfile::tempdir().unwrap();
    let mut obj = ObjBuilder::default();
    for (axis, sign) in [
        (DVec3::X, 1.0),
        (DVec3::X, -1.0),
        (DVec3::Y, 1.0),
        (DVec3::Y, -1.0),
        (DVec3::Z, 1.0),
    ] {
        let outward = axis * sign;
        obj.quad("wall", outward * 0.5, -outward, [1.0, 1.0], 0.0);
    }
    obj.quad(
        "mirror",
        DVec3::new(0.0, 0.0, -0.5),
        DVec3::Z,
        [1.0, 1.0],
        0.0,
    );
    let materials = [
        Mat {
            name: "wall",
            kd: [0.5; 3],
            ke: [1.0; 3],
        },
        Mat {
            name: "mirror",
            kd: [0.0; 3],
            ke: [0.0; 3],
        },
    ];
    let scene = load_scene(
        dir.path(),
        &obj,
        &materials,
        "[materials.mirror]\nmirror = [0.9, 0.9, 0.9]\n",
    );
    let (lf, resident, _) =
        vlf::propagate::propagate(gpu(), &scene, &draft_params(), &Silent).unwrap();
    // a cube of half-size 0.05 at (0.15, 0, 0): its left face x = 0.10 faces the eye's side
    cube_object(
        dir.path(),
        "cube",
        DVec3::new(0.15, 0.0, 0.0),
        0.05,
        0.05,
        0.0,
    );
    let (path, config) = display(dir.path(), 64, 16, &object_table("cube", "cube.obj"));
    let image = draw(&lf, &resident, (&path, &config), None);
    // the wall's pixels: x_screen = -0.1 .. 0.1 over 64 columns; a point (X, Z) projects from the
    // eye (0, 0.35) onto z = 0.15 at x = X * 0.2 / (0.35 - Z)
    let column = |x: f64, z: f64| (x * 0.2 / (0.35 - z) + 0.1) / 0.2 * 64.0;
    // seen directly: the left face's far edge (X 0.10, Z -0.05) is the silhouette
    let direct = column(0.10, -0.05);
    // in the mirror the cube's image lies at z' = -1 - z: Z from -0.95 to -1.05
    let reflected = column(0.10, -1.05);
    let y = 32;
    let mirror_bg = pixel(&image, 30, y)[0] as f64;
    let cube = pixel(&image, 60, y)[0] as f64;
    let reflected_cube =
        pixel(&image, ((reflected + column(0.2, -0.95)) / 2.0) as u32, y)[0] as f64;
    eprintln!("background in the mirror {mirror_bg:.3}, cube {cube:.3}, its reflection {reflected_cube:.3}");
    assert!(
        reflected_cube < 0.5 * mirror_bg,
        "no dark cube in the mirror: {reflected_cube} against {mirror_bg}"
    );
    let seen = first_edge(&image, y, 20, mirror_bg, reflected_cube);
    eprintln!("reflected edge at {seen:.2} px, geometry {reflected:.2} px");
    assert!(
        (seen - reflected).abs() < 0.25,
        "the reflection's edge is at {seen:.2} px, geometry puts it at {reflected:.2} px"
    );
    let wall_bg = pixel(&image, (direct - 3.0) as u32, y)[0] as f64;
    let seen_direct = first_edge(&image, y, (direct - 2.0) as u32, wall_bg, cube);
    eprintln!("direct edge at {seen_direct:.2} px, geometry {direct:.2} px");
    assert!(
        (seen_direct - direct).abs() < 0.25,
        "the cube's edge is at {seen_direct:.2} px, geometry puts it at {direct:.2} px"
    );
}
