//! The scene contract (ARCHITECTURE.md, "Scene files: the contract"): `scene.toml` (this module)
//! plus an OBJ/MTL mesh (`obj.rs`) or a glTF 2.0 model (`gltf.rs`); a `.gltf`/`.glb` also loads
//! directly, with an optional scene.toml beside it. Loading validates everything and yields a
//! [`Scene`] in world units (metres); textures are resolved to texel density (`texels.rs`).

pub mod builder;
pub mod gltf;
pub mod normalise;
pub mod obj;
mod obj_lines;
pub mod texels;
mod weld;

use crate::error::{Result, VlfError};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// `scene.toml` as written by users and other tools.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct SceneFile {
    pub name: String,
    pub mesh: PathBuf,
    #[serde(default)]
    pub sky: Option<SkyFile>,
    #[serde(default)]
    pub camera: Vec<Camera>,
    #[serde(default)]
    pub materials: BTreeMap<String, MaterialOverride>,
}

#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct SkyFile {
    pub radiance: [f32; 3],
}

#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Camera {
    pub name: String,
    pub eye: [f32; 3],
    pub target: [f32; 3],
    pub up: [f32; 3],
    pub fov_y_deg: f32,
    pub size: [u32; 2],
}

#[derive(Clone, Debug, Default, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct MaterialOverride {
    pub mirror: Option<[f32; 3]>,
    /// the specular part's GGX roughness alpha: 0 an ideal mirror, up to 1
    pub roughness: Option<f32>,
    pub diffuse: Option<[f32; 3]>,
    pub emission: Option<[f32; 3]>,
    pub two_sided: Option<bool>,
}

pub use crate::material::Material;

/// A texture in linear RGB (decoded from sRGB), row-major from the top-left texel.
#[derive(Clone, Debug, PartialEq)]
pub struct Texture {
    pub path: PathBuf,
    pub width: u32,
    pub height: u32,
    pub texels: Vec<[f32; 3]>,
    /// coverage per texel (same order), only for a texture some material cuts holes with
    /// (`Material::cutout`); empty otherwise (opaque)
    pub alpha: Vec<f32>,
}

impl Texture {
    /// Bilinear lookup with wrapping; v = 0 is the image's bottom row (OBJ convention).
    pub fn sample(&self, uv: [f32; 2]) -> [f32; 3] {
        self.bilinear(uv, |i| self.texels[i])
    }

    /// The coverage at `uv`, bilinear as `sample` (1 for a texture without coverage): the CPU
    /// twin of `texture_alpha` in shaders/common/textures.wgsl.
    pub fn coverage(&self, uv: [f32; 2]) -> f32 {
        if self.alpha.len() != self.texels.len() {
            return 1.0;
        }
        self.bilinear(uv, |i| [self.alpha[i]; 3])[0]
    }

    fn bilinear(&self, uv: [f32; 2], texel: impl Fn(usize) -> [f32; 3]) -> [f32; 3] {
        let (w, h) = (self.width as f32, self.height as f32);
        let x = uv[0].rem_euclid(1.0) * w - 0.5;
        let y = (1.0 - uv[1].rem_euclid(1.0)) * h - 0.5;
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let at = |xi: f32, yi: f32| {
            let xi = (xi as i64).rem_euclid(self.width as i64) as usize;
            let yi = (yi as i64).rem_euclid(self.height as i64) as usize;
            texel(yi * self.width as usize + xi)
        };
        let (a, b, c, d) = (
            at(x0, y0),
            at(x0 + 1.0, y0),
            at(x0, y0 + 1.0),
            at(x0 + 1.0, y0 + 1.0),
        );
        std::array::from_fn(|k| {
            (a[k] * (1.0 - fx) + b[k] * fx) * (1.0 - fy) + (c[k] * (1.0 - fx) + d[k] * fx) * fy
        })
    }
}

