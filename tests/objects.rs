//! Moving objects in the light field (issue 28) on the software adapter: an object inside a
//! closed furnace shows exactly rho * Le / (1 - rho_walls) plus its own emission (lit through
//! the irradiance probes), hides at run time, and is seen in a mirror where geometry puts its
//! reflection; its shadows, from the shadow atlas and per pixel, take what the closed forms say
//! of an emitter's light and the sky's; a study's condition switches the light field that lights
//! the scene and them.

use crate::common;
use common::*;
use glam::DVec3;
use std::path::Path;
use vlf::display::frame::{FrameOfViews, Poses, Slots};
use vlf::display::DisplayConfig;
use vlf::progress::Silent;
use vlf::render::Frame;
use vlf::study::session::ObjectChange;

/// A one-wall display looking along -z from a head at (0, 0, 0.35) through a 0.2 x 0.2 m wall at
/// z = 0.15, `pixels` square, with `objects` (TOML `[[object]]` tables), small probes and no
/// shadows (these tests look at the objects; the shadow test has its own display).
fn display(dir: &Path, pixels: u32, aa: u32, objects: &str) -> (std::path::PathBuf, DisplayConfig) {
    let lighting = "shadow_samples = 0\nsky_shadow_samples = 0\nvertex_shadow_samples = 0\nvertex_sky_shadow_samples = 0\n";
    display_lit(dir, (pixels, aa), lighting, objects)
}

/// `display` with `lighting`'s keys of `[object_lighting]` (after its small probes).
fn display_lit(
    dir: &Path,
    (pixels, aa): (u32, u32),
    lighting: &str,
    objects: &str,
) -> (std::path::PathBuf, DisplayConfig) {
    let text = format!(
        "name = \"objects test\"\nantialiasing = {aa}\n\n[tracking]\nsource = \"static\"\nhead = [0.0, 0.0, 0.35]\n\n\
         [object_lighting]\nprobe_resolution = 6\nprobe_rays = 256\n{lighting}\n\
         [[wall]]\nname = \"front\"\nlower_left = [-0.1, -0.1, 0.15]\nlower_right = [0.1, -0.1, 0.15]\n\
         upper_left = [-0.1, 0.1, 0.15]\npixels = [{pixels}, {pixels}]\noutput = {{ monitor = 0 }}\n\n{objects}"
    );
    let path = dir.join("display.toml");
    std::fs::write(&path, text).unwrap();
    let config = DisplayConfig::load(&path).unwrap();
    (path, config)
}

fn object_table(name: &str, mesh: &str) -> String {
    format!("[[object]]\nname = \"{name}\"\nmesh = \"{mesh}\"\n\n")
}

/// Every view of the display drawn once from its static head after a study's `changes`, read
/// back.
fn draw(
    lf: &vlf::lightfield::LightField,
    resident: &vlf::lightfield::ResidentLightField,
    (path, config): (&Path, &DisplayConfig),
    changes: &[ObjectChange],
) -> Frame {
    let poses = config.pose_source(path).unwrap();
    let mut frame =
        FrameOfViews::cave((lf, resident), config, path, &poses, Slots::PerWall, None).unwrap();
    frame.change_objects(changes);
    let pose = poses.at(0.0);
    let tracked = Poses::Tracked {
        pose: &pose,
        held: &Default::default(),
        arrived: None,
    };
    frame.read_back(tracked).unwrap().remove(0).0
}

fn pixel(f: &Frame, x: u32, y: u32) -> [f32; 4] {
    f.pixels[(y * f.width + x) as usize]
}

/// The furnace of side 1 (walls emitting Le = 1 with albedo 0.5) written to `dir`, propagated
/// at the draft settings, and the object "grey.obj" (a cube of albedo 0.6, at x = -0.06): the
/// scene file and the light field.
fn furnace(
    dir: &Path,
) -> (
    std::path::PathBuf,
    vlf::lightfield::LightField,
    vlf::lightfield::ResidentLightField,
) {
    let mut obj = ObjBuilder::default();
    obj.cube("wall", DVec3::ZERO, 0.5, true);
    let walls = [Mat {
        name: "wall",
        kd: [0.5; 3],
        ke: [1.0; 3],
    }];
    let path = write_scene(dir, &obj, &walls, "");
    let scene = vlf::scene::Scene::load(&path).unwrap();
    let (lf, resident, _) =
        vlf::propagate::propagate(gpu(), &scene, &draft_params(), &Silent).unwrap();
    cube_object(dir, "grey", DVec3::new(-0.06, 0.0, -0.1), 0.04, 0.6, 0.0);
    (path, lf, resident)
}

