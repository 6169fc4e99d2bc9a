//! glTF 2.0 (`.gltf` with external or embedded buffers, and binary `.glb`).

use std::borrow::Cow;
use std::path::{Path, PathBuf};

use glam::{DAffine3, DMat4, DVec3};
use gltf::accessor::{DataType, Dimensions};
use gltf::mesh::{Mode, Semantic};

use crate::{MeshError, TriMesh};

/// Deeper node chains are refused: glTF forbids cycles but does not make parsers check.
const MAX_NODE_DEPTH: usize = 256;
/// Node instances visited per file, against hierarchies that share children.
const MAX_NODE_VISITS: usize = 1 << 20;
/// Triangles a file may produce once its instances are expanded (1.5 GiB of indices):
/// a few KB of nodes sharing children can otherwise ask for terabytes.
const MAX_INSTANCED_TRIANGLES: u64 = 1 << 27;

/// Loads every triangle primitive of every node of the default scene (of all scenes
/// when the file names no default), with each node's world transform applied.
pub fn load_gltf(path: impl AsRef<Path>) -> Result<TriMesh, MeshError> {
    let path = path.as_ref();
    let bytes = volga_core::input::read_input(path).map_err(|source| MeshError::Io {
        path: path.to_owned(),
        source,
    })?;
    read_gltf(&bytes, path)
}

/// Parses glTF or GLB bytes already in memory. `path` names the file in error
/// messages and locates external buffers (relative to its directory).
///
/// Only `TRIANGLES` primitives are accepted (others are an error naming the mesh and
/// primitive); positions must be `VEC3` floats (quantized positions are refused).
/// A node whose world transform mirrors (negative determinant) has its triangles'
/// corner order reversed, as the glTF specification requires for front faces, so
/// outward stays outward. Accessors are read by volga with every offset, stride and
/// length checked against the buffers, so a malformed file is an error, not a panic.
///
/// The `gltf` crate has panicked on some malformed documents (its validation indexes
/// before checking); volga checks those cases first and, as a last resort, turns a
/// panic inside the parser into an error naming the file (with `panic = "unwind"`).
pub fn read_gltf(bytes: &[u8], path: &Path) -> Result<TriMesh, MeshError> {
    std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| parse_gltf(bytes, path))).unwrap_or_else(|panic| {
        let reason = panic
            .downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| panic.downcast_ref::<String>().cloned())
            .unwrap_or_default();
        Err(MeshError::GltfPanic {
            path: path.to_owned(),
            reason,
        })
    })
}

fn parse_gltf(bytes: &[u8], path: &Path) -> Result<TriMesh, MeshError> {
    let fail = |message: String| MeshError::Gltf {
        path: path.to_owned(),
        message,
    };
    check_glb_header(bytes).map_err(fail)?;
    let invalid = |e: gltf::Error| fail(format!("not a valid glTF file: {e}"));
    let gltf::Gltf { document, blob } = gltf::Gltf::from_slice_without_validation(bytes).map_err(invalid)?;
    let root = document.into_json();
    check_attribute_indices(&root).map_err(fail)?;
    let gltf = gltf::Gltf {
        document: gltf::Document::from_json(root).map_err(invalid)?,
        blob,
    };
    let buffers = load_buffers(&gltf, path).map_err(fail)?;
    let scenes: Vec<gltf::Scene> = match gltf.default_scene() {
        Some(scene) => vec![scene],
        None => gltf.scenes().collect(),
    };
    let mut builder = Builder {
        path,
        buffers,
        mesh: TriMesh::default(),
        visits: 0,
        counts: Some((0, 0)),
    };
    // First count what the instances expand to, refusing before allocating.
    for scene in &scenes {
        for node in scene.nodes() {
            builder.add_node(node, &DAffine3::IDENTITY, 0)?;
        }
    }
    let (vertices, triangles) = builder.counts.take().unwrap_or_default();
    if vertices > u32::MAX as u64 {
        return Err(MeshError::TooManyVertices { path: path.to_owned() });
    }
    if triangles > MAX_INSTANCED_TRIANGLES {
        return Err(fail(format!(
            "the node instances expand to {triangles} triangles, more than the {MAX_INSTANCED_TRIANGLES} supported"
        )));
    }
    builder.visits = 0;
    for scene in scenes {
        for node in scene.nodes() {
            builder.add_node(node, &DAffine3::IDENTITY, 0)?;
        }
    }
    if builder.mesh.triangles.is_empty() {
        return Err(MeshError::Empty { path: path.to_owned() });
    }
    Ok(builder.mesh)
}

