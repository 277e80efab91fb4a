//! Normal maps (issue 29 item 3): a floor whose normal map tilts it, lit by a small emitter at
//! grazing incidence. The light field's view shows albedo/pi x Le x (the emitter's irradiance
//! at the tilted normal), in closed form; a flat normal map shows what the floor without one
//! shows; a bumpy map's view agrees with `vlf reference`, which shades with the mapped normal
//! too; MTL `norm` and `bump` (a height map) are read.

use crate::common;
use common::*;
use glam::DVec3;
use vlf::progress::Silent;
use vlf::propagate::PropagationParams;
use vlf::scene::{Camera, Scene};

const ALBEDO: f64 = 0.8;
/// The emitter's radiance: the floor's middle shows about 0.3 untilted.
const LE: f64 = 900.0;
/// The emitter: a square of this side centred here, facing the floor's middle.
const EMITTER_CENTRE: [f64; 3] = [-3.0, 1.0, 0.0];
const EMITTER_SIDE: f64 = 0.2;
/// The constant map's tilt toward the emitter.
const TILT_DEG: f64 = 20.0;

/// The emitter's corners (metres), counter-clockwise seen from the floor's middle.
fn emitter_corners() -> [DVec3; 4] {
    let c = DVec3::from(EMITTER_CENTRE);
    let n = (-c).normalize();
    let a = DVec3::Z;
    let b = n.cross(a).normalize();
    let h = EMITTER_SIDE / 2.0;
    let corners = [
        c - a * h - b * h,
        c + a * h - b * h,
        c + a * h + b * h,
        c - a * h + b * h,
    ];
    // the front (counter-clockwise) must face the floor
    let front = (corners[1] - corners[0]).cross(corners[2] - corners[0]);
    match front.dot(n) > 0.0 {
        true => corners,
        false => [corners[0], corners[3], corners[2], corners[1]],
    }
}

/// The floor (2 x 2 at y = 0, texture coordinates 0..1 with u along +x and v along -z) with
/// material "floor" carrying `floor_mtl` lines, and the emitter; no sky.
fn floor_scene(dir: &std::path::Path, floor_mtl: &str) -> Scene {
    let mut obj = String::from(
        "mtllib scene.mtl\n\
         v -1 0 1\nv 1 0 1\nv 1 0 -1\nv -1 0 -1\n\
         vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n",
    );
    for p in emitter_corners() {
        obj += &format!("v {} {} {}\n", p.x, p.y, p.z);
    }
    obj += "usemtl floor\nf 1/1 2/2 3/3 4/4\nusemtl light\nf 5 6 7 8\n";
    std::fs::write(dir.join("scene.obj"), obj).unwrap();
    std::fs::write(
        dir.join("scene.mtl"),
        format!(
            "newmtl floor\nKd {ALBEDO} {ALBEDO} {ALBEDO}\n{floor_mtl}\n\nnewmtl light\nKd 0 0 0\nKe {LE} {LE} {LE}\n"
        ),
    )
    .unwrap();
    std::fs::write(
        dir.join("scene.toml"),
        "name = \"normal-mapped floor\"\nmesh = \"scene.obj\"\n",
    )
    .unwrap();
    Scene::load(&dir.join("scene.toml")).unwrap()
}

/// A 4 x 4 normal map PNG of one colour.
fn flat_png(path: &std::path::Path) {
    image::RgbImage::from_pixel(4, 4, image::Rgb([128, 128, 255]))
        .save(path)
        .unwrap();
}

/// The floor with a normal map whose texels are `normal(u)` (tangent space, exact floats: the
/// PNG the MTL names is replaced after import), `width` texels along u.
fn mapped_floor(dir: &std::path::Path, width: u32, normal: impl Fn(f64) -> DVec3) -> Scene {
    flat_png(&dir.join("normals.png"));
    let mut scene = floor_scene(dir, "norm normals.png");
    let m = scene.materials.iter().find(|m| m.name == "floor").unwrap();
    let map = m.normal_map.expect("MTL norm is read as a normal map");
    let t = &mut scene.textures[map.texture as usize];
    t.width = width;
    t.height = 1;
    t.texels = (0..width)
        .map(|i| {
            let n = normal((i as f64 + 0.5) / width as f64).normalize();
            [
                0.5 + 0.5 * n.x as f32,
                0.5 + 0.5 * n.y as f32,
                0.5 + 0.5 * n.z as f32,
            ]
        })
        .collect();
    scene
}

/// The constant tilt: toward the emitter (-x), i.e. tangent-space x negative (T = +x).
fn tilted() -> DVec3 {
    let t = TILT_DEG.to_radians();
    DVec3::new(-t.sin(), 0.0, t.cos())
}

