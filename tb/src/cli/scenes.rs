//! `sms scenes`: every known scene with its triangle count, BVH node counts and build times; a
//! described scene whose mesh is not in the data folder is listed as missing, so an installed
//! binary without the data still shows every name.

use std::time::Instant;

use crate::cli::SceneArgs;
use crate::error::Error;
use crate::workload::bvh::{Bvh, BvhKind};

#[derive(Clone, Debug, clap::Args)]
#[command(after_long_help = crate::workload::scene::description_help())]
pub struct Args {
    /// Only these scenes (default: all built-in and described scenes).
    pub names: Vec<String>,
    #[command(flatten)]
    pub scenes: SceneArgs,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let library = args.scenes.library();
    let names = if args.names.is_empty() { library.names()? } else { args.names };
    println!(
        "{:<20} {:>10} {:>10} {:>9} {:>10} {:>9} {:>10} {:>9} {:>9}",
        "scene", "triangles", "bvh2", "ms", "bvh6", "ms", "cwbvh", "ms", "load ms"
    );
    let mut missing = 0;
    for name in names {
        crate::cli::note(format!("loading {name} ..."));
        let start = Instant::now();
        let scene = match library.load(&name) {
            Ok(scene) => scene,
            Err(Error::MissingData { file, .. }) => {
                println!("{name:<20} mesh missing: {}", file.display());
                missing += 1;
                continue;
            }
            Err(e) => return Err(e.into()),
        };
        let load_ms = start.elapsed().as_millis();
        let mut row = format!("{name:<20} {:>10}", scene.primitives.triangle_count());
        for kind in [BvhKind::Bvh2, BvhKind::Bvh6, BvhKind::Cwbvh] {
            let start = Instant::now();
            let bvh = Bvh::build(&scene.primitives, kind)?;
            row += &format!(" {:>10} {:>9}", bvh.node_count(), start.elapsed().as_millis());
        }
        println!("{row} {load_ms:>9}");
    }
    if missing > 0 {
        eprintln!(
            "{missing} scenes' meshes are missing ({}); point sms at the folder holding them with --scenes-dir DIR or the SMS_SCENES_DIR environment variable",
            library.describe_origin()
        );
    }
    Ok(())
}
