//! Wavefront OBJ through `tobj`, behind volga's own line scan.

use std::path::Path;

use glam::DVec3;

use crate::{MeshError, TriMesh};

/// Loads an OBJ file: polygons triangulated (fans), every object and group merged,
/// materials ignored (a missing `.mtl` is not an error), points and lines skipped.
pub fn load_obj(path: impl AsRef<Path>) -> Result<TriMesh, MeshError> {
    let path = path.as_ref();
    let bytes = volga_core::input::read_input(path).map_err(|source| MeshError::Io {
        path: path.to_owned(),
        source,
    })?;
    read_obj(&bytes, path)
}

/// Parses OBJ text already in memory; `path` names it in error messages.
///
/// `tobj` reports errors without line numbers, so volga first scans the text itself
/// and rejects, naming the line, what would make `tobj` fail (or, for some malformed
/// indices, overflow): a `v`, `vt`, `vn`, `f` or `l` statement whose numbers do not
/// parse, a face with fewer than three corners, an index that is 0 or refers past the
/// elements defined *before* its line (negative indices count back from there, as in
/// the OBJ specification), a `usemtl` without a name. Vertices that are NaN or
/// infinite are rejected with the line of their `v` statement. Only text that passes
/// is handed to `tobj`.
pub fn read_obj(bytes: &[u8], path: &Path) -> Result<TriMesh, MeshError> {
    let text = std::str::from_utf8(bytes).map_err(|e| MeshError::ObjSyntax {
        path: path.to_owned(),
        line: bytes[..e.valid_up_to()].iter().filter(|&&b| b == b'\n').count() + 1,
        message: "not UTF-8 text".into(),
    })?;
    scan(text).map_err(|fault| match fault {
        Fault::Syntax { line, message } => MeshError::ObjSyntax {
            path: path.to_owned(),
            line,
            message,
        },
        Fault::NonFinite { line, vertex, position } => MeshError::NonFiniteVertex {
            path: path.to_owned(),
            line,
            vertex,
            position,
        },
    })?;
    // tobj's `merging` and `reordering` features add fields; another crate of the
    // workspace may turn them on.
    #[allow(clippy::needless_update)]
    let options = tobj::LoadOptions {
        triangulate: true,
        single_index: false,
        ignore_points: true,
        ignore_lines: true,
        ..Default::default()
    };
    let (models, _materials) =
        tobj::load_obj_buf(&mut text.as_bytes(), &options, |_| Ok(Default::default())).map_err(|e| MeshError::Obj {
            path: path.to_owned(),
            message: e.to_string(),
        })?;

    let mut mesh = TriMesh::default();
    for model in models {
        let base = mesh.positions.len();
        let vertex_count = model.mesh.positions.len() / 3;
        mesh.positions.extend(
            model
                .mesh
                .positions
                .chunks_exact(3)
                .map(|c| DVec3::new(c[0], c[1], c[2])),
        );
        if u32::try_from(mesh.positions.len()).is_err() {
            return Err(MeshError::TooManyVertices { path: path.to_owned() });
        }
        for t in model.mesh.indices.chunks_exact(3) {
            if t.iter().any(|&i| i as usize >= vertex_count) {
                let message = format!("object `{}` has a face index out of range", model.name);
                return Err(MeshError::Obj {
                    path: path.to_owned(),
                    message,
                });
            }
            mesh.triangles.push([t[0], t[1], t[2]].map(|i| i + base as u32));
        }
    }
    if mesh.triangles.is_empty() {
        return Err(MeshError::Empty { path: path.to_owned() });
    }
    Ok(mesh)
}

enum Fault {
    Syntax {
        line: usize,
        message: String,
    },
    NonFinite {
        line: usize,
        vertex: usize,
        position: [f64; 3],
    },
}

/// Counts of the elements defined so far, which face indices refer to.
#[derive(Default)]
struct Defined {
    vertices: usize,
    texcoords: usize,
    normals: usize,
}

