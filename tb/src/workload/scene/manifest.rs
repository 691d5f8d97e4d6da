//! The scene data's manifest (`scenes/MANIFEST.md`, a copy of the one in the shared scene folder,
//! embedded in `sms`): which files the shared folder holds, each with its size and SHA-256, so
//! `sms scenes` can list the scenes without reading their meshes and `sms scenes --fetch` can
//! check what it downloads.
//!
//! The manifest is Markdown for people; what is read is its file table, one row per file:
//!
//! ```text
//! | Scene | File | Format | Triangles (unique / instanced) | Vertices | Bytes | sha256 (stored file) |
//! |---|---|---|---|---|---|---|
//! | bunny69k | `stanford-bunny-69k.obj.gz` | OBJ (gzip) | 69,451 / 69,451 | 35,947 | 819,403 | `22e3…6f` |
//! ```
//!
//! The file name and the hash are in backticks, numbers may carry thousands separators, and a
//! file without triangles (a material library) has `–` there.

/// One file of the scene data.
#[derive(Clone, Debug, PartialEq, Eq, serde::Serialize)]
pub struct ManifestFile {
    /// The scene the file belongs to (the manifest's first column).
    pub scene: String,
    /// The file's name in the data folder: a plain name, never a path.
    pub file: String,
    /// Triangles after flattening instances, as the manifest counts them (fan triangulation);
    /// `None` for files without geometry. Loading drops zero-area triangles, so a loaded scene
    /// may hold fewer.
    pub triangles: Option<u64>,
    /// Size of the stored file.
    pub bytes: u64,
    /// SHA-256 of the stored file (compressed files as compressed), 64 lowercase hex digits.
    pub sha256: String,
}

/// The manifest's file table.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Manifest {
    pub files: Vec<ManifestFile>,
}

/// The manifest shipped with sms: the scene data its described scenes read.
pub const SHIPPED_TEXT: &str = include_str!(concat!(env!("CARGO_MANIFEST_DIR"), "/../scenes/MANIFEST.md"));

impl Manifest {
    /// The manifest shipped with sms ([`SHIPPED_TEXT`]).
    pub fn shipped() -> Manifest {
        Manifest::parse(SHIPPED_TEXT).expect("the shipped manifest parses (a test checks it)")
    }

    /// Reads the file table of a manifest's text; an error names the line and what is wrong.
    pub fn parse(text: &str) -> Result<Manifest, String> {
        let mut files: Vec<ManifestFile> = Vec::new();
        let mut in_table = false;
        for (i, line) in text.lines().enumerate() {
            let at = |what: String| format!("line {}: {what}", i + 1);
            let line = line.trim();
            if !line.starts_with('|') {
                in_table = false;
                continue;
            }
            let cells: Vec<&str> = line.trim_matches('|').split('|').map(str::trim).collect();
            if cells.first() == Some(&"Scene") && cells.get(1) == Some(&"File") {
                if cells.len() != 7 {
                    return Err(at(format!("the file table has {} columns, expected 7", cells.len())));
                }
                in_table = true;
                continue;
            }
            if !in_table || cells.iter().all(|c| c.chars().all(|ch| matches!(ch, '-' | ':'))) {
                continue;
            }
            let [scene, file, _format, triangles, _vertices, bytes, sha256] = cells[..] else {
                return Err(at(format!("{} cells, expected 7", cells.len())));
            };
            let file = ticked(file).ok_or_else(|| at(format!("file '{file}' is not in backticks")))?;
            if file.is_empty() || file.starts_with('.') || file.contains(['/', '\\']) {
                return Err(at(format!("file '{file}': a plain file name is expected, not a path")));
            }
            let bytes = number(bytes).ok_or_else(|| at(format!("bytes '{bytes}' is not a number")))?;
            let sha256 = ticked(sha256)
                .filter(|h| {
                    h.len() == 64 && h.bytes().all(|b| b.is_ascii_digit() || (b'a'..=b'f').contains(&b))
                })
                .ok_or_else(|| {
                    at(format!("sha256 '{sha256}' is not 64 lowercase hex digits in backticks"))
                })?;
            // "unique / instanced": the instanced count is what a flat structure holds.
            let triangles = triangles.rsplit('/').next().and_then(|t| number(t.trim()));
            if files.iter().any(|f| f.file == file) {
                return Err(at(format!("file '{file}' is listed twice")));
            }
            files.push(ManifestFile {
                scene: scene.to_owned(),
                file: file.to_owned(),
                triangles,
                bytes,
                sha256: sha256.to_owned(),
            });
        }
        if files.is_empty() {
            return Err("no file table (a row '| Scene | File | … |' followed by one row per file)".into());
        }
        Ok(Manifest { files })
    }

