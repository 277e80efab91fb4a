//! Projector warp and blend, and the wand ray (src/display/warp.rs, post.rs,
//! shaders/warp.wgsl): the identity warp is bit-identical to no warp, a mirror and a shift
//! send known pixels where expected, a curved grid puts a bright pixel where the grid says,
//! two soft-edged projectors sum to the unblended wall in linear light and follow their masks
//! (computed, and read back from a 16-bit PNG), bad warp and blend settings name the file and
//! key, the wand ray lands where projection predicts (within 1 px), keyframes carry a wand,
//! headless runs write one image per projector and draw the ray, and the pass's parameters
//! have one size in Rust and WGSL.

use crate::common;
use common::*;
use glam::{Quat, Vec3};
use std::path::{Path, PathBuf};
use vlf::display::post::{apply, wand_overlay};
use vlf::display::projection::project_to_pixel;
use vlf::display::warp::{load_outputs, Grid, OutputSpec};
use vlf::display::DisplayConfig;
use vlf::progress::Silent;
use vlf::render::Frame;
use vlf::tracking::live::WandPose;
use vlf::tracking::source::Pose;

/// A test image whose every pixel differs: smooth ramps plus a hash, linear radiance.
fn pattern(width: u32, height: u32) -> Frame {
    let pixels = (0..width * height)
        .map(|i| {
            let (x, y) = ((i % width) as f32, (i / width) as f32);
            let h = ((i.wrapping_mul(2654435761)) >> 16) as f32 / 65536.0;
            [
                0.1 + x / width as f32,
                0.2 + y / height as f32,
                0.05 + 0.9 * h,
                1.0,
            ]
        })
        .collect();
    Frame {
        width,
        height,
        pixels,
    }
}

fn spec(pixels: [u32; 2], grid: Grid, mask: Option<Vec<f32>>) -> OutputSpec {
    OutputSpec {
        name: "p".into(),
        pixels,
        grid,
        mask,
    }
}

#[test]
fn the_identity_warp_is_bit_identical_to_no_warp() {
    let image = pattern(97, 61);
    let out = apply(
        &gpu(),
        &image,
        &spec([97, 61], Grid::identity(), None),
        None,
    )
    .unwrap();
    assert!(
        out.pixels == image.pixels,
        "the 2 x 2 identity grid changed the image"
    );
    // a finer identity grid: vertex (c, r) at (c / 6, r / 4)
    let points = (0..5)
        .flat_map(|r| (0..7).map(move |c| [c as f32 / 6.0, r as f32 / 4.0]))
        .collect();
    let fine = Grid {
        columns: 7,
        rows: 5,
        points,
    };
    let out = apply(&gpu(), &image, &spec([97, 61], fine, None), None).unwrap();
    let differ = out
        .pixels
        .iter()
        .zip(&image.pixels)
        .filter(|(a, b)| a != b)
        .count();
    assert_eq!(differ, 0, "the 7 x 5 identity grid changed {differ} pixels");
}

#[test]
fn a_mirror_and_a_shift_send_known_pixels_where_expected() {
    let (w, h) = (80u32, 40u32);
    let image = pattern(w, h);
    let at = |f: &Frame, x: u32, y: u32| f.pixels[(y * f.width + x) as usize];
    // mirrored left-right (rear projection): output x shows source w - 1 - x
    let out = apply(
        &gpu(),
        &image,
        &spec([w, h], Grid::region([1.0, 0.0, 0.0, 1.0]), None),
        None,
    )
    .unwrap();
    for (x, y) in [(0, 0), (5, 7), (79, 39), (40, 20)] {
        assert_eq!(
            at(&out, x, y),
            at(&image, w - 1 - x, y),
            "mirror at ({x}, {y})"
        );
    }
    // shifted by 10 pixels on a 3 x 3 grid: output x shows source x + 10, black past the edge
    let s = 10.0 / w as f32;
    let points = (0..3)
        .flat_map(|r| (0..3).map(move |c| [c as f32 / 2.0 + s, r as f32 / 2.0]))
        .collect();
    let out = apply(
        &gpu(),
        &image,
        &spec(
            [w, h],
            Grid {
                columns: 3,
                rows: 3,
                points,
            },
            None,
        ),
        None,
    )
    .unwrap();
    for (x, y) in [(0, 0), (33, 12), (69, 39)] {
        assert_eq!(at(&out, x, y), at(&image, x + 10, y), "shift at ({x}, {y})");
    }
    assert_eq!(
        at(&out, 75, 10)[..3],
        [0.0; 3],
        "past the wall image's edge is black"
    );
}

