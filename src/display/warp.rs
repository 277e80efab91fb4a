//! Projector warp and blend: a wall's image may go to several projectors whose outputs overlap
//! (`[[wall.projector]]`). Each projector has a warp, as in MPCDI's geometry warp: for every
//! vertex of a `rows` x `columns` grid over the projector's output image, the normalised
//! position in the wall image that it shows (u right, v down from the wall image's top-left
//! corner, 0..1 from edge to edge; vertex (c, r) sits at (c / (columns - 1), r / (rows - 1))
//! of the output, edge to edge). The warp is a rectangle of the wall image (`region`), an
//! inline grid (`warp_grid`) or a PFM file (`warp_file`, 3 channels x, y, unused, as MPCDI
//! writes it). Each projector also has a blend mask: a per-pixel attenuation in linear light,
//! from a greyscale image (`blend_mask`: 16- or 8-bit PNG, or a 1-channel PFM, at the
//! projector's pixel size) or computed here from the regions of the wall's projectors
//! (`blend = { exponent = 2.0 }`: soft edges that sum to one wherever the projectors with
//! computed soft edges overlap).
//! This module checks and loads them; `post.rs` applies them on the GPU.

use super::{DisplayConfig, Wall};
use crate::error::{Result, VlfError};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Projector {
    pub name: String,
    /// the projector's output image, pixels
    pub pixels: [u32; 2],
    /// a linear warp: the rectangle [u0, v0, u1, v1] of the wall image (u1 < u0 mirrors)
    pub region: Option<[f32; 4]>,
    /// an inline warp grid
    pub warp_grid: Option<WarpGrid>,
    /// a warp grid file: PFM, 3 channels (x, y, unused), path relative to the configuration
    pub warp_file: Option<PathBuf>,
    /// a blend mask file: greyscale PNG (16 or 8 bits) or 1-channel PFM, linear attenuation
    pub blend_mask: Option<PathBuf>,
    /// a soft-edge blend mask computed from the regions of the wall's projectors
    pub blend: Option<SoftEdge>,
}

/// An inline warp grid: `points` row by row from the top-left vertex, `columns` x `rows` of them.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct WarpGrid {
    pub columns: u32,
    pub rows: u32,
    pub points: Vec<[f32; 2]>,
}

/// Soft edges: a projector's weight at a point of the wall is its distance to the nearest of
/// its region's edges that lie inside the wall, raised to `exponent`; the weights of the
/// projectors covering the point are normalised to sum to one. 1 is a linear cross-fade, 2
/// (the default) an S-curve, flat at both ends. The mask multiplies linear light before the
/// output's sRGB encoding, so a projector calibrated to sRGB needs no extra gamma here.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct SoftEdge {
    #[serde(default = "default_exponent")]
    pub exponent: f32,
}

fn default_exponent() -> f32 {
    2.0
}

/// The most vertices of a warp grid (8 bytes each in one GPU storage buffer of 128 MiB at most).
pub const MAX_VERTICES: usize = 16_000_000;
/// The most pixels of a projector's output (its mask: 4 bytes each in one such buffer).
pub const MAX_OUTPUT_PIXELS: u64 = 32 << 20;

/// A checked warp grid.
#[derive(Clone, Debug, PartialEq)]
pub struct Grid {
    pub columns: u32,
    pub rows: u32,
    pub points: Vec<[f32; 2]>,
}

impl Grid {
    /// The identity: the output shows the whole wall image as it is.
    pub fn identity() -> Grid {
        Grid::region([0.0, 0.0, 1.0, 1.0])
    }
    /// The output shows the rectangle [u0, v0, u1, v1] of the wall image.
    pub fn region([u0, v0, u1, v1]: [f32; 4]) -> Grid {
        Grid {
            columns: 2,
            rows: 2,
            points: vec![[u0, v0], [u1, v0], [u0, v1], [u1, v1]],
        }
    }

