//! `sms scenes --fetch DIR --from URL` end to end against a mirror this test serves over
//! loopback: every file checked against the manifest, a mismatching or missing file a one-line
//! error naming it, nothing wrong left under a data file's name, a second run fetching only what
//! is missing or damaged, and the folder it lays out read by `sms --scenes-dir`.

mod common;
use common::TmpDir;

use std::collections::HashMap;
use std::io::{BufRead, BufReader, Write};
use std::net::TcpListener;
use std::path::Path;
use std::process::{Command, Output};
use std::sync::{Arc, Mutex};

use tb::digest::sha256_hex;

/// A unit cube, as a gzip-compressed OBJ (the bunny's file name, so `bunny69k` loads it).
fn cube_gz() -> Vec<u8> {
    let obj = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n\
               f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 2 3 7 6\nf 3 4 8 7\nf 4 1 5 8\n";
    let mut gz = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
    gz.write_all(obj.as_bytes()).unwrap();
    gz.finish().unwrap()
}

/// A tiny HTTP/1.1 file server on 127.0.0.1: `GET /<name>` answers the bytes stored under
/// that name (200) or 404, and counts the requests per name.
struct Mirror {
    url: String,
    files: Arc<Mutex<HashMap<String, Vec<u8>>>>,
    hits: Arc<Mutex<HashMap<String, usize>>>,
}

impl Mirror {
    fn start() -> Self {
        let listener = TcpListener::bind("127.0.0.1:0").unwrap();
        let url = format!("http://{}/data", listener.local_addr().unwrap());
        let files: Arc<Mutex<HashMap<String, Vec<u8>>>> = Arc::default();
        let hits: Arc<Mutex<HashMap<String, usize>>> = Arc::default();
        let (f, h) = (files.clone(), hits.clone());
        std::thread::spawn(move || {
            for stream in listener.incoming().flatten() {
                let mut reader = BufReader::new(stream.try_clone().unwrap());
                let mut request = String::new();
                if reader.read_line(&mut request).is_err() {
                    continue;
                }
                // The headers, up to the blank line.
                let mut line = String::new();
                while reader.read_line(&mut line).is_ok_and(|n| n > 0) && line.trim() != "" {
                    line.clear();
                }
                let path = request.split(' ').nth(1).unwrap_or("").trim_start_matches("/data/").to_owned();
                *h.lock().unwrap().entry(path.clone()).or_default() += 1;
                let body = f.lock().unwrap().get(&path).cloned();
                let mut out = stream;
                let _ = match body {
                    Some(b) => out
                        .write_all(
                            format!(
                                "HTTP/1.1 200 OK\r\nContent-Length: {}\r\nConnection: close\r\n\r\n",
                                b.len()
                            )
                            .as_bytes(),
                        )
                        .and_then(|()| out.write_all(&b)),
                    None => out.write_all(
                        b"HTTP/1.1 404 Not Found\r\nContent-Length: 0\r\nConnection: close\r\n\r\n",
                    ),
                };
            }
        });
        Mirror { url, files, hits }
    }

    fn put(&self, name: &str, bytes: &[u8]) {
        self.files.lock().unwrap().insert(name.to_owned(), bytes.to_vec());
    }

    fn hits(&self, name: &str) -> usize {
        self.hits.lock().unwrap().get(name).copied().unwrap_or(0)
    }
}

/// A manifest in the shared folder's format listing `files` as `(name, bytes)`.
fn manifest(files: &[(&str, &[u8])]) -> String {
    let mut text = String::from(
        "# Shared scene data\n\n## Files\n\n\
         | Scene | File | Format | Triangles (unique / instanced) | Vertices | Bytes | sha256 (stored file) |\n\
         |---|---|---|---|---|---|---|\n",
    );
    for (name, bytes) in files {
        text += &format!(
            "| test | `{name}` | test | 12 / 12 | 8 | {} | `{}` |\n",
            bytes.len(),
            sha256_hex(bytes)
        );
    }
    text + "\nTotal: a test.\n"
}

