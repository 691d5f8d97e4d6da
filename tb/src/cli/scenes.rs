//! `sms scenes`: every known scene and whether its data is there, from the scene descriptions
//! and the data manifest alone (no mesh is read, so it answers at once); `--build` loads each
//! scene and builds its BVHs for their node counts and build times; `--fetch DIR --from URL`
//! lays out the data folder from a copy of it, checking every file against the manifest
//! ([`crate::workload::scene::fetch`]).

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::bail;
use serde::Serialize;

use crate::cli::{note, Format, OutputArgs, SceneArgs};
use crate::error::Error;
use crate::report::table::Table;
use crate::workload::bvh::{Bvh, BvhKind};
use crate::workload::scene::fetch::{self, Fetched, Source};
use crate::workload::scene::manifest::Manifest;
use crate::workload::scene::{described_files, procedural, SceneLibrary, SceneSource};

#[derive(Clone, Debug, clap::Args)]
#[command(after_long_help = crate::workload::scene::description_help())]
pub struct Args {
    /// Only these scenes: names, or paths to meshes or descriptions (default: all built-in and
    /// described scenes).
    pub names: Vec<String>,
    /// Load each scene and build its BVHs: triangles as loaded (zero-area ones dropped), BVH
    /// node counts and build times. Slow for large scenes (every shipped scene: about a minute
    /// and 2 GB).
    #[arg(long, conflicts_with = "fetch")]
    pub build: bool,
    /// Lay out the scene data folder DIR: download every file the manifest lists from --from,
    /// check its size and SHA-256, skip files already there and intact (run it again to resume).
    /// Then point sms at DIR with --scenes-dir DIR or SMS_SCENES_DIR.
    #[arg(long, value_name = "DIR", requires = "from", conflicts_with = "names")]
    pub fetch: Option<PathBuf>,
    /// Where --fetch downloads from: the address of a copy of the scene data folder
    /// (http://, https:// or file://; `<URL>/<file>` for each file) or a folder path.
    #[arg(long, value_name = "URL", requires = "fetch")]
    pub from: Option<String>,
    /// The manifest --fetch follows, instead of the one built into sms (scenes/MANIFEST.md).
    #[arg(long, value_name = "FILE", requires = "fetch")]
    pub manifest: Option<PathBuf>,
    #[command(flatten)]
    pub output: OutputArgs,
    #[command(flatten)]
    pub scenes: SceneArgs,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    if let Some(dir) = &args.fetch {
        return fetch_data(&args, dir);
    }
    let library = args.scenes.library()?;
    let names = if args.names.is_empty() { library.names()? } else { args.names.clone() };
    // Every name resolved before any is loaded: a typo costs nothing.
    for name in &names {
        library.resolve(name)?;
    }
    if args.build {
        return build(&args.output, &library, &names);
    }
    list(&args.output, &library, &names)
}

/// One data file of a listed scene.
#[derive(Serialize)]
struct DataFile {
    file: String,
    /// Size the manifest lists (a file given by path: its size).
    bytes: Option<u64>,
    /// `present`, `missing`, `wrong size`, or `not in the manifest`.
    state: &'static str,
}

/// One row of the listing.
#[derive(Serialize)]
struct Listed {
    name: String,
    /// `built-in`, `described` or `file`.
    kind: &'static str,
    /// Triangles after flattening instances: the manifest's count for described scenes, the
    /// loaded count for built-in scenes and files given by path (wknd's spheres: 0).
    triangles: Option<u64>,
    files: Vec<DataFile>,
}

impl Listed {
    fn ready(&self) -> bool {
        self.files.iter().all(|f| f.state == "present")
    }
}

/// A described scene's file `name` in the data folder, against the manifest.
fn data_file(library: &SceneLibrary, manifest: &Manifest, name: &str) -> DataFile {
    let entry = manifest.file(name);
    let size = std::fs::metadata(library.data.join(name)).ok().filter(|m| m.is_file()).map(|m| m.len());
    let state = match (entry, size) {
        (_, None) => "missing",
        (None, Some(_)) => "not in the manifest",
        (Some(e), Some(n)) if e.bytes != n => "wrong size",
        (Some(_), Some(_)) => "present",
    };
    DataFile { file: name.to_owned(), bytes: entry.map(|e| e.bytes), state }
}

