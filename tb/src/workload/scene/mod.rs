//! Scenes: geometry, a camera and render settings, loaded by name.
//!
//! A name is either built in (see [`procedural`]) or the stem of a TOML description in the
//! project's `scenes/` folder, whose mesh files live in the shared read-only scene folder
//! (`../shared/scenes` from the project root) and are never copied into the project.
//!
//! A description looks like this (every table but `[[mesh]]` is optional):
//! ```toml
//! [[mesh]]
//! file = "karimSchooner.obj.gz"          # relative to the data folder
//! transform = [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]   # row-major, p_world = M * p
//! [camera]                               # no eye/look_at: frame the bounding box
//! eye = [378, 278, 500]
//! look_at = [178, 278, 0]
//! up = [0, 1, 0]
//! vfov = 50                              # vertical, degrees
//! [render]
//! width = 128
//! height = 128
//! spp = 2
//! max_bounces = 3
//! ```

mod glb;
mod mesh;
mod obj;
mod ply;
pub mod procedural;

use std::ops::Range;
use std::path::{Path, PathBuf};

use glam::{Affine3A, Mat4, Vec3A};
use obvhs::triangle::Triangle;
use serde::Deserialize;

use crate::error::{Error, Result};
use crate::workload::geometry::Primitives;

/// A pinhole camera (`glm::lookAt` + vertical field of view, as LumiBench defines them).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    pub eye: Vec3A,
    pub look_at: Vec3A,
    pub up: Vec3A,
    /// Vertical field of view in degrees.
    pub vfov: f32,
}

impl Camera {
    pub fn look_at(eye: [f32; 3], look_at: [f32; 3], vfov: f32) -> Self {
        Camera { eye: eye.into(), look_at: look_at.into(), up: Vec3A::Y, vfov }
    }

    /// A camera that sees the whole box `[min, max]` from above one corner.
    pub fn framing(min: Vec3A, max: Vec3A, up: Vec3A, vfov: f32) -> Self {
        let up = up.normalize_or(Vec3A::Y);
        let center = (min + max) * 0.5;
        let radius = ((max - min) * 0.5).length().max(f32::MIN_POSITIVE);
        let side = up.any_orthonormal_vector();
        let front = up.cross(side);
        let dir = (0.45 * up + 0.8 * side + 0.6 * front).normalize();
        let distance = radius / (0.5 * vfov.to_radians()).sin() * 1.05;
        Camera { eye: center + dir * distance, look_at: center, up, vfov }
    }
}

/// How a scene is rendered unless the caller overrides it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RenderSettings {
    pub width: u32,
    pub height: u32,
    pub spp: u32,
    /// Diffuse bounces after the primary ray: a path traces at most `max_bounces + 1` rays.
    pub max_bounces: u32,
}

impl Default for RenderSettings {
    /// LumiBench's path tracing (SPEC section 8): 128 x 128 pixels, 2 samples per pixel
    /// (RayTracingInVulkan lumibench.sh: `--width 128 --height 128 --samples 2`), and the
    /// renderer's default of 16 bounces (src/Options.cpp:22, `--bounces` default 16). Its ray
    /// generation shader traces at bounce b = 0..15 and stops before tracing at b == 16
    /// (assets/shaders/RayTracing.rgen:47-58): at most 16 rays per path, the primary ray and 15
    /// more, which is `max_bounces = 15` here.
    fn default() -> Self {
        RenderSettings { width: 128, height: 128, spp: 2, max_bounces: LUMIBENCH_MAX_BOUNCES }
    }
}

/// Where a mesh's primitives are stored.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum MeshGeometry {
    /// `Scene::primitives[range]`: the object is stored in world space (an OBJ object or PLY
    /// file with the description's transform baked in, as LumiBench bakes it; a built-in scene).
    World(Range<u32>),
    /// `Objects::local[range]`: a glTF mesh in its own space, placed by its instances.
    Local(Range<u32>),
}

impl MeshGeometry {
    pub fn range(&self) -> Range<u32> {
        match self {
            MeshGeometry::World(r) | MeshGeometry::Local(r) => r.clone(),
        }
    }
}

/// One placement of a mesh: a TLAS leaf.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Instance {
    /// Index into [`Objects::meshes`].
    pub mesh: u32,
    /// Object to world; `None` is the identity (the ray is used as it is).
    pub to_world: Option<Affine3A>,
}