/// One triangle of the imported mesh, counter-clockwise seen from its front.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Triangle {
    pub vertices: [u32; 3],
    pub material: u32,
    /// texture coordinates of the corners, where the OBJ has them
    pub uv: Option<[[f32; 2]; 3]>,
}

/// A loaded, validated scene in world units.
#[derive(Clone, Debug)]
pub struct Scene {
    pub name: String,
    pub source: PathBuf,
    pub positions: Vec<[f32; 3]>,
    pub triangles: Vec<Triangle>,
    pub materials: Vec<Material>,
    pub textures: Vec<Texture>,
    pub sky: Option<[f32; 3]>,
    pub cameras: Vec<Camera>,
    /// Things the importer could not represent or had to repair, for the user and the report.
    pub warnings: Vec<String>,
    /// SHA-256 over scene.toml, the mesh and its material library (or buffers and images).
    pub hash: String,
    /// the textures' host memory, kept and at full resolution
    pub texture_memory: texels::TextureMemory,
}

/// True for a path naming a glTF model (`.gltf` or `.glb`).
pub fn is_gltf(path: &Path) -> bool {
    path.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("gltf") || e.eq_ignore_ascii_case("glb"))
}

impl SceneFile {
    /// Parse and validate `scene.toml` text; `path` names the file in errors.
    pub fn parse(text: &str, path: &Path) -> Result<SceneFile> {
        let file: SceneFile = toml::from_str(text).map_err(|e| VlfError::SceneToml {
            path: path.to_path_buf(),
            message: toml_message(&e),
        })?;
        file.validate(path)?;
        Ok(file)
    }
}

impl Scene {
    /// Load `scene.toml`, or a `.gltf`/`.glb` model directly ([`Scene::load_model`]).
    pub fn load(path: &Path) -> Result<Scene> {
        if is_gltf(path) {
            return Scene::load_model(path);
        }
        let text = std::fs::read_to_string(path).map_err(|e| VlfError::io(path, e))?;
        let file = SceneFile::parse(&text, path)?;
        Scene::from_file(path, &text, file)
    }

    /// A glTF model on its own: a scene.toml beside it whose `mesh` names it supplies the sky,
    /// cameras and overrides; without one the model's name, no sky, and the model's cameras
    /// (or one that frames the model).
    pub fn load_model(model: &Path) -> Result<Scene> {
        let dir = model.parent().unwrap_or(Path::new("."));
        let beside = dir.join("scene.toml");
        let mut note = None;
        if beside.is_file() {
            let text = std::fs::read_to_string(&beside).map_err(|e| VlfError::io(&beside, e))?;
            let file = SceneFile::parse(&text, &beside)?;
            if dir.join(&file.mesh).file_name() == model.file_name() {
                return Scene::from_file(&beside, &text, file);
            }
            note = Some(format!(
                "{}: not used for {} (its mesh is {})",
                beside.display(),
                model.display(),
                file.mesh.display()
            ));
        }
        let name = model
            .file_stem()
            .map_or("model".into(), |s| s.to_string_lossy().into_owned());
        let file = SceneFile {
            name,
            mesh: PathBuf::from(model.file_name().unwrap_or_default()),
            sky: None,
            camera: Vec::new(),
            materials: BTreeMap::new(),
        };
        let mut scene = Scene::from_file(&model.with_file_name("(none)"), "", file)?;
        scene.source = model.to_path_buf();
        scene.warnings.extend(note);
        Ok(scene)
    }