#[test]
fn a_curved_grid_puts_a_bright_pixel_where_the_grid_says() {
    let (w, h) = (64u32, 48u32);
    let mut image = Frame {
        width: w,
        height: h,
        pixels: vec![[0.0, 0.0, 0.0, 1.0]; (w * h) as usize],
    };
    let (sx, sy) = (41u32, 17u32);
    image.pixels[(sy * w + sx) as usize] = [1.0, 1.0, 1.0, 1.0];
    // a keystoned, bowed 4 x 3 grid
    let points: Vec<[f32; 2]> = (0..3)
        .flat_map(|r| {
            (0..4).map(move |c| {
                let (u, v) = (c as f32 / 3.0, r as f32 / 2.0);
                [
                    0.1 + 0.8 * u + 0.06 * (v - 0.5) * (u - 0.5),
                    0.05 + 0.9 * v + 0.04 * (u - 0.5) * (u - 0.5),
                ]
            })
        })
        .collect();
    let grid = Grid {
        columns: 4,
        rows: 3,
        points,
    };
    let (ow, oh) = (90u32, 70u32);
    let out = apply(&gpu(), &image, &spec([ow, oh], grid.clone(), None), None).unwrap();
    // where the grid says the source pixel's centre is shown (nearest output pixel centre)
    let target = [(sx as f32 + 0.5) / w as f32, (sy as f32 + 0.5) / h as f32];
    let mut best = (f32::INFINITY, 0, 0);
    for y in 0..oh {
        for x in 0..ow {
            let uv = grid.at([(x as f32 + 0.5) / ow as f32, (y as f32 + 0.5) / oh as f32]);
            let d = (uv[0] - target[0]).hypot(uv[1] - target[1]);
            if d < best.0 {
                best = (d, x, y);
            }
        }
    }
    let brightest = (0..ow * oh)
        .max_by(|a, b| out.pixels[*a as usize][0].total_cmp(&out.pixels[*b as usize][0]))
        .unwrap();
    let (bx, by) = (brightest % ow, brightest / ow);
    assert!(
        out.pixels[brightest as usize][0] > 0.3,
        "the bright pixel was lost"
    );
    assert!(
        (bx as i32 - best.1 as i32).abs() <= 1 && (by as i32 - best.2 as i32).abs() <= 1,
        "brightest output pixel ({bx}, {by}); the grid says ({}, {})",
        best.1,
        best.2
    );
}

/// A one-wall display with two projectors side by side overlapping by 15% of the wall.
fn two_projectors(blend: &str, extra: &str) -> String {
    format!(
        r#"name = "two"
[tracking]
source = "static"
head = [0.0, 1.0, 2.0]
[[wall]]
name = "wall"
lower_left = [-2.0, 0.0, 0.0]
lower_right = [2.0, 0.0, 0.0]
upper_left = [-2.0, 1.0, 0.0]
pixels = [200, 50]
output = {{ monitor = 0 }}
[[wall.projector]]
name = "left"
pixels = [115, 50]
region = [0.0, 0.0, 0.575, 1.0]
{blend}
[[wall.projector]]
name = "right"
pixels = [115, 50]
region = [0.425, 0.0, 1.0, 1.0]
blend = {{ exponent = 2.0 }}
{extra}"#
    )
}

fn load(dir: &Path, text: &str) -> vlf::Result<(DisplayConfig, Vec<Vec<OutputSpec>>)> {
    let path = dir.join("display.toml");
    std::fs::write(&path, text).unwrap();
    let config = DisplayConfig::load(&path)?;
    let outputs = load_outputs(&config, &path)?;
    Ok((config, outputs))
}