    /// The entry of the data file `name`.
    pub fn file(&self, name: &str) -> Option<&ManifestFile> {
        self.files.iter().find(|f| f.file == name)
    }

    /// Bytes of every file together.
    pub fn total_bytes(&self) -> u64 {
        self.files.iter().map(|f| f.bytes).sum()
    }
}

/// The text between the backticks of `` `text` ``.
fn ticked(cell: &str) -> Option<&str> {
    cell.strip_prefix('`')?.strip_suffix('`')
}

/// A whole number, thousands separators (`,`) allowed.
fn number(cell: &str) -> Option<u64> {
    let digits: String = cell.chars().filter(|&c| c != ',').collect();
    if digits.is_empty() || !digits.bytes().all(|b| b.is_ascii_digit()) {
        return None;
    }
    digits.parse().ok()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_shipped_manifest_lists_every_file_the_described_scenes_read() {
        let m = Manifest::shipped();
        assert_eq!(m.files.len(), 17);
        // The manifest's own sentence: "Total of the files above: 99,339,616 bytes".
        assert!(SHIPPED_TEXT.contains("Total of the files above: 99,339,616 bytes"));
        assert_eq!(m.total_bytes(), 99_339_616);
        let bunny = m.file("stanford-bunny-69k.obj.gz").unwrap();
        assert_eq!((bunny.triangles, bunny.bytes), (Some(69_451), 819_403));
        assert_eq!(m.file("composite-gallery-6.9M-instanced.glb").unwrap().triangles, Some(6_923_978));
        assert_eq!(m.file("karimSchooner.mtl").unwrap().triangles, None);
        for (name, _) in crate::workload::scene::SHIPPED {
            for file in crate::workload::scene::described_files(name).unwrap() {
                assert!(m.file(&file).is_some(), "{name} reads {file}, which the manifest does not list");
            }
        }
    }

    #[test]
    fn a_bad_manifest_is_an_error_naming_its_line() {
        let head = "# x\n\n| Scene | File | Format | Triangles | Vertices | Bytes | sha256 |\n|---|---|---|---|---|---|---|\n";
        let hash = "a".repeat(64);
        let row = |file: &str, bytes: &str, sha: &str| {
            format!("| s | {file} | OBJ | 3 / 3 | 3 | {bytes} | {sha} |\n")
        };
        let ok = format!("{head}{}", row("`a.obj`", "1,024", &format!("`{hash}`")));
        let m = Manifest::parse(&ok).unwrap();
        assert_eq!(m.files[0].bytes, 1024);
        for (text, want) in [
            (
                format!("{head}{}", row("a.obj", "1", &format!("`{hash}`"))),
                "line 5: file 'a.obj' is not in backticks",
            ),
            (
                format!("{head}{}", row("`../a.obj`", "1", &format!("`{hash}`"))),
                "line 5: file '../a.obj': a plain",
            ),
            (format!("{head}{}", row("`a.obj`", "1 KB", &format!("`{hash}`"))), "line 5: bytes '1 KB'"),
            (format!("{head}{}", row("`a.obj`", "1", "`abc`")), "line 5: sha256 '`abc`'"),
            (
                format!("{ok}{}", row("`a.obj`", "1", &format!("`{hash}`"))),
                "line 6: file 'a.obj' is listed twice",
            ),
            ("no table here".to_string(), "no file table"),
        ] {
            let e = Manifest::parse(&text).unwrap_err();
            assert!(e.starts_with(want), "{e}");
        }
    }
}