    fn from_file(path: &Path, text: &str, file: SceneFile) -> Result<Scene> {
        let dir = path.parent().unwrap_or(Path::new("."));
        let mesh_path = dir.join(&file.mesh);
        let gltf = is_gltf(&mesh_path);
        // the hash of the scene file and the mesh is taken while the mesh is parsed (a 5M-triangle
        // OBJ's hash took a fifth of a second after it)
        let (mesh, hash) = std::thread::scope(|scope| {
            let hashing = scope.spawn(|| source_hash(text, &mesh_path));
            let mesh = match gltf {
                true => gltf::import(&mesh_path, &file.materials),
                false => obj::import(&mesh_path, &file.materials),
            };
            let hashed = hashing.join().expect("hashing the scene panicked");
            mesh.and_then(|mesh| {
                let hash =
                    hashed.and_then(|h| finish_hash(h, text, &mesh_path, &mesh.source_files))?;
                Ok((mesh, hash))
            })
        })?;
        for name in file.materials.keys() {
            if !mesh.materials.iter().any(|m| &m.name == name) {
                return Err(VlfError::SceneToml {
                    path: path.to_path_buf(),
                    message: format!(
                        "[materials.{name}] overrides a material that {} does not use; it has: {}",
                        mesh_path.display(),
                        mesh.materials
                            .iter()
                            .map(|m| m.name.as_str())
                            .collect::<Vec<_>>()
                            .join(", ")
                    ),
                });
            }
        }
        let mut cameras = file.camera;
        for c in mesh.cameras {
            if !cameras.iter().any(|k| k.name == c.name) {
                cameras.push(c);
            }
        }
        if cameras.is_empty() && gltf {
            cameras.push(framing_camera(&mesh.positions));
        }
        Ok(Scene {
            name: file.name,
            source: path.to_path_buf(),
            positions: mesh.positions,
            triangles: mesh.triangles,
            materials: mesh.materials,
            textures: mesh.textures,
            sky: file
                .sky
                .map(|s| s.radiance)
                .filter(|r| r.iter().any(|&c| c > 0.0)),
            cameras,
            warnings: mesh.warnings,
            hash,
            texture_memory: mesh.texture_memory,
        })
    }

    pub fn camera(&self, name: Option<&str>) -> Result<&Camera> {
        match name {
            None => self.cameras.first().ok_or_else(|| VlfError::UnknownCamera {
                name: "(default)".into(),
                available: "no [[camera]] entries; add one to scene.toml".into(),
            }),
            Some(n) => {
                self.cameras
                    .iter()
                    .find(|c| c.name == n)
                    .ok_or_else(|| VlfError::UnknownCamera {
                        name: n.into(),
                        available: self
                            .cameras
                            .iter()
                            .map(|c| c.name.as_str())
                            .collect::<Vec<_>>()
                            .join(", "),
                    })
            }
        }
    }
}

/// SHA-256 of the scene file's text and the mesh file: the start of the scene's hash.
fn source_hash(text: &str, mesh_path: &Path) -> Result<sha2::Sha256> {
    use sha2::Digest;
    let mut hasher = sha2::Sha256::new();
    hasher.update(text.as_bytes());
    hasher.update(std::fs::read(mesh_path).map_err(|e| VlfError::io(mesh_path, e))?);
    Ok(hasher)
}

/// The scene's hash: SHA-256 of the scene file's text and every file the importer read, in
/// the order it read them; `started` has taken the text and the mesh file, which importers list
/// first (where one did not, the hash starts again).
fn finish_hash(
    started: sha2::Sha256,
    text: &str,
    mesh_path: &Path,
    source_files: &[PathBuf],
) -> Result<String> {
    use sha2::Digest;
    let (mut hasher, rest) = match source_files.split_first() {
        Some((first, rest)) if first == mesh_path => (started, rest),
        _ => (sha2::Sha256::new_with_prefix(text.as_bytes()), source_files),
    };
    for f in rest {
        hasher.update(std::fs::read(f).map_err(|e| VlfError::io(f, e))?);
    }
    Ok(format!("{:x}", hasher.finalize()))
}

