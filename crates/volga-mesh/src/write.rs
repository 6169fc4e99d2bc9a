//! Mesh writers: OBJ (text) and PLY (binary little-endian), as bytes.
//!
//! They produce bytes rather than writing files so the caller hands them to
//! `volga_io::write_atomic` or `StagedOutputs` (outputs are all-or-nothing; this crate does
//! no file output). Positions are written as `f64` (OBJ: the shortest decimal that reads
//! back to the same `f64`; PLY: `double`), so a mesh placed at 1e6 keeps its precision.

use std::fmt::Write as _;

use glam::DVec3;

use crate::TriMesh;

/// Wavefront OBJ text: `v x y z` per vertex, `vn` per normal if given (one per vertex,
/// same order), `f a//a b//b c//c` (1-based) per triangle.
///
/// Panics if `normals` is given with a length other than the vertex count.
pub fn obj_bytes(mesh: &TriMesh, normals: Option<&[DVec3]>) -> Vec<u8> {
    if let Some(n) = normals {
        assert_eq!(n.len(), mesh.positions.len(), "one normal per vertex");
    }
    let mut s = String::with_capacity(mesh.positions.len() * 48 + mesh.triangles.len() * 32);
    s.push_str("# written by volga\n");
    for p in &mesh.positions {
        let _ = writeln!(s, "v {} {} {}", p.x, p.y, p.z);
    }
    if let Some(ns) = normals {
        for n in ns {
            let _ = writeln!(s, "vn {} {} {}", n.x, n.y, n.z);
        }
    }
    for t in &mesh.triangles {
        let [a, b, c] = t.map(|v| v as u64 + 1);
        if normals.is_some() {
            let _ = writeln!(s, "f {a}//{a} {b}//{b} {c}//{c}");
        } else {
            let _ = writeln!(s, "f {a} {b} {c}");
        }
    }
    s.into_bytes()
}

/// Binary little-endian PLY: vertices as `double x, y, z` (plus `float nx, ny, nz` when
/// normals are given), faces as `list uchar uint vertex_indices`.
///
/// Panics if `normals` is given with a length other than the vertex count.
pub fn ply_bytes(mesh: &TriMesh, normals: Option<&[DVec3]>) -> Vec<u8> {
    if let Some(n) = normals {
        assert_eq!(n.len(), mesh.positions.len(), "one normal per vertex");
    }
    let mut header = String::new();
    header.push_str("ply\nformat binary_little_endian 1.0\ncomment written by volga\n");
    let _ = writeln!(header, "element vertex {}", mesh.positions.len());
    header.push_str("property double x\nproperty double y\nproperty double z\n");
    if normals.is_some() {
        header.push_str("property float nx\nproperty float ny\nproperty float nz\n");
    }
    let _ = writeln!(header, "element face {}", mesh.triangles.len());
    header.push_str("property list uchar uint vertex_indices\nend_header\n");
    let per_vertex = 24 + if normals.is_some() { 12 } else { 0 };
    let mut out = Vec::with_capacity(header.len() + mesh.positions.len() * per_vertex + mesh.triangles.len() * 13);
    out.extend_from_slice(header.as_bytes());
    for (i, p) in mesh.positions.iter().enumerate() {
        for c in p.to_array() {
            out.extend_from_slice(&c.to_le_bytes());
        }
        if let Some(ns) = normals {
            for c in ns[i].to_array() {
                out.extend_from_slice(&(c as f32).to_le_bytes());
            }
        }
    }
    for t in &mesh.triangles {
        out.push(3);
        for v in t {
            out.extend_from_slice(&v.to_le_bytes());
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use volga_core::Aabb;

    #[test]
    fn obj_round_trips_through_the_reader() {
        let cube = TriMesh::from_aabb(&Aabb::new(DVec3::new(1e6, 0.1, -0.3), DVec3::new(1e6 + 0.7, 1.0, 2.0)));
        let bytes = obj_bytes(&cube, None);
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("cube.obj");
        std::fs::write(&path, &bytes).unwrap();
        let back = crate::load_obj(&path).unwrap();
        // The reader may renumber vertices; the triangles' corners must be the same f64s.
        assert_eq!(back.triangle_count(), cube.triangle_count());
        for i in 0..cube.triangle_count() {
            assert_eq!(back.triangle(i), cube.triangle(i));
        }
    }

    #[test]
    fn ply_layout_is_exact() {
        let cube = TriMesh::from_aabb(&Aabb::new(DVec3::ZERO, DVec3::ONE));
        let normals = vec![DVec3::X; 8];
        let bytes = ply_bytes(&cube, Some(&normals));
        let text = String::from_utf8_lossy(&bytes);
        let end = text.find("end_header\n").unwrap() + "end_header\n".len();
        assert!(text[..end].contains("element vertex 8\n") && text[..end].contains("element face 12\n"));
        assert_eq!(bytes.len() - end, 8 * 36 + 12 * 13);
        // Vertex 7 is (1, 1, 1); its x is the first double of its record.
        let v7 = end + 7 * 36;
        assert_eq!(f64::from_le_bytes(bytes[v7..v7 + 8].try_into().unwrap()), 1.0);
        let f0 = end + 8 * 36;
        assert_eq!(bytes[f0], 3);
        assert_eq!(
            u32::from_le_bytes(bytes[f0 + 5..f0 + 9].try_into().unwrap()),
            cube.triangles[0][1]
        );
    }
}
