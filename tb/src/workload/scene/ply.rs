//! PLY positions and faces, ASCII or binary little-endian.
//!
//! Hand-written (ply-rs builds a property map per element, far too slow and large for big meshes):
//! reads `vertex` x/y/z and `face` `vertex_indices` (or `vertex_index`) lists, skips every other
//! element and property, and names the element of every error.
//!
//! The header is read as bytes: `comment` and `obj_info` lines, and free-text lines such as the
//! bare `Created by Blender3D …` line Blender's exporter writes, are skipped whatever their
//! encoding, as assimp skips them; a malformed `format`, `element` or `property` line is still an
//! error naming its line.

use std::io::BufRead;
use std::path::Path;

use glam::Vec3A;

use super::sink::{checked_vertex, MeshFile, TriangleSink};
use crate::error::{Error, Result};

#[derive(Clone, Copy, Debug)]
enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Scalar {
    fn parse(name: &str) -> Option<Self> {
        Some(match name {
            "char" | "int8" => Scalar::I8,
            "uchar" | "uint8" => Scalar::U8,
            "short" | "int16" => Scalar::I16,
            "ushort" | "uint16" => Scalar::U16,
            "int" | "int32" => Scalar::I32,
            "uint" | "uint32" => Scalar::U32,
            "float" | "float32" => Scalar::F32,
            "double" | "float64" => Scalar::F64,
            _ => return None,
        })
    }
}

enum Property {
    Scalar(String, Scalar),
    List(String, Scalar, Scalar),
}

struct Element {
    name: String,
    count: usize,
    properties: Vec<Property>,
}

/// Source of property values: whitespace-separated text or little-endian binary.
enum Body<R> {
    Ascii(R, Vec<String>),
    Binary(R),
}

impl<R: BufRead> Body<R> {
    /// Reads one value; `Ok(None)` means end of file.
    fn value(&mut self, ty: Scalar) -> std::io::Result<Option<f64>> {
        match self {
            Body::Ascii(reader, pending) => {
                while pending.is_empty() {
                    let mut line = Vec::new();
                    if reader.read_until(b'\n', &mut line)? == 0 {
                        return Ok(None);
                    }
                    // Bytes that are not UTF-8 cannot be numbers: they fail to parse below.
                    let line = String::from_utf8_lossy(&line);
                    pending.extend(line.split_ascii_whitespace().rev().map(str::to_owned));
                }
                let token = pending.pop().unwrap_or_default();
                token.parse().map(Some).map_err(|_| {
                    std::io::Error::new(std::io::ErrorKind::InvalidData, format!("'{token}' is not a number"))
                })
            }
            Body::Binary(reader) => {
                let mut b = [0u8; 8];
                let n = match ty {
                    Scalar::I8 | Scalar::U8 => 1,
                    Scalar::I16 | Scalar::U16 => 2,
                    Scalar::I32 | Scalar::U32 | Scalar::F32 => 4,
                    Scalar::F64 => 8,
                };
                match reader.read_exact(&mut b[..n]) {
                    Err(e) if e.kind() == std::io::ErrorKind::UnexpectedEof => return Ok(None),
                    r => r?,
                }
                Ok(Some(match ty {
                    Scalar::I8 => b[0] as i8 as f64,
                    Scalar::U8 => b[0] as f64,
                    Scalar::I16 => i16::from_le_bytes([b[0], b[1]]) as f64,
                    Scalar::U16 => u16::from_le_bytes([b[0], b[1]]) as f64,
                    Scalar::I32 => i32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
                    Scalar::U32 => u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
                    Scalar::F32 => f32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
                    Scalar::F64 => f64::from_le_bytes(b),
                }))
            }
        }
    }
}

