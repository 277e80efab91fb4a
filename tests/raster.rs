//! Raster first hits (issue 32) against ray-cast first hits on the software adapter: the same
//! light field drawn both ways, the eye rays through the same positions (the standard 4x MSAA
//! ones), gives the same image. A pixel differs only where one of its samples sits on a
//! triangle's edge (the rasteriser's fixed-point coverage and the ray's barycentric test
//! disagree within a hair) or where two surfaces meet at the same depth; everywhere else the
//! same surface, point and texels give the same radiance. Checked on the shipped scenes, a
//! generated classroom, paced tiles (fewer samples read), and moving objects (their backs
//! culled, seen in a mirror).

use crate::common;
use common::*;
use glam::{Affine3A, DVec3};
use vlf::gpu::MemoryLedger;
use vlf::lightfield::{LightField, ResidentLightField};
use vlf::progress::Silent;
use vlf::render::budget::PacedSetting;
use vlf::render::raster::FirstHits;
use vlf::render::{Frame, ObjectsToDraw, Renderer};

/// Eye rays per pixel: the MSAA count every adapter takes.
const SAMPLES: u32 = 4;

/// A pixel matches when every channel is within this of the other's (relative, at least 1).
const SAME: f32 = 1e-5;

/// How two images of one view differ: the share of pixels that do not match, and the largest
/// difference of those that do not, relative to the image's brightest pixel.
struct Difference {
    share: f64,
    largest: f32,
}

fn difference(rays: &Frame, raster: &Frame) -> Difference {
    let peak = (rays.pixels.iter())
        .flat_map(|p| p[..3].iter().copied())
        .fold(0.0f32, f32::max)
        .max(1e-6);
    let mut differing = 0usize;
    let mut largest = 0.0f32;
    for (a, b) in rays.pixels.iter().zip(&raster.pixels) {
        let d = (0..3).map(|c| (a[c] - b[c]).abs()).fold(0.0f32, f32::max);
        let scale = (0..3).map(|c| a[c].abs()).fold(1.0f32, f32::max);
        if d > SAME * scale {
            differing += 1;
            largest = largest.max(d / peak);
        }
    }
    Difference {
        share: differing as f64 / rays.pixels.len() as f64,
        largest,
    }
}

/// Two renderers of one light field (with `objects` where given): ray-cast first hits on the
/// MSAA positions, and raster first hits.
fn both_ways(
    lf: &LightField,
    resident: &ResidentLightField,
    objects: Option<(&vlf::dynamic::Objects, &vlf::dynamic::Tracked)>,
) -> [Renderer; 2] {
    [FirstHits::Rays, FirstHits::Raster].map(|hits| {
        let to_draw = objects.map(|(o, _)| ObjectsToDraw {
            mesh: o.mesh(),
            lighting: vlf::render::probes::ObjectLighting {
                probe_resolution: 6,
                probe_rays: 256,
                ..Default::default()
            },
        });
        let mut r =
            Renderer::with_objects(resident, lf, &MemoryLedger::default(), to_draw).unwrap();
        r.set_samples_per_pixel(SAMPLES).unwrap();
        match hits {
            FirstHits::Rays => r.set_msaa_sample_positions(SAMPLES).unwrap(),
            FirstHits::Raster => r.set_first_hits(FirstHits::Raster).unwrap(),
        }
        if let Some((o, tracked)) = objects {
            r.pose_objects(&o.joint_matrices(tracked), None);
        }
        assert_eq!(r.first_hits(), hits);
        r
    })
}

/// Every camera of the light field drawn both ways at `size`; the differences, named.
fn compare_cameras(
    name: &str,
    lf: &LightField,
    resident: &ResidentLightField,
    size: [u32; 2],
) -> Vec<(String, Difference)> {
    let [mut rays, mut raster] = both_ways(lf, resident, None);
    (lf.meta.cameras.iter())
        .map(|camera| {
            let a = rays.render(camera, size[0], size[1]).unwrap();
            let b = raster.render(camera, size[0], size[1]).unwrap();
            (
                format!("{name}, camera {}", camera.name),
                difference(&a, &b),
            )
        })
        .collect()
}

/// The bounds: edge pixels are a small share of a small image (measured on lavapipe: 0.02% to
/// 0.18% of the shipped scenes' 160x120 pixels, 0.9% of the classroom's, none with the moving
/// objects; asserted within 0.5%, 2% for the classroom), and one of four samples on another
/// surface moves a pixel by at most a quarter of the brightest radiance (measured 0.25), half
/// where a pair's shared reflection changes with it.
fn assert_same(results: &[(String, Difference)], share: f64) {
    for (name, d) in results {
        eprintln!(
            "{name}: {:.3}% of pixels differ, the largest by {:.4} of the peak",
            d.share * 100.0,
            d.largest
        );
    }
    for (name, d) in results {
        assert!(
            d.share <= share,
            "{name}: {:.3}% of pixels differ (bound {:.3}%)",
            d.share * 100.0,
            share * 100.0
        );
        assert!(
            d.largest <= 0.5,
            "{name}: a pixel differs by {} of the peak",
            d.largest
        );
    }
}

