//! Loading meshes as a user would: files on disk, good and bad.

use std::path::{Path, PathBuf};

use glam::DVec3;
use proptest::prelude::*;
use volga_mesh::{load_gltf, load_mesh, load_obj, read_gltf, read_obj, MeshError};

fn write(dir: &tempfile::TempDir, name: &str, contents: &[u8]) -> PathBuf {
    let path = dir.path().join(name);
    std::fs::write(&path, contents).unwrap();
    path
}

/// The error's message, checked to begin with the file's path (and `:line` if given).
fn message_naming(result: Result<volga_mesh::TriMesh, MeshError>, path: &Path, line: Option<usize>) -> String {
    let message = result.expect_err("expected an error").to_string();
    let prefix = match line {
        Some(line) => format!("{}:{line}: ", path.display()),
        None => format!("{}: ", path.display()),
    };
    assert!(message.starts_with(&prefix), "`{message}` should start with `{prefix}`");
    message
}

#[test]
fn malformed_obj_lines_are_named() {
    let dir = tempfile::tempdir().unwrap();
    let cases: [(&str, usize, &str); 4] = [
        ("v 0 0 0\nv 1 2\nv 0 1 0\nf 1 2 3\n", 2, "needs three numbers"),
        (
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 99\n",
            4,
            "vertex index 99 is out of range",
        ),
        (
            "# header\nv 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n",
            3,
            "vertex 2 is not finite",
        ),
        ("v 0 0 0\r\nv 1 0 0\r\nv 0 1 0\r\nf 1 2 x3\r\n", 4, "is not an index"),
    ];
    for (i, (text, line, needle)) in cases.into_iter().enumerate() {
        let path = write(&dir, &format!("bad{i}.obj"), text.as_bytes());
        let message = message_naming(load_obj(&path), &path, Some(line));
        assert!(message.contains(needle), "{message}");
    }
    // Missing file and unknown extension also name the file.
    let missing = dir.path().join("missing.obj");
    message_naming(load_mesh(&missing), &missing, None);
    let stl = write(&dir, "mesh.stl", b"solid");
    message_naming(load_mesh(&stl), &stl, None);
}

#[test]
fn obj_with_missing_material_library_loads() {
    let dir = tempfile::tempdir().unwrap();
    let text = "mtllib nowhere.mtl\nusemtl red\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nf 1/1 2/1 3/1 4/1\n";
    let path = write(&dir, "quad.OBJ", text.as_bytes());
    let mesh = load_mesh(&path).unwrap();
    assert_eq!(mesh.triangle_count(), 2);
    assert_eq!(mesh.boundary_edge_count(), 4);
}

// --- glTF fixtures -----------------------------------------------------------------

fn base64(bytes: &[u8]) -> String {
    const ALPHABET: &[u8] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::new();
    for chunk in bytes.chunks(3) {
        let n = chunk
            .iter()
            .enumerate()
            .fold(0u32, |n, (i, &b)| n | (b as u32) << (16 - 8 * i));
        for i in 0..4 {
            if i <= chunk.len() {
                out.push(ALPHABET[(n >> (18 - 6 * i) & 63) as usize] as char);
            } else {
                out.push('=');
            }
        }
    }
    out
}

/// One triangle (0,0,0), (1,0,0), (0,1,0) with u16 indices: 36 + 6 bytes, padded to 44.
fn triangle_buffer() -> Vec<u8> {
    let mut bytes = Vec::new();
    for v in [[0.0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]] {
        for c in v {
            bytes.extend_from_slice(&c.to_le_bytes());
        }
    }
    for i in [0u16, 1, 2] {
        bytes.extend_from_slice(&i.to_le_bytes());
    }
    bytes.extend_from_slice(&[0, 0]);
    bytes
}

/// A glTF document whose parent node translates by (10, 0, 0) and scales by 2, with a
/// child translating by (0, 1, 0) that holds the triangle. `buffer` is the buffers
/// entry, `mode` the primitive mode, `scene` the top-level default-scene member.
fn gltf_json(buffer: &str, mode: u32, scene: &str) -> String {
    format!(
        r#"{{
  "asset": {{ "version": "2.0" }},
  {scene}
  "scenes": [ {{ "nodes": [0] }} ],
  "nodes": [
    {{ "translation": [10, 0, 0], "scale": [2, 2, 2], "children": [1] }},
    {{ "translation": [0, 1, 0], "mesh": 0 }}
  ],
  "meshes": [ {{ "name": "tri", "primitives": [
    {{ "attributes": {{ "POSITION": 0 }}, "indices": 1, "mode": {mode} }}
  ] }} ],
  "buffers": [ {buffer} ],
  "bufferViews": [
    {{ "buffer": 0, "byteOffset": 0, "byteLength": 36 }},
    {{ "buffer": 0, "byteOffset": 36, "byteLength": 6 }}
  ],
  "accessors": [
    {{ "bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0] }},
    {{ "bufferView": 1, "componentType": 5123, "count": 3, "type": "SCALAR" }}
  ]
}}"#
    )
}

