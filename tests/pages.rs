//! Texel arrays and mirror tiles in pages: when they outgrow one storage binding (128 MiB on the
//! software adapter) they are split over up to four buffers. Here
//! `vlf::lightfield::tiles::with_small_pages` makes the pages small (for this test's thread
//! only) so that a small scene spans several; propagation and rendering must give the one-page
//! result. (The real > 128 MiB case is in `vlf stress`, STABILITY.md.)

use crate::common;
use common::*;
use glam::DVec3;
use vlf::progress::Silent;
use vlf::propagate::PropagationParams;
use vlf::scene::Scene;

fn mirror_room(dir: &std::path::Path) -> Scene {
    let mut obj = ObjBuilder::default();
    obj.cube("wall", DVec3::ZERO, 0.8, true);
    obj.quad(
        "light",
        DVec3::new(0.0, 0.79, 0.0),
        -DVec3::Y,
        [0.4, 0.4],
        0.0,
    );
    obj.quad(
        "glass",
        DVec3::new(-0.79, 0.0, 0.0),
        DVec3::X,
        [1.2, 1.2],
        0.0,
    );
    obj.quad(
        "glass",
        DVec3::new(0.0, 0.0, -0.79),
        DVec3::Z,
        [1.2, 1.2],
        0.0,
    );
    Scene::load(&write_scene(
        dir,
        &obj,
        &[
            Mat {
                name: "wall",
                kd: [0.6, 0.6, 0.6],
                ke: [0.0; 3],
            },
            Mat {
                name: "light",
                kd: [0.0; 3],
                ke: [10.0; 3],
            },
            Mat {
                name: "glass",
                kd: [0.0; 3],
                ke: [0.0; 3],
            },
        ],
        "[materials.glass]\nmirror = [0.8, 0.8, 0.8]\n",
    ))
    .unwrap()
}

#[test]
fn paged_mirror_tiles_give_the_one_page_result() {
    let dir = tempfile::tempdir().unwrap();
    let scene = mirror_room(dir.path());
    let params = PropagationParams {
        geodesic_frequency: 4,
        grid_resolution: 48,
        tile_size: 8,
        texel_density: 8.0,
        tolerance: 1e-3,
        max_iterations: 50,
        perturb: 1,
        accelerate: true,
        memory_budget_mib: None,
        direct_samples: 16,
        mirror_direct: false,
        rim_rays: false,
    };
    let render = |lf: &vlf::lightfield::LightField| {
        let resident = lf.upload(gpu()).unwrap();
        let pages = (
            resident.total.len(),
            resident.tiles.as_ref().unwrap().radiance.len(),
        );
        let mut renderer =
            vlf::render::Renderer::new(&resident, lf, &vlf::gpu::MemoryLedger::default()).unwrap();
        (
            renderer.render(lf.camera(None).unwrap(), 96, 96).unwrap(),
            pages,
        )
    };
    let (one, _, _) = vlf::propagate::propagate(gpu(), &scene, &params, &Silent).unwrap();
    let (one_image, one_pages) = render(&one);
    let cells = one.tiles.as_ref().unwrap().total.len();
    // pages of a third of the cells, rounded to whole tiles
    let page_bytes = (cells as u64 * 16 / 3).next_multiple_of(64 * 16);
    let texel_page_bytes = (one.total.len() as u64 * 16 / 3).next_multiple_of(16);
    let (paged, paged_image, paged_pages, report) =
        vlf::lightfield::tiles::with_small_pages(page_bytes, texel_page_bytes, || {
            let (paged, _, report) =
                vlf::propagate::propagate(gpu(), &scene, &params, &Silent).unwrap();
            let (paged_image, paged_pages) = render(&paged);
            (paged, paged_image, paged_pages, report)
        });
    println!(
        "{} texels, {cells} tile cells: (texel, tile) pages {one_pages:?} unpaged, {paged_pages:?} paged; {} iterations",
        one.total.len(),
        report.iterations
    );
    assert_eq!(one_pages, (1, 1));
    assert!(
        paged_pages.0 >= 3 && paged_pages.1 >= 3,
        "{paged_pages:?} pages"
    );
    let (a, b) = (
        &one.tiles.as_ref().unwrap().total,
        &paged.tiles.as_ref().unwrap().total,
    );
    let scale = a
        .iter()
        .map(|v| v[0].max(v[1]).max(v[2]))
        .fold(0.0f32, f32::max);
    let worst = a
        .iter()
        .zip(b)
        .flat_map(|(x, y)| (0..3).map(move |k| (x[k] - y[k]).abs()))
        .fold(0.0f32, f32::max)
        / scale;
    assert!(
        worst < 1e-6,
        "tile radiance differs by {worst:.2e} of the maximum"
    );
    let texel_scale = one
        .total
        .iter()
        .map(|v| v[0].max(v[1]).max(v[2]))
        .fold(0.0f32, f32::max);
    let texels = one
        .total
        .iter()
        .zip(&paged.total)
        .flat_map(|(x, y)| (0..3).map(move |k| (x[k] - y[k]).abs()))
        .fold(0.0f32, f32::max)
        / texel_scale;
    assert!(
        texels < 1e-6,
        "texels differ by {texels:.2e} of the maximum"
    );
    let image = one_image
        .pixels
        .iter()
        .zip(&paged_image.pixels)
        .flat_map(|(x, y)| (0..3).map(move |k| (x[k] - y[k]).abs()))
        .fold(0.0f32, f32::max);
    assert!(
        image < 1e-5 * texel_scale,
        "the paged light field renders differently ({image:.2e})"
    );
}