fn shipped(scene: &str) -> (LightField, ResidentLightField) {
    let scene = vlf::scene::Scene::load(&repo_path(&format!("scenes/{scene}/scene.toml"))).unwrap();
    let (lf, resident, _) =
        vlf::propagate::propagate(gpu(), &scene, &draft_params(), &Silent).unwrap();
    (lf, resident)
}

#[test]
fn raster_first_hits_draw_the_shipped_scenes_as_ray_cast_ones_do() {
    let mut results = Vec::new();
    for scene in ["cornell", "cornell-mirror", "textured-room"] {
        let (lf, resident) = shipped(scene);
        results.extend(compare_cameras(scene, &lf, &resident, [160, 120]));
    }
    assert_same(&results, 0.005);
}

/// The comparison sees where eye rays go: ray-cast first hits on the Hammersley set (the
/// default) against raster ones on the MSAA positions differ wherever the radiance varies within
/// a pixel (measured: 38% of Cornell's pixels), far past the bound the same positions are held
/// to.
#[test]
fn the_comparison_fails_when_the_two_ways_sample_different_positions() {
    let (lf, resident) = shipped("cornell");
    let [_, mut raster] = both_ways(&lf, &resident, None);
    let mut hammersley = Renderer::new(&resident, &lf, &MemoryLedger::default()).unwrap();
    hammersley.set_samples_per_pixel(SAMPLES).unwrap();
    let camera = &lf.meta.cameras[0];
    let a = hammersley.render(camera, 160, 120).unwrap();
    let b = raster.render(camera, 160, 120).unwrap();
    let d = difference(&a, &b);
    eprintln!(
        "Hammersley against MSAA positions: {:.3}% of pixels differ",
        d.share * 100.0
    );
    assert!(d.share > 0.1, "{:.3}%", d.share * 100.0);
}

/// The generated classroom: a BVH (not the exhaustive cast of a small mesh), many small parts.
#[cfg(feature = "lab")]
#[test]
fn raster_first_hits_draw_a_generated_classroom_as_ray_cast_ones_do() {
    let dir = tempfile::tempdir().unwrap();
    let options = vlf::lab::generate::GenerateOptions {
        kind: vlf::lab::generate::SceneKind::Classroom,
        size: 10000,
        mirrors: true,
        glossy: false,
    };
    let generated = vlf::lab::generate::generate(&options, dir.path()).unwrap();
    let scene = vlf::scene::Scene::load(&generated.scene).unwrap();
    let params = vlf::propagate::PropagationParams {
        texel_density: 4.0,
        ..draft_params()
    };
    let (lf, resident, _) = vlf::propagate::propagate(gpu(), &scene, &params, &Silent).unwrap();
    assert_same(
        &compare_cameras("classroom 10K", &lf, &resident, [160, 120]),
        0.02,
    );
}

/// Frame pacing: half the tiles at 1 eye ray, half at 4: a paced tile reads one of the four
/// samples, the same one both ways.
#[test]
fn paced_tiles_read_fewer_samples_the_same_way_both_ways() {
    let (lf, resident) = shipped("cornell-mirror");
    let [mut rays, mut raster] = both_ways(&lf, &resident, None);
    let paced = PacedSetting {
        low: 1,
        high: SAMPLES,
        fraction: 0.5,
    };
    rays.set_pacing(paced);
    raster.set_pacing(paced);
    let camera = &lf.meta.cameras[0];
    let a = rays.render(camera, 160, 120).unwrap();
    let b = raster.render(camera, 160, 120).unwrap();
    assert_same(
        &[("paced cornell-mirror".into(), difference(&a, &b))],
        0.005,
    );
    // and paced is not what unpaced draws: the pacing reached the tiles
    raster.set_samples_per_pixel(SAMPLES).unwrap();
    let full = raster.render(camera, 160, 120).unwrap();
    assert!(difference(&full, &b).share > 0.01);
}

/// Each pixel's depth (the view's clip depth of the nearest first hit, which the headset
/// submits) of `camera`'s view drawn by `renderer`, `size`, read back.
fn depth_image(
    renderer: &mut Renderer,
    lf: &LightField,
    camera: &vlf::scene::Camera,
    [width, height]: [u32; 2],
) -> Vec<f32> {
    let ctx = gpu();
    let norm = &lf.meta.normalisation;
    let view_proj = vlf::render::view_projection(camera, norm, width, height);
    renderer.set_view_matrix(view_proj, norm.to_unit(camera.eye).as_vec3());
    let targets = renderer.view_targets(width, height);
    let padded_row = (width * 4).next_multiple_of(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT);
    let bytes = padded_row as u64 * height as u64;
    let readback = ctx.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("depth readback"),
        size: bytes,
        usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::COPY_SRC,
        mapped_at_creation: false,
    });
    let mut encoder = ctx.device.create_command_encoder(&Default::default());
    renderer.encode_view(&mut encoder, &targets, None);
    let size = [width, height];
    vlf::gpu::copy_texture_to_buffer(&mut encoder, &targets.depth, &readback, padded_row, size);
    ctx.queue.submit([encoder.finish()]);
    let rows: Vec<f32> = ctx.read_buffer(&readback, bytes).unwrap();
    (rows.chunks(padded_row as usize / 4))
        .flat_map(|row| row[..width as usize].to_vec())
        .collect()
}

