//! Scenes: geometry, a camera and render settings, loaded by name.
//!
//! A scene is given ([`SceneLibrary::resolve`]) by
//! - a built-in name (see [`procedural`]),
//! - the name of a shipped description: the project's `scenes/*.toml`, embedded in the binary
//!   at build time ([`SHIPPED`]), whose mesh files live in the shared read-only scene folder
//!   ([`SceneLibrary::locate`]: `--scenes-dir`, `SMS_SCENES_DIR`, or a `shared/scenes` folder
//!   found above the current folder or the executable) and are never copied into the project,
//! - a path to a mesh file (`.obj`, `.ply`, `.glb`, `.gltf`, each optionally `.gz`): one mesh,
//!   the camera framing its bounds, LumiBench's render settings,
//! - a path to a TOML description, whose mesh paths are relative to the description's folder.
//!
//! [`CameraOverride`] replaces any scene's camera (the `--camera-*` and `--vfov` flags).
//!
//! A description's format, every key annotated, is [`DESCRIPTION_EXAMPLE`]; `sms scenes --help`
//! and docs/scenes.md show it.

pub mod fetch;
mod glb;
pub mod manifest;
mod mesh;
mod obj;
mod ply;
pub mod procedural;
mod sink;

use std::ops::Range;
use std::path::{Path, PathBuf};

use glam::{Affine3A, Mat4, Vec3A};
use obvhs::triangle::Triangle;
use serde::{Deserialize, Serialize};

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
    /// The files read for a scene given by path (its description, then each mesh), with their
    /// SHA-256, which reports state; empty for built-in scenes and shipped descriptions, which
    /// their name identifies.
    pub files: Vec<SourceFile>,
}

/// A file a scene given by path was read from.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct SourceFile {
    /// As given (a description's meshes: joined to the description's folder).
    pub path: String,
    /// SHA-256 of the file's bytes as stored (before any gzip decompression), 64 hex digits.
    pub sha256: String,
}

impl SourceFile {
    /// `path` and the SHA-256 of its content.
    pub fn read(path: &Path) -> Result<Self> {
        use sha2::Digest;
        use std::io::Read;
        let mut file = std::fs::File::open(path).map_err(|e| Error::io(path, e))?;
        let mut hasher = sha2::Sha256::new();
        let mut buf = vec![0u8; 1 << 16];
        loop {
            let n = file.read(&mut buf).map_err(|e| Error::io(path, e))?;
            if n == 0 {
                break;
            }
            hasher.update(&buf[..n]);
        }
        let sha256 = crate::digest::hex(&hasher.finalize());
        Ok(SourceFile { path: path.display().to_string(), sha256 })
    }
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

/// A scene description with every key, annotated (shown by `sms scenes --help` and
/// docs/scenes.md; a test loads it). Unknown keys are errors.
pub const DESCRIPTION_EXAMPLE: &str = r#"# Every table but [[mesh]] is optional.
[[mesh]]                  # one table per mesh file, in any number
file = "ship.obj.gz"      # .obj, .ply, .glb or .gltf, optionally .gz; relative to this file
                          # (a shipped description's: to the shared scene folder)
transform = [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]   # optional, row-major: p_world = M * p
[camera]                  # without eye and look_at the camera frames the scene's bounds
eye = [378, 278, 500]
look_at = [178, 278, 0]
up = [0, 1, 0]            # default 0,1,0
vfov = 50                 # vertical field of view in degrees, default 45
[render]                  # defaults: LumiBench's 128x128 pixels, 2 spp, 15 bounces
width = 128
height = 128
spp = 2
max_bounces = 3           # diffuse bounces after the primary ray
"#;

/// `sms scenes --help`'s account of scene descriptions.
pub fn description_help() -> String {
    format!(
        "Scene descriptions: `--scene path/to/scene.toml` loads a TOML file like this one:\n\n{}\n\n\
         Each OBJ file (or each `o` object in it) and each PLY file is one BLAS; a glTF mesh is one BLAS \
         placed by each node that references it. --camera-eye, --camera-look-at, --camera-up and \
         --vfov override [camera]; --res, --spp and --bounces override [render].",
        DESCRIPTION_EXAMPLE.lines().map(|l| format!("    {l}")).collect::<Vec<_>>().join("\n")
    )
}

/// The scene descriptions shipped with sms (`scenes/*.toml`), embedded at build time (see
/// `tb/build.rs`): `(name, text)` sorted by name. Their mesh paths are relative to the shared
/// data folder ([`SceneLibrary::data`]).
pub const SHIPPED: &[(&str, &str)] = include!(concat!(env!("OUT_DIR"), "/shipped_scenes.rs"));

/// The mesh files the shipped description `name` reads (relative to the data folder); `None`
/// when no description has that name.
pub fn described_files(name: &str) -> Option<Vec<String>> {
    let (_, text) = SHIPPED.iter().find(|(n, _)| *n == name)?;
    let desc: SceneDesc = toml::from_str(text).ok()?;
    Some(desc.mesh.into_iter().map(|m| m.file).collect())
}

/// The environment variable naming the shared scene data folder.
pub const SCENES_DIR_ENV: &str = "SMS_SCENES_DIR";

/// How [`SceneLibrary::data`] was chosen: named in the error when a mesh is missing.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum DataOrigin {
    /// `--scenes-dir` (or [`SceneLibrary::with_data_dir`]).
    Flag,
    /// [`SCENES_DIR_ENV`].
    Env,
    /// A `shared/scenes` folder found in the current folder or one of its parents.
    BesideCurrentDir,
    /// A `shared/scenes` folder found in the executable's folder or one of its parents.
    BesideExecutable,
    /// None of those: described scenes cannot find their meshes.
    NotFound,
}