fn sms(args: &[&str]) -> Output {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_sms"));
    cmd.args(args);
    // Loopback directly, whatever proxy the environment names.
    for var in ["http_proxy", "HTTP_PROXY", "https_proxy", "HTTPS_PROXY", "all_proxy", "ALL_PROXY"] {
        cmd.env_remove(var);
    }
    cmd.output().unwrap()
}

fn files_in(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> =
        std::fs::read_dir(dir).unwrap().map(|e| e.unwrap().file_name().into_string().unwrap()).collect();
    names.sort();
    names
}

#[test]
fn fetch_checks_every_file_names_each_failure_and_resumes() {
    let tmp = TmpDir::new("fetch", "loopback");
    let mirror = Mirror::start();
    let (bunny, mtl, ply) =
        (cube_gz(), b"newmtl hull\nKd 0.5 0.4 0.3\n".to_vec(), b"ply\nformat ascii 1.0\n".to_vec());
    let listed = manifest(&[
        ("stanford-bunny-69k.obj.gz", &bunny),
        ("karimSchooner.mtl", &mtl),
        ("city.ply.gz", &ply),
    ]);
    let manifest_path = tmp.join("MANIFEST.md");
    std::fs::write(&manifest_path, &listed).unwrap();
    let dir = tmp.join("scenes");
    let d = dir.to_str().unwrap();
    let fetch = |quiet: bool| {
        let args =
            ["scenes", "--fetch", d, "--from", &mirror.url, "--manifest", manifest_path.to_str().unwrap()];
        sms(&[&args[..], if quiet { &["-q"][..] } else { &[] }].concat())
    };

    // The mirror holds the bunny as listed, another material file, and no PLY.
    mirror.put("stanford-bunny-69k.obj.gz", &bunny);
    mirror.put("karimSchooner.mtl", b"newmtl hull\nKd 0.9 0.4 0.3\n");
    let o = fetch(true);
    let err = String::from_utf8(o.stderr).unwrap();
    assert_eq!(o.status.code(), Some(1), "{err}");
    let lines: Vec<&str> = err.lines().collect();
    assert_eq!(lines.len(), 3, "one line per failed file and the summary, nothing else under -q: {err}");
    assert!(lines[0].starts_with("error: karimSchooner.mtl: SHA-256 "), "{err}");
    assert!(lines[0].ends_with(&format!("the manifest lists {}", sha256_hex(&mtl))), "{err}");
    assert!(lines[1].starts_with("error: city.ply.gz: HTTP status 404 from http://127.0.0.1:"), "{err}");
    assert!(lines[2].starts_with("error: 2 of 3 files not fetched"), "{err}");
    // Only the intact file is there: no partial download, no wrong file under a listed name.
    assert_eq!(files_in(&dir), ["stanford-bunny-69k.obj.gz"]);
    assert_eq!(std::fs::read(dir.join("stanford-bunny-69k.obj.gz")).unwrap(), bunny);

    // Fixed at the mirror; run again: only what was missing is fetched.
    mirror.put("karimSchooner.mtl", &mtl);
    mirror.put("city.ply.gz", &ply);
    let o = fetch(false);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    assert!(err.contains("stanford-bunny-69k.obj.gz: already there, intact"), "{err}");
    assert!(err.contains("karimSchooner.mtl: downloaded"), "{err}");
    assert!(err.contains(&format!("use it with --scenes-dir {d}")), "{err}");
    assert_eq!(
        (
            mirror.hits("stanford-bunny-69k.obj.gz"),
            mirror.hits("karimSchooner.mtl"),
            mirror.hits("city.ply.gz")
        ),
        (1, 2, 2)
    );
    assert_eq!(
        files_in(&dir),
        ["MANIFEST.md", "city.ply.gz", "karimSchooner.mtl", "stanford-bunny-69k.obj.gz"]
    );
    assert_eq!(
        std::fs::read_to_string(dir.join("MANIFEST.md")).unwrap(),
        listed,
        "the folder states its manifest"
    );

    // A damaged file (a truncated copy) is fetched again; intact ones are not.
    std::fs::write(dir.join("stanford-bunny-69k.obj.gz"), &bunny[..bunny.len() / 2]).unwrap();
    assert!(fetch(true).status.success());
    assert_eq!((mirror.hits("stanford-bunny-69k.obj.gz"), mirror.hits("karimSchooner.mtl")), (2, 2));
    assert_eq!(std::fs::read(dir.join("stanford-bunny-69k.obj.gz")).unwrap(), bunny);

    // The folder is one sms reads: the shipped description finds its mesh there.
    let o = sms(&[
        "run",
        "--scene",
        "bunny69k",
        "--scenes-dir",
        d,
        "--res",
        "8x8",
        "--spp",
        "1",
        "-c",
        "RB_8",
        "-q",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));

    // No server at all: each file one line naming it.
    let closed = TcpListener::bind("127.0.0.1:0").unwrap().local_addr().unwrap();
    let empty = tmp.join("empty");
    let args =
        ["scenes", "--fetch", empty.to_str().unwrap(), "--manifest", manifest_path.to_str().unwrap(), "-q"];
    let o = sms(&[&args[..], &["--from", &format!("http://{closed}")]].concat());
    let err = String::from_utf8(o.stderr).unwrap();
    assert!(!o.status.success() && err.lines().count() == 4, "{err}");
    for (line, file) in err.lines().zip(["stanford-bunny-69k.obj.gz", "karimSchooner.mtl", "city.ply.gz"]) {
        assert!(line.starts_with(&format!("error: {file}: http://{closed}/{file}: ")), "{err}");
    }
    assert_eq!(files_in(&empty), Vec::<String>::new());
}