/// The furnace: a closed box of side 1 whose walls emit Le = 1 with albedo 0.5 holds radiance
/// 2 everywhere; a cube of albedo 0.6 in it receives pi * 2 from every side and shows 1.2, and
/// one that also emits 0.3 shows 1.5. The probes' spherical harmonics hold a uniform field
/// exactly, so what is left is the light field's own convergence (draft settings, tolerance
/// 1e-2 with the geometric tail: measured within 0.02%; asserted within 0.2%).
#[test]
fn an_object_in_a_closed_furnace_shows_rho_le_over_one_minus_rho_plus_its_emission() {
    let dir = tempfile::tempdir().unwrap();
    let (_, lf, resident) = furnace(dir.path());
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
    let image = draw(&lf, &resident, (&path, &config), &[]);
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
    let hidden = draw(
        &lf,
        &resident,
        (&path, &config),
        &[ObjectChange::Visible("grey".into(), false)],
    );
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

/// A trough in the furnace: two plates of albedo 0.5, 8 cm wide and 60 cm long, meeting at a
/// right angle along a vertical edge, open toward the viewer. Each plate's inner face sees the
/// other where the probes (baked without them) hold the walls' radiance 2: without the
/// occlusion rays a plate shows 0.5 x 2 = 1 everywhere; with them its light falls toward the
/// edge as the exact solution's (the two plates' radiosity in 2D, their length being 7.5 widths)
/// does. Twice: with the probes holding all the light, and with the walls' emission sampled by
/// the vertices' shadow rays (the probes the rest), where what a plate sees of the other takes
/// that plate's own shadowed direct light. One bounce within the object is taken (what a plate
/// sees of the other shows that plate's light with the probes' light unoccluded), and 16 rays
/// per vertex (the default) see the other plate with some noise. Measured (lavapipe) at 0.29,
/// 0.48 and 0.83 of the width from the edge (the columns nearest 0.3, 0.5, 0.75): probes -1.0%,
/// -3.2%, +0.7% (asserted within 5%); shadow rays -0.0%, -0.3%, -0.6% (asserted within 2%);
/// without the occlusion rays +27%, +20%, +12% (asserted more than 8% off where nearer the edge
/// than 0.6 of the width).
#[test]
fn a_trough_hides_the_probes_light_from_itself() {
    let dir = tempfile::tempdir().unwrap();
    let (_, lf, resident) = furnace(dir.path());
    let (rho, width) = (0.5f32, 0.08);
    trough_object(dir.path(), rho, width);
    let objects = object_table("trough", "trough.obj");
    let probes_only = "shadow_samples = 0\nsky_shadow_samples = 0\nvertex_shadow_samples = 0\nvertex_sky_shadow_samples = 0\n";
    let sampled = "shadow_samples = 0\nsky_shadow_samples = 0\nvertex_shadow_samples = 128\nvertex_sky_shadow_samples = 0\n";
    let exact = trough_radiosity(rho as f64, 2.0, 2000);
    for (name, lighting, bound) in [
        ("probes", probes_only.to_string(), 0.05),
        ("shadow rays", sampled.to_string(), 0.02),
        (
            "no occlusion rays",
            format!("{probes_only}occlusion_rays = 0\n"),
            -0.08,
        ),
    ] {
        let (path, config) = display_lit(dir.path(), (48, 4), &lighting, &objects);
        let image = draw(&lf, &resident, (&path, &config), &[]);
        for share in [0.3, 0.5, 0.75] {
            let (share, got) = trough_pixel(&image, share, width);
            let want = exact(share);
            let off = (got - want).abs() / want;
            eprintln!(
                "{name}: {share} of the width from the edge: {got:.4}, exact {want:.4} ({:+.2}%)",
                100.0 * (got - want) / want
            );
            if bound > 0.0 {
                assert!(
                    off < bound,
                    "{name}: {got} at {share} of the width, exact {want}"
                );
            } else if share < 0.6 {
                assert!(
                    off > -bound,
                    "{name}: {got} at {share} of the width is already near the exact {want}"
                );
            }
        }
    }
}

/// The trough's edge at x = 0, z = -0.2 (y from -0.3 to 0.3); its plates run from it along
/// (-1, 0, 1) / sqrt 2 and (1, 0, 1) / sqrt 2.
fn trough_plates() -> [(DVec3, DVec3); 2] {
    let c = std::f64::consts::FRAC_1_SQRT_2;
    let (left, right) = (DVec3::new(-c, 0.0, c), DVec3::new(c, 0.0, c));
    // each plate's inner normal is the other plate's direction
    [(left, right), (right, left)]
}

/// trough.obj/.mtl: the two plates, 12 x 40 quads each, their own vertices (no normal smoothed
/// over the edge), wound to face inward.
fn trough_object(dir: &Path, rho: f32, width: f64) {
    let edge = DVec3::new(0.0, 0.0, -0.2);
    let (across, along) = (12, 40);
    let mut text = String::from("mtllib trough.mtl\nusemtl plate\n");
    let mut first = 1;
    for (run, inward) in trough_plates() {
        let at = |i: usize, j: usize| {
            edge + run * (width * i as f64 / across as f64)
                + DVec3::Y * (-0.3 + 0.6 * j as f64 / along as f64)
        };
        for j in 0..=along {
            for i in 0..=across {
                let p = at(i, j);
                text += &format!("v {} {} {}\n", p.x, p.y, p.z);
            }
        }
        let index = |i: usize, j: usize| first + j * (across + 1) + i;
        let facing = (at(1, 0) - at(0, 0)).cross(at(0, 1) - at(0, 0)).dot(inward) > 0.0;
        for j in 0..along {
            for i in 0..across {
                let (a, b, c, d) = (
                    index(i, j),
                    index(i + 1, j),
                    index(i + 1, j + 1),
                    index(i, j + 1),
                );
                let [(a, b, c), (d, e, f)] = if facing {
                    [(a, b, c), (a, c, d)]
                } else {
                    [(a, c, b), (a, d, c)]
                };
                text += &format!("f {a} {b} {c}\nf {d} {e} {f}\n");
            }
        }
        first += (across + 1) * (along + 1);
    }
    std::fs::write(dir.join("trough.obj"), text).unwrap();
    std::fs::write(
        dir.join("trough.mtl"),
        format!("newmtl plate\nKd {rho} {rho} {rho}\nKe 0 0 0\nKs 0 0 0\n"),
    )
    .unwrap();
}

/// The exact radiance of the trough's plates in 2D, in an enclosure of radiance `outside`: by
/// symmetry both plates alike, B(s) = rho ((1 - F(s)) outside + the integral of B(t) s t / (2
/// r^3) dt over the other plate (r^2 = s^2 + t^2)), F(s) = (1 - s / sqrt(s^2 + w^2)) / 2, solved
/// on `n` midpoints of the width by iteration; returned as a function of the share of the width.
fn trough_radiosity(rho: f64, outside: f64, n: usize) -> impl Fn(f64) -> f64 {
    let h = 1.0 / n as f64;
    let x: Vec<f64> = (0..n).map(|i| (i as f64 + 0.5) * h).collect();
    let seen = |s: f64| 0.5 * (1.0 - s / (s * s + 1.0).sqrt());
    let mut b = vec![rho * outside; n];
    for _ in 0..60 {
        b = (x.iter())
            .map(|&s| {
                let other: f64 = (x.iter().zip(&b))
                    .map(|(&t, &bt)| bt * s * t / (2.0 * (s * s + t * t).powf(1.5)) * h)
                    .sum();
                rho * ((1.0 - seen(s)) * outside + other)
            })
            .collect();
    }
    move |share: f64| b[((share / h) as usize).min(n - 1)]
}

/// The left plate's mean radiance over the 16 middle rows (the trough is the same along its
/// length there) in the column whose centre sees the plate nearest `share` of its `width` from
/// the edge, and the share that centre sees.
fn trough_pixel(image: &Frame, share: f64, width: f64) -> (f64, f64) {
    let c = std::f64::consts::FRAC_1_SQRT_2;
    // the ray from the head (z = 0.35) through the wall (z = 0.15, x in -0.1..0.1) at x meets
    // the plate (0, 0, -0.2) + s (-c, 0, c) at s = -k x / c, k = 0.55 / (0.2 - x)
    let seen = |column: u32| {
        let x = -0.1 + 0.2 * (column as f64 + 0.5) / image.width as f64;
        -(0.55 / (0.2 - x)) * x / c / width
    };
    let column = (0..image.width / 2)
        .min_by(|&a, &b| (seen(a) - share).abs().total_cmp(&(seen(b) - share).abs()))
        .unwrap();
    let rows = image.height / 2 - 8..image.height / 2 + 8;
    let mean = rows
        .clone()
        .map(|y| pixel(image, column, y)[0] as f64)
        .sum::<f64>()
        / rows.len() as f64;
    (seen(column), mean)
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
    let scene = mirror_furnace(dir.path());
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
    let image = draw(&lf, &resident, (&path, &config), &[]);
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
    // reflections off (a study's condition): the mirror shows the room behind the cube again,
    // the cube itself stays
    let off = draw(
        &lf,
        &resident,
        (&path, &config),
        &[ObjectChange::Reflections(false)],
    );
    let x = ((reflected + column(0.2, -0.95)) / 2.0) as u32;
    let behind = pixel(&off, x, y)[0] as f64;
    assert!(
        (behind - mirror_bg).abs() < 0.05 * mirror_bg,
        "reflections off: {behind} against {mirror_bg}"
    );
    assert_eq!(pixel(&off, 60, y), pixel(&image, 60, y));
}

/// The scene of tests/occlusion.rs without its static blocker (a 2 x 2 m floor of albedo 0.5
/// under a 0.2 m emitter of radiance 10 at 0.5 m) and the blocker as a moving object: the light
/// it takes from each floor point seen, (view without it) - (view with it), against Lambert's
/// closed form for the part of the emitter it hides from that point, in umbra, penumbra and full
/// light, within the penumbra bound tests/occlusion.rs holds the static blocker to (3.5e-2 of the
/// brightest; 1e-5 where it hides nothing), with the shadows drawn per pixel (64 shadow rays per
/// pair of eye rays).
#[test]
fn a_moving_occluder_shadows_the_floor_as_the_closed_form_says_per_pixel() {
    // measured (lavapipe, 16 eye rays, one shadow estimate per pair of them of 64 shadow rays to
    // the emitter's two triangles): lit 0, umbra 1.3e-2, penumbra 2.5e-2. In the umbra the light
    // taken is all the light field holds there, whose draft direct light (64 samples per texel,
    // 24 texels per metre) is what is off
    occluder_within_bounds(Receiver::Floor("per_pixel"));
}

/// The same with the shadows from the shadow atlas (the default: 64 shadow rays per texel of the
/// floor's chart at twice the light field's texels per side, once per frame, read bilinearly as
/// the light field's texels are), within the same bounds where the lookup's footprint (a shadow
/// texel each way of the point) lies wholly in full light, umbra or touches the penumbra: a
/// texel method cannot be exact closer to the penumbra than its texel.
#[test]
fn a_moving_occluder_shadows_the_floor_as_the_closed_form_says_in_the_shadow_atlas() {
    // measured (lavapipe): lit 0, umbra 1.28e-2, penumbra 2.94e-2
    occluder_within_bounds(Receiver::Floor("atlas"));
}

/// The same occluder over a moving panel (albedo 0.5, 1.2 m square, 2 cm above the floor, a
/// vertex every 2 cm), lit per vertex (the default: 256 shadow rays at each vertex, once per
/// frame, interpolated over each triangle): the light the occluder takes from each panel point
/// seen against the same closed form, within the same bounds where the interpolation's footprint
/// (a vertex spacing each way) lies wholly in full light, umbra or touches the penumbra.
#[test]
fn a_moving_occluder_shadows_a_moving_panel_lit_per_vertex_as_the_closed_form_says() {
    // measured (lavapipe): lit 0, umbra 5.1e-3, penumbra 1.03e-2
    occluder_within_bounds(Receiver::Panel);
}

/// What the moving occluder shadows: the static floor with its shadows drawn the given way
/// ("per_pixel", "atlas"), or a moving panel lying on it, lit per vertex.
enum Receiver {
    Floor(&'static str),
    Panel,
}

/// The panel's height over the floor and its vertices' spacing (`Receiver::Panel`).
const PANEL_HEIGHT: f64 = 0.02;
const PANEL_SPACING: f64 = 0.02;

/// A flat square mesh of `cells` x `cells` quads of `spacing` metres facing +y at `centre`,
/// material "panel" (albedo 0.5), as OBJ and MTL text.
fn panel_obj(centre: DVec3, cells: u32, spacing: f64) -> (String, String) {
    let mut obj = String::from("mtllib panel.mtl\nvn 0 1 0\nusemtl panel\n");
    let side = cells + 1;
    let half = cells as f64 * spacing / 2.0;
    for j in 0..side {
        for i in 0..side {
            let p = centre + DVec3::new(i as f64 * spacing - half, 0.0, j as f64 * spacing - half);
            obj += &format!("v {} {} {}\n", p.x, p.y, p.z);
        }
    }
    for j in 0..cells {
        for i in 0..cells {
            let v = |a: u32, b: u32| (j + b) * side + i + a + 1;
            // counter-clockwise seen from above (+y)
            let [a, b, c, d] = [v(0, 0), v(0, 1), v(1, 1), v(1, 0)];
            obj += &format!("f {a}//1 {b}//1 {c}//1\nf {a}//1 {c}//1 {d}//1\n");
        }
    }
    (obj, "newmtl panel\nKd 0.5 0.5 0.5\n".into())
}

/// The moving occluder's scene drawn with its shadows on `receiver`: the worst error, over the
/// brightest, within 1e-5 in full light and 3.5e-2 in umbra and penumbra.
fn occluder_within_bounds(receiver: Receiver) {
    let dir = tempfile::tempdir().unwrap();
    let mut obj = ObjBuilder::default();
    obj.quad("floor", DVec3::ZERO, DVec3::Y, [2.0, 2.0], 0.0);
    obj.quad(
        "light",
        DVec3::new(0.1, 0.5, -0.05),
        -DVec3::Y,
        [0.2, 0.2],
        0.3,
    );
    let (rho, le) = (0.5f64, 10.0f32);
    let materials = [
        Mat {
            name: "floor",
            kd: [rho as f32; 3],
            ke: [0.0; 3],
        },
        Mat {
            name: "light",
            kd: [0.0; 3],
            ke: [le; 3],
        },
    ];
    let scene = load_scene(dir.path(), &obj, &materials, "");
    let params = vlf::propagate::PropagationParams {
        direct_samples: 64,
        texel_density: 24.0,
        ..draft_params()
    };
    let (lf, resident, _) = vlf::propagate::propagate(gpu(), &scene, &params, &Silent).unwrap();
    let mut blocker = ObjBuilder::default();
    blocker.quad(
        "thing",
        DVec3::new(0.12, 0.3, -0.02),
        DVec3::Y,
        [0.3, 0.3],
        0.5,
    );
    std::fs::write(dir.path().join("blocker.obj"), blocker.text("blocker.mtl")).unwrap();
    std::fs::write(dir.path().join("blocker.mtl"), "newmtl thing\nKd 0 0 0\n").unwrap();
    // the eye at (1, 0.7, 0) looking down at (0.1, 0, 0)
    let eye = DVec3::new(1.0, 0.7, 0.0);
    let n = 64u32;
    let (shadows, height) = match receiver {
        Receiver::Floor(shadows) => (shadows, 0.0),
        Receiver::Panel => ("atlas", PANEL_HEIGHT),
    };
    // (no occlusion rays and no indirect rays in the atlas: the panel and the floor would lose
    // the probes' light the blocker covers too, which the closed form of the emitter's light
    // leaves out; a_trough_hides_the_probes_light_from_itself and
    // an_object_takes_the_indirect_light_it_blocks_from_the_wall_behind_it check those)
    let lighting = format!(
        "shadow_samples = 64\nshadows = \"{shadows}\"\natlas_shadow_samples = 64\n\
         vertex_shadow_samples = 256\nocclusion_rays = 0\natlas_indirect_rays = 0"
    );
    let mut objects = object_table("blocker", "blocker.obj");
    if height > 0.0 {
        let (obj, mtl) = panel_obj(DVec3::new(0.1, height, 0.0), 60, PANEL_SPACING);
        std::fs::write(dir.path().join("panel.obj"), obj).unwrap();
        std::fs::write(dir.path().join("panel.mtl"), mtl).unwrap();
        objects += &object_table("panel", "panel.obj");
    }
    let (path, config, wall) = floor_view(
        dir.path(),
        (eye, DVec3::new(0.1, 0.0, 0.0), n),
        &lighting,
        &objects,
    );
    let corner = |a: f64, b: f64| wall[0] + wall[1] * a + wall[2] * b;
    let with = draw(&lf, &resident, (&path, &config), &[]);
    let hide = ObjectChange::Visible("blocker".into(), false);
    let without = draw(&lf, &resident, (&path, &config), &[hide]);
    // switched off (a study's condition), the blocker stays in view and takes no light
    let unshadowed = draw(
        &lf,
        &resident,
        (&path, &config),
        &[ObjectChange::Shadows(false)],
    );
    // the closed form, in metres, for the floor point each pixel's centre sees
    let corners_of = |name: &str, mesh: &vlf::scene::Scene| -> Vec<DVec3> {
        let m = mesh.materials.iter().position(|m| m.name == name).unwrap() as u32;
        let mut c: Vec<DVec3> = (mesh.triangles.iter().filter(|t| t.material == m))
            .flat_map(|t| {
                t.vertices
                    .map(|i| DVec3::from(mesh.positions[i as usize].map(|x| x as f64)))
            })
            .collect();
        c.sort_by(|a, b| a.to_array().partial_cmp(&b.to_array()).unwrap());
        c.dedup_by(|a, b| a.distance(*b) < 1e-9);
        let mid = c.iter().sum::<DVec3>() / c.len() as f64;
        c.sort_by(|a, b| {
            (a.z - mid.z)
                .atan2(a.x - mid.x)
                .total_cmp(&(b.z - mid.z).atan2(b.x - mid.x))
        });
        c
    };
    let emitter = corners_of("light", &scene);
    let occluder = corners_of(
        "thing",
        &vlf::scene::Scene::load_model(&dir.path().join("blocker.obj")).unwrap(),
    );
    let flat = |v: DVec3| glam::DVec2::new(v.x, v.z);
    let emitter_2d: Vec<glam::DVec2> = emitter.iter().map(|&v| flat(v)).collect();
    let k = rho / std::f64::consts::PI * le as f64;
    // the light the blocker hides from floor point p, and all the emitter gives there
    let closed_form = |p: DVec3| -> (f64, f64) {
        let shadow: Vec<glam::DVec2> = (occluder.iter())
            .map(|&o| flat(p + (o - p) * ((emitter[0].y - p.y) / (o.y - p.y))))
            .collect();
        let hidden: Vec<DVec3> = (clip_convex(&emitter_2d, &shadow).iter())
            .map(|q| DVec3::new(q.x, emitter[0].y, q.y))
            .collect();
        let full = k * polygon_irradiance(p, DVec3::Y, &emitter);
        match hidden.len() >= 3 {
            true => (k * polygon_irradiance(p, DVec3::Y, &hidden), full),
            false => (0.0, full),
        }
    };
    // the shadow atlas's texel in metres (the light field's 24 per unit, halved), or the
    // panel's vertex spacing: a point whose footprint (a texel or a spacing each way) reaches
    // the penumbra counts in the penumbra
    let texel = match (&receiver, shadows) {
        (Receiver::Panel, _) => PANEL_SPACING,
        (_, "atlas") => 1.0 / (params.texel_density * lf.meta.normalisation.scale * 2.0),
        _ => 0.0,
    };
    // per pixel: the error of the light taken, whether the footprint is all lit, all umbra
    let (mut rows, mut brightest) = (Vec::<(f64, bool, bool)>::new(), 0.0f64);
    for y in 2..n - 2 {
        for x in 2..n - 2 {
            let a = (x as f64 + 0.5) / n as f64 * 2.0 - 1.0;
            let b = 1.0 - (y as f64 + 0.5) / n as f64 * 2.0;
            let ray = (corner(a, b) - eye).normalize();
            let p = eye + ray * ((eye.y - height) / -ray.y);
            // the floor point is hidden from the eye where the ray passes the blocker or emitter
            let passes =
                |h: f64, c: DVec3, r: f64| (eye + ray * ((eye.y - h) / -ray.y)).distance(c) < r;
            if passes(0.3, DVec3::new(0.12, 0.3, -0.02), 0.25)
                || passes(0.5, DVec3::new(0.1, 0.5, -0.05), 0.16)
            {
                continue;
            }
            let (blocked, full) = closed_form(p);
            let footprint: Vec<(f64, f64)> = (0..9)
                .map(|i| {
                    let step = DVec3::new((i % 3) as f64 - 1.0, 0.0, (i / 3) as f64 - 1.0);
                    closed_form(p + step * texel)
                })
                .collect();
            let lit = footprint.iter().all(|(b, _)| *b <= 0.0);
            let umbra = footprint.iter().all(|(b, f)| *b >= *f * (1.0 - 1e-9));
            let taken = (pixel(&without, x, y)[0] - pixel(&with, x, y)[0]) as f64;
            // (the switch is the static scene's: a moving surface keeps its own shadows)
            if height == 0.0 {
                assert_eq!(
                    pixel(&without, x, y),
                    pixel(&unshadowed, x, y),
                    "shadows off still shadow"
                );
            }
            brightest = brightest.max(full);
            rows.push(((taken - blocked).abs(), lit, umbra));
        }
    }
    type Row = (f64, bool, bool);
    let lit = |r: &Row| r.1;
    let umbra = |r: &Row| r.2;
    let penumbra = |r: &Row| !r.1 && !r.2;
    let worst = |pick: &dyn Fn(&Row) -> bool| {
        (rows.iter().filter(|r| pick(r)))
            .map(|r| r.0 / brightest)
            .fold(0.0, f64::max)
    };
    let count = |pick: &dyn Fn(&Row) -> bool| rows.iter().filter(|r| pick(r)).count();
    let name = match receiver {
        Receiver::Floor(shadows) => shadows,
        Receiver::Panel => "panel per vertex",
    };
    eprintln!(
        "{name}: pixels: {} lit, {} umbra, {} penumbra; worst error / brightest: lit {:.2e}, umbra {:.2e}, penumbra {:.2e}",
        count(&lit), count(&umbra), count(&penumbra), worst(&lit), worst(&umbra), worst(&penumbra)
    );
    assert!(
        count(&umbra) >= 10 && count(&penumbra) >= 50,
        "the shadow is not in the view"
    );
    assert!(
        worst(&lit) < 1e-5,
        "light taken where the blocker hides nothing"
    );
    assert!(worst(&umbra) < 0.035, "the umbra is off");
    assert!(worst(&penumbra) < 0.035, "the penumbra is off");
}

/// A floor of albedo 0.5 under a uniform sky of radiance 1 (no emitter) and a moving 0.3 m square
/// 0.1 m above it: the sky light the square takes from each floor point seen, against the closed
/// form (the square's irradiance as a polygon of radiance 1, Lambert's formula, times albedo /
/// pi, over each pixel), from the shadow atlas (256 sky rays per texel, the whole view within its
/// reach) and per pixel (256 sky rays per pair of eye rays), within 3% (atlas) and 4% (per pixel)
/// of the floor's brightness everywhere.
#[test]
fn a_moving_square_takes_the_sky_light_the_closed_form_says() {
    let dir = tempfile::tempdir().unwrap();
    let mut obj = ObjBuilder::default();
    obj.quad("floor", DVec3::ZERO, DVec3::Y, [2.0, 2.0], 0.0);
    let rho = 0.5f64;
    let floor = [Mat {
        name: "floor",
        kd: [rho as f32; 3],
        ke: [0.0; 3],
    }];
    let scene = load_scene(
        dir.path(),
        &obj,
        &floor,
        "[sky]\nradiance = [1.0, 1.0, 1.0]\n",
    );
    let params = vlf::propagate::PropagationParams {
        texel_density: 24.0,
        ..draft_params()
    };
    let (lf, resident, _) = vlf::propagate::propagate(gpu(), &scene, &params, &Silent).unwrap();
    let mut square = ObjBuilder::default();
    let (centre, half) = (DVec3::new(0.0, 0.1, 0.0), 0.15);
    square.quad("thing", centre, DVec3::Y, [2.0 * half; 2], 0.0);
    std::fs::write(dir.path().join("square.obj"), square.text("square.mtl")).unwrap();
    std::fs::write(dir.path().join("square.mtl"), "newmtl thing\nKd 0 0 0\n").unwrap();
    let corners = [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)]
        .map(|(a, b)| centre + DVec3::new(a * half, 0.0, b * half));
    // the eye at (0.9, 0.6, 0.1) looking down at the square
    let eye = DVec3::new(0.9, 0.6, 0.1);
    let n = 48u32;
    let mut errors = Vec::new();
    for shadows in ["atlas", "per_pixel"] {
        let lighting = format!(
            "sky_shadow_samples = 256\nshadows = \"{shadows}\"\natlas_sky_shadow_samples = 256\n\
             sky_shadow_reach = 4.0"
        );
        let (path, config, wall) = floor_view(
            dir.path(),
            (eye, DVec3::ZERO, n),
            &lighting,
            &object_table("square", "square.obj"),
        );
        let corner = |a: f64, b: f64| wall[0] + wall[1] * a + wall[2] * b;
        let with = draw(&lf, &resident, (&path, &config), &[]);
        let hide = ObjectChange::Visible("square".into(), false);
        let without = draw(&lf, &resident, (&path, &config), &[hide]);
        let (mut worst, mut seen, mut darkest) = (0.0f64, 0, 0.0f64);
        for y in 2..n - 2 {
            for x in 2..n - 2 {
                let a = (x as f64 + 0.5) / n as f64 * 2.0 - 1.0;
                let b = 1.0 - (y as f64 + 0.5) / n as f64 * 2.0;
                let ray = (corner(a, b) - eye).normalize();
                // rays that meet the square or pass within 3 cm of its edge (a pixel's eye rays
                // spread over about 1.3 cm there) are left out
                let at = eye + ray * ((eye.y - centre.y) / -ray.y);
                if (at - centre).abs().max_element() < half + 0.03 {
                    continue;
                }
                // the closed form over the pixel (4 x 4 points: its eye rays spread over it)
                let blocked = (0..16)
                    .map(|k| {
                        let da = ((k % 4) as f64 - 1.5) / 4.0 * 2.0 / n as f64;
                        let db = ((k / 4) as f64 - 1.5) / 4.0 * 2.0 / n as f64;
                        let ray = (corner(a + da, b - db) - eye).normalize();
                        let p = eye + ray * (eye.y / -ray.y);
                        rho / std::f64::consts::PI * polygon_irradiance(p, DVec3::Y, &corners)
                    })
                    .sum::<f64>()
                    / 16.0;
                let taken = (pixel(&without, x, y)[0] - pixel(&with, x, y)[0]) as f64;
                // the floor's brightness under the open sky: rho x 1
                worst = worst.max((taken - blocked).abs() / rho);
                darkest = darkest.max(blocked / rho);
                seen += 1;
            }
        }
        eprintln!("{shadows}: {seen} floor pixels, the most sky taken {darkest:.3}, worst error / brightness {worst:.2e}");
        assert!(seen > 500 && darkest > 0.3, "the shadow is not in the view");
        errors.push(worst);
    }
    // measured (lavapipe): atlas 2.6e-2 (where it is worst, beside the square's edge, its texels
    // under the square reach the lookup), per pixel 3.5e-2 (it takes up to 15% too little of
    // the blocked light beyond the square's far edge, with 64 rays as with 256: not noise; not
    // explained yet)
    assert!(
        errors[0] < 0.03,
        "atlas: the sky's shadow is off by {}",
        errors[0]
    );
    assert!(
        errors[1] < 0.04,
        "per pixel: the sky's shadow is off by {}",
        errors[1]
    );
}

/// The indirect light an object blocks, from the shadow atlas: in the furnace (walls emitting
/// Le = 1 with albedo 0.5: radiance L = 2 everywhere) a black square 10 cm wide hangs 5 cm in
/// front of the back wall. A point of that wall that sees it over a form factor F loses that part
/// of its hemisphere's light, the walls' emission and what they reflect alike: it shows
/// Le + rho L (1 - F) = 2 - F (the other walls see the darkened patch too little to matter). The
/// shadow rays alone take only the emission's part: 2 - rho Le F = 2 - F / 2. Compared over the
/// wall's points 2 to 4.5 cm beside the square's edge within 2.5 cm of its middle height, each
/// pixel against the closed form at its centre's point (F 0.143 on average). Measured (lavapipe,
/// 30 pixels): with 256 indirect rays per texel 1.8544 against 2 - F = 1.8569 (-0.06% of L; 16
/// rays, the default: -0.08%); without them 1.9275 against 2 - F / 2 = 1.9284, 3.5% of L too
/// bright. Asserted: within 1% of L, and the latter more than 2.5% off the whole closed form.
#[test]
fn an_object_takes_the_indirect_light_it_blocks_from_the_wall_behind_it() {
    let dir = tempfile::tempdir().unwrap();
    let (_, lf, resident) = furnace(dir.path());
    let (centre, half) = (DVec3::new(0.0, 0.0, -0.45), 0.05);
    let mut plate = ObjBuilder::default();
    plate.quad("thing", centre, -DVec3::Z, [2.0 * half; 2], 0.0);
    std::fs::write(dir.path().join("plate.obj"), plate.text("plate.mtl")).unwrap();
    std::fs::write(dir.path().join("plate.mtl"), "newmtl thing\nKd 0 0 0\n").unwrap();
    let corners = [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)]
        .map(|(a, b)| centre + DVec3::new(a * half, b * half, 0.0));
    let n = 97u32;
    let mut off = Vec::new();
    for rays in [256, 0] {
        let lighting = format!("atlas_shadow_samples = 256\natlas_indirect_rays = {rays}\n");
        let objects = object_table("plate", "plate.obj");
        let (path, config) = display_lit(dir.path(), (n, 4), &lighting, &objects);
        let image = draw(&lf, &resident, (&path, &config), &[]);
        let (mut shown, mut form, mut seen) = (0.0, 0.0, 0);
        for j in 0..n {
            for i in 0..n {
                // the pixel's centre on the display (0.2 m wide at z = 0.15, the head at
                // z = 0.35), carried on to the back wall at z = -0.5
                let at = |k: u32| (k as f64 + 0.5) / n as f64 * 0.2 - 0.1;
                let p = DVec3::new(at(i), -at(j), 0.0) * (0.85 / 0.2) + DVec3::new(0.0, 0.0, -0.5);
                if !(0.07..=0.095).contains(&p.x.abs()) || p.y.abs() > 0.025 {
                    continue;
                }
                shown += pixel(&image, i, j)[0] as f64;
                form += polygon_irradiance(p, DVec3::Z, &corners) / std::f64::consts::PI;
                seen += 1;
            }
        }
        let (shown, form) = (shown / seen as f64, form / seen as f64);
        let (both, direct) = (2.0 - form, 2.0 - form / 2.0);
        eprintln!(
            "indirect rays {rays}: {seen} pixels, F {form:.4}, shown {shown:.4}, closed form \
             {both:.4} (the emission's part alone {direct:.4})"
        );
        assert!(seen >= 8, "{seen} pixels");
        off.push(((shown - both) / 2.0, (shown - direct) / 2.0));
    }
    assert!(
        off[0].0.abs() < 0.01,
        "with the indirect rays: {:?}",
        off[0]
    );
    assert!(off[1].1.abs() < 0.01, "the shadow rays alone: {:?}", off[1]);
    assert!(off[1].0 > 0.025, "without the indirect rays: {:?}", off[1]);
}