/// Camera settings that replace a scene's own (`--camera-eye`, `--camera-look-at`,
/// `--camera-up`, `--vfov`). A mesh or description without a camera is framed with the given
/// up vector and field of view; then a given eye or look-at point replaces the framed one.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct CameraOverride {
    pub eye: Option<[f32; 3]>,
    pub look_at: Option<[f32; 3]>,
    pub up: Option<[f32; 3]>,
    /// Vertical field of view in degrees.
    pub vfov: Option<f32>,
}

impl CameraOverride {
    /// Every given value is finite, the field of view is in (0, 180) degrees and `up` is not
    /// zero; errors name the flag.
    pub fn validate(&self) -> Result<()> {
        let vectors =
            [("--camera-eye", self.eye), ("--camera-look-at", self.look_at), ("--camera-up", self.up)];
        for (flag, v) in vectors {
            if let Some(v) = v {
                if !v.iter().all(|x| x.is_finite()) {
                    return Err(Error::Invalid(format!("{flag} {v:?} is not finite")));
                }
            }
        }
        if self.up.is_some_and(|u| u == [0.0; 3]) {
            return Err(Error::Invalid("--camera-up must not be zero".into()));
        }
        if let Some(f) = self.vfov {
            if !(f > 0.0 && f < 180.0) {
                return Err(Error::Invalid(format!("--vfov {f} is not between 0 and 180 degrees")));
            }
        }
        Ok(())
    }

    /// `camera` with the given values replaced, refusing an eye on the look-at point.
    fn apply(&self, camera: Camera) -> Result<Camera> {
        let c = Camera {
            eye: self.eye.map_or(camera.eye, Vec3A::from),
            look_at: self.look_at.map_or(camera.look_at, Vec3A::from),
            up: self.up.map_or(camera.up, Vec3A::from),
            vfov: self.vfov.unwrap_or(camera.vfov),
        };
        if c.eye == c.look_at {
            return Err(Error::Invalid(format!("the camera's eye and look-at point are both {}", c.eye)));
        }
        Ok(c)
    }
}

/// Parses `x,y,z` (a camera flag's value).
pub fn parse_vec3(s: &str) -> std::result::Result<[f32; 3], String> {
    let parts: Vec<&str> = s.split(',').map(str::trim).collect();
    let [x, y, z] = parts[..] else { return Err(format!("'{s}' is not x,y,z")) };
    let num = |t: &str| t.parse::<f32>().map_err(|_| format!("'{t}' in '{s}' is not a number"));
    Ok([num(x)?, num(y)?, num(z)?])
}

