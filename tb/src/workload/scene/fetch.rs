//! `sms scenes --fetch DIR --from URL`: lays out the scene data folder `sms` reads by copying
//! every file a [`Manifest`] lists from a copy of that folder, checking each file's size and
//! SHA-256 against the manifest.
//!
//! ```text
//!   for each file of the manifest:
//!     DIR/file present with the manifest's size and SHA-256  → kept, nothing downloaded
//!     else  URL/file ──stream──► DIR/.file.part (hashed, counted, cut off past the size)
//!           size and SHA-256 as listed → renamed to DIR/file
//!           otherwise                  → .part removed, a one-line error naming the file
//! ```
//!
//! So an interrupted or partly failed fetch, run again, downloads only what is missing or
//! wrong, and a file of the wrong content never sits under a data file's name. The source is
//! an `http://` or `https://` address (the system's proxy variables apply), a `file://` address
//! or a folder path.

use std::io::{Read, Write};
use std::path::{Path, PathBuf};
use std::time::Duration;

use sha2::{Digest, Sha256};

use super::manifest::{Manifest, ManifestFile};
use crate::digest::hex;

/// What happened to one file.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Fetched {
    /// Already in the folder with the listed size and SHA-256.
    Present,
    Downloaded,
}

/// Where the files come from.
#[derive(Clone, Debug)]
pub enum Source {
    /// `http://` or `https://`: the files are `<base>/<file>`.
    Http { base: String, agent: ureq::Agent },
    /// A folder holding the files (a path, or a `file://` address).
    Folder(PathBuf),
}

impl Source {
    /// The source `from` names, or why it names none.
    pub fn parse(from: &str) -> Result<Source, String> {
        if from.starts_with("http://") || from.starts_with("https://") {
            let config = ureq::Agent::config_builder()
                .timeout_connect(Some(Duration::from_secs(30)))
                .timeout_recv_response(Some(Duration::from_secs(60)))
                .build();
            return Ok(Source::Http { base: from.trim_end_matches('/').to_owned(), agent: config.into() });
        }
        let path = match from.strip_prefix("file://") {
            Some(rest) => PathBuf::from(rest),
            None if from.contains("://") => {
                return Err(format!(
                    "'{from}': expected an http://, https:// or file:// address, or a folder"
                ))
            }
            None => PathBuf::from(from),
        };
        if !path.is_dir() {
            return Err(format!("{}: not a folder", path.display()));
        }
        Ok(Source::Folder(path))
    }

    /// Where `file` is read from, as errors name it.
    fn locate(&self, file: &str) -> String {
        match self {
            Source::Http { base, .. } => format!("{base}/{file}"),
            Source::Folder(dir) => dir.join(file).display().to_string(),
        }
    }

    /// A reader of `file`'s bytes.
    fn open(&self, file: &str) -> Result<Box<dyn Read>, String> {
        let at = self.locate(file);
        match self {
            Source::Http { agent, .. } => {
                let response = agent.get(&at).call().map_err(|e| match e {
                    ureq::Error::StatusCode(code) => format!("HTTP status {code} from {at}"),
                    e => format!("{at}: {e}"),
                })?;
                Ok(Box::new(response.into_body().into_reader()))
            }
            Source::Folder(_) => {
                let f = std::fs::File::open(&at).map_err(|e| format!("{at}: {e}"))?;
                Ok(Box::new(f))
            }
        }
    }
}

/// Size and SHA-256 of what `reader` yields, written to `out` as it comes; refused past `limit`
/// bytes (a file longer than listed is wrong however it ends).
fn copy_hashed(mut reader: impl Read, mut out: impl Write, limit: u64) -> std::io::Result<(u64, String)> {
    let mut hasher = Sha256::new();
    let mut buf = vec![0u8; 1 << 16];
    let mut n = 0u64;
    loop {
        let got = match reader.read(&mut buf) {
            Ok(0) => break,
            Ok(got) => got,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
            Err(e) => return Err(e),
        };
        n += got as u64;
        if n > limit {
            return Err(std::io::Error::other(format!("more than the {limit} bytes listed")));
        }
        hasher.update(&buf[..got]);
        out.write_all(&buf[..got])?;
    }
    out.flush()?;
    Ok((n, hex(&hasher.finalize())))
}

/// Whether `path` holds exactly the bytes `f` lists (size first: no hashing of a wrong size).
pub fn is_intact(path: &Path, f: &ManifestFile) -> bool {
    let Ok(meta) = std::fs::metadata(path) else { return false };
    if !meta.is_file() || meta.len() != f.bytes {
        return false;
    }
    let Ok(file) = std::fs::File::open(path) else { return false };
    copy_hashed(file, std::io::sink(), f.bytes).is_ok_and(|(_, sha)| sha == f.sha256)
}

