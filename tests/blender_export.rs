//! tools/blender_to_hair.py, the export path from Blender (when a Python with bpy is found, as for
//! tests/cycles.rs; skipped with a message otherwise): a hair curves object made in Blender, with
//! a transform, comes out as a .hair file whose strands are its curves in world space.

mod common;

use common::bpy_python;
use glam::Vec3;
use precompute::strands::read_hair;

/// Makes two curves (3 and 4 points) with radii, on an object scaled by 2 and moved by (1, 0, 0),
/// then runs the exporter (argv: the tool, the output) on it.
const MAKE_AND_EXPORT: &str = r#"
import runpy, sys
import bpy
curves = bpy.data.hair_curves.new("groom")
curves.add_curves([3, 4])
positions = [0, 0, 0,  0, 0, 1,  0, 0.5, 2,   1, 0, 0,  1, 0, 1,  1, 0, 2,  1, 0, 3]
curves.attributes["position"].data.foreach_set("vector", positions)
radius = curves.attributes.new("radius", "FLOAT", "POINT")
radius.data.foreach_set("value", [0.01, 0.01, 0.005,  0.02, 0.02, 0.02, 0.01])
obj = bpy.data.objects.new("groom", curves)
obj.scale = (2, 2, 2)
obj.location = (1, 0, 0)
bpy.context.scene.collection.objects.link(obj)
bpy.context.view_layer.objects.active = obj
bpy.context.view_layer.update()
tool, out = sys.argv[-2], sys.argv[-1]
sys.argv = ["blender_to_hair.py", out]
runpy.run_path(tool, run_name="__main__")
"#;

#[test]
fn a_blender_hair_object_exports_as_hair_in_world_space() {
    let Some(python) = bpy_python() else {
        println!("no Python with bpy (DUALHAIR_BPY_PYTHON or .venv-cycles): skipped");
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("groom.hair");
    let tool = format!("{}/tools/blender_to_hair.py", env!("CARGO_MANIFEST_DIR"));
    let run = std::process::Command::new(python).arg("-c").arg(MAKE_AND_EXPORT).arg(&tool).arg(&out).output().unwrap();
    assert!(run.status.success(), "{}{}", String::from_utf8_lossy(&run.stdout), String::from_utf8_lossy(&run.stderr));
    let s = read_hair(&out).unwrap();
    assert_eq!(s.offsets, [0, 3, 7]);
    let local = [
        [0.0, 0.0, 0.0],
        [0.0, 0.0, 1.0],
        [0.0, 0.5, 2.0],
        [1.0, 0.0, 0.0],
        [1.0, 0.0, 1.0],
        [1.0, 0.0, 2.0],
        [1.0, 0.0, 3.0],
    ];
    for (p, q) in s.points.iter().zip(local) {
        assert!((*p - (2.0 * Vec3::from_array(q.map(|x| x as f32)) + Vec3::X)).length() < 1e-6, "{p}");
    }
    for (r, q) in s.radii.iter().zip([0.01, 0.01, 0.005, 0.02, 0.02, 0.02, 0.01]) {
        assert!((r / (2.0 * q) - 1.0).abs() < 1e-5, "{r} vs {q}");
    }
}
