//! The GPU kernels against their CPU twins on a tiny scene (<= 20 faces, 21 directions,
//! grid 32), and propagation repeated bit for bit on one device.

use crate::common;
use common::*;
use glam::DVec3;
use vlf::lightfield::directions::DirectionSet;
use vlf::prepare::PreparedScene;
use vlf::progress::Silent;
use vlf::propagate::cpu::{self, specular as cpu_specular};
use vlf::propagate::transport::Propagator;
use vlf::propagate::{gpu_directions, initial_radiance, PropagationParams};
use vlf::scene::Scene;

fn tiny_scene(dir: &std::path::Path) -> Scene {
    tiny_scene_with(dir, "")
}

/// `extra`: scene TOML, e.g. material overrides that turn the blocks into mirrors.
fn tiny_scene_with(dir: &std::path::Path, extra: &str) -> Scene {
    let mut obj = ObjBuilder::default();
    obj.cube("room", DVec3::ZERO, 0.5, true);
    // a tilted block and a floating emitter: occlusion in every direction
    obj.quad(
        "block",
        DVec3::new(0.1, -0.2, 0.05),
        DVec3::new(0.3, 1.0, 0.2),
        [0.4, 0.3],
        0.4,
    );
    obj.quad(
        "block",
        DVec3::new(-0.15, -0.1, 0.2),
        DVec3::new(-1.0, 0.2, 0.4),
        [0.3, 0.5],
        0.1,
    );
    obj.quad(
        "block",
        DVec3::new(0.2, 0.0, -0.2),
        DVec3::new(0.5, 0.1, -1.0),
        [0.35, 0.35],
        0.9,
    );
    obj.quad(
        "light",
        DVec3::new(0.0, 0.45, 0.0),
        DVec3::new(0.05, -1.0, 0.02),
        [0.3, 0.25],
        0.2,
    );
    let path = write_scene(
        dir,
        &obj,
        &[
            Mat {
                name: "room",
                kd: [0.7, 0.5, 0.3],
                ke: [0.0; 3],
            },
            Mat {
                name: "block",
                kd: [0.4, 0.6, 0.8],
                ke: [0.0; 3],
            },
            Mat {
                name: "light",
                kd: [0.2; 3],
                ke: [4.0, 3.0, 2.0],
            },
        ],
        &format!("[sky]\nradiance = [0.0, 0.0, 0.0]\n{extra}"),
    );
    Scene::load(&path).unwrap()
}

fn tiny_params() -> PropagationParams {
    PropagationParams {
        geodesic_frequency: 2,
        grid_resolution: 32,
        tile_size: 8,
        texel_density: 10.0,
        tolerance: 1e-3,
        max_iterations: 50,
        perturb: 1,
        accelerate: true,
        memory_budget_mib: None,
        direct_samples: 0,
        mirror_direct: false,
        rim_rays: false,
    }
}

#[test]
fn gpu_visibility_and_gather_equal_the_cpu_twin() {
    visibility_and_gather_equal_the_cpu_twin(false);
}

/// The same with `rim_rays`: texels the lists cannot place cast rays (through the BVH on the
/// GPU, through every triangle on the CPU), and the twin still agrees.
#[test]
fn gpu_gather_with_rim_rays_equals_the_cpu_twin() {
    visibility_and_gather_equal_the_cpu_twin(true);
}

