//! `dualhair resolve`: writes a scene with everything derived made explicit, for other renderers
//! (`tools/cycles_reference.py`) and for the record: the hair as a .hair file in world units after
//! its transform, the framed camera's position and orientation, the fiber's sigma_a, and absolute
//! paths. The resolved scene renders the same image as the original.

use anyhow::{Context, Result};
use dualhair::output::write_atomically;
use dualhair::scene::{CameraSpec, HairSpec, SceneFile};
use precompute::fiber::Absorption;
use precompute::strands::write_hair;
use std::path::{Path, PathBuf};

/// Writes DIR/scene.json and DIR/hair.hair.
#[derive(clap::Args, Debug)]
pub struct ResolveArgs {
    /// Scene file (.json) or hair file (.hair).
    pub scene: PathBuf,
    /// Folder for scene.json and hair.hair (created if missing).
    #[arg(short, long, value_name = "DIR")]
    pub output: PathBuf,
}

pub fn run(args: &ResolveArgs) -> Result<()> {
    let file = SceneFile::load(&args.scene)?;
    // Everything `build` checks, without the BVH, which nothing here needs.
    let (strands, camera) = (|| {
        file.check_settings()?;
        let strands = file.hair()?;
        let camera = file.camera(&strands)?;
        file.lights()?;
        anyhow::Ok((strands, camera))
    })()
    .with_context(|| format!("{}", args.scene.display()))?;
    std::fs::create_dir_all(&args.output)
        .with_context(|| format!("{}: cannot create the folder", args.output.display()))?;
    let hair_path = args.output.join("hair.hair");
    write_atomically(&hair_path, |tmp| {
        let info = format!("dualhair resolve of {}", args.scene.display());
        Ok(write_hair(std::io::BufWriter::new(std::fs::File::create(tmp)?), &strands, &info)?)
    })?;
    let (position, look_at, up) = camera.orientation();
    let mut resolved = file.clone();
    resolved.hair = HairSpec {
        file: Some(PathBuf::from("hair.hair")),
        generate: None,
        scale: 1.0,
        rotate: [0.0; 3],
        translate: [0.0; 3],
        radius: None,
    };
    resolved.fiber.absorption = Absorption::SigmaA(file.fiber.sigma_a().0);
    resolved.camera = CameraSpec {
        position: Some(position.to_array()),
        look_at: Some(look_at.to_array()),
        up: up.to_array(),
        ..file.camera.clone()
    };
    if let Some(env) = &mut resolved.lights.environment {
        env.file = env.file.as_deref().map(absolute).transpose()?;
    }
    resolved.dual.density_grid = resolved.dual.density_grid.as_deref().map(absolute).transpose()?;
    let scene_path = args.output.join("scene.json");
    write_atomically(&scene_path, |tmp| Ok(std::fs::write(tmp, serde_json::to_string_pretty(&resolved)? + "\n")?))?;
    eprintln!("wrote {} and {}", scene_path.display(), hair_path.display());
    Ok(())
}

fn absolute(path: &Path) -> Result<PathBuf> {
    std::path::absolute(path).with_context(|| format!("{}: cannot make the path absolute", path.display()))
}