/// The gltf crate subtracts the header size from the declared length unchecked.
fn check_glb_header(bytes: &[u8]) -> Result<(), String> {
    if !bytes.starts_with(b"glTF") {
        return Ok(());
    }
    let length = bytes.get(8..12).ok_or("truncated GLB header")?;
    let length = u32::from_le_bytes([length[0], length[1], length[2], length[3]]);
    if length < 12 {
        return Err(format!(
            "GLB header declares a total length of {length} bytes, less than the header itself"
        ));
    }
    Ok(())
}

/// The crate's validation of a primitive indexes its POSITION accessor unchecked.
fn check_attribute_indices(root: &gltf::json::Root) -> Result<(), String> {
    for (m, mesh) in root.meshes.iter().enumerate() {
        for (k, primitive) in mesh.primitives.iter().enumerate() {
            if let Some(index) = primitive
                .attributes
                .values()
                .find(|i| i.value() >= root.accessors.len())
            {
                return Err(format!(
                    "mesh #{m}, primitive {k}: attribute accessor {} does not exist",
                    index.value()
                ));
            }
        }
    }
    Ok(())
}

fn load_buffers<'a>(gltf: &'a gltf::Gltf, path: &Path) -> Result<Vec<Cow<'a, [u8]>>, String> {
    let mut buffers = Vec::new();
    for buffer in gltf.buffers() {
        let i = buffer.index();
        let data: Cow<[u8]> = match buffer.source() {
            gltf::buffer::Source::Bin => Cow::Borrowed(
                gltf.blob
                    .as_deref()
                    .ok_or(format!("buffer {i} refers to the GLB binary chunk, which is missing"))?,
            ),
            gltf::buffer::Source::Uri(uri) => match uri.strip_prefix("data:") {
                Some(data_uri) => {
                    let (header, payload) = data_uri
                        .split_once(',')
                        .ok_or(format!("buffer {i}: malformed data URI"))?;
                    if !header.ends_with(";base64") {
                        return Err(format!("buffer {i}: only base64 data URIs are supported"));
                    }
                    Cow::Owned(decode_base64(payload).map_err(|e| format!("buffer {i}: {e}"))?)
                }
                None => {
                    let file = resolve_uri(path, uri).map_err(|e| format!("buffer {i}: {e}"))?;
                    Cow::Owned(
                        volga_core::input::read_input(&file)
                            .map_err(|e| format!("buffer {i}: cannot read {}: {e}", file.display()))?,
                    )
                }
            },
        };
        if data.len() < buffer.length() {
            return Err(format!(
                "buffer {i} holds {} bytes, fewer than its byteLength {}",
                data.len(),
                buffer.length()
            ));
        }
        buffers.push(match data {
            Cow::Borrowed(d) => Cow::Borrowed(&d[..buffer.length()]),
            Cow::Owned(mut d) => {
                d.truncate(buffer.length());
                Cow::Owned(d)
            }
        });
    }
    Ok(buffers)
}

struct Builder<'a> {
    path: &'a Path,
    buffers: Vec<Cow<'a, [u8]>>,
    mesh: TriMesh,
    visits: usize,
    /// `Some((vertices, triangles))` while counting the instances (nothing is read).
    counts: Option<(u64, u64)>,
}