/// A one-wall display of `n` x `n` pixels (16 eye rays each) from a static head at `eye` through
/// a 6 cm wall 10 cm ahead toward `target`, with small probes, the `[object_lighting]` keys
/// `lighting` and the `[[object]]` tables `objects`: its file, its config and the wall's centre
/// and half sides (the wall's point (a, b), -1..1 each way, is centre + a right + b up).
fn floor_view(
    dir: &Path,
    (eye, target, n): (DVec3, DVec3, u32),
    lighting: &str,
    objects: &str,
) -> (std::path::PathBuf, DisplayConfig, [DVec3; 3]) {
    let ahead = (target - eye).normalize();
    let right = ahead.cross(DVec3::Y).normalize() * 0.03;
    let up = right.cross(ahead).normalize() * 0.03;
    let centre = eye + ahead * 0.1;
    let fmt = |v: DVec3| format!("[{}, {}, {}]", v.x, v.y, v.z);
    let text = format!(
        "name = \"shadow\"\nantialiasing = 16\n\n[tracking]\nsource = \"static\"\nhead = {}\n\n\
         [object_lighting]\nprobe_resolution = 4\nprobe_rays = 64\n{lighting}\n\n\
         [[wall]]\nname = \"floor view\"\nlower_left = {}\nlower_right = {}\nupper_left = {}\n\
         pixels = [{n}, {n}]\noutput = {{ monitor = 0 }}\n\n{}",
        fmt(eye),
        fmt(centre - right - up),
        fmt(centre + right - up),
        fmt(centre - right + up),
        objects
    );
    let path = dir.join("display.toml");
    std::fs::write(&path, text).unwrap();
    let config = DisplayConfig::load(&path).unwrap();
    (path, config, [centre, right, up])
}