#[test]
fn two_soft_edged_projectors_sum_to_the_unblended_wall() {
    let dir = tempfile::tempdir().unwrap();
    let (_, outputs) = load(
        dir.path(),
        &two_projectors("blend = { exponent = 2.0 }", ""),
    )
    .unwrap();
    let image = pattern(200, 50);
    let left = apply(&gpu(), &image, &outputs[0][0], None).unwrap();
    let right = apply(&gpu(), &image, &outputs[0][1], None).unwrap();
    let mask = outputs[0][0].mask.as_ref().unwrap();
    // projector pixels fall on wall pixels: left x shows wall x, right x shows wall x + 85
    let mut worst = 0f32;
    let mut ramp = Vec::new();
    for y in 0..50usize {
        for x in 0..200usize {
            let wall = image.pixels[y * 200 + x];
            let l = if x < 115 {
                left.pixels[y * 115 + x]
            } else {
                [0.0; 4]
            };
            let r = if x >= 85 {
                right.pixels[y * 115 + x - 85]
            } else {
                [0.0; 4]
            };
            for c in 0..3 {
                worst = worst.max((l[c] + r[c] - wall[c]).abs() / wall[c]);
            }
            if x < 115 {
                // the left projector's output over the wall is its mask
                let m = l[0] / wall[0];
                assert!(
                    (m - mask[y * 115 + x]).abs() < 1e-5,
                    "left ({x}, {y}): output/wall {m} vs mask {}",
                    mask[y * 115 + x]
                );
                if y == 25 && x >= 85 {
                    ramp.push(m);
                }
            }
        }
    }
    assert!(
        worst < 1e-5,
        "left + right differs from the wall by {worst} (relative, linear light)"
    );
    // a soft edge: 1 outside the overlap, falling smoothly to 0 across it
    assert!(
        mask[25 * 115 + 10] == 1.0 && ramp.windows(2).all(|w| w[1] < w[0]),
        "ramp {ramp:?}"
    );
    assert!(
        ramp[0] > 0.99 && *ramp.last().unwrap() < 0.01 && (ramp[15] - 0.5).abs() < 0.05,
        "ramp {ramp:?}"
    );

    // the same mask from a 16-bit PNG file
    vlf::display::warp::write_mask_png(&dir.path().join("left.png"), [115, 50], mask).unwrap();
    let (_, from_file) =
        load(dir.path(), &two_projectors("blend_mask = \"left.png\"", "")).unwrap();
    let file_mask = from_file[0][0].mask.as_ref().unwrap();
    assert!(
        file_mask
            .iter()
            .zip(mask)
            .all(|(a, b)| (a - b).abs() <= 0.5 / 65535.0 + 1e-7),
        "the PNG mask differs from the computed one"
    );
    let left_file = apply(&gpu(), &image, &from_file[0][0], None).unwrap();
    let worst = left_file
        .pixels
        .iter()
        .zip(&left.pixels)
        .map(|(a, b)| (a[0] - b[0]).abs())
        .fold(0f32, f32::max);
    assert!(worst < 1e-4, "the PNG-masked output differs by {worst}");
}

#[test]
fn bad_warps_and_masks_name_the_file_and_key() {
    let dir = tempfile::tempdir().unwrap();
    let err = |blend: &str, extra: &str| {
        load(dir.path(), &two_projectors(blend, extra))
            .unwrap_err()
            .to_string()
    };
    let expect = |e: String, words: &[&str]| {
        assert!(
            words.iter().all(|w| e.contains(w)),
            "{e}\nshould mention {words:?}"
        )
    };
    expect(
        err("blend_mask = \"nowhere.png\"", ""),
        &[
            "display.toml",
            "projector[0] (\"left\")",
            "blend_mask",
            "nowhere.png",
        ],
    );
    vlf::display::warp::write_mask_png(&dir.path().join("small.png"), [100, 50], &vec![1.0; 5000])
        .unwrap();
    expect(
        err("blend_mask = \"small.png\"", ""),
        &["blend_mask", "100x50", "115x50"],
    );
    image::RgbImage::new(115, 50)
        .save(dir.path().join("colour.png"))
        .unwrap();
    expect(
        err("blend_mask = \"colour.png\"", ""),
        &["blend_mask", "greyscale"],
    );
    let grid = |points: &str| {
        format!("warp_grid = {{ columns = 2, rows = 2, points = {points} }}\nblend = {{ exponent = 1.0 }}")
    };
    // (region and a grid together)
    expect(
        err(
            &grid("[[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0]]"),
            "",
        ),
        &["projector[0]", "one of region, warp_grid and warp_file"],
    );
    let text = two_projectors("", "").replacen(
        "region = [0.0, 0.0, 0.575, 1.0]",
        &grid("[[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]"),
        1,
    );
    expect(
        load(dir.path(), &text).unwrap_err().to_string(),
        &["warp_grid", "3 points", "needs 4"],
    );
    let text = two_projectors("", "").replacen(
        "region = [0.0, 0.0, 0.575, 1.0]",
        &grid("[[0.0, 0.0], [nan, 0.0], [0.0, 1.0], [1.0, 1.0]]"),
        1,
    );
    expect(
        load(dir.path(), &text).unwrap_err().to_string(),
        &["warp_grid", "finite"],
    );
    let text = two_projectors("", "").replacen(
        "region = [0.0, 0.0, 0.575, 1.0]",
        &grid("[[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]"),
        1,
    );
    expect(
        load(dir.path(), &text).unwrap_err().to_string(),
        &["warp_grid", "not monotonic", "row 1"],
    );
    // a warp file: missing, then the wrong size of grid in it
    let file = |name: &str| {
        two_projectors("", "")
            .replacen(
                "region = [0.0, 0.0, 0.575, 1.0]",
                &format!("warp_file = \"{name}\""),
                1,
            )
            .replace("blend = { exponent = 2.0 }", "")
    };
    expect(
        load(dir.path(), &file("gone.pfm")).unwrap_err().to_string(),
        &["projector[0]", "warp_file", "gone.pfm"],
    );
    vlf::display::warp::write_pfm(&dir.path().join("one.pfm"), 1, 3, 3, &[0.0; 9]).unwrap();
    expect(
        load(dir.path(), &file("one.pfm")).unwrap_err().to_string(),
        &["warp", "1 x 3 vertices"],
    );
    let mut nan = vec![0.0f32; 12];
    nan.copy_from_slice(&[
        0.0,
        0.0,
        0.0,
        1.0,
        0.0,
        0.0,
        0.0,
        1.0,
        0.0,
        f32::NAN,
        1.0,
        0.0,
    ]);
    vlf::display::warp::write_pfm(&dir.path().join("nan.pfm"), 2, 2, 3, &nan).unwrap();
    expect(
        load(dir.path(), &file("nan.pfm")).unwrap_err().to_string(),
        &["warp", "(column 1, row 1)", "finite"],
    );
    expect(err("blend = { exponent = 2.0 }", "bogus = 1"), &["bogus"]);
    expect(
        err("blend = { exponent = 2.0, gamma = 2.2 }", ""),
        &["gamma"],
    );
}