fn scan(text: &str) -> Result<(), Fault> {
    let mut defined = Defined::default();
    for (index, line) in text.lines().enumerate() {
        let line_number = index + 1;
        let syntax = |message: String| Fault::Syntax {
            line: line_number,
            message: format!("{message}: `{}`", excerpt(line)),
        };
        let mut words = line.split_whitespace();
        match words.next() {
            Some("v") => {
                let values: Vec<&str> = words.collect();
                let xyz = parse_numbers::<3>(&values).ok_or_else(|| syntax("`v` needs three numbers x y z".into()))?;
                let w = match values.len() {
                    3 | 6 => 1.0, // x y z, or x y z r g b (colours are not used)
                    4 => values[3]
                        .parse::<f64>()
                        .ok()
                        .filter(|&w| w != 0.0)
                        .ok_or_else(|| syntax("the fourth number of `v` (w) must be a non-zero number".into()))?,
                    _ => return Err(syntax("`v` takes x y z, x y z w, or x y z r g b".into())),
                };
                defined.vertices += 1;
                let position = xyz.map(|c| c / w);
                if !position.iter().all(|c| c.is_finite()) {
                    return Err(Fault::NonFinite {
                        line: line_number,
                        vertex: defined.vertices,
                        position,
                    });
                }
            }
            Some("vt") => {
                let values: Vec<&str> = words.collect();
                parse_numbers::<2>(&values).ok_or_else(|| syntax("`vt` needs two numbers u v".into()))?;
                defined.texcoords += 1;
            }
            Some("vn") => {
                let values: Vec<&str> = words.collect();
                parse_numbers::<3>(&values).ok_or_else(|| syntax("`vn` needs three numbers".into()))?;
                defined.normals += 1;
            }
            Some("f") => {
                let mut corners = 0;
                for token in words {
                    check_face_corner(token, &defined).map_err(syntax)?;
                    corners += 1;
                }
                if corners < 3 {
                    return Err(syntax(format!("a face needs at least 3 corners, found {corners}")));
                }
            }
            // tobj parses `l` as it parses `f` (it drops two-corner ones afterwards), so
            // its indices are checked as a face's are: an index past the elements defined
            // overflowed in tobj.
            Some("l") => {
                for token in words {
                    check_face_corner(token, &defined).map_err(syntax)?;
                }
            }
            // tobj takes the name after the first space, so mirror that exactly.
            Some("usemtl") if line.split_once(' ').unwrap_or_default().1.trim().is_empty() => {
                return Err(syntax("`usemtl` needs a material name".into()));
            }
            _ => {}
        }
    }
    Ok(())
}

/// The first `N` values as numbers, if there are at least `N` and they parse.
fn parse_numbers<const N: usize>(values: &[&str]) -> Option<[f64; N]> {
    let mut out = [0.0; N];
    for (slot, value) in out.iter_mut().zip(values.get(..N)?) {
        *slot = value.parse().ok()?;
    }
    Some(out)
}

/// The up to three `/`-separated indices of a face corner `v`, `v/vt`, `v//vn` or
/// `v/vt/vn` (empty slots are `None`), as tobj reads them.
fn corner_indices(token: &str) -> Result<[Option<isize>; 3], String> {
    let mut indices = [None; 3];
    for (slot, part) in token.split('/').enumerate() {
        if part.is_empty() {
            continue;
        }
        let value = part
            .parse::<isize>()
            .map_err(|_| format!("`{part}` in corner `{token}` is not an index"))?;
        *indices
            .get_mut(slot)
            .ok_or_else(|| format!("corner `{token}` has more than three indices"))? = Some(value);
    }
    Ok(indices)
}

fn check_face_corner(token: &str, defined: &Defined) -> Result<(), String> {
    let indices = corner_indices(token)?;
    if indices[0].is_none() {
        return Err(format!("corner `{token}` has no vertex index"));
    }
    let kinds = [
        ("vertex", defined.vertices),
        ("texture coordinate", defined.texcoords),
        ("normal", defined.normals),
    ];
    for (index, (kind, count)) in indices.into_iter().zip(kinds) {
        let Some(index) = index else { continue };
        if index == 0 {
            return Err(format!("{kind} index 0 in corner `{token}` (OBJ indices start at 1)"));
        }
        if index.unsigned_abs() > count {
            return Err(format!(
                "{kind} index {index} is out of range: {count} defined before this line"
            ));
        }
    }
    Ok(())
}