    /// Checks: at least 2 x 2 vertices, one point per vertex, every point finite, and every
    /// row and column monotonic the same way (a mirror is allowed, a fold is not).
    pub fn check(&self) -> std::result::Result<(), String> {
        let (c, r) = (self.columns as usize, self.rows as usize);
        if c < 2 || r < 2 || c > 4096 || r > 4096 {
            return Err(format!(
                "the grid is {c} x {r} vertices; it needs 2 to 4096 each way"
            ));
        }
        if c * r > MAX_VERTICES {
            return Err(format!(
                "the grid is {c} x {r} vertices; at most {MAX_VERTICES} in all fit one GPU buffer"
            ));
        }
        if self.points.len() != c * r {
            return Err(format!(
                "{} points for a grid of {c} columns x {r} rows: it needs {}",
                self.points.len(),
                c * r
            ));
        }
        if let Some(i) = self
            .points
            .iter()
            .position(|p| !(p[0].is_finite() && p[1].is_finite()))
        {
            return Err(format!("the point of vertex (column {}, row {}) is {:?}: every point must be a finite number", i % c, i / c, self.points[i]));
        }
        let p = |x: usize, y: usize| self.points[y * c + x];
        let sx = (p(1, 0)[0] - p(0, 0)[0]).signum();
        let sy = (p(0, 1)[1] - p(0, 0)[1]).signum();
        for y in 0..r {
            for x in 0..c {
                if x + 1 < c && (p(x + 1, y)[0] - p(x, y)[0]) * sx <= 0.0 {
                    return Err(format!("not monotonic: along row {y}, x goes from {} (column {x}) to {} (column {}); every row must run the same way (a fold or a repeated point is refused)", p(x, y)[0], p(x + 1, y)[0], x + 1));
                }
                if y + 1 < r && (p(x, y + 1)[1] - p(x, y)[1]) * sy <= 0.0 {
                    return Err(format!("not monotonic: down column {x}, y goes from {} (row {y}) to {} (row {}); every column must run the same way (a fold or a repeated point is refused)", p(x, y)[1], p(x, y + 1)[1], y + 1));
                }
            }
        }
        Ok(())
    }

    /// The wall image position shown at output position `t` (0..1 each way): bilinear in the
    /// grid, as the GPU pass does it.
    pub fn at(&self, t: [f32; 2]) -> [f32; 2] {
        let (c, r) = (self.columns, self.rows);
        let g = [t[0] * (c - 1) as f32, t[1] * (r - 1) as f32];
        let (i, j) = (
            (g[0].floor().max(0.0) as u32).min(c - 2),
            (g[1].floor().max(0.0) as u32).min(r - 2),
        );
        let (fx, fy) = (g[0] - i as f32, g[1] - j as f32);
        let p = |x: u32, y: u32| self.points[(y * c + x) as usize];
        let lerp =
            |a: [f32; 2], b: [f32; 2], s: f32| [a[0] + (b[0] - a[0]) * s, a[1] + (b[1] - a[1]) * s];
        lerp(
            lerp(p(i, j), p(i + 1, j), fx),
            lerp(p(i, j + 1), p(i + 1, j + 1), fx),
            fy,
        )
    }
}

/// One output of a wall: a projector with its warp and mask (None: no attenuation).
#[derive(Clone, Debug)]
pub struct OutputSpec {
    pub name: String,
    pub pixels: [u32; 2],
    pub grid: Grid,
    /// row-major from the top-left pixel, `pixels[0] * pixels[1]` values
    pub mask: Option<Vec<f32>>,
}