#[test]
fn an_mpcdi_style_pfm_warp_reads_back_as_written() {
    let dir = tempfile::tempdir().unwrap();
    let points: Vec<[f32; 2]> = (0..3)
        .flat_map(|r| (0..4).map(move |c| [0.1 + c as f32 * 0.25, 0.2 + r as f32 * 0.3]))
        .collect();
    let values: Vec<f32> = points.iter().flat_map(|p| [p[0], p[1], 0.0]).collect();
    vlf::display::warp::write_pfm(&dir.path().join("warp.pfm"), 4, 3, 3, &values).unwrap();
    let grid = vlf::display::warp::read_warp_pfm(&dir.path().join("warp.pfm")).unwrap();
    assert_eq!((grid.columns, grid.rows), (4, 3));
    assert_eq!(grid.points, points, "rows come back top first");
}

/// A front wall 3 m wide, 160 x 160 pixels, a head in front of it and a wand pointing up and
/// ahead: the ray's pixels on the wall image and where projection puts the wand's segment.
#[test]
fn the_wand_ray_lands_where_projection_predicts() {
    let text = r#"name = "front"
[tracking]
source = "static"
head = [0.0, 1.5, 0.5]
[[wall]]
name = "front"
lower_left = [-1.5, 0.0, -1.5]
lower_right = [1.5, 0.0, -1.5]
upper_left = [-1.5, 3.0, -1.5]
pixels = [160, 160]
output = { monitor = 0 }
"#;
    let config = DisplayConfig::parse(text, Path::new("front.toml")).unwrap();
    let wall = &config.walls[0];
    let norm = vlf::prepare::Normalisation {
        center: [0.3, 1.0, 1.0],
        scale: 0.4,
    };
    let pose = Pose {
        head: Vec3::new(0.0, 1.5, 0.5),
        head_rotation: Quat::IDENTITY,
        room_position: Vec3::new(0.5, 0.0, -0.2),
        room_yaw_deg: 20.0,
    };
    let wand = WandPose {
        position: Vec3::new(0.2, 1.0, 0.0),
        rotation: Quat::from_rotation_y(15f32.to_radians())
            * Quat::from_rotation_x(30f32.to_radians()),
    };
    let black = Frame {
        width: 160,
        height: 160,
        pixels: vec![[0.0, 0.0, 0.0, 1.0]; 160 * 160],
    };
    let output = vlf::display::post::wall_output(wall);
    let none = apply(&gpu(), &black, &output, None).unwrap();
    assert!(
        none.pixels == black.pixels,
        "without a wand nothing is drawn"
    );
    let overlay = wand_overlay(&config, wall, 0.0, &pose, Some(&wand), &norm).unwrap();
    let out = apply(&gpu(), &black, &output, Some(&overlay)).unwrap();
    // the segment's projection: a straight line in the image; sample it finely
    let to_unit = |p: Vec3| norm.to_unit(pose.room_to_world(p).into()).as_vec3();
    let line: Vec<(f32, f32)> = (0..=2000)
        .filter_map(|i| {
            project_to_pixel(
                overlay.view_proj,
                to_unit(wand.position + wand.rotation * Vec3::NEG_Z * (10.0 * i as f32 / 2000.0)),
                [160, 160],
            )
        })
        .collect();
    let mut rows = 0;
    for y in 0..160u32 {
        let lit: Vec<u32> = (0..160)
            .filter(|x| out.pixels[(y * 160 + x) as usize][0] > 0.5)
            .collect();
        let cy = y as f32 + 0.5;
        // where the projected segment crosses this row's centre
        let cross = line
            .windows(2)
            .find(|w| (w[0].1 - cy) * (w[1].1 - cy) <= 0.0 && w[0].1 != w[1].1);
        match (lit.is_empty(), cross) {
            (true, None) => {}
            (false, Some(w)) => {
                let s = (cy - w[0].1) / (w[1].1 - w[0].1);
                let expected = w[0].0 + s * (w[1].0 - w[0].0);
                let centroid = lit.iter().map(|x| *x as f32 + 0.5).sum::<f32>() / lit.len() as f32;
                assert!(
                    (centroid - expected).abs() <= 1.0,
                    "row {y}: ray centred at x {centroid}, projection says {expected}"
                );
                assert!(
                    lit.len() <= 6,
                    "row {y}: {} pixels lit; a thin ray is a few",
                    lit.len()
                );
                rows += 1;
            }
            (false, None) => {
                // past the segment's end only by the ray's rounded tip: within 1.5 px of it
                for x in &lit {
                    let d = line
                        .iter()
                        .map(|p| (p.0 - (*x as f32 + 0.5)).hypot(p.1 - cy))
                        .fold(f32::INFINITY, f32::min);
                    assert!(
                        d <= 1.5,
                        "row {y}: pixel {x} lit {d} px from the wand's projected segment"
                    );
                }
            }
            (true, Some(_)) => {
                // the far end thins out below a pixel only with min_pixels 0; here it must show
                panic!("row {y}: the segment crosses it but no pixel is lit");
            }
        }
    }
    assert!(
        rows >= 40,
        "the ray crosses only {rows} rows of the wall image"
    );
    // and the colour is the configured one
    let lit = out.pixels.iter().find(|p| p[0] > 0.5).unwrap();
    assert_eq!(lit[..3], config.wand_ray.colour);
}