#[test]
fn fetch_refuses_bad_arguments_before_downloading() {
    let tmp = TmpDir::new("fetch", "arguments");
    let file = tmp.join("a-file");
    std::fs::write(&file, b"x").unwrap();
    let f = file.to_str().unwrap();
    let bad_manifest = tmp.join("bad.md");
    std::fs::write(&bad_manifest, "| Scene | File | Format | Triangles | Vertices | Bytes | sha256 |\n| s | a.obj | x | 1 | 1 | 1 | `00` |\n").unwrap();
    let cases: [(&[&str], &str); 5] = [
        (&["scenes", "--fetch", "d"], "--from <URL>"),
        (&["scenes", "--fetch", f, "--from", "http://127.0.0.1:9"], &format!("--fetch {f}: not a folder")),
        (
            &["scenes", "--fetch", "d", "--from", "ftp://x/y"],
            "--from 'ftp://x/y': expected an http://, https:// or file:// address",
        ),
        (&["scenes", "--fetch", "d", "--from", f], &format!("--from {f}: not a folder")),
        (
            &[
                "scenes",
                "--fetch",
                "d",
                "--from",
                "http://127.0.0.1:9",
                "--manifest",
                bad_manifest.to_str().unwrap(),
            ],
            "line 2: file 'a.obj' is not in backticks",
        ),
    ];
    for (args, want) in cases {
        let o = sms(args);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success() && err.contains(want), "{args:?}: {err}");
    }
    assert!(!Path::new("d").exists(), "nothing created");
}

/// The shipped manifest is the shared folder's: a user without the data reads the same list of
/// files, sizes and hashes, and every file of the shared folder is intact by it (what --fetch
/// checks a download against).
#[test]
fn the_shipped_manifest_describes_the_shared_scene_folder() {
    if !tb::prereq::scene_data() {
        return;
    }
    let library = tb::workload::scene::SceneLibrary::default();
    let shared = library.data.join("MANIFEST.md");
    let text = std::fs::read_to_string(&shared).unwrap_or_else(|e| panic!("{}: {e}", shared.display()));
    assert_eq!(
        text,
        tb::workload::scene::manifest::SHIPPED_TEXT,
        "scenes/MANIFEST.md is a copy of {}",
        shared.display()
    );
    let manifest = tb::workload::scene::manifest::Manifest::shipped();
    for f in &manifest.files {
        assert!(
            tb::workload::scene::fetch::is_intact(&library.data.join(&f.file), f),
            "{} as listed",
            f.file
        );
    }
}