/// A scene's structure as the Vulkan pipeline builds it: meshes (one BLAS each) and their
/// instances (the TLAS leaves). Each OBJ object (see the OBJ reader) and PLY file is one
/// world-space mesh with one identity instance (LumiBench places every model with
/// `glm::mat4(1)`: RayTracingInVulkan `src/Vulkan/RayTracing/Application.cpp:341-352`); each glTF
/// mesh is one local mesh with one instance per node that references it, carrying the node's
/// world transform; a built-in scene is one mesh.
#[derive(Clone, Debug, Default)]
pub struct Objects {
    /// Object-space triangles of the local (glTF) meshes.
    pub local: Vec<Triangle>,
    pub meshes: Vec<MeshGeometry>,
    pub instances: Vec<Instance>,
}

impl Objects {
    /// One world-space mesh of `len` primitives with one identity instance.
    pub fn single(len: usize) -> Self {
        let mut o = Objects::default();
        o.add_world(0..len as u32);
        o
    }

    /// Adds a world-space mesh `Scene::primitives[range]` and one identity instance of it.
    pub fn add_world(&mut self, range: Range<u32>) {
        self.meshes.push(MeshGeometry::World(range));
        self.instances.push(Instance { mesh: self.meshes.len() as u32 - 1, to_world: None });
    }

    /// Primitives of all instances together (what the flattened list holds).
    pub fn instanced_primitives(&self) -> u64 {
        self.instances.iter().map(|i| self.meshes[i.mesh as usize].range().len() as u64).sum()
    }
}
/// LumiBench's 16 bounces as diffuse bounces after the primary ray (see
/// [`RenderSettings::default`]).
pub const LUMIBENCH_MAX_BOUNCES: u32 = 15;