/// A camera that frames the whole model: from the front (+z), a little above and to the side,
/// 60 degrees vertically, the bounding sphere filling the view.
pub fn framing_camera(positions: &[[f32; 3]]) -> Camera {
    let n = normalise::normalise(positions);
    let centre = glam::DVec3::from(n.center);
    let radius = normalise::NORMALISED_RADIUS / n.scale;
    let direction = glam::DVec3::new(0.35, 0.3, 1.0).normalize();
    let eye = centre + direction * radius / (30f64.to_radians().sin()) * 1.05;
    Camera {
        name: "view".into(),
        eye: eye.as_vec3().to_array(),
        target: centre.as_vec3().to_array(),
        up: [0.0, 1.0, 0.0],
        fov_y_deg: 60.0,
        size: [1024, 768],
    }
}

/// toml's message already names line and column; keep it on one readable block.
fn toml_message(e: &toml::de::Error) -> String {
    e.to_string().trim_end().to_string()
}

impl SceneFile {
    fn validate(&self, path: &Path) -> Result<()> {
        let err = |message: String| VlfError::SceneToml {
            path: path.to_path_buf(),
            message,
        };
        if let Some(sky) = &self.sky {
            check_color(&sky.radiance, false).map_err(|m| err(format!("sky.radiance: {m}")))?;
        }
        let mut names = std::collections::HashSet::new();
        for (i, c) in self.camera.iter().enumerate() {
            let at = format!("camera[{i}] ({:?})", c.name);
            if !names.insert(c.name.clone()) {
                return Err(err(format!("{at}: duplicate camera name")));
            }
            for (field, v) in [("eye", c.eye), ("target", c.target), ("up", c.up)] {
                if v.iter().any(|x| !x.is_finite()) {
                    return Err(err(format!("{at}.{field}: must be finite numbers")));
                }
            }
            if c.eye == c.target {
                return Err(err(format!("{at}: eye and target are the same point")));
            }
            let forward = glam::Vec3::from(c.target) - glam::Vec3::from(c.eye);
            if forward.cross(glam::Vec3::from(c.up)).length_squared() < 1e-12 {
                return Err(err(format!("{at}.up: parallel to the viewing direction")));
            }
            if !(c.fov_y_deg > 0.0 && c.fov_y_deg < 180.0) {
                return Err(err(format!(
                    "{at}.fov_y_deg: {} is not between 0 and 180",
                    c.fov_y_deg
                )));
            }
            if c.size[0] == 0 || c.size[1] == 0 || c.size[0] > 16384 || c.size[1] > 16384 {
                return Err(err(format!(
                    "{at}.size: {:?} must be 1..16384 pixels each way",
                    c.size
                )));
            }
        }
        for (name, m) in &self.materials {
            let at = format!("materials.{name}");
            if let Some(c) = m.diffuse {
                check_color(&c, true).map_err(|e| err(format!("{at}.diffuse: {e}")))?;
            }
            if let Some(c) = m.mirror {
                check_color(&c, true).map_err(|e| err(format!("{at}.mirror: {e}")))?;
            }
            if let Some(c) = m.emission {
                check_color(&c, false).map_err(|e| err(format!("{at}.emission: {e}")))?;
            }
            if let Some(r) = m.roughness {
                if !(0.0..=1.0).contains(&r) {
                    return Err(err(format!(
                        "{at}.roughness: {r} must be a GGX alpha in [0, 1] (0: an ideal mirror)"
                    )));
                }
            }
        }
        Ok(())
    }
}

/// Reflectances lie in [0, 1]; radiances are finite and >= 0.
pub fn check_color(c: &[f32; 3], reflectance: bool) -> std::result::Result<(), String> {
    if c.iter().any(|x| !x.is_finite()) {
        return Err(format!("{c:?} is not finite"));
    }
    if c.iter().any(|&x| x < 0.0) {
        return Err(format!("{c:?} has a negative component"));
    }
    if reflectance && c.iter().any(|&x| x > 1.0) {
        return Err(format!(
            "{c:?} exceeds 1: a surface cannot reflect more light than it receives"
        ));
    }
    Ok(())
}