fn params() -> PropagationParams {
    PropagationParams {
        geodesic_frequency: 4,
        grid_resolution: 64,
        texel_density: 64.0,
        tolerance: 1e-3,
        max_iterations: 6,
        direct_samples: 64,
        ..draft_params()
    }
}

const SIZE: u32 = 32;

/// Straight down on the floor's middle, 1.8 x 1.8 m in view.
fn camera() -> Camera {
    Camera {
        name: "above".into(),
        eye: [0.0, 2.5, 0.0],
        target: [0.0, 0.0, 0.0],
        up: [0.0, 0.0, -1.0],
        fov_y_deg: 40.0,
        size: [SIZE, SIZE],
    }
}

/// Where pixel (x, y)'s centre ray meets the floor (metres).
fn floor_point(x: u32, y: u32) -> DVec3 {
    let c = camera();
    let half = (c.fov_y_deg as f64 / 2.0).to_radians().tan();
    let ndc = [
        (x as f64 + 0.5) / SIZE as f64 * 2.0 - 1.0,
        1.0 - (y as f64 + 0.5) / SIZE as f64 * 2.0,
    ];
    // right +x, up -z, forward -y
    let dir = DVec3::new(ndc[0] * half, -1.0, -ndc[1] * half);
    let eye = DVec3::from(c.eye.map(|v| v as f64));
    eye + dir * (eye.y / -dir.y)
}

/// What the floor shows at point p with shading normal n (world): albedo/pi x Le x the
/// emitter's irradiance at n, which the emitter lies wholly above.
fn closed_form(p: DVec3, n: DVec3) -> f64 {
    ALBEDO / std::f64::consts::PI * LE * polygon_irradiance(p, n, &emitter_corners())
}

/// The light field's view with `samples` eye rays per pixel.
fn light_field_view(scene: &Scene, samples: u32) -> vlf::render::Frame {
    let (lf, _, _) = vlf::propagate::propagate(gpu(), scene, &params(), &Silent).unwrap();
    let ledger = vlf::gpu::MemoryLedger::default();
    let resident = lf.upload(gpu()).unwrap();
    let mut r = vlf::render::Renderer::new(&resident, &lf, &ledger).unwrap();
    r.set_samples_per_pixel(samples).unwrap();
    r.render(&camera(), SIZE, SIZE).unwrap()
}

/// Per pixel (inside the floor's middle, |x|, |z| < 0.8): the frame's green over the closed
/// form at normal `n`; the worst relative error and the mean one.
fn against_closed_form(frame: &vlf::render::Frame, n: DVec3) -> (f64, f64) {
    let (mut worst, mut sum, mut count) = (0.0f64, 0.0, 0);
    for y in 0..SIZE {
        for x in 0..SIZE {
            let p = floor_point(x, y);
            if p.x.abs() > 0.8 || p.z.abs() > 0.8 {
                continue;
            }
            let got = frame.pixels[(y * SIZE + x) as usize][1] as f64;
            let error = got / closed_form(p, n) - 1.0;
            worst = worst.max(error.abs());
            sum += error;
            count += 1;
        }
    }
    (worst, sum / count as f64)
}

/// The tilted normal in world space: T = +x, B = -z (v runs along -z), N = +y.
fn world(ts: DVec3) -> DVec3 {
    DVec3::new(ts.x, ts.z, -ts.y).normalize()
}

#[test]
fn a_tilted_normal_map_shows_the_emitter_at_the_tilted_normal_in_the_light_field_and_the_path_tracer(
) {
    let dir = tempfile::tempdir().unwrap();
    let scene = mapped_floor(dir.path(), 1, |_| tilted());
    let n = world(tilted());
    let view = light_field_view(&scene, 1);
    let (worst, mean) = against_closed_form(&view, n);
    let untilted = closed_form(DVec3::ZERO, DVec3::Y);
    eprintln!(
        "light field, {TILT_DEG} degree tilt: worst {worst:.4}, mean {mean:+.4} relative to the \
         closed form (the middle shows {:.4}; untilted it would show {untilted:.4})",
        closed_form(DVec3::ZERO, n)
    );
    // untilted the middle would be off by a factor ~2
    assert!(
        worst < 0.03 && mean.abs() < 0.01,
        "light field: worst {worst}, mean {mean}"
    );
    let r =
        vlf::reference::render(gpu(), &scene, &camera(), [SIZE, SIZE], 256, 7, &Silent).unwrap();
    let (worst, mean) = against_closed_form(&r.mean, n);
    eprintln!("path tracer (256 spp): worst {worst:.4}, mean {mean:+.4}");
    assert!(
        worst < 0.06 && mean.abs() < 0.01,
        "path tracer: worst {worst}, mean {mean}"
    );
}