#[test]
fn keyframes_carry_a_wand() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("path.toml");
    std::fs::write(
        &path,
        "[[keyframe]]\nt = 0.0\nhead = [0.0, 1.7, 0.0]\nposition = [0.0, 0.0, 0.0]\nwand_position = [0.0, 1.0, 0.0]\nwand_yaw_deg = 0.0\n\
         [[keyframe]]\nt = 2.0\nhead = [0.0, 1.7, 0.0]\nposition = [0.0, 0.0, 0.0]\nwand_position = [1.0, 1.0, 0.0]\nwand_yaw_deg = 90.0\n\
         [[keyframe]]\nt = 3.0\nhead = [0.0, 1.7, 0.0]\nposition = [0.0, 0.0, 0.0]\n",
    )
    .unwrap();
    let p = vlf::tracking::source::ScriptedPath::load(&path).unwrap();
    let w = p.wand_at(1.0).unwrap();
    assert!((w.position - Vec3::new(0.5, 1.0, 0.0)).length() < 1e-6);
    assert!(
        (w.rotation * Vec3::NEG_Z
            - Vec3::new(
                -(45f32.to_radians().sin()),
                0.0,
                -(45f32.to_radians().cos())
            ))
        .length()
            < 1e-5,
        "slerped halfway"
    );
    assert!(p.wand_at(3.5).is_none(), "the last keyframe has no wand");
    std::fs::write(&path, "[[keyframe]]\nt = 0.0\nhead = [0.0, 1.7, 0.0]\nposition = [0.0, 0.0, 0.0]\nwand_yaw_deg = 10.0\n").unwrap();
    let e = vlf::tracking::source::ScriptedPath::load(&path)
        .unwrap_err()
        .to_string();
    assert!(e.contains("keyframe[0].wand_position"), "{e}");
}