impl Builder<'_> {
    fn fail(&self, message: String) -> MeshError {
        MeshError::Gltf {
            path: self.path.to_owned(),
            message,
        }
    }

    fn add_node(&mut self, node: gltf::Node, parent: &DAffine3, depth: usize) -> Result<(), MeshError> {
        self.visits += 1;
        if depth > MAX_NODE_DEPTH || self.visits > MAX_NODE_VISITS {
            return Err(self.fail(format!(
                "node {}: the node hierarchy is deeper than {MAX_NODE_DEPTH} levels or has more than \
                 {MAX_NODE_VISITS} node instances (is it cyclic?)",
                node.index()
            )));
        }
        let local = DMat4::from_cols_array_2d(&node.transform().matrix().map(|column| column.map(f64::from)));
        let world = *parent * DAffine3::from_mat4(local);
        if let Some(mesh) = node.mesh() {
            let name = mesh
                .name()
                .map_or_else(|| format!("#{}", mesh.index()), |n| format!("`{n}`"));
            for primitive in mesh.primitives() {
                self.add_primitive(&name, &primitive, &world)?;
            }
        }
        for child in node.children() {
            self.add_node(child, &world, depth + 1)?;
        }
        Ok(())
    }

    fn add_primitive(&mut self, mesh: &str, primitive: &gltf::Primitive, world: &DAffine3) -> Result<(), MeshError> {
        let k = primitive.index();
        if primitive.mode() != Mode::Triangles {
            return Err(MeshError::UnsupportedPrimitive {
                path: self.path.to_owned(),
                mesh: mesh.to_owned(),
                primitive: k,
                mode: mode_name(primitive.mode()).to_owned(),
            });
        }
        if let Some((vertices, triangles)) = &mut self.counts {
            let positions = primitive.get(&Semantic::Positions).map_or(0, |a| a.count() as u64);
            *vertices = vertices.saturating_add(positions);
            *triangles = triangles.saturating_add(primitive.indices().map_or(positions, |a| a.count() as u64) / 3);
            return Ok(());
        }
        let path = self.path;
        let context = |e: String| MeshError::Gltf {
            path: path.to_owned(),
            message: format!("mesh {mesh}, primitive {k}: {e}"),
        };
        let positions = primitive
            .get(&Semantic::Positions)
            .ok_or_else(|| context("no POSITION attribute".into()))?;
        let local_positions = read_positions(&positions, &self.buffers).map_err(context)?;
        let indices = match primitive.indices() {
            Some(accessor) => read_indices(&accessor, &self.buffers).map_err(context)?,
            None => (0..local_positions.len() as u64).map(|i| i as u32).collect(),
        };
        if indices.len() % 3 != 0 {
            return Err(context(format!(
                "{} indices do not make whole triangles",
                indices.len()
            )));
        }
        if let Some(&bad) = indices.iter().find(|&&i| i as usize >= local_positions.len()) {
            return Err(context(format!(
                "index {bad} is out of range ({} vertices)",
                local_positions.len()
            )));
        }
        let base = self.mesh.positions.len();
        if u32::try_from(base + local_positions.len()).is_err() {
            return Err(MeshError::TooManyVertices {
                path: self.path.to_owned(),
            });
        }
        for (i, p) in local_positions.iter().enumerate() {
            let world_pos = world.transform_point3(*p);
            if !world_pos.is_finite() {
                return Err(context(format!("vertex {i} is not finite in world space: {world_pos}")));
            }
            self.mesh.positions.push(world_pos);
        }
        let mirrored = world.matrix3.determinant() < 0.0;
        for t in indices.chunks_exact(3) {
            let [a, b, c] = [t[0], t[1], t[2]].map(|i| i + base as u32);
            self.mesh.triangles.push(if mirrored { [a, c, b] } else { [a, b, c] });
        }
        Ok(())
    }
}

fn mode_name(mode: Mode) -> &'static str {
    match mode {
        Mode::Points => "POINTS",
        Mode::Lines => "LINES",
        Mode::LineLoop => "LINE_LOOP",
        Mode::LineStrip => "LINE_STRIP",
        Mode::Triangles => "TRIANGLES",
        Mode::TriangleStrip => "TRIANGLE_STRIP",
        Mode::TriangleFan => "TRIANGLE_FAN",
    }
}

/// The bytes of an accessor's elements: `(data, stride, count)` with element `i` at
/// `data[i * stride..][..element_size]`, every bound checked.
fn accessor_data<'b>(
    accessor: &gltf::Accessor,
    buffers: &'b [Cow<[u8]>],
    element_size: usize,
) -> Result<(&'b [u8], usize, usize), String> {
    let a = accessor.index();
    if accessor.sparse().is_some() {
        return Err(format!("accessor {a} is sparse, which is not supported"));
    }
    let view = accessor.view().ok_or(format!("accessor {a} has no bufferView"))?;
    let buffer = buffers
        .get(view.buffer().index())
        .ok_or(format!("accessor {a}: missing buffer"))?;
    let view_end = view
        .offset()
        .checked_add(view.length())
        .filter(|&end| end <= buffer.len());
    let view_end = view_end.ok_or(format!("bufferView {} extends past its buffer", view.index()))?;
    let stride = view.stride().unwrap_or(element_size);
    if stride < element_size {
        return Err(format!(
            "bufferView {} has a stride of {stride} bytes, less than an element",
            view.index()
        ));
    }
    let count = accessor.count();
    if count == 0 {
        return Ok((&[], stride, 0));
    }
    let start = view.offset().checked_add(accessor.offset());
    let end = start.and_then(|s| stride.checked_mul(count - 1)?.checked_add(element_size)?.checked_add(s));
    match (start, end) {
        (Some(start), Some(end)) if end <= view_end => Ok((&buffer[start..end], stride, count)),
        _ => Err(format!("accessor {a} extends past bufferView {}", view.index())),
    }
}