/// The configuration-only checks of a wall's projectors (files are read by `load_outputs`).
pub fn validate_projectors(wall: &Wall) -> std::result::Result<(), String> {
    let mut names = std::collections::HashSet::new();
    for (i, p) in wall.projectors.iter().enumerate() {
        let at = format!("projector[{i}] ({:?})", p.name);
        if !names.insert(p.name.as_str()) {
            return Err(format!("{at}.name: duplicate projector name"));
        }
        if p.pixels[0] == 0
            || p.pixels[1] == 0
            || p.pixels[0] > 16384
            || p.pixels[1] > 16384
            || p.pixels[0] as u64 * p.pixels[1] as u64 > MAX_OUTPUT_PIXELS
        {
            return Err(format!("{at}.pixels: {:?} must be 1..16384 each way and at most {MAX_OUTPUT_PIXELS} in all", p.pixels));
        }
        let warps = [
            p.region.is_some(),
            p.warp_grid.is_some(),
            p.warp_file.is_some(),
        ]
        .iter()
        .filter(|b| **b)
        .count();
        if warps > 1 {
            return Err(format!("{at}: give one of region, warp_grid and warp_file"));
        }
        if p.blend.is_some() && p.blend_mask.is_some() {
            return Err(format!(
                "{at}: give blend (computed soft edges) or blend_mask (a file), not both"
            ));
        }
        if let Some(r) = p.region {
            if r.iter().any(|x| !x.is_finite()) || r[0] == r[2] || r[1] == r[3] {
                return Err(format!("{at}.region: {r:?} must be [u0, v0, u1, v1], finite, with u0 != u1 and v0 != v1"));
            }
        }
        if let Some(g) = &p.warp_grid {
            Grid {
                columns: g.columns,
                rows: g.rows,
                points: g.points.clone(),
            }
            .check()
            .map_err(|e| format!("{at}.warp_grid: {e}"))?;
        }
        if let Some(b) = &p.blend {
            if !(b.exponent.is_finite() && (0.1..=16.0).contains(&b.exponent)) {
                return Err(format!(
                    "{at}.blend.exponent: {} must be 0.1 to 16",
                    b.exponent
                ));
            }
            if p.region.is_none() {
                return Err(format!("{at}.blend: computed soft edges need the projector's region (a warp grid or file needs a blend_mask file instead)"));
            }
        }
    }
    Ok(())
}

/// Every wall's outputs with their warps and masks read and checked: one list per wall, empty
/// for a wall without projectors. Errors name the file, wall, projector and key.
pub fn load_outputs(config: &DisplayConfig, config_path: &Path) -> Result<Vec<Vec<OutputSpec>>> {
    let dir = config_path.parent().unwrap_or(Path::new("."));
    let mut walls = Vec::new();
    for (w, wall) in config.walls.iter().enumerate() {
        let mut outputs = Vec::new();
        for (i, p) in wall.projectors.iter().enumerate() {
            let err = |message: String| VlfError::Config {
                path: config_path.to_path_buf(),
                message: format!(
                    "wall[{w}] ({:?}).projector[{i}] ({:?}).{message}",
                    wall.name, p.name
                ),
            };
            let grid = if let Some(r) = p.region {
                Grid::region(r)
            } else if let Some(g) = &p.warp_grid {
                Grid {
                    columns: g.columns,
                    rows: g.rows,
                    points: g.points.clone(),
                }
            } else if let Some(file) = &p.warp_file {
                let path = dir.join(file);
                read_warp_pfm(&path)
                    .map_err(|e| err(format!("warp_file: {}: {e}", path.display())))?
            } else {
                Grid::identity()
            };
            grid.check().map_err(|e| err(format!("warp: {e}")))?;
            let mask = if let Some(file) = &p.blend_mask {
                let path = dir.join(file);
                let (size, values) = read_mask(&path)
                    .map_err(|e| err(format!("blend_mask: {}: {e}", path.display())))?;
                if size != p.pixels {
                    return Err(err(format!(
                        "blend_mask: {} is {}x{} pixels but the projector's output is {}x{}: write the mask at the projector's resolution",
                        path.display(), size[0], size[1], p.pixels[0], p.pixels[1]
                    )));
                }
                Some(values)
            } else {
                p.blend
                    .as_ref()
                    .map(|b| soft_edge_mask(wall, i, b.exponent))
            };
            outputs.push(OutputSpec {
                name: p.name.clone(),
                pixels: p.pixels,
                grid,
                mask,
            });
        }
        walls.push(outputs);
    }
    Ok(walls)
}