fn list(output: &OutputArgs, library: &SceneLibrary, names: &[String]) -> anyhow::Result<()> {
    let manifest = Manifest::shipped();
    let mut rows = Vec::new();
    for name in names {
        rows.push(match library.resolve(name)? {
            SceneSource::BuiltIn(name) => {
                let scene = procedural::build(&name).expect("a built-in name builds");
                let triangles = Some(scene.primitives.triangle_count() as u64);
                Listed { name, kind: "built-in", triangles, files: vec![] }
            }
            SceneSource::Described(name, _) => {
                let files: Vec<DataFile> = described_files(&name)
                    .unwrap_or_default()
                    .iter()
                    .map(|f| data_file(library, &manifest, f))
                    .collect();
                let triangles = files.iter().map(|f| manifest.file(&f.file).and_then(|e| e.triangles)).sum();
                Listed { name, kind: "described", triangles, files }
            }
            SceneSource::Description(_) | SceneSource::Mesh(_) => {
                let scene = library.load(name)?;
                let files = scene
                    .files
                    .iter()
                    .map(|f| DataFile {
                        file: f.path.clone(),
                        bytes: std::fs::metadata(&f.path).ok().map(|m| m.len()),
                        state: "present",
                    })
                    .collect();
                let triangles = Some(scene.primitives.triangle_count() as u64);
                Listed { name: scene.name, kind: "file", triangles, files }
            }
        });
    }
    let missing = rows.iter().filter(|r| !r.ready()).count();
    match output.format() {
        Format::Json => {
            let json = serde_json::json!({
                "data_dir": library.data.display().to_string(),
                "data_from": library.describe_origin(),
                "scenes": rows,
            });
            println!("{}", serde_json::to_string_pretty(&json)?);
        }
        _ => {
            let mut t = Table::new(["scene", "kind", "triangles", "bytes", "data", "files"]);
            for r in &rows {
                let bytes: Option<u64> =
                    r.files.iter().map(|f| f.bytes).sum::<Option<u64>>().filter(|_| !r.files.is_empty());
                let state = if r.files.is_empty() {
                    "built in".to_string()
                } else if r.ready() {
                    "present".to_string()
                } else {
                    let bad: Vec<String> = r
                        .files
                        .iter()
                        .filter(|f| f.state != "present")
                        .map(|f| format!("{}: {}", f.file, f.state))
                        .collect();
                    bad.join(", ")
                };
                let files: Vec<&str> = r.files.iter().map(|f| f.file.as_str()).collect();
                t.row([
                    r.name.clone(),
                    r.kind.to_string(),
                    r.triangles.map_or(String::new(), |n| n.to_string()),
                    bytes.map_or(String::new(), |n| n.to_string()),
                    state,
                    files.join(" "),
                ]);
            }
            print!("{}", output.table(&t).expect("a text format"));
        }
    }
    note(format!("scene data: {}", library.describe_origin()));
    if missing > 0 {
        note(format!(
            "{missing} scene(s) lack data; `sms scenes --fetch DIR --from URL` lays out a data folder from a copy \
             of it, then --scenes-dir DIR or SMS_SCENES_DIR=DIR points sms at it"
        ));
    }
    Ok(())
}