fn read_positions(accessor: &gltf::Accessor, buffers: &[Cow<[u8]>]) -> Result<Vec<DVec3>, String> {
    if accessor.data_type() != DataType::F32 || accessor.dimensions() != Dimensions::Vec3 {
        return Err(format!(
            "POSITION accessor {} is {:?} {:?}; only float VEC3 is supported",
            accessor.index(),
            accessor.data_type(),
            accessor.dimensions()
        ));
    }
    let (data, stride, count) = accessor_data(accessor, buffers, 12)?;
    let float = |bytes: &[u8], at: usize| f32::from_le_bytes([bytes[at], bytes[at + 1], bytes[at + 2], bytes[at + 3]]);
    Ok((0..count)
        .map(|i| {
            let e = &data[i * stride..i * stride + 12];
            DVec3::new(float(e, 0) as f64, float(e, 4) as f64, float(e, 8) as f64)
        })
        .collect())
}

fn read_indices(accessor: &gltf::Accessor, buffers: &[Cow<[u8]>]) -> Result<Vec<u32>, String> {
    let size = match (accessor.data_type(), accessor.dimensions()) {
        (DataType::U8, Dimensions::Scalar) => 1,
        (DataType::U16, Dimensions::Scalar) => 2,
        (DataType::U32, Dimensions::Scalar) => 4,
        (t, d) => {
            return Err(format!(
                "index accessor {} is {t:?} {d:?}; expected an unsigned SCALAR",
                accessor.index()
            ))
        }
    };
    let (data, stride, count) = accessor_data(accessor, buffers, size)?;
    Ok((0..count)
        .map(|i| {
            let e = &data[i * stride..i * stride + size];
            match size {
                1 => e[0] as u32,
                2 => u16::from_le_bytes([e[0], e[1]]) as u32,
                _ => u32::from_le_bytes([e[0], e[1], e[2], e[3]]),
            }
        })
        .collect())
}

/// Standard or URL-safe base64 (RFC 4648), padding optional, whitespace ignored.
fn decode_base64(text: &str) -> Result<Vec<u8>, String> {
    let mut out = Vec::with_capacity(text.len() / 4 * 3);
    let (mut accumulator, mut bits) = (0u32, 0u32);
    for (offset, byte) in text.bytes().enumerate() {
        let value = match byte {
            b'A'..=b'Z' => byte - b'A',
            b'a'..=b'z' => byte - b'a' + 26,
            b'0'..=b'9' => byte - b'0' + 52,
            b'+' | b'-' => 62,
            b'/' | b'_' => 63,
            b'=' => break,
            b' ' | b'\t' | b'\r' | b'\n' => continue,
            _ => return Err(format!("invalid base64 character at offset {offset}")),
        };
        accumulator = (accumulator << 6) | value as u32;
        bits += 6;
        if bits >= 8 {
            bits -= 8;
            out.push((accumulator >> bits) as u8);
            accumulator &= (1 << bits) - 1;
        }
    }
    Ok(out)
}