/// The shipped body config (config/displays/cave-4wall-body.toml) loads its avatar (the shipped
/// mannequin) and the wand's ray, and poses them where its tracked head, wand and left hand are
/// (the hands within 1 mm): the ray's rigid placement is the wand's, its beam running 10 m along
/// the wand's -z.
#[test]
fn the_shipped_body_config_puts_the_avatar_and_the_wand_ray_on_the_participant() {
    let path = repo_path("config/displays/cave-4wall-body.toml");
    let config = DisplayConfig::load(&path).unwrap();
    let objects = vlf::dynamic::Objects::load(&config.objects, &path).unwrap();
    assert_eq!(config.object_names(), ["body", "wand ray"]);
    let mesh = objects.mesh();
    assert!(
        mesh.triangles.len() > 4000,
        "{} triangles",
        mesh.triangles.len()
    );
    // 19 joints of the mannequin and one for the ray
    assert_eq!(mesh.joint_count, 20);
    let poses = config.pose_source(&path).unwrap();
    let pose = poses.at(0.0);
    let held = poses.held_at(&config.tracking, 0.0);
    assert!(held.wand.is_some() && held.left_hand.is_some());
    let tracked = vlf::dynamic::Tracked::from_pose(&pose, &held, 0.0);
    let joints = objects.joint_matrices(&tracked);
    assert!(joints
        .iter()
        .all(|m| m.is_finite() && *m != glam::Mat4::ZERO));
    // the static left hand: the avatar's left hand on it, as the right is on the wand
    let [left, right] = objects.avatar_hands(&tracked).unwrap();
    let hand = |a: Option<glam::Affine3A>| glam::Vec3::from(a.unwrap().translation);
    assert!(left.distance(hand(tracked.left_hand)) < 1e-3, "{left}");
    assert!(right.distance(hand(tracked.wand)) < 1e-3, "{right}");
    let ray = joints[19];
    let start = ray.transform_point3(glam::Vec3::ZERO);
    let end = ray.transform_point3(glam::Vec3::new(0.0, 0.0, -10.0));
    let wand_at = glam::Vec3::from(tracked.wand.unwrap().translation);
    assert!(start.distance(wand_at) < 1e-5);
    let along = tracked.wand.unwrap().transform_vector3(-glam::Vec3::Z);
    assert!(((end - start).normalize() - along).length() < 1e-5);
}