fn visibility_and_gather_equal_the_cpu_twin(rim_rays: bool) {
    let ctx = gpu();
    let dir = tempfile::tempdir().unwrap();
    let scene = tiny_scene(dir.path());
    let params = PropagationParams {
        rim_rays,
        ..tiny_params()
    };
    let prepared = PreparedScene::new(&scene, params.texel_density).unwrap();
    assert!(prepared.faces.len() <= 20);
    let directions = DirectionSet::geodesic(params.geodesic_frequency);
    assert_eq!(directions.len(), 21);
    let mut prop =
        Propagator::new(ctx.clone(), &prepared, &params, &directions, None, None).unwrap();
    prop.build_visibility().unwrap();
    let cells = (params.grid_resolution * params.grid_resolution) as u64 * directions.len() as u64;
    let (gpu_offset, gpu_count, gpu_layers) =
        prop.visibility.as_ref().unwrap().read(&ctx, cells).unwrap();

    let vertices: Vec<[f32; 4]> = prepared
        .positions
        .iter()
        .map(|p| [p.x as f32, p.y as f32, p.z as f32, 0.0])
        .collect();
    let triangles: Vec<[u32; 4]> = prepared
        .triangles
        .iter()
        .map(|t| [t.vertices[0], t.vertices[1], t.vertices[2], t.face])
        .collect();
    let gdirs = gpu_directions(&directions.directions);
    let vis = cpu::build_visibility(&prop.grid, &gdirs, &vertices, &triangles);
    let bvh_triangles = &prepared.bvh.triangles;
    assert_eq!(vis.cell_count, gpu_count, "per-cell layer counts differ");
    assert_eq!(vis.cell_offset, gpu_offset, "per-cell offsets differ");
    let mut mismatched = 0;
    for (a, b) in vis.layers.iter().zip(&gpu_layers) {
        let (da, db) = (f32::from_bits(a[1]), f32::from_bits(b[1]));
        if a[0] != b[0] || (da - db).abs() > 1e-5 * da.abs().max(1.0) {
            mismatched += 1;
        }
    }
    assert_eq!(
        mismatched,
        0,
        "{mismatched} of {} layers differ",
        vis.layers.len()
    );

    // three iterations; each GPU result against the CPU gather of the same unshot input
    let (faces, materials) = (prop.faces.clone(), prop.materials.clone());
    let (mut unshot, _) = initial_radiance(&prepared, &faces, &materials);
    for iteration in 0..3 {
        let mut grid = prop.grid;
        grid.iteration = iteration;
        if rim_rays {
            grid.flags |= vlf::gpu::types::GRID_FLAG_RIM_RAYS;
        }
        let inputs = cpu::GatherInputs {
            grid: &grid,
            directions: &gdirs,
            faces: &faces,
            materials: &materials,
            visibility: &vis,
            texel_points: &prepared.atlas.points,
            unshot: &unshot,
            tiles: None,
            triangles: bvh_triangles,
        };
        let expected: Vec<[f32; 4]> = (0..prepared.atlas.texel_count())
            .map(|t| inputs.gather(t))
            .collect();
        if rim_rays && iteration == 1 {
            // the rays take part: without them some texel gathers differently
            let mut lists_only = grid;
            lists_only.flags &= !vlf::gpu::types::GRID_FLAG_RIM_RAYS;
            let plain = cpu::GatherInputs {
                grid: &lists_only,
                ..inputs
            };
            let changed = (0..prepared.atlas.texel_count())
                .filter(|&t| plain.gather(t) != expected[t])
                .count();
            assert!(changed > 0, "no texel's gather used a rim ray");
            eprintln!("{changed} texels gather differently with rim rays");
        }
        prop.iterate().unwrap();
        let got = prop.read_unshot().unwrap();
        let scale = expected
            .iter()
            .flat_map(|v| v[..3].iter())
            .fold(0.0f32, |m, &x| m.max(x.abs()));
        assert!(scale > 0.0, "nothing was lit");
        let mut worst = 0.0f32;
        for (e, g) in expected.iter().zip(&got) {
            for c in 0..3 {
                let rel = (e[c] - g[c]).abs() / e[c].abs().max(1e-3 * scale);
                worst = worst.max(rel);
            }
        }
        assert!(
            worst <= 1e-5,
            "iteration {iteration}: GPU and CPU gather differ by {worst:.2e} relative"
        );
        unshot = got;
    }
}