fn shipped(rel: &str) -> PathBuf {
    repo_path("config/displays").join(rel)
}

/// Headless, through the real renderer: the shipped two-projector wall writes one image per
/// projector whose identity-warped twin is bit-identical to the wall; the soft-edged pair sums
/// to the wall; and the CAVE with a wand draws the ray on the front wall.
#[test]
fn headless_writes_every_projector_and_draws_the_wand() {
    let dir = tempfile::tempdir().unwrap();
    let scene = vlf::scene::Scene::load(&repo_path("scenes/cornell/scene.toml")).unwrap();
    let params = common::draft_params();
    let (lf, resident, _) = vlf::propagate::propagate(gpu(), &scene, &params, &Silent).unwrap();
    // the shipped wall at small pixels, with a third, identity projector
    let text = std::fs::read_to_string(shipped("wall-2projectors.toml")).unwrap();
    let text = text
        .replace("pixels = [3340, 1200]", "pixels = [200, 72]")
        .replace("pixels = [1920, 1200]", "pixels = [115, 72]");
    let text = format!("{text}\n[[wall.projector]]\nname = \"whole\"\npixels = [200, 72]\nregion = [0.0, 0.0, 1.0, 1.0]\n");
    let path = dir.path().join("wall.toml");
    std::fs::write(&path, &text).unwrap();
    let display = DisplayConfig::load(&path).unwrap();
    let out = dir.path().join("out");
    let report =
        vlf::display::headless::run(&lf, &resident, &display, &path, 2, &out, true).unwrap();
    let read =
        |name: &str| vlf::render::image_io::read_exr(&out.join(format!("{name}.exr"))).unwrap();
    let wall = read("wall-mono");
    for p in ["left", "right", "whole"] {
        assert!(
            out.join(format!("wall-mono-{p}.png")).exists(),
            "no image for projector {p}: {:?}",
            report.images
        );
    }
    assert!(
        wall.pixels.iter().map(|p| p[1]).sum::<f32>() > 1.0,
        "the wall shows the box"
    );
    assert!(
        read("wall-mono-whole").pixels == wall.pixels,
        "the identity projector differs from the wall"
    );
    let (left, right) = (read("wall-mono-left"), read("wall-mono-right"));
    let mut worst = 0f32;
    for y in 0..72usize {
        for x in 85..115usize {
            for c in 0..3 {
                let sum = left.pixels[y * 115 + x][c] + right.pixels[y * 115 + x - 85][c];
                worst = worst.max(
                    (sum - wall.pixels[y * 200 + x][c]).abs()
                        / wall.pixels[y * 200 + x][c].max(1e-3),
                );
            }
        }
    }
    assert!(
        worst < 1e-4,
        "in the overlap, left + right differs from the wall by {worst} (relative)"
    );

    // the CAVE with a static wand, small: the ray is on the front wall's images
    let text = std::fs::read_to_string(shipped("cave-4wall-wand.toml"))
        .unwrap()
        .replace("pixels = [1920, 1200]", "pixels = [96, 60]");
    let path = dir.path().join("cave.toml");
    std::fs::write(&path, text).unwrap();
    let display = DisplayConfig::load(&path).unwrap();
    let out = dir.path().join("cave");
    vlf::display::headless::run(&lf, &resident, &display, &path, 1, &out, true).unwrap();
    let colour = display.wand_ray.colour;
    for eye in ["left", "right"] {
        let front = vlf::render::image_io::read_exr(&out.join(format!("front-{eye}.exr"))).unwrap();
        let ray = front.pixels.iter().filter(|p| p[..3] == colour).count();
        assert!(ray >= 20, "front-{eye}: {ray} pixels of the ray's colour");
    }
}

#[test]
fn the_warp_parameters_have_the_same_size_in_rust_and_wgsl() {
    let module = vlf::gpu::shaders::expand("warp.wgsl")
        .unwrap()
        .validate()
        .unwrap();
    let mut layouter = naga::proc::Layouter::default();
    layouter.update(module.to_ctx()).unwrap();
    let (handle, _) = module
        .types
        .iter()
        .find(|(_, t)| t.name.as_deref() == Some("WarpParams"))
        .expect("WGSL struct WarpParams");
    assert_eq!(
        std::mem::size_of::<vlf::display::post::GpuWarp>(),
        layouter[handle].size as usize
    );
}
