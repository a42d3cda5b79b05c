//! The export paths from Blender (when a Python with bpy is found, as for tests/cycles.rs; skipped
//! with a message otherwise): a hair curves object made in Blender, with a transform, comes out
//! of tools/blender_to_hair.py as a .hair file whose strands are its curves in world space, and
//! out of Blender's own USD exporter as BasisCurves that read as the same strands.

use crate::common::bpy_python;
use glam::Vec3;
use precompute::strands::{read_hair, read_strands};

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

/// The same kind of groom (polyline curves, as .hair holds them, on a moved and scaled object),
/// written by tools/blender_to_hair.py and by Blender's USD exporter (.usda and .usdc).
const MAKE_AND_EXPORT_BOTH: &str = r#"
import runpy, sys
import bpy
curves = bpy.data.hair_curves.new("groom")
curves.add_curves([3, 4, 2])
positions = [0, 0, 0,  0, 0, 1,  0, 0.5, 2,   1, 0, 0,  1, 0, 1,  1, 0.25, 2,  1, 0, 3,  2, 0, 0,  2, 1, 1]
curves.attributes["position"].data.foreach_set("vector", positions)
radius = curves.attributes.new("radius", "FLOAT", "POINT")
radius.data.foreach_set("value", [0.01, 0.01, 0.005,  0.02, 0.02, 0.02, 0.01,  0.015, 0.0125])
curves.set_types(type="POLY")
obj = bpy.data.objects.new("groom", curves)
obj.scale = (2, 2, 2)
obj.location = (1, -3, 0.5)
bpy.context.scene.collection.objects.link(obj)
bpy.context.view_layer.objects.active = obj
bpy.context.view_layer.update()
tool, out = sys.argv[-2], sys.argv[-1]
for ext in ("usda", "usdc"):
    bpy.ops.wm.usd_export(filepath=f"{out}/groom.{ext}")
sys.argv = ["blender_to_hair.py", f"{out}/groom.hair"]
runpy.run_path(tool, run_name="__main__")
"#;

#[test]
fn blenders_usd_export_reads_as_its_hair_export_and_renders_the_same() {
    let Some(python) = bpy_python() else {
        println!("no Python with bpy (DUALHAIR_BPY_PYTHON or .venv-cycles): skipped");
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let tool = format!("{}/tools/blender_to_hair.py", env!("CARGO_MANIFEST_DIR"));
    let run =
        std::process::Command::new(python).arg("-c").arg(MAKE_AND_EXPORT_BOTH).arg(&tool).arg(d).output().unwrap();
    assert!(run.status.success(), "{}{}", String::from_utf8_lossy(&run.stdout), String::from_utf8_lossy(&run.stderr));
    let hair = read_hair(&d.join("groom.hair")).unwrap();
    assert_eq!(hair.offsets, [0, 3, 7, 9]);
    for ext in ["usda", "usdc"] {
        let usd = read_strands(&d.join(format!("groom.{ext}"))).unwrap();
        assert_eq!(usd, hair, "groom.{ext}");
    }
    let render = |file: &str| {
        let out = d.join(format!("{file}.exr"));
        let args = ["render", "--width", "24", "--height", "24", "--spp", "4", "-q", "-o"];
        let run =
            crate::common::dualhair(&[&args[..], &[out.to_str().unwrap(), d.join(file).to_str().unwrap()]].concat());
        assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
        std::fs::read(out).unwrap()
    };
    let image = render("groom.hair");
    assert!(render("groom.usdc") == image, "the USD export renders differently from the .hair export");
}