/// Where a `--scene` value leads ([`SceneLibrary::resolve`]).
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum SceneSource {
    /// A built-in scene ([`procedural`]).
    BuiltIn(String),
    /// A shipped description: its name and text.
    Described(String, &'static str),
    /// A description file given by path (its mesh paths are relative to it).
    Description(PathBuf),
    /// A mesh file given by path.
    Mesh(PathBuf),
}

/// Mesh file name endings accepted by path.
const MESH_EXTENSIONS: [&str; 4] = ["obj", "ply", "glb", "gltf"];

/// Whether `spec` names a mesh file by its ending (`.obj`, `.ply`, `.glb`, `.gltf`, each
/// optionally `.gz`).
fn is_mesh_name(spec: &str) -> bool {
    let lower = spec.to_ascii_lowercase();
    let base = lower.strip_suffix(".gz").unwrap_or(&lower);
    MESH_EXTENSIONS.iter().any(|e| base.ends_with(&format!(".{e}")))
}

/// Where scenes come from: the built-in ones, the shipped descriptions (embedded), the shared
/// folder their meshes are read from, and files given by path.
#[derive(Clone, Debug)]
pub struct SceneLibrary {
    /// Folder the shipped descriptions' mesh paths are relative to.
    pub data: PathBuf,
    /// How `data` was chosen.
    pub origin: DataOrigin,
    /// Camera settings replacing every loaded scene's own.
    pub camera: CameraOverride,
}

impl Default for SceneLibrary {
    /// The shared data folder found as [`SceneLibrary::locate`] describes.
    fn default() -> Self {
        let (data, origin) = SceneLibrary::locate();
        SceneLibrary { data, origin, camera: CameraOverride::default() }
    }
}

impl SceneLibrary {
    /// A library reading mesh files from `data` (what `--scenes-dir` gives).
    pub fn with_data_dir(data: impl Into<PathBuf>) -> Self {
        SceneLibrary { data: data.into(), origin: DataOrigin::Flag, camera: CameraOverride::default() }
    }

    /// The default shared data folder, in this order: `$SMS_SCENES_DIR` if set; else the
    /// nearest folder `shared/scenes` in the current folder or one of its parents (a clone
    /// beside the shared folder, `<work>/<clone>` and `<work>/shared/scenes`, finds it from
    /// anywhere inside the clone); else the same search from the executable's folder (a binary
    /// built in the clone, run from anywhere). Nothing is compiled in: an installed binary with
    /// none of these has no data folder, and a described scene's missing mesh says how to give
    /// one (`--scenes-dir` or `SMS_SCENES_DIR`).
    pub fn locate() -> (PathBuf, DataOrigin) {
        if let Some(dir) = std::env::var_os(SCENES_DIR_ENV).filter(|d| !d.is_empty()) {
            return (PathBuf::from(dir), DataOrigin::Env);
        }
        let find = |start: &Path| start.ancestors().map(|a| a.join("shared/scenes")).find(|d| d.is_dir());
        if let Some(dir) = std::env::current_dir().ok().as_deref().and_then(find) {
            return (dir, DataOrigin::BesideCurrentDir);
        }
        let exe = std::env::current_exe().ok().and_then(|e| e.canonicalize().ok());
        if let Some(dir) = exe.as_deref().and_then(Path::parent).and_then(find) {
            return (dir, DataOrigin::BesideExecutable);
        }
        (PathBuf::from("shared/scenes"), DataOrigin::NotFound)
    }

    /// Names of the shipped descriptions (sorted), without the built-in ones.
    pub fn described(&self) -> Result<Vec<String>> {
        Ok(SHIPPED.iter().map(|(n, _)| n.to_string()).collect())
    }

    /// Built-in names followed by the described ones.
    pub fn names(&self) -> Result<Vec<String>> {
        let mut names: Vec<String> = procedural::NAMES.iter().map(|n| n.to_string()).collect();
        names.extend(self.described()?);
        Ok(names)
    }

    /// What `spec` names: a built-in scene, a shipped description, or else a file by path: a
    /// `.toml` description or a mesh (`.obj`, `.ply`, `.glb`, `.gltf`, optionally `.gz`).
    /// Anything else, a folder, or a file that does not exist, is an error naming it.
    pub fn resolve(&self, spec: &str) -> Result<SceneSource> {
        if procedural::NAMES.contains(&spec) {
            return Ok(SceneSource::BuiltIn(spec.to_owned()));
        }
        if let Some((name, text)) = SHIPPED.iter().find(|(n, _)| *n == spec) {
            return Ok(SceneSource::Described(name.to_string(), text));
        }
        let path = PathBuf::from(spec);
        if path.is_dir() {
            return Err(Error::SceneIsDirectory { path });
        }
        let toml = spec.to_ascii_lowercase().ends_with(".toml");
        if !toml && !is_mesh_name(spec) {
            if path.is_file() {
                return Err(Error::format(
                    &path,
                    "file name",
                    "unknown scene file type (expected .toml, or a mesh: .obj, .ply, .glb or .gltf, optionally .gz)",
                ));
            }
            return Err(Error::UnknownScene { name: spec.to_owned(), known: self.names()? });
        }
        std::fs::metadata(&path).map_err(|e| Error::io(&path, e))?;
        Ok(if toml { SceneSource::Description(path) } else { SceneSource::Mesh(path) })
    }

    /// Loads a scene by built-in name, described name or path ([`SceneLibrary::resolve`]),
    /// with [`SceneLibrary::camera`] applied.
    pub fn load(&self, spec: &str) -> Result<Scene> {
        self.camera.validate()?;
        match self.resolve(spec)? {
            SceneSource::BuiltIn(name) => {
                let mut scene =
                    procedural::build(&name).ok_or(Error::UnknownScene { name, known: self.names()? })?;
                scene.camera = self.camera.apply(scene.camera)?;
                Ok(scene)
            }
            SceneSource::Described(name, text) => {
                let origin = format!("shipped description '{name}'");
                self.load_text(&name, Path::new(&format!("{name}.toml")), text, &self.data, Some(&origin))
            }
            SceneSource::Description(path) => self.load_description(&file_stem(&path), &path),
            SceneSource::Mesh(path) => self.load_mesh_file(&path),
        }
    }

    /// The name a loaded `spec` will have ([`Scene::name`]), without loading it.
    pub fn name_of(&self, spec: &str) -> Result<String> {
        Ok(match self.resolve(spec)? {
            SceneSource::BuiltIn(name) | SceneSource::Described(name, _) => name,
            SceneSource::Description(path) | SceneSource::Mesh(path) => file_stem(&path),
        })
    }

    /// Loads a scene from a description file; its mesh paths are relative to the file's folder.
    pub fn load_description(&self, name: &str, path: &Path) -> Result<Scene> {
        let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
        let dir = path.parent().unwrap_or(Path::new("")).to_path_buf();
        let mut scene = self.load_text(name, path, &text, &dir, None)?;
        let meshes: SceneDesc = toml::from_str(&text).expect("parsed by load_text");
        scene.files = std::iter::once(SourceFile::read(path))
            .chain(meshes.mesh.iter().map(|m| SourceFile::read(&dir.join(&m.file))))
            .collect::<Result<_>>()?;
        Ok(scene)
    }

    /// One mesh file, identity transform, camera framing its bounds, LumiBench render settings.
    fn load_mesh_file(&self, path: &Path) -> Result<Scene> {
        let mut triangles = Vec::new();
        let mut sink = sink::TriangleSink::new(&mut triangles);
        mesh::load_mesh(path, &Affine3A::IDENTITY, &mut sink)?;
        let (dropped_degenerate, objects) = (sink.dropped, std::mem::take(&mut sink.objects));
        let primitives = Primitives::Triangles(triangles);
        let camera = self.camera(path, CameraDesc::default(), &primitives)?;
        Ok(Scene {
            name: file_stem(path),
            primitives,
            objects,
            camera,
            render: RenderSettings::default(),
            dropped_degenerate,
            files: vec![SourceFile::read(path)?],
        })
    }

    /// The camera of a description (or of a bare mesh: `CameraDesc::default()`), with the
    /// override applied; framing uses the overridden up vector and field of view.
    fn camera(&self, path: &Path, c: CameraDesc, primitives: &Primitives) -> Result<Camera> {
        let up: Vec3A = self.camera.up.unwrap_or(c.up).into();
        let vfov = self.camera.vfov.unwrap_or(c.vfov);
        let camera = match (c.eye, c.look_at) {
            (Some(eye), Some(look_at)) => Camera { eye: eye.into(), look_at: look_at.into(), up, vfov },
            (None, None) => {
                let b = primitives.bounds();
                Camera::framing(b.min, b.max, up, vfov)
            }
            _ => {
                return Err(Error::format(
                    path,
                    "camera",
                    "give both eye and look_at, or neither to frame the scene",
                ))
            }
        };
        self.camera.apply(camera)
    }

    /// Loads the description `text` (read from `path`, named in errors) whose mesh paths are
    /// relative to `base`. `shipped` names a shipped description: its missing meshes are
    /// reported with how to point sms at the shared data.
    fn load_text(
        &self,
        name: &str,
        path: &Path,
        text: &str,
        base: &Path,
        shipped: Option<&str>,
    ) -> Result<Scene> {
        let desc: SceneDesc = toml::from_str(text).map_err(|e| {
            let line = e.span().map_or(1, |s| text[..s.start].matches('\n').count() + 1);
            Error::format(path, format!("line {line}"), e.message().to_owned())
        })?;
        if desc.mesh.is_empty() {
            return Err(Error::format(path, "mesh", "no [[mesh]] entries"));
        }
        let mut triangles = Vec::new();
        let mut sink = sink::TriangleSink::new(&mut triangles);
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
            let file = base.join(&m.file);
            if let Some(scene) = shipped {
                if !file.exists() {
                    return Err(self.missing_data(scene, &m.file));
                }
            }
            mesh::load_mesh(&file, &xf, &mut sink)?;
        }
        let dropped_degenerate = sink.dropped;
        let objects = std::mem::take(&mut sink.objects);
        let primitives = Primitives::Triangles(triangles);
        let camera = self.camera(path, desc.camera, &primitives)?;
        Ok(Scene {
            name: name.to_owned(),
            primitives,
            objects,
            camera,
            render: desc.render,
            dropped_degenerate,
            files: Vec::new(),
        })
    }

    /// The error for the mesh `file` of the shipped description `scene` missing from the data
    /// folder.
    fn missing_data(&self, scene: &str, file: &str) -> Error {
        // Without a data folder, the joined path would be made up: name the file.
        let file =
            if self.origin == DataOrigin::NotFound { PathBuf::from(file) } else { self.data.join(file) };
        Error::MissingData { file, scene: scene.to_owned(), origin: self.describe_origin() }
    }

    /// The first mesh a shipped description reads that is not in the data folder, as loading
    /// that description reports it; `None` when every one is there.
    pub fn first_missing_mesh(&self) -> Option<Error> {
        SHIPPED.iter().find_map(|(name, text)| {
            let desc: SceneDesc = toml::from_str(text).ok()?;
            let file = desc.mesh.into_iter().find(|m| !self.data.join(&m.file).exists())?.file;
            Some(self.missing_data(&format!("shipped description '{name}'"), &file))
        })
    }

    /// How the data folder was chosen, for [`Error::MissingData`] and `sms scenes`.
    pub(crate) fn describe_origin(&self) -> String {
        let dir = self.data.display();
        match self.origin {
            DataOrigin::Flag => format!("the scenes folder {dir} given by --scenes-dir"),
            DataOrigin::Env => format!("the scenes folder {dir} given by {SCENES_DIR_ENV}"),
            DataOrigin::BesideCurrentDir => format!("the scenes folder {dir}, found above the current folder"),
            DataOrigin::BesideExecutable => format!("the scenes folder {dir}, found above the executable"),
            DataOrigin::NotFound => format!(
                "no scenes folder: neither --scenes-dir nor {SCENES_DIR_ENV} is set, and no shared/scenes folder is in the current folder, the executable's or one of their parents"
            ),
        }
    }
}

/// A file's name without its extensions (`cube.obj.gz` → `cube`).
fn file_stem(path: &Path) -> String {
    let name = path.file_name().and_then(|n| n.to_str()).unwrap_or("scene");
    name.split('.').next().filter(|s| !s.is_empty()).unwrap_or(name).to_owned()
}

/// Loads a scene by name from the default library.
pub fn load_scene(name: &str) -> Result<Scene> {
    SceneLibrary::default().load(name)
}

#[cfg(test)]
mod tests;