/// Everything needed to trace a scene.
#[derive(Clone, Debug)]
pub struct Scene {
    pub name: String,
    /// Every primitive in world space (instances flattened): what the flat BVH is built over.
    pub primitives: Primitives,
    /// Meshes and instances: what a two-level acceleration structure is built over.
    pub objects: Objects,
    pub camera: Camera,
    pub render: RenderSettings,
    /// Zero-area triangles the loaders dropped.
    pub dropped_degenerate: usize,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct MeshDesc {
    file: String,
    transform: Option<[[f32; 4]; 4]>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct CameraDesc {
    eye: Option<[f32; 3]>,
    look_at: Option<[f32; 3]>,
    #[serde(default = "default_up")]
    up: [f32; 3],
    #[serde(default = "default_vfov")]
    vfov: f32,
}

fn default_up() -> [f32; 3] {
    [0.0, 1.0, 0.0]
}

fn default_vfov() -> f32 {
    45.0
}

impl Default for CameraDesc {
    fn default() -> Self {
        CameraDesc { eye: None, look_at: None, up: default_up(), vfov: default_vfov() }
    }
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SceneDesc {
    mesh: Vec<MeshDesc>,
    #[serde(default)]
    camera: CameraDesc,
    #[serde(default)]
    render: RenderSettings,
}

/// Where scene descriptions and mesh files are found.
#[derive(Clone, Debug)]
pub struct SceneLibrary {
    /// Folder of `<name>.toml` descriptions.
    pub descriptions: PathBuf,
    /// Folder the descriptions' mesh paths are relative to.
    pub data: PathBuf,
}

impl Default for SceneLibrary {
    /// The project's `scenes/` and the shared scene folder: `$SMS_SCENES_DIR` if set, else the
    /// first `shared/scenes` beside the project or beside one of its parent folders (a clone
    /// anywhere under the machine's work folder finds it), else `/work/shared/scenes`.
    fn default() -> Self {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
        SceneLibrary { descriptions: root.join("scenes"), data: shared_scenes_dir(&root) }
    }
}

/// See [`SceneLibrary::default`]. Falls back to `../shared/scenes` of the project (named in the
/// error when a mesh is missing) when no candidate exists.
fn shared_scenes_dir(root: &Path) -> PathBuf {
    if let Some(dir) = std::env::var_os("SMS_SCENES_DIR") {
        return PathBuf::from(dir);
    }
    let beside = root.join("../shared/scenes");
    let root = root.canonicalize().unwrap_or_else(|_| root.to_path_buf());
    root.ancestors()
        .map(|a| a.join("shared/scenes"))
        .chain(std::iter::once(PathBuf::from("/work/shared/scenes")))
        .find(|d| d.join("MANIFEST.md").is_file())
        .unwrap_or(beside)
}

impl SceneLibrary {
    /// A library reading mesh files from `data` instead of the default shared folder.
    pub fn with_data_dir(data: impl Into<PathBuf>) -> Self {
        SceneLibrary { data: data.into(), ..SceneLibrary::default() }
    }

    /// Names of the described scenes (sorted), without the built-in ones.
    pub fn described(&self) -> Result<Vec<String>> {
        let dir = std::fs::read_dir(&self.descriptions).map_err(|e| Error::io(&self.descriptions, e))?;
        let mut names = Vec::new();
        for entry in dir {
            let path = entry.map_err(|e| Error::io(&self.descriptions, e))?.path();
            if path.extension().is_some_and(|e| e == "toml") {
                if let Some(stem) = path.file_stem().and_then(|s| s.to_str()) {
                    names.push(stem.to_owned());
                }
            }
        }
        names.sort();
        Ok(names)
    }

    /// Built-in names followed by the described ones.
    pub fn names(&self) -> Result<Vec<String>> {
        let mut names: Vec<String> = procedural::NAMES.iter().map(|n| n.to_string()).collect();
        names.extend(self.described()?);
        Ok(names)
    }

    pub fn load(&self, name: &str) -> Result<Scene> {
        if let Some(scene) = procedural::build(name) {
            return Ok(scene);
        }
        let path = self.descriptions.join(format!("{name}.toml"));
        if !self.described()?.iter().any(|n| n == name) {
            return Err(Error::UnknownScene { name: name.to_owned(), known: self.names()? });
        }
        self.load_description(name, &path)
    }

    /// Loads a scene from a description file (its mesh paths are relative to `self.data`).
    pub fn load_description(&self, name: &str, path: &Path) -> Result<Scene> {
        let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
        let desc: SceneDesc = toml::from_str(&text).map_err(|e| {
            let line = e.span().map_or(1, |s| text[..s.start].matches('\n').count() + 1);
            Error::format(path, format!("line {line}"), e.message().to_owned())
        })?;
        if desc.mesh.is_empty() {
            return Err(Error::format(path, "mesh", "no [[mesh]] entries"));
        }
        let mut triangles = Vec::new();
        let mut sink = mesh::TriangleSink::new(&mut triangles);
        for m in &desc.mesh {
            let xf = match m.transform {
                Some(rows) => {
                    let affine = Affine3A::from_mat4(Mat4::from_cols_array_2d(&rows).transpose());
                    if rows[3] != [0.0, 0.0, 0.0, 1.0] || !affine.is_finite() {
                        return Err(Error::format(
                            path,
                            format!("mesh '{}'", m.file),
                            "transform must be finite and affine (last row 0 0 0 1)",
                        ));
                    }
                    affine
                }
                None => Affine3A::IDENTITY,
            };
            mesh::load_mesh(&self.data.join(&m.file), &xf, &mut sink)?;
        }
        let dropped_degenerate = sink.dropped;
        let objects = std::mem::take(&mut sink.objects);
        let primitives = Primitives::Triangles(triangles);
        let c = desc.camera;
        let camera = match (c.eye, c.look_at) {
            (Some(eye), Some(look_at)) => {
                Camera { eye: eye.into(), look_at: look_at.into(), up: c.up.into(), vfov: c.vfov }
            }
            (None, None) => {
                let b = primitives.bounds();
                Camera::framing(b.min, b.max, c.up.into(), c.vfov)
            }
            _ => {
                return Err(Error::format(
                    path,
                    "camera",
                    "give both eye and look_at, or neither to frame the scene",
                ))
            }
        };
        Ok(Scene {
            name: name.to_owned(),
            primitives,
            objects,
            camera,
            render: desc.render,
            dropped_degenerate,
        })
    }
}

/// Loads a scene by name from the default library.
pub fn load_scene(name: &str) -> Result<Scene> {
    SceneLibrary::default().load(name)
}

#[cfg(test)]
mod tests;