fn embedded_buffer() -> String {
    format!(
        r#"{{ "byteLength": 44, "uri": "data:application/octet-stream;base64,{}" }}"#,
        base64(&triangle_buffer())
    )
}

const EXPECTED_WORLD: [DVec3; 3] = [
    DVec3::new(10.0, 2.0, 0.0),
    DVec3::new(12.0, 2.0, 0.0),
    DVec3::new(10.0, 4.0, 0.0),
];

#[test]
fn gltf_node_transforms_are_applied() {
    let dir = tempfile::tempdir().unwrap();
    let path = write(
        &dir,
        "tri.gltf",
        gltf_json(&embedded_buffer(), 4, r#""scene": 0,"#).as_bytes(),
    );
    let mesh = load_mesh(&path).unwrap();
    assert_eq!(mesh.triangles, vec![[0, 1, 2]]);
    assert_eq!(mesh.positions, EXPECTED_WORLD);
    // No default scene: every scene is loaded, the same here.
    let path = write(&dir, "noscene.gltf", gltf_json(&embedded_buffer(), 4, "").as_bytes());
    assert_eq!(load_gltf(&path).unwrap().positions, EXPECTED_WORLD);
}

#[test]
fn gltf_external_buffer_and_glb() {
    let dir = tempfile::tempdir().unwrap();
    write(&dir, "tri data.bin", &triangle_buffer());
    let json = gltf_json(r#"{ "byteLength": 44, "uri": "tri%20data.bin" }"#, 4, r#""scene": 0,"#);
    let path = write(&dir, "external.gltf", json.as_bytes());
    assert_eq!(load_gltf(&path).unwrap().positions, EXPECTED_WORLD);

    // The same document as GLB: JSON chunk (space-padded) and BIN chunk.
    let mut json = gltf_json(r#"{ "byteLength": 44 }"#, 4, r#""scene": 0,"#).into_bytes();
    while json.len() % 4 != 0 {
        json.push(b' ');
    }
    let bin = triangle_buffer();
    let total = 12 + 8 + json.len() + 8 + bin.len();
    let mut glb = Vec::new();
    glb.extend_from_slice(b"glTF");
    glb.extend_from_slice(&2u32.to_le_bytes());
    glb.extend_from_slice(&(total as u32).to_le_bytes());
    glb.extend_from_slice(&(json.len() as u32).to_le_bytes());
    glb.extend_from_slice(b"JSON");
    glb.extend_from_slice(&json);
    glb.extend_from_slice(&(bin.len() as u32).to_le_bytes());
    glb.extend_from_slice(b"BIN\0");
    glb.extend_from_slice(&bin);
    let path = write(&dir, "tri.glb", &glb);
    assert_eq!(load_mesh(&path).unwrap().positions, EXPECTED_WORLD);
    // Truncated: an error naming the file.
    let path = write(&dir, "cut.glb", &glb[..glb.len() - 10]);
    message_naming(load_mesh(&path), &path, None);
}

#[test]
fn gltf_errors_name_the_file_and_primitive() {
    let dir = tempfile::tempdir().unwrap();
    let garbage = write(&dir, "garbage.gltf", b"\x00\x01 this is not glTF");
    message_naming(load_gltf(&garbage), &garbage, None);
    let garbage = write(&dir, "garbage.glb", b"glTF\x02\x00\x00\x00\xff\xff\xff\xff");
    message_naming(load_gltf(&garbage), &garbage, None);

    let lines = write(
        &dir,
        "lines.gltf",
        gltf_json(&embedded_buffer(), 1, r#""scene": 0,"#).as_bytes(),
    );
    let message = message_naming(load_gltf(&lines), &lines, None);
    assert!(message.contains("mesh `tri`, primitive 0: mode LINES"), "{message}");

    let short = r#"{ "byteLength": 44, "uri": "data:application/octet-stream;base64,AAAA" }"#;
    let short = write(&dir, "short.gltf", gltf_json(short, 4, r#""scene": 0,"#).as_bytes());
    let message = message_naming(load_gltf(&short), &short, None);
    assert!(message.contains("fewer than its byteLength"), "{message}");

    let missing = write(
        &dir,
        "missing.gltf",
        gltf_json(r#"{ "byteLength": 44, "uri": "nope.bin" }"#, 4, "").as_bytes(),
    );
    let message = message_naming(load_gltf(&missing), &missing, None);
    assert!(message.contains("nope.bin"), "{message}");
}

#[test]
fn gltf_mirroring_node_keeps_triangles_outward() {
    let json =
        gltf_json(&embedded_buffer(), 4, r#""scene": 0,"#).replace(r#""scale": [2, 2, 2]"#, r#""scale": [-2, 2, 2]"#);
    let mesh = read_gltf(json.as_bytes(), Path::new("mirror.gltf")).unwrap();
    let [a, b, c] = mesh.triangle(0);
    // The local triangle faces +z; a mirror in x keeps it facing +z once reordered.
    assert!((b - a).cross(c - a).z > 0.0);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(300))]

    #[test]
    fn random_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..400)) {
        let _ = read_obj(&bytes, Path::new("random.obj"));
        // `read_gltf` catches a panic of its parser as `GltfPanic`: that counts as a panic.
        let gltf = read_gltf(&bytes, Path::new("random.gltf"));
        prop_assert!(!matches!(gltf, Err(MeshError::GltfPanic { .. })), "{:?}", gltf.err());
        let mut glb = b"glTF\x02\x00\x00\x00".to_vec();
        glb.extend_from_slice(&bytes);
        let glb = read_gltf(&glb, Path::new("random.glb"));
        prop_assert!(!matches!(glb, Err(MeshError::GltfPanic { .. })), "{:?}", glb.err());
    }

    /// Lines built from OBJ keywords and awkward numbers, to reach deep into both parsers.
    #[test]
    fn random_obj_text_never_panics(lines in proptest::collection::vec(
        (prop::sample::select(vec!["v", "vt", "vn", "f", "l", "o", "g", "usemtl", "mtllib", "s", "#", ""]),
         proptest::collection::vec(prop::sample::select(vec![
             "0", "1", "2", "3", "-1", "-2", "-9", "1.5", "nan", "inf", "-0", "1e308", "1/1", "1//1", "1/1/1",
             "2/0/1", "-1/-1", "1/2/3/4", "/1", "x", "99999999999999999999", "-9223372036854775808",
         ]), 0..7)),
        0..24)) {
        let text: String = lines.iter().map(|(k, words)| format!("{k} {}\n", words.join(" "))).collect();
        match read_obj(text.as_bytes(), Path::new("fuzz.obj")) {
            Ok(mesh) => {
                prop_assert!(!mesh.triangles.is_empty());
                prop_assert!(mesh.validate().is_ok());
            }
            Err(e) => prop_assert!(e.to_string().starts_with("fuzz.obj")),
        }
    }

    /// The valid document with one number or word replaced: Ok or Err, never a panic.
    #[test]
    fn mutated_gltf_never_panics(position in 0usize..2000, replacement in prop::sample::select(vec![
        "0", "-1", "4294967295", "1e40", "\"x\"", "null", "[]", "{}", "99", "5121", "5125", "\"VEC2\"", "\"MAT4\"",
    ])) {
        let json = gltf_json(&embedded_buffer(), 4, r#""scene": 0,"#);
        // Replace the number (or quoted word) starting at or after `position`.
        let bytes = json.as_bytes();
        let start = (position..bytes.len()).find(|&i| bytes[i].is_ascii_digit() || bytes[i] == b'"');
        if let Some(start) = start {
            let end = if bytes[start] == b'"' {
                bytes[start + 1..].iter().position(|&b| b == b'"').map_or(bytes.len(), |i| start + i + 2)
            } else {
                (start..bytes.len()).find(|&i| !(bytes[i].is_ascii_digit() || bytes[i] == b'.')).unwrap_or(bytes.len())
            };
            let mutated = format!("{}{}{}", &json[..start], replacement, &json[end..]);
            if let Err(e) = read_gltf(mutated.as_bytes(), Path::new("mutated.gltf")) {
                prop_assert!(!matches!(e, MeshError::GltfPanic { .. }), "the parser panicked: {e}");
                prop_assert!(e.to_string().starts_with("mutated.gltf"));
            }
        }
    }
}

/// A crafted model whose buffer URI climbs out of its folder (or is absolute, or goes
/// through a symbolic link to a file outside) must not be read, even though the file
/// exists and holds a valid buffer.
#[test]
fn gltf_buffer_uris_outside_the_model_folder_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let outside = write(&dir, "outside.bin", &triangle_buffer());
    std::fs::create_dir(dir.path().join("model")).unwrap();
    let absolute = outside.display().to_string();
    let mut uris = vec![
        "../outside.bin".to_string(),
        "sub/../../outside.bin".to_string(),
        "%2e%2e/outside.bin".to_string(),
        "../../../../../../../../etc/passwd".to_string(),
        absolute.clone(),
        format!("file://{absolute}"),
    ];
    #[cfg(unix)]
    {
        std::os::unix::fs::symlink(&outside, dir.path().join("model/link.bin")).unwrap();
        uris.push("link.bin".to_string());
    }
    for uri in uris {
        let json = gltf_json(
            &format!(r#"{{ "byteLength": 44, "uri": "{uri}" }}"#),
            4,
            r#""scene": 0,"#,
        );
        let path = dir.path().join("model/escape.gltf");
        std::fs::write(&path, json).unwrap();
        let message = message_naming(load_gltf(&path), &path, None);
        assert!(
            message.contains(&format!("`{uri}`")) && message.contains("model's folder"),
            "{uri}: {message}"
        );
    }
    // The same buffer inside the folder loads.
    std::fs::copy(&outside, dir.path().join("model/inside.bin")).unwrap();
    let json = gltf_json(r#"{ "byteLength": 44, "uri": "./inside.bin" }"#, 4, r#""scene": 0,"#);
    let path = dir.path().join("model/inside.gltf");
    std::fs::write(&path, json).unwrap();
    assert_eq!(load_gltf(&path).unwrap().positions, EXPECTED_WORLD);
}