/// The computed soft-edge mask of projector `index` of `wall`, shared with the wall's other
/// projectors that have computed soft edges (each with a region).
pub fn soft_edge_mask(wall: &Wall, index: usize, exponent: f32) -> Vec<f32> {
    let own_region = wall.projectors[index]
        .region
        .unwrap_or([0.0, 0.0, 1.0, 1.0]);
    let regions: Vec<[f32; 4]> = wall
        .projectors
        .iter()
        .filter(|p| p.blend.is_some())
        .filter_map(|p| p.region)
        .collect();
    // a projector's weight at wall point s: distance to its nearest edge inside the wall
    let weight = |r: [f32; 4], s: [f32; 2]| -> f64 {
        let (u0, u1, v0, v1) = (
            r[0].min(r[2]),
            r[0].max(r[2]),
            r[1].min(r[3]),
            r[1].max(r[3]),
        );
        if s[0] < u0 || s[0] > u1 || s[1] < v0 || s[1] > v1 {
            return 0.0;
        }
        let inner = |edge: f32| edge > 1e-4 && edge < 1.0 - 1e-4;
        let mut d = f32::INFINITY;
        for (edge, dist) in [
            (u0, s[0] - u0),
            (u1, u1 - s[0]),
            (v0, s[1] - v0),
            (v1, v1 - s[1]),
        ] {
            if inner(edge) {
                d = d.min(dist);
            }
        }
        if d.is_infinite() {
            1.0
        } else {
            (d.max(0.0) as f64).powf(exponent as f64)
        }
    };
    let [w, h] = wall.projectors[index].pixels;
    let grid = Grid::region(own_region);
    let mut mask = Vec::with_capacity((w * h) as usize);
    for y in 0..h {
        for x in 0..w {
            let s = grid.at([(x as f32 + 0.5) / w as f32, (y as f32 + 0.5) / h as f32]);
            let total: f64 = regions.iter().map(|r| weight(*r, s)).sum();
            let own = weight(own_region, s);
            mask.push(if total > 0.0 {
                (own / total) as f32
            } else {
                0.0
            });
        }
    }
    mask
}

/// A PFM image: (width, height, channels, values row-major from the top row).
pub fn read_pfm(path: &Path) -> std::result::Result<(u32, u32, usize, Vec<f32>), String> {
    let bytes = std::fs::read(path).map_err(|e| format!("cannot read: {e}"))?;
    // three whitespace-separated header tokens after the magic, then one whitespace byte
    let mut tokens = Vec::new();
    let mut pos = 0;
    while tokens.len() < 4 {
        while pos < bytes.len() && bytes[pos].is_ascii_whitespace() {
            pos += 1;
        }
        let start = pos;
        while pos < bytes.len() && !bytes[pos].is_ascii_whitespace() {
            pos += 1;
        }
        if start == pos || pos - start > 32 {
            return Err("not a PFM file (its header is PF or Pf, width height, scale)".into());
        }
        tokens.push(String::from_utf8_lossy(&bytes[start..pos]).to_string());
    }
    pos += 1;
    let channels = match tokens[0].as_str() {
        "PF" => 3,
        "Pf" => 1,
        other => {
            return Err(format!(
                "not a PFM file: it starts with {other:?}, not PF or Pf"
            ))
        }
    };
    let parse = |t: &str| t.parse::<u32>().ok().filter(|v| (1..=16384).contains(v));
    let (Some(w), Some(h)) = (parse(&tokens[1]), parse(&tokens[2])) else {
        return Err(format!(
            "the PFM size {} x {} must be 1..16384 each way",
            tokens[1], tokens[2]
        ));
    };
    let scale: f32 = tokens[3]
        .parse()
        .map_err(|_| format!("the PFM scale {:?} is not a number", tokens[3]))?;
    let n = w as usize * h as usize * channels;
    let data = bytes.get(pos..pos + n * 4).ok_or_else(|| {
        format!(
            "the PFM data is short: {w} x {h} x {channels} floats need {} bytes after the header",
            n * 4
        )
    })?;
    let mut values = vec![0f32; n];
    let row = w as usize * channels;
    for (i, c) in data.chunks_exact(4).enumerate() {
        let v = if scale < 0.0 {
            f32::from_le_bytes([c[0], c[1], c[2], c[3]])
        } else {
            f32::from_be_bytes([c[0], c[1], c[2], c[3]])
        };
        // PFM stores the bottom row first
        let (y, x) = (i / row, i % row);
        values[(h as usize - 1 - y) * row + x] = v;
    }
    Ok((w, h, channels, values))
}