#[test]
fn a_flat_normal_map_shows_what_the_floor_without_one_shows() {
    let dir = tempfile::tempdir().unwrap();
    let flat = mapped_floor(dir.path(), 1, |_| DVec3::Z);
    let plain_dir = tempfile::tempdir().unwrap();
    let plain = floor_scene(plain_dir.path(), "");
    assert!(plain.materials.iter().all(|m| m.normal_map.is_none()));
    let (a, b) = (light_field_view(&flat, 1), light_field_view(&plain, 1));
    let worst = (a.pixels.iter().zip(&b.pixels))
        .flat_map(|(p, q)| {
            (0..3).map(move |c| (p[c] - q[c]).abs() as f64 / (q[c] as f64).max(1e-3))
        })
        .fold(0.0, f64::max);
    eprintln!("flat normal map against none: worst relative difference {worst:.2e}");
    assert!(
        worst < 1e-5,
        "a flat normal map changes the view by {worst}"
    );
}

#[test]
fn a_bumpy_floor_in_the_light_field_agrees_with_the_path_tracer() {
    let dir = tempfile::tempdir().unwrap();
    // ridges along z: the normal swings +-30 degrees about z, four periods across the floor
    let scene = mapped_floor(dir.path(), 64, |u| {
        let a = 0.5 * (2.0 * std::f64::consts::PI * 4.0 * u).sin();
        DVec3::new(a.sin(), 0.0, a.cos())
    });
    // the ridges are 8 pixels apart: the view's eye rays spread over the pixel as the path
    // tracer's do
    let view = light_field_view(&scene, 16);
    let r =
        vlf::reference::render(gpu(), &scene, &camera(), [SIZE, SIZE], 256, 11, &Silent).unwrap();
    if let Ok(out) = std::env::var("VLF_NORMAL_MAP_IMAGES") {
        let out = std::path::Path::new(&out);
        vlf::metrics::write_difference_png(&view, &r.mean, &out.join("difference.png")).unwrap();
        for (frame, name) in [(&view, "view.png"), (&r.mean, "reference.png")] {
            vlf::render::image_io::display_image(frame, 1.0)
                .save(out.join(name))
                .unwrap();
        }
    }
    let c = vlf::metrics::compare(&view, &r.mean).unwrap();
    // the ridges' contrast: without the map the floor is smooth
    let g: Vec<f64> = view.pixels.iter().map(|p| p[1] as f64).collect();
    let row = (SIZE / 2 * SIZE) as usize;
    let (lo, hi) = (g[row..row + SIZE as usize].iter())
        .fold((f64::MAX, 0.0f64), |(lo, hi), &v| (lo.min(v), hi.max(v)));
    eprintln!(
        "bumpy floor: display MSE {:.3e}, relMSE {:.3e} against the path tracer (256 spp); the \
         middle row spans {lo:.4}..{hi:.4}",
        c.display_mse, c.rel_mse
    );
    assert!(hi > 1.5 * lo, "the ridges do not show: {lo}..{hi}");
    assert!(c.display_mse < 2e-4, "display MSE {}", c.display_mse);
}

#[test]
fn mtl_norm_and_bump_are_read() {
    let dir = tempfile::tempdir().unwrap();
    flat_png(&dir.path().join("normals.png"));
    let scene = floor_scene(dir.path(), "norm -bm 0.5 normals.png");
    let floor = scene.materials.iter().find(|m| m.name == "floor").unwrap();
    let map = floor.normal_map.expect("norm");
    assert_eq!(map.scale, 0.5);
    let t = &scene.textures[map.texture as usize];
    // raw values, not the sRGB curve: 128 stays 128/255
    assert!(
        (t.texels[0][0] - 128.0 / 255.0).abs() < 1e-6,
        "{:?}",
        t.texels[0]
    );
    // a height ramp rising along x by 16/255 per texel: a constant tilt against +x
    let ramp = image::RgbImage::from_fn(8, 8, |x, _| {
        let h = (16 * x) as u8;
        image::Rgb([h, h, h])
    });
    ramp.save(dir.path().join("height.png")).unwrap();
    let scene = floor_scene(dir.path(), "bump -bm 4 height.png");
    let floor = scene.materials.iter().find(|m| m.name == "floor").unwrap();
    let t = &scene.textures[floor.normal_map.expect("bump").texture as usize];
    let n = t.texels[8 * 3 + 3].map(|c| 2.0 * c - 1.0);
    let slope = 4.0 * 16.0 / 255.0;
    let expected = glam::Vec3::new(-slope, 0.0, 1.0).normalize();
    assert!(
        (glam::Vec3::from(n) - expected).length() < 1e-4,
        "{n:?} against {expected:?}"
    );
}
