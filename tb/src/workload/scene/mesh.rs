//! Mesh files to triangles: format dispatch, gzip, and the checks every format shares.
//!
//! Only positions and faces are read. Every loader feeds one [`TriangleSink`] (in
//! [`super::sink`]), so the rules for non-finite vertices and degenerate triangles are written
//! once: a non-finite vertex is an error naming where it is, a zero-area triangle is dropped and
//! counted.

use std::fs::File;
use std::io::{BufRead, BufReader, Read};
use std::path::Path;

use flate2::read::GzDecoder;
use glam::Affine3A;

use super::sink::{MeshFile, TriangleSink};
use super::{glb, obj, ply};
use crate::error::{Error, Result};

/// A gzip stream whose read errors say they are about the compressed data (a truncated
/// download otherwise reads as a bare "incomplete deflate stream").
struct Gz<R>(GzDecoder<R>);

impl<R: Read> Read for Gz<R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        self.0
            .read(buf)
            .map_err(|e| std::io::Error::new(e.kind(), format!("corrupt or truncated gzip data ({e})")))
    }
}

/// Opens `path` for buffered reading, decompressing it when its name ends in `.gz`.
fn open(path: &Path) -> Result<Box<dyn BufRead>> {
    let file = File::open(path).map_err(|e| Error::io(path, e))?;
    Ok(if path.extension().is_some_and(|e| e == "gz") {
        Box::new(BufReader::with_capacity(1 << 16, Gz(GzDecoder::new(file))))
    } else {
        Box::new(BufReader::with_capacity(1 << 16, file))
    })
}

/// What the first bytes of a file named `.obj` (after any gzip decompression) say it is, when
/// that is not OBJ text: the error's text, naming what to do.
fn not_obj_text(head: &[u8]) -> Option<&'static str> {
    let utf16 = "UTF-16 text; sms reads OBJ as ASCII or UTF-8 text: convert it (iconv -f UTF-16 -t UTF-8)";
    if head.starts_with(&[0xff, 0xfe]) || head.starts_with(&[0xfe, 0xff]) {
        return Some(utf16);
    }
    if head.starts_with(b"glTF") {
        return Some("binary glTF (GLB) data, not OBJ text: name the file .glb");
    }
    if head.starts_with(&[0x1f, 0x8b]) {
        return Some("gzip-compressed data: name the file .obj.gz");
    }
    if head.starts_with(b"ply\n") || head.starts_with(b"ply\r\n") {
        return Some("a PLY file, not OBJ text: name the file .ply");
    }
    let nul = |bytes: &mut dyn Iterator<Item = &u8>| bytes.filter(|&&b| b == 0).count();
    if nul(&mut head.iter()) == 0 {
        return None;
    }
    // ASCII as UTF-16 without a byte-order mark: every other byte is 0.
    let (even, odd) = (nul(&mut head.iter().step_by(2)), nul(&mut head.iter().skip(1).step_by(2)));
    let half = head.len() / 2;
    if head.len() >= 8 && (even >= half * 9 / 10 || odd >= half * 9 / 10) {
        return Some(utf16);
    }
    Some("binary data, not OBJ text (it holds NUL bytes): is it another format under an .obj name?")
}

/// Loads the triangles of a mesh file (OBJ, PLY, glTF/GLB, optionally gzip-compressed) into
/// `sink`, transformed by `xf`.
pub(crate) fn load_mesh(path: &Path, xf: &Affine3A, sink: &mut TriangleSink) -> Result<()> {
    let name = path.file_name().and_then(|n| n.to_str()).unwrap_or_default();
    let format = name.strip_suffix(".gz").unwrap_or(name);
    let ext = format.rsplit('.').next().unwrap_or_default().to_ascii_lowercase();
    let (before, offered, non_surface) = (sink.triangles.len(), sink.offered, sink.non_surface);
    match ext.as_str() {
        // Each file is at least one object (LumiBench makes every OBJ file its own BLAS).
        "obj" | "ply" => {
            let (mut reader, file) = (open(path)?, MeshFile { path, xf });
            if ext == "obj" {
                let head = reader.fill_buf().map_err(|e| Error::io(path, e))?;
                if let Some(what) = not_obj_text(&head[..head.len().min(4096)]) {
                    return Err(Error::format(path, "content", what));
                }
            }
            sink.begin_object();
            if ext == "obj" {
                obj::load(reader, file, sink)?;
            } else {
                ply::load(reader, file, sink)?;
            }
            sink.end_object();
        }
        "glb" | "gltf" => {
            let mut bytes = Vec::new();
            open(path)?.read_to_end(&mut bytes).map_err(|e| Error::io(path, e))?;
            glb::load(&bytes, path, xf, sink)?
        }
        _ => {
            return Err(Error::format(
                path,
                "file name",
                "unknown mesh format (expected .obj, .ply, .glb or .gltf, optionally .gz)",
            ))
        }
    }
    if sink.triangles.len() == before {
        let why = match (sink.offered - offered, sink.non_surface - non_surface) {
            (0, 0) => "the file holds no faces".to_string(),
            (0, n) => {
                format!("its {n} primitive(s) are points or lines, which have no surface for a ray to hit")
            }
            (n, _) => format!("all {n} of its faces have zero area"),
        };
        return Err(Error::EmptyMesh { path: path.to_owned(), why });
    }
    Ok(())
}