/// Brings `f` into `dir` from `source` unless it is there intact.
pub fn fetch_file(source: &Source, dir: &Path, f: &ManifestFile) -> Result<Fetched, String> {
    let dest = dir.join(&f.file);
    if is_intact(&dest, f) {
        return Ok(Fetched::Present);
    }
    let part = dir.join(format!(".{}.part", f.file));
    let result = (|| {
        let reader = source.open(&f.file)?;
        let out = std::fs::File::create(&part).map_err(|e| format!("{}: {e}", part.display()))?;
        let (bytes, sha256) = copy_hashed(reader, std::io::BufWriter::new(out), f.bytes)
            .map_err(|e| format!("reading {}: {e}", source.locate(&f.file)))?;
        if bytes != f.bytes {
            return Err(format!(
                "{bytes} bytes from {}; the manifest lists {}",
                source.locate(&f.file),
                f.bytes
            ));
        }
        if sha256 != f.sha256 {
            return Err(format!(
                "SHA-256 {sha256} of what {} holds; the manifest lists {}",
                source.locate(&f.file),
                f.sha256
            ));
        }
        std::fs::rename(&part, &dest).map_err(|e| format!("{}: {e}", dest.display()))
    })();
    match result {
        Ok(()) => Ok(Fetched::Downloaded),
        Err(e) => {
            let _ = std::fs::remove_file(&part);
            Err(e)
        }
    }
}

/// Every file of `manifest` into `dir` (created if missing) from `source`, in manifest order;
/// `done` hears of each file as it is settled. Failures do not stop the others; the result
/// lists every file's outcome.
pub fn fetch_all(
    manifest: &Manifest,
    source: &Source,
    dir: &Path,
    mut done: impl FnMut(&ManifestFile, &Result<Fetched, String>),
) -> Vec<(ManifestFile, Result<Fetched, String>)> {
    manifest
        .files
        .iter()
        .map(|f| {
            let r = fetch_file(source, dir, f);
            done(f, &r);
            (f.clone(), r)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn entry(file: &str, bytes: &[u8]) -> ManifestFile {
        ManifestFile {
            scene: "s".into(),
            file: file.into(),
            triangles: None,
            bytes: bytes.len() as u64,
            sha256: crate::digest::sha256_hex(bytes),
        }
    }

    #[test]
    fn a_folder_source_is_copied_checked_and_kept_on_a_second_run() {
        let tmp = std::env::temp_dir().join(format!("sms-fetch-unit-{}", std::process::id()));
        let (from, to) = (tmp.join("from"), tmp.join("to"));
        std::fs::create_dir_all(&from).unwrap();
        std::fs::create_dir_all(&to).unwrap();
        std::fs::write(from.join("a.obj"), b"v 0 0 0\n").unwrap();
        std::fs::write(from.join("b.obj"), b"tampered").unwrap();
        let source = Source::parse(from.to_str().unwrap()).unwrap();
        let good = entry("a.obj", b"v 0 0 0\n");
        assert_eq!(fetch_file(&source, &to, &good), Ok(Fetched::Downloaded));
        assert_eq!(fetch_file(&source, &to, &good), Ok(Fetched::Present));
        let bad = entry("b.obj", b"original");
        let e = fetch_file(&source, &to, &bad).unwrap_err();
        assert!(e.starts_with("SHA-256 ") && e.contains("the manifest lists"), "{e}");
        let long = entry("b.obj", b"tamp");
        let e = fetch_file(&source, &to, &long).unwrap_err();
        assert!(e.contains("more than the 4 bytes listed"), "{e}");
        let e = fetch_file(&source, &to, &entry("c.obj", b"")).unwrap_err();
        assert!(e.contains("c.obj") && e.contains("No such file"), "{e}");
        // Nothing of a failed file is left behind.
        let mut left: Vec<String> =
            std::fs::read_dir(&to).unwrap().map(|e| e.unwrap().file_name().into_string().unwrap()).collect();
        left.sort();
        assert_eq!(left, ["a.obj"]);
        assert!(Source::parse("ftp://example/x").unwrap_err().contains("expected an http://"));
        assert!(Source::parse(tmp.join("none").to_str().unwrap()).unwrap_err().ends_with("not a folder"));
        std::fs::remove_dir_all(&tmp).unwrap();
    }
}