/// The shipped headset body (config/headset/body.toml) loads the mannequin and, from a head and
/// two controllers' grips located in the stage and a navigated room, puts its hands on the grips
/// in the world (within 1 mm); a grip the runtime does not locate leaves that arm hanging.
#[test]
fn the_shipped_headset_body_puts_the_hands_on_the_controllers_grips() {
    use glam::{Affine3A, Quat, Vec3};
    use vlf::xr::body::{head_between, stage_pose, tracked, ObjectsFile};
    let path = repo_path("config/headset/body.toml");
    let file = ObjectsFile::load(&path).unwrap();
    let objects = vlf::dynamic::Objects::load(&file.objects, &path).unwrap();
    assert_eq!(objects.configs().len(), 1);
    let turn = Quat::from_rotation_y(0.4);
    let head = head_between([
        (turn, Vec3::new(0.1, 1.65, 0.2) - turn * Vec3::X * 0.032),
        (turn, Vec3::new(0.1, 1.65, 0.2) + turn * Vec3::X * 0.032),
    ]);
    // the room walked 2 m and turned a quarter: the hands go with it
    let room = vlf::tracking::Pose::new(Vec3::ZERO, Vec3::new(2.0, 0.0, -1.0), 90.0);
    let left = stage_pose(Quat::from_rotation_x(0.5), Vec3::new(-0.25, 1.3, -0.1));
    let right = stage_pose(Quat::from_rotation_z(0.3), Vec3::new(0.2, 1.2, -0.2));
    let world = |a: Affine3A| {
        Affine3A::from_rotation_translation(
            Quat::from_rotation_y(std::f32::consts::FRAC_PI_2),
            room.room_position,
        ) * a
    };
    let both = tracked(&room, head, [Some(left), Some(right)], 0.0);
    let [l, r] = objects.avatar_hands(&both).unwrap();
    assert!(l.distance(world(left).translation.into()) < 1e-3, "{l}");
    assert!(r.distance(world(right).translation.into()) < 1e-3, "{r}");
    let one = tracked(&room, head, [None, Some(right)], 0.0);
    let [hanging, r] = objects.avatar_hands(&one).unwrap();
    assert!(r.distance(world(right).translation.into()) < 1e-3, "{r}");
    let eyes: Vec3 = world(head).translation.into();
    assert!(
        eyes.y - hanging.y > 0.6,
        "the untracked hand at {hanging}, the eyes at {eyes}"
    );
}

