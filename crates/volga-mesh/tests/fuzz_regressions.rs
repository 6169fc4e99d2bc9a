//! Inputs found while fuzzing the mesh readers (fuzz/, docs/FUZZING.md): each must give
//! an error, never a panic or an allocation the file does not pay for.

use std::path::Path;

use volga_mesh::{read_gltf, read_obj, MeshError};

/// A GLB of `json` and one binary chunk `bin`.
fn glb(json: &str, bin: &[u8]) -> Vec<u8> {
    let mut json = json.as_bytes().to_vec();
    json.resize(json.len().next_multiple_of(4), b' ');
    let mut bin = bin.to_vec();
    bin.resize(bin.len().next_multiple_of(4), 0);
    let total = 12 + 8 + json.len() + 8 + bin.len();
    let mut out = Vec::new();
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    out.extend_from_slice(&(json.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&json);
    out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
    out.extend_from_slice(b"BIN\0");
    out.extend_from_slice(&bin);
    out
}

/// 16 KB of glTF: two chains of 16 node levels whose nodes both list the next level's two
/// nodes as children, so the 2100-triangle mesh at the bottom is instanced 2^16 times,
/// 1.4·10^8 triangles (1.6 GB of indices alone). It used to be expanded until memory ran
/// out; the instances are now counted first and the file refused.
#[test]
fn instancing_bomb_is_refused_before_allocating() {
    let levels = 16;
    let triangles = 2100;
    let mut bin: Vec<u8> = [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0]
        .iter()
        .flat_map(|f| f.to_le_bytes())
        .collect();
    bin.extend((0..triangles).flat_map(|_| [0u8, 1, 2]));
    let nodes: Vec<String> = (0..levels)
        .flat_map(|i| {
            let node = if i + 1 < levels {
                format!("{{\"children\": [{}, {}]}}", 2 * i + 2, 2 * i + 3)
            } else {
                "{\"mesh\": 0}".to_string()
            };
            [node.clone(), node]
        })
        .collect();
    let json = format!(
        r#"{{"asset": {{"version": "2.0"}}, "scenes": [{{"nodes": [0, 1]}}], "nodes": [{}],
            "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0}}, "indices": 1}}]}}],
            "buffers": [{{"byteLength": {}}}],
            "bufferViews": [{{"buffer": 0, "byteLength": 36}}, {{"buffer": 0, "byteOffset": 36, "byteLength": {}}}],
            "accessors": [
                {{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]}},
                {{"bufferView": 1, "componentType": 5121, "count": {}, "type": "SCALAR"}}]}}"#,
        nodes.join(", "),
        bin.len(),
        3 * triangles,
        3 * triangles
    );
    let bytes = glb(&json, &bin);
    assert!(bytes.len() < 16 << 10);
    let e = read_gltf(&bytes, Path::new("bomb.glb")).unwrap_err().to_string();
    assert!(
        e.starts_with("bomb.glb") && e.contains("instances expand to 137625600 triangles"),
        "{e}"
    );
}

/// Found by the stable runner (target `obj`, 2026-11-27): tobj reads `l` statements as it
/// reads faces, and a normal index counting back past the normals defined (`2//-9` with
/// one normal) wrapped to a huge index that overflowed in `tobj::add_vertex_multi_index`
/// (a panic with overflow checks, wrong data without). volga's scan now checks `l`
/// corners as it checks faces' and names the line.
#[test]
fn line_statement_with_an_out_of_range_normal_is_refused() {
    let text = "vn 0 1 1 \nl 2//-9 2 3\nv 1 6 1\nv 1 0 7";
    match read_obj(text.as_bytes(), Path::new("l.obj")) {
        Err(MeshError::ObjSyntax { line: 2, message, .. }) => assert!(message.contains("out of range"), "{message}"),
        other => panic!("expected a syntax error on line 2, got {other:?}"),
    }
}
