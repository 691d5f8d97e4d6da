//! The mesh readers on files nobody on this project wrote: Debian's `assimp-testmodels`, which
//! `.ci/run` installs. Without the package these tests fail saying what to install (or skip under
//! `SMS_SKIP_MISSING=1`, counted); they never pass unread.

use std::path::PathBuf;

use tb::workload::scene::{Scene, SceneLibrary};

/// Where Debian's `assimp-testmodels` puts the models.
const MODELS: &str = "/usr/share/assimp/models";

/// `name` inside the models folder; a missing package fails the test saying what to install, or
/// skips it (`None`) under `SMS_SKIP_MISSING=1`.
fn model(name: &str) -> Option<PathBuf> {
    let path = PathBuf::from(MODELS).join(name);
    tb::prereq::files(&path, "Debian's assimp-testmodels (apt-get install assimp-testmodels)").then_some(path)
}

fn load(path: &std::path::Path) -> Result<Scene, String> {
    SceneLibrary::default().load(path.to_str().expect("UTF-8 path")).map_err(|e| e.to_string())
}

#[test]
fn embedded_and_external_buffer_gltf_load_the_same_box() {
    let (Some(embedded), Some(external)) = (
        model("glTF2/BoxTextured-glTF-Embedded/BoxTextured.gltf"),
        model("glTF2/BoxTextured-glTF/BoxTextured.gltf"),
    ) else {
        return;
    };
    let text = std::fs::read_to_string(&embedded).unwrap();
    assert!(text.contains("\"uri\": \"data:application/octet-stream;base64,"), "its buffer is a data: URI");
    let (a, b) = (load(&embedded).expect("embedded"), load(&external).expect("external"));
    // A box: 6 faces of 2 triangles.
    assert_eq!(a.primitives.triangle_count(), 12);
    assert_eq!(format!("{:?}", a.primitives), format!("{:?}", b.primitives));
}

#[test]
fn draco_gltf_is_one_line_naming_the_extension() {
    let Some(path) = model("glTF2/draco/2CylinderEngine.gltf") else { return };
    assert_eq!(
        load(&path).expect_err("draco"),
        format!(
            "{}: glTF: requires the extension KHR_draco_mesh_compression, which sms does not read",
            path.display()
        )
    );
}

#[test]
fn obj_with_a_latin1_material_name_loads() {
    let Some(path) = model("OBJ/regr01.obj") else { return };
    assert!(std::str::from_utf8(&std::fs::read(&path).unwrap()).is_err(), "the file is not UTF-8");
    let scene = load(&path).expect("regr01.obj");
    // 2710 triangular faces.
    assert_eq!(scene.primitives.triangle_count() + scene.dropped_degenerate, 2710);
}

#[test]
fn blender_ply_with_a_free_text_header_line_loads() {
    let Some(path) = model("PLY/Wuson.ply") else { return };
    let text = String::from_utf8_lossy(&std::fs::read(&path).unwrap()).into_owned();
    assert!(text.lines().nth(2).unwrap().starts_with("Created by Blender3D"), "the free-text line");
    let scene = load(&path).expect("Wuson.ply");
    // 3732 triangular faces.
    assert_eq!(scene.primitives.triangle_count() + scene.dropped_degenerate, 3732);
}