/// Write a PFM image (values row-major from the top row; little-endian).
pub fn write_pfm(
    path: &Path,
    width: u32,
    height: u32,
    channels: usize,
    values: &[f32],
) -> Result<()> {
    let mut bytes = format!(
        "{}\n{width} {height}\n-1.0\n",
        if channels == 3 { "PF" } else { "Pf" }
    )
    .into_bytes();
    let row = width as usize * channels;
    for y in (0..height as usize).rev() {
        for v in &values[y * row..(y + 1) * row] {
            bytes.extend_from_slice(&v.to_le_bytes());
        }
    }
    std::fs::write(path, bytes).map_err(|e| VlfError::write(path, e))
}

/// An MPCDI-style warp file: a 3-channel PFM whose pixels are the grid's vertices (x, y, unused).
pub fn read_warp_pfm(path: &Path) -> std::result::Result<Grid, String> {
    let (w, h, channels, values) = read_pfm(path)?;
    if channels != 3 {
        return Err(
            "a warp grid is a 3-channel PFM (PF: x, y, unused per vertex), this one has 1 channel"
                .into(),
        );
    }
    Ok(Grid {
        columns: w,
        rows: h,
        points: values.chunks_exact(3).map(|p| [p[0], p[1]]).collect(),
    })
}

/// A greyscale blend mask: ([width, height], values row-major from the top-left, linear).
pub fn read_mask(path: &Path) -> std::result::Result<([u32; 2], Vec<f32>), String> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase())
        .unwrap_or_default();
    let (size, values) = if ext == "pfm" {
        let (w, h, channels, values) = read_pfm(path)?;
        if channels != 1 {
            return Err("a blend mask is a 1-channel PFM (Pf); this one has 3 channels".into());
        }
        ([w, h], values)
    } else {
        let img = image::open(path).map_err(|e| format!("cannot read the image: {e}"))?;
        if img.color().has_color() {
            return Err(format!(
                "a blend mask must be greyscale; this image is {:?}",
                img.color()
            ));
        }
        let grey = img.to_luma16();
        (
            [grey.width(), grey.height()],
            grey.pixels().map(|p| p[0] as f32 / 65535.0).collect(),
        )
    };
    if let Some(i) = values.iter().position(|v| !(v.is_finite() && *v >= 0.0)) {
        return Err(format!(
            "pixel ({}, {}) is {}: a mask is a finite attenuation of at least 0",
            i as u32 % size[0],
            i as u32 / size[0],
            values[i]
        ));
    }
    Ok((size, values))
}

/// Write a mask as a 16-bit greyscale PNG (values clamped to 0..1).
pub fn write_mask_png(path: &Path, [w, h]: [u32; 2], values: &[f32]) -> Result<()> {
    let data: Vec<u16> = values
        .iter()
        .map(|v| (v.clamp(0.0, 1.0) * 65535.0).round() as u16)
        .collect();
    let img = image::ImageBuffer::<image::Luma<u16>, Vec<u16>>::from_raw(w, h, data).ok_or_else(
        || VlfError::Image {
            path: path.to_path_buf(),
            message: format!("{} values for {w}x{h} pixels", values.len()),
        },
    )?;
    img.save(path).map_err(|e| VlfError::Image {
        path: path.to_path_buf(),
        message: e.to_string(),
    })
}