fn parse_header(reader: &mut impl BufRead, path: &Path) -> Result<(bool, Vec<Element>)> {
    let mut ascii = None;
    let mut elements: Vec<Element> = Vec::new();
    let mut line_no = 0;
    let mut bytes = Vec::new();
    loop {
        bytes.clear();
        if reader.read_until(b'\n', &mut bytes).map_err(|e| Error::io(path, e))? == 0 {
            return Err(Error::format(path, "header", "no end_header"));
        }
        let line = String::from_utf8_lossy(&bytes);
        line_no += 1;
        let at = format!("header line {line_no}");
        let bad = |what: &str| Error::format(path, at.clone(), what.to_owned());
        let t: Vec<&str> = line.split_ascii_whitespace().collect();
        match t.as_slice() {
            ["ply"] if line_no == 1 => {}
            _ if line_no == 1 => return Err(bad("not a PLY file (no 'ply' magic)")),
            ["format", "ascii", _] => ascii = Some(true),
            ["format", "binary_little_endian", _] => ascii = Some(false),
            ["format", other, ..] => return Err(bad(&format!("unsupported format '{other}'"))),
            ["element", name, count] => elements.push(Element {
                name: name.to_string(),
                count: count.parse().map_err(|_| bad("bad element count"))?,
                properties: Vec::new(),
            }),
            ["property", "list", count_ty, item_ty, name] => {
                let (Some(c), Some(i)) = (Scalar::parse(count_ty), Scalar::parse(item_ty)) else {
                    return Err(bad("unknown property type"));
                };
                elements
                    .last_mut()
                    .ok_or_else(|| bad("property before any element"))?
                    .properties
                    .push(Property::List(name.to_string(), c, i));
            }
            ["property", ty, name] => {
                let ty = Scalar::parse(ty).ok_or_else(|| bad("unknown property type"))?;
                elements
                    .last_mut()
                    .ok_or_else(|| bad("property before any element"))?
                    .properties
                    .push(Property::Scalar(name.to_string(), ty));
            }
            ["end_header"] => break,
            ["format" | "element" | "property" | "end_header", ..] => {
                return Err(bad(&format!("malformed header line '{}'", line.trim())))
            }
            // `comment`, `obj_info`, free text.
            _ => {}
        }
    }
    let ascii = ascii.ok_or_else(|| Error::format(path, "header", "no format line"))?;
    Ok((ascii, elements))
}

/// Reads the PLY file in `reader` (ASCII or binary) into `sink`.
pub(super) fn load(mut reader: impl BufRead, file: MeshFile, sink: &mut TriangleSink) -> Result<()> {
    let MeshFile { path, xf } = file;
    let (ascii, elements) = parse_header(&mut reader, path)?;
    let mut body = if ascii { Body::Ascii(reader, Vec::new()) } else { Body::Binary(reader) };
    let mut vertices: Vec<Vec3A> = Vec::new();
    let mut seen_vertex = false;
    let mut polygon = Vec::new();
    for element in &elements {
        let is_vertex = element.name == "vertex";
        let is_face = element.name == "face";
        if is_vertex {
            for axis in ["x", "y", "z"] {
                if !element.properties.iter().any(|p| matches!(p, Property::Scalar(n, _) if n == axis)) {
                    return Err(Error::format(path, "header", format!("vertex has no '{axis}'")));
                }
            }
            vertices.reserve(element.count.min(1 << 26));
            seen_vertex = true;
        }
        if is_face && !seen_vertex {
            return Err(Error::format(path, "header", "face element before vertex element"));
        }
        for index in 0..element.count {
            let at = || format!("{} {index}", element.name);
            let mut read = |ty| match body.value(ty) {
                Ok(Some(v)) => Ok(v),
                Ok(None) => Err(Error::format(path, at(), "unexpected end of file")),
                Err(e) => Err(Error::format(path, at(), e.to_string())),
            };
            let mut p = [0.0f32; 3];
            polygon.clear();
            for property in &element.properties {
                match property {
                    Property::Scalar(name, ty) => {
                        let v = read(*ty)?;
                        if let Some(axis) = ["x", "y", "z"].iter().position(|a| a == name) {
                            p[axis] = v as f32;
                        }
                    }
                    Property::List(name, count_ty, item_ty) => {
                        let n = read(*count_ty)?;
                        let wanted = is_face && (name == "vertex_indices" || name == "vertex_index");
                        for _ in 0..n as usize {
                            let i = read(*item_ty)?;
                            if wanted {
                                let v = usize::try_from(i as i64)
                                    .ok()
                                    .and_then(|i| vertices.get(i))
                                    .ok_or_else(|| {
                                        Error::format(
                                            path,
                                            at(),
                                            format!(
                                                "vertex index {i} out of range ({} vertices)",
                                                vertices.len()
                                            ),
                                        )
                                    })?;
                                polygon.push(*v);
                            }
                        }
                    }
                }
            }
            if is_vertex {
                vertices.push(checked_vertex(path, at, xf, Vec3A::from(p))?);
            } else if is_face {
                sink.add_fan(polygon.iter().copied());
            }
        }
    }
    Ok(())
}