#[test]
fn gpu_mirror_gather_equals_the_cpu_twin() {
    // the blocks are mixed mirrors (0.5 mirror + their diffuse part): tile cells gather through
    // the geodesic lookup, and texels receive from mirror senders' tiles
    let ctx = gpu();
    let dir = tempfile::tempdir().unwrap();
    let scene = tiny_scene_with(
        dir.path(),
        "[materials.block]\nmirror = [0.5, 0.5, 0.5]\ndiffuse = [0.3, 0.3, 0.3]\n",
    );
    let params = tiny_params();
    let prepared = PreparedScene::new(&scene, params.texel_density).unwrap();
    let directions = DirectionSet::geodesic(params.geodesic_frequency);
    let mut prop =
        Propagator::new(ctx.clone(), &prepared, &params, &directions, None, None).unwrap();
    prop.build_visibility().unwrap();
    let vertices: Vec<[f32; 4]> = prepared
        .positions
        .iter()
        .map(|p| [p.x as f32, p.y as f32, p.z as f32, 0.0])
        .collect();
    let triangles: Vec<[u32; 4]> = prepared
        .triangles
        .iter()
        .map(|t| [t.vertices[0], t.vertices[1], t.vertices[2], t.face])
        .collect();
    let gdirs = gpu_directions(&directions.directions);
    let vis = cpu::build_visibility(&prop.grid, &gdirs, &vertices, &triangles);
    let bvh_triangles = &prepared.bvh.triangles;
    let layout = prop.tile_layout().expect("mirror tiles").clone();
    let (faces, materials) = (prop.faces.clone(), prop.materials.clone());
    let (mut unshot, _) = initial_radiance(&prepared, &faces, &materials);
    let mut tile_unshot = vec![[0.0f32; 4]; layout.cell_count() as usize];
    // the tile headers as the GPU's gather reads them (specular textures' factors after them)
    let mut headers = layout.headers.clone();
    if prop.grid.specular_words > 0 {
        headers.extend(vlf::propagate::transport::specular_factor_words(
            &prepared, &layout,
        ));
    }
    for iteration in 0..3 {
        let mut grid = prop.grid;
        grid.iteration = iteration;
        let tiles = cpu_specular::TileInputs {
            rects: &layout.rects,
            index: &layout.index,
            headers: &headers,
            tile_directions: &gdirs,
            set: &directions,
            radiance: &tile_unshot,
        };
        let inputs = cpu::GatherInputs {
            grid: &grid,
            directions: &gdirs,
            faces: &faces,
            materials: &materials,
            visibility: &vis,
            texel_points: &prepared.atlas.points,
            unshot: &unshot,
            tiles: Some(&tiles),
            triangles: bvh_triangles,
        };
        let expected_texels: Vec<[f32; 4]> = (0..prepared.atlas.texel_count())
            .map(|t| inputs.gather(t))
            .collect();
        let expected_tiles: Vec<[f32; 4]> = (0..layout.cell_count() as u32)
            .map(|c| inputs.gather_tile(c))
            .collect();
        if iteration > 0 {
            // the mirror senders' tiles really take part: without them the texels come out darker
            let diffuse_only = cpu::GatherInputs {
                tiles: None,
                ..inputs
            };
            let without: f32 = (0..prepared.atlas.texel_count())
                .map(|t| diffuse_only.gather(t)[0])
                .sum();
            let with: f32 = expected_texels.iter().map(|v| v[0]).sum();
            assert!(
                with > without * 1.001,
                "iteration {iteration}: mirror senders add nothing ({with} vs {without})"
            );
        }
        prop.iterate().unwrap();
        let (got_texels, got_tiles) = (
            prop.read_unshot().unwrap(),
            prop.read_tile_unshot().unwrap(),
        );
        for (what, expected, got) in [
            ("texels", &expected_texels, &got_texels),
            ("tile cells", &expected_tiles, &got_tiles),
        ] {
            let scale = expected
                .iter()
                .flat_map(|v| v[..3].iter())
                .fold(0.0f32, |m, &x| m.max(x.abs()));
            assert!(scale > 0.0, "iteration {iteration}: no {what} lit");
            let worst = expected
                .iter()
                .zip(got.iter())
                .flat_map(|(e, g)| (0..3).map(move |c| (e[c] - g[c]).abs() / scale))
                .fold(0.0f32, f32::max);
            println!("iteration {iteration}: {what} agree to {worst:.1e} of the largest value");
            // the geodesic lookup is f64 on the CPU, f32 on the GPU: a tap weight may differ in
            // its last bits
            assert!(
                worst <= 1e-4,
                "iteration {iteration}: GPU and CPU {what} differ by {worst:.2e} of the maximum"
            );
        }
        unshot = got_texels;
        tile_unshot = got_tiles;
    }
}

#[test]
fn propagation_is_bit_for_bit_repeatable() {
    let ctx = gpu();
    let scene = Scene::load(&repo_path("scenes/cornell/scene.toml")).unwrap();
    let params = PropagationParams {
        geodesic_frequency: 4,
        grid_resolution: 48,
        tile_size: 8,
        texel_density: 12.0,
        tolerance: 1e-3,
        max_iterations: 100,
        perturb: 1,
        accelerate: true,
        memory_budget_mib: None,
        direct_samples: 0,
        mirror_direct: false,
        rim_rays: false,
    };
    let (a, _, ra) = vlf::propagate::propagate(ctx.clone(), &scene, &params, &Silent).unwrap();
    let (b, _, rb) = vlf::propagate::propagate(ctx.clone(), &scene, &params, &Silent).unwrap();
    assert_eq!(ra.iterations, rb.iterations);
    assert_eq!(ra.final_residual.to_bits(), rb.final_residual.to_bits());
    let bits = |t: &[[f32; 4]]| t.iter().flatten().map(|x| x.to_bits()).collect::<Vec<_>>();
    let (ba, bb) = (bits(&a.total), bits(&b.total));
    let differing = ba.iter().zip(&bb).filter(|(x, y)| x != y).count();
    assert_eq!(
        differing, 0,
        "{differing} radiance values differ between two runs"
    );
    assert!(a.total.iter().flatten().all(|x| x.is_finite()));
}