/// A study's conditions (`[[condition]]`) bind their own light field for the scene and for the
/// objects' probes: in the furnace, direct light only (one iteration: the walls show Le + rho
/// Le = 1.5) lights the grey cube from probes baked from that light field, 0.6 x 1.5 = 0.9,
/// against 2 and 1.2 converged; `objects_visible = []` hides the cube; the switch back draws
/// the converged light again; two conditions of the same light field share it.
#[test]
fn a_condition_switches_the_light_field_that_lights_the_scene_and_the_objects() {
    use vlf::display::conditions::{Conditions, MainField};
    let dir = tempfile::tempdir().unwrap();
    let (scene_path, lf, resident) = furnace(dir.path());
    let conditions = "[[condition]]\nname = \"gi-on\"\n\n\
                      [[condition]]\nname = \"gi-off\"\nglobal_illumination = false\nexposure = 2.0\n\n\
                      [[condition]]\nname = \"gi-off-empty\"\nglobal_illumination = false\nobjects_visible = []\n";
    let (path, config) = display(
        dir.path(),
        32,
        4,
        &(object_table("grey", "grey.obj") + conditions),
    );
    let main = MainField {
        source: &scene_path,
        lf: &lf,
        resident: &resident,
    };
    let prepared = Conditions::prepare(&config, &path, main, &Silent)
        .unwrap()
        .unwrap();
    assert_eq!(
        prepared.fields.len(),
        1,
        "gi-off and gi-off-empty share one light field"
    );
    assert_eq!(prepared.field_of, [0, 1, 1]);
    let poses = config.pose_source(&path).unwrap();
    let mut frame = FrameOfViews::cave(
        (&lf, &resident),
        &config,
        &path,
        &poses,
        Slots::PerWall,
        Some(&prepared),
    )
    .unwrap();
    let pose = poses.at(0.0);
    let read = |frame: &mut FrameOfViews| {
        let tracked = Poses::Tracked {
            pose: &pose,
            held: &Default::default(),
            arrived: None,
        };
        let image = frame.read_back(tracked).unwrap().remove(0).0;
        (
            pixel(&image, 16, 2)[0] as f64,
            pixel(&image, 10, 16)[0] as f64,
        )
    };
    let within = |v: f64, want: f64| (v - want).abs() / want;
    assert_eq!((frame.condition(), frame.exposure()), (Some("gi-on"), 1.0));
    let (wall, grey) = read(&mut frame);
    assert!(
        within(wall, 2.0) < 0.01 && within(grey, 1.2) < 0.01,
        "{wall} {grey}"
    );
    frame.set_condition("gi-off").unwrap();
    assert_eq!(frame.exposure(), 2.0);
    let (direct_wall, direct_grey) = read(&mut frame);
    eprintln!("direct light only: wall {direct_wall:.4} (1.5), grey {direct_grey:.4} (0.9)");
    assert!(
        within(direct_wall, 1.5) < 0.02,
        "the walls show {direct_wall}, not 1.5"
    );
    assert!(
        within(direct_grey, 0.9) < 0.02,
        "the grey cube shows {direct_grey}, not 0.9"
    );
    frame.set_condition("gi-off-empty").unwrap();
    let (_, behind) = read(&mut frame);
    assert!(
        within(behind, 1.5) < 0.02,
        "the hidden cube still shows: {behind}"
    );
    frame.set_condition("gi-on").unwrap();
    let (wall, grey) = read(&mut frame);
    assert!(
        within(wall, 2.0) < 0.01 && within(grey, 1.2) < 0.01,
        "{wall} {grey}"
    );
    assert!(frame.set_condition("sepia").is_err());
    assert_eq!(frame.condition(), Some("gi-on"));
}