/// The file an external (non-`data:`) URI of the glTF file `model` names, confined to
/// the model's folder: the URI is percent-decoded and must be a relative path without a
/// scheme (`file:`, `http:`…) whose normalised form stays inside the folder (`..` may
/// step back only into it), and whose target, after following symbolic links, still
/// lies inside the folder. So a model handed to a batch build can read its own
/// buffers and nothing else. Errors quote the URI.
pub(crate) fn resolve_uri(model: &Path, uri: &str) -> Result<PathBuf, String> {
    let decoded = percent_decode(uri);
    let refuse = |why: &str| {
        Err(format!(
            "URI `{uri}` {why}; only files inside the model's folder are read"
        ))
    };
    let scheme_len = decoded.find(':').filter(|&k| {
        k > 0
            && decoded[..k]
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || "+.-".contains(c))
    });
    if scheme_len.is_some() {
        return refuse("has a scheme (not a relative path)");
    }
    if decoded.is_empty() {
        return refuse("is empty");
    }
    if decoded.starts_with(['/', '\\']) || Path::new(&decoded).is_absolute() || decoded.contains('\\') {
        return refuse("is an absolute path or contains a backslash");
    }
    let folder = model
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let file = match volga_core::input::confine(folder, &decoded) {
        Ok(file) => file,
        Err(why) => return refuse(why),
    };
    // Symbolic links may still point outside: compare the real paths.
    let real_folder = folder.canonicalize().map_err(|e| {
        format!(
            "URI `{uri}`: cannot resolve the model's folder {}: {e}",
            folder.display()
        )
    })?;
    let real_file = file
        .canonicalize()
        .map_err(|e| format!("URI `{uri}`: cannot read {}: {e}", file.display()))?;
    if !real_file.starts_with(&real_folder) {
        return refuse(&format!(
            "resolves to {} outside the model's folder (through a symbolic link)",
            real_file.display()
        ));
    }
    Ok(file)
}

/// Decodes `%XX` escapes of a relative URI; anything malformed is kept literally.
fn percent_decode(uri: &str) -> String {
    let bytes = uri.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        let hex = bytes.get(i + 1..i + 3).filter(|h| h.iter().all(u8::is_ascii_hexdigit));
        let hex = hex.and_then(|h| u8::from_str_radix(std::str::from_utf8(h).ok()?, 16).ok());
        match (bytes[i], hex) {
            (b'%', Some(value)) => {
                out.push(value);
                i += 3;
            }
            (byte, _) => {
                out.push(byte);
                i += 1;
            }
        }
    }
    String::from_utf8_lossy(&out).into_owned()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn base64_round_trip() {
        assert_eq!(decode_base64("aGVsbG8gd29ybGQ=").unwrap(), b"hello world");
        assert_eq!(decode_base64("AAECAw").unwrap(), vec![0, 1, 2, 3]);
        assert!(decode_base64("a*b").is_err());
    }

    #[test]
    fn uris_stay_in_the_model_folder() {
        let dir = tempfile::tempdir().unwrap();
        let model = dir.path().join("sub").join("m.gltf");
        std::fs::create_dir_all(dir.path().join("sub/bin")).unwrap();
        std::fs::write(dir.path().join("sub/bin/b.bin"), b"x").unwrap();
        std::fs::write(dir.path().join("secret"), b"s").unwrap();
        assert_eq!(
            resolve_uri(&model, "bin/b.bin").unwrap(),
            dir.path().join("sub/bin/b.bin")
        );
        assert_eq!(
            resolve_uri(&model, "bin/../bin/./b.bin").unwrap(),
            dir.path().join("sub/bin/b.bin")
        );
        for uri in [
            "../secret",
            "bin/../../secret",
            "%2E%2E/secret",
            "/etc/passwd",
            "%2Fetc%2Fpasswd",
            "file:///etc/passwd",
            "http://example.com/b.bin",
            "..\\secret",
            "",
            ".",
        ] {
            let e = resolve_uri(&model, uri).unwrap_err();
            assert!(
                e.contains(&format!("`{uri}`")) && e.contains("model's folder"),
                "{uri}: {e}"
            );
        }
        #[cfg(unix)]
        {
            std::os::unix::fs::symlink(dir.path().join("secret"), dir.path().join("sub/link.bin")).unwrap();
            let e = resolve_uri(&model, "link.bin").unwrap_err();
            assert!(e.contains("symbolic link"), "{e}");
        }
    }

    #[test]
    fn percent_escapes() {
        assert_eq!(percent_decode("my%20mesh.bin"), "my mesh.bin");
        assert_eq!(percent_decode("100%"), "100%");
    }

    #[test]
    fn garbage_names_the_file() {
        for bytes in [
            &b"not json"[..],
            b"glTF\x02\0\0\0\x04\0\0\0",
            b"glTF",
            b"{}",
            b"{\"asset\":{\"version\":\"2.0\"}}",
        ] {
            let e = read_gltf(bytes, Path::new("bad.gltf")).unwrap_err();
            assert!(e.to_string().starts_with("bad.gltf: "), "{e}");
        }
    }
}