/// The start of a line, for messages.
fn excerpt(line: &str) -> String {
    let trimmed = line.trim();
    if trimmed.chars().count() > 60 {
        format!("{}…", trimmed.chars().take(60).collect::<String>())
    } else {
        trimmed.to_owned()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn read(text: &str) -> Result<TriMesh, MeshError> {
        read_obj(text.as_bytes(), Path::new("test.obj"))
    }

    fn error_line(text: &str) -> (usize, String) {
        match read(text) {
            Err(e @ MeshError::ObjSyntax { line, .. }) | Err(e @ MeshError::NonFiniteVertex { line, .. }) => {
                (line, e.to_string())
            }
            other => panic!("expected a located error, got {other:?}"),
        }
    }

    #[test]
    fn quads_are_triangulated_and_objects_merged() {
        let text = "o a\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n\
                    o b\nv 0 0 1\nf -1 1 2\nusemtl x\nmtllib missing.mtl\n";
        let mesh = read(text).unwrap();
        assert_eq!(mesh.triangles.len(), 3);
        assert_eq!(mesh.positions.len(), 4 + 3);
    }

    #[test]
    fn faces_with_texcoords_and_normals() {
        let text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvn 0 0 1\nf 1/1/1 2/1/1 3//1\nv 0 0 2 2\nf 1 2 -1\n";
        let mesh = read(text).unwrap();
        assert_eq!(mesh.triangles.len(), 2);
        assert!(mesh.positions.contains(&DVec3::new(0.0, 0.0, 1.0)), "w divides");
    }

    #[test]
    fn malformed_lines_are_named() {
        let (line, message) = error_line("v 0 0 0\nv 1 2\nf 1 2 3\n");
        assert_eq!(line, 2);
        assert!(message.starts_with("test.obj:2: `v` needs three numbers"), "{message}");
        assert_eq!(error_line("v 0 0 0\nv 1 0 0\nv 0 1 0\n\nf 1 2 99\n").0, 5);
        assert_eq!(error_line("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n").0, 4);
        assert_eq!(error_line("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 -4\n").0, 4);
        assert_eq!(error_line("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/1 2 3\n").0, 4); // no vt defined
        assert_eq!(error_line("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2\n").0, 4);
        assert_eq!(error_line("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3x\n").0, 4);
        assert_eq!(error_line("v 0 0 0 0\n").0, 1);
        assert_eq!(error_line("v 0 0 0\nusemtl\n").0, 2);
        assert_eq!(error_line("v 0 0 0\nvn 1 x 0\n").0, 2);
    }

    #[test]
    fn non_finite_vertices_name_their_line() {
        let text = "v 0 0 0\n# comment\nv 1 0 0\nv nan 0 0\nf 1 2 3\n";
        match read(text) {
            Err(e @ MeshError::NonFiniteVertex { line: 4, vertex: 3, .. }) => {
                assert!(e.to_string().starts_with("test.obj:4: vertex 3 is not finite"), "{e}");
            }
            other => panic!("{other:?}"),
        }
        assert_eq!(error_line("v 1e999 0 0\n").0, 1);
        assert_eq!(error_line("v 1 0 0 1e-320\n").0, 1);
    }

    #[test]
    fn empty_and_binary_input() {
        assert!(matches!(read("v 0 0 0\n"), Err(MeshError::Empty { .. })));
        assert!(matches!(read(""), Err(MeshError::Empty { .. })));
        let bytes = b"v 0 0 0\n\xff\xfe\n";
        assert!(matches!(
            read_obj(bytes, Path::new("x.obj")),
            Err(MeshError::ObjSyntax { line: 2, .. })
        ));
    }
}
