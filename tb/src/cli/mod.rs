//! The `sms` subcommands, one module each: a clap `Args` struct and `run(args)`. The binary only
//! dispatches, so new subcommands are added here without touching the others.

pub mod check;
pub mod cost;
pub mod depth;
pub mod scenes;
pub mod stack_config;

use std::path::PathBuf;

use crate::scene::SceneLibrary;

/// Where scene descriptions and data are, shared by subcommands that load scenes.
#[derive(Clone, Debug, clap::Args)]
pub struct SceneArgs {
    /// Folder of the shared mesh files (default: ../shared/scenes beside the project).
    #[arg(long)]
    pub scenes_dir: Option<PathBuf>,
}

impl SceneArgs {
    pub fn library(&self) -> SceneLibrary {
        match &self.scenes_dir {
            Some(dir) => SceneLibrary::with_data_dir(dir),
            None => SceneLibrary::default(),
        }
    }
}