/// The depth image the headset submits is the same both ways but on triangle edges (a sample
/// on another surface changes its pixel's nearest first hit).
#[test]
fn raster_first_hits_give_the_same_depth_image() {
    let (lf, resident) = shipped("cornell-mirror");
    let [mut rays, mut raster] = both_ways(&lf, &resident, None);
    for camera in &lf.meta.cameras {
        let a = depth_image(&mut rays, &lf, camera, [160, 120]);
        let b = depth_image(&mut raster, &lf, camera, [160, 120]);
        let differing = (a.iter().zip(&b))
            .filter(|(a, b)| (*a - *b).abs() > 1e-6)
            .count();
        let share = differing as f64 / a.len() as f64;
        eprintln!(
            "depth, camera {}: {:.3}% of pixels differ",
            camera.name,
            share * 100.0
        );
        assert!(a.iter().any(|&d| d < 1.0), "nothing seen");
        assert!(
            share <= 0.005,
            "camera {}: {:.3}% of depths differ",
            camera.name,
            share * 100.0
        );
    }
}

/// Raster first hits need an MSAA count the adapter takes, and say so naming the setting; a
/// pixel then draws no more eye rays than the visibility buffer has samples.
#[test]
fn raster_first_hits_refuse_a_sample_count_the_adapter_does_not_take() {
    let (lf, resident) = shipped("cornell");
    let mut r = Renderer::new(&resident, &lf, &MemoryLedger::default()).unwrap();
    r.set_samples_per_pixel(3).unwrap();
    let e = r
        .set_first_hits(FirstHits::Raster)
        .err()
        .unwrap()
        .to_string();
    assert!(e.contains("first_hits") && e.contains('3'), "{e}");
    // and once drawn with 4 samples, no pixel reads more
    r.set_samples_per_pixel(SAMPLES).unwrap();
    r.set_first_hits(FirstHits::Raster).unwrap();
    let e = r.set_samples_per_pixel(8).err().unwrap().to_string();
    assert!(e.contains("aa") && e.contains('8'), "{e}");
    r.set_samples_per_pixel(1).unwrap();
}

/// Moving objects are seen the same way: a furnace with a mirror for its back wall, a cube in
/// front of it (seen directly and in the mirror) and one around the eye (its backs are all the
/// eye could see of it: culled both ways, or the view would be black).
#[test]
fn moving_objects_are_seen_the_same_way_both_ways() {
    let dir = tempfile::tempdir().unwrap();
    let scene = mirror_furnace(dir.path());
    let (lf, resident, _) =
        vlf::propagate::propagate(gpu(), &scene, &draft_params(), &Silent).unwrap();
    // the cube in front, and the one around the eye
    for (name, centre, half) in [
        ("cube", DVec3::new(0.15, 0.0, 0.0), 0.05),
        ("head", DVec3::new(0.0, 0.0, 0.35), 0.03),
    ] {
        cube_object(dir.path(), name, centre, half, 0.2, 0.0);
    }
    let configs: Vec<vlf::dynamic::ObjectConfig> = ["cube", "head"]
        .iter()
        .map(|name| toml::from_str(&format!("name = \"{name}\"\nmesh = \"{name}.obj\"\n")).unwrap())
        .collect();
    let objects = vlf::dynamic::Objects::load(&configs, &dir.path().join("display.toml")).unwrap();
    let tracked = vlf::dynamic::Tracked {
        time: 0.0,
        head: Affine3A::IDENTITY,
        wand: None,
        left_hand: None,
        targets: Default::default(),
    };
    let [mut rays, mut raster] = both_ways(&lf, &resident, Some((&objects, &tracked)));
    let camera = vlf::scene::Camera {
        name: "inside the head".into(),
        eye: [0.0, 0.0, 0.35],
        target: [0.0, 0.0, 0.0],
        up: [0.0, 1.0, 0.0],
        fov_y_deg: 60.0,
        size: [96, 96],
    };
    let a = rays.render(&camera, 96, 96).unwrap();
    let b = raster.render(&camera, 96, 96).unwrap();
    // the cube is there, darker than the furnace's walls, and the eye sees past its head
    let at = |f: &Frame, x: u32, y: u32| f.pixels[(y * f.width + x) as usize][0];
    let (furnace, cube) = (at(&b, 30, 48), at(&b, 80, 48));
    eprintln!("furnace in the mirror {furnace:.3}, cube {cube:.3}");
    assert!(furnace > 1.0 && cube < 0.5 * furnace, "{furnace} {cube}");
    assert_same(&[("moving objects".into(), difference(&a, &b))], 0.005);
}