/// The listing with every scene loaded and its BVHs built (`--build`).
fn build(output: &OutputArgs, library: &SceneLibrary, names: &[String]) -> anyhow::Result<()> {
    let mut t = Table::new(["scene", "triangles", "bvh2", "ms", "bvh6", "ms", "cwbvh", "ms", "load ms"]);
    let mut json = Vec::new();
    let mut missing = 0;
    for name in names {
        note(format!("loading {name} ..."));
        let start = Instant::now();
        let scene = match library.load(name) {
            Ok(scene) => scene,
            Err(Error::MissingData { file, .. }) => {
                let why = format!("mesh missing: {}", file.display());
                t.row([
                    name.clone(),
                    why.clone(),
                    "-".into(),
                    "-".into(),
                    "-".into(),
                    "-".into(),
                    "-".into(),
                    "-".into(),
                    "-".into(),
                ]);
                json.push(serde_json::json!({ "name": name, "missing": file.display().to_string() }));
                missing += 1;
                continue;
            }
            Err(e) => return Err(e.into()),
        };
        let load_ms = start.elapsed().as_millis();
        let triangles = scene.primitives.triangle_count();
        let mut row = vec![name.clone(), triangles.to_string()];
        let mut bvhs = serde_json::Map::new();
        for kind in [BvhKind::Bvh2, BvhKind::Bvh6, BvhKind::Cwbvh] {
            let start = Instant::now();
            let bvh = Bvh::build(&scene.primitives, kind)?;
            let ms = start.elapsed().as_millis();
            row.extend([bvh.node_count().to_string(), ms.to_string()]);
            let kind = serde_json::to_value(kind)?.as_str().unwrap_or_default().to_owned();
            bvhs.insert(kind, serde_json::json!({ "nodes": bvh.node_count(), "build_ms": ms }));
        }
        row.push(load_ms.to_string());
        t.row(row);
        json.push(
            serde_json::json!({ "name": name, "triangles": triangles, "bvh": bvhs, "load_ms": load_ms }),
        );
    }
    match output.table(&t) {
        Some(text) => print!("{text}"),
        None => println!("{}", serde_json::to_string_pretty(&serde_json::json!({ "scenes": json }))?),
    }
    if missing > 0 {
        note(format!(
            "{missing} scenes' meshes are missing ({}); point sms at the folder holding them with --scenes-dir DIR or the SMS_SCENES_DIR environment variable",
            library.describe_origin()
        ));
    }
    Ok(())
}

/// `--fetch DIR --from URL [--manifest FILE]`.
fn fetch_data(args: &Args, dir: &Path) -> anyhow::Result<()> {
    let from = args.from.as_deref().expect("clap requires --from with --fetch");
    let source = Source::parse(from).map_err(|e| anyhow::anyhow!("--from {e}"))?;
    let (manifest, text) = match &args.manifest {
        Some(path) => {
            let text = std::fs::read_to_string(path)
                .map_err(|e| anyhow::anyhow!("--manifest {}: {e}", path.display()))?;
            let m =
                Manifest::parse(&text).map_err(|e| anyhow::anyhow!("--manifest {}: {e}", path.display()))?;
            (m, text)
        }
        None => (Manifest::shipped(), crate::workload::scene::manifest::SHIPPED_TEXT.to_owned()),
    };
    if dir.exists() && !dir.is_dir() {
        bail!(
            "--fetch {}: not a folder (a file has that name); give the folder to lay the data out in",
            dir.display()
        );
    }
    std::fs::create_dir_all(dir)
        .map_err(|e| anyhow::anyhow!("--fetch {}: cannot create the folder ({e})", dir.display()))?;
    let total = manifest.files.len();
    note(format!(
        "fetching {total} files ({} bytes) from {from} into {}",
        manifest.total_bytes(),
        dir.display()
    ));
    let results = fetch::fetch_all(&manifest, &source, dir, |f, r| match r {
        Ok(Fetched::Present) => note(format!("{}: already there, intact", f.file)),
        Ok(Fetched::Downloaded) => {
            note(format!("{}: downloaded, {} bytes, SHA-256 as listed", f.file, f.bytes))
        }
        // A failure is an error, printed under -q too: one line naming the file.
        Err(e) => eprintln!("error: {}: {e}", f.file),
    });
    let failed = results.iter().filter(|(_, r)| r.is_err()).count();
    if failed > 0 {
        bail!(
            "{failed} of {total} files not fetched (each named above); run the same command again to retry them (the \
             {} intact ones are kept)",
            total - failed
        );
    }
    // The folder states what it holds, as the shared one does.
    let copy = dir.join("MANIFEST.md");
    if std::fs::read_to_string(&copy).ok().as_deref() != Some(text.as_str()) {
        std::fs::write(&copy, &text).map_err(|e| anyhow::anyhow!("{}: {e}", copy.display()))?;
    }
    let downloaded = results.iter().filter(|(_, r)| *r == Ok(Fetched::Downloaded)).count();
    note(format!(
        "{total} files intact in {} ({downloaded} downloaded, {} already there); use it with --scenes-dir {} or \
         SMS_SCENES_DIR={}",
        dir.display(),
        total - downloaded,
        dir.display(),
        dir.display()
    ));
    Ok(())
}
