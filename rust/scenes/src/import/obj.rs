//! OBJ read line by line from any reader, checking counts against the limits as they grow, so
//! memory stays within the limits whatever the input (a file's size bounds nothing when one
//! polygon line makes thousands of triangles). Hand-written rather than tobj, which reads the
//! whole file into its own buffers before a count could be checked.
//!
//! Read: `v` (x y z; more numbers ignored), `f` (polygons, triangulated as fans; `v`, `v/vt`,
//! `v//vn`, `v/vt/vn`, negative indices count back), `o` and `g` (a new mesh). Everything else
//! (normals, texture coordinates, materials, points, lines) is ignored.

use std::collections::HashMap;
use std::io::BufRead;
use std::sync::Arc;

use antumbra_core::scene::{Mesh, Object};
use glam::Vec3;

use super::limits::{check, ImportLimits, Totals};
use super::{y_up_to_z_up, Imported};

/// The name of the mesh before the first `o` or `g` line.
const UNNAMED: &str = "unnamed_object";

/// One `o`/`g` group being read: its own vertices (those its faces use) and triangles.
struct Group {
    name: String,
    /// File vertex index to this group's.
    local: HashMap<u32, u32>,
    positions: Vec<Vec3>,
    triangles: Vec<[u32; 3]>,
}

impl Group {
    fn new(name: String) -> Self {
        Group {
            name,
            local: HashMap::new(),
            positions: Vec::new(),
            triangles: Vec::new(),
        }
    }

    fn vertex(&mut self, index: u32, pool: &[Vec3]) -> u32 {
        *self.local.entry(index).or_insert_with(|| {
            self.positions.push(pool[index as usize]);
            (self.positions.len() - 1) as u32
        })
    }
}

/// The meshes of an OBJ read from `reader`; errors name the line (never echo its bytes).
pub(super) fn read_obj(
    mut reader: impl BufRead,
    limits: &ImportLimits,
) -> Result<Imported, String> {
    let mut totals = Totals::default();
    let mut out = Imported::default();
    let mut pool: Vec<Vec3> = Vec::new();
    let mut group = Group::new(UNNAMED.into());
    let mut line = Vec::new();
    let mut number = 0usize;
    loop {
        line.clear();
        let n = reader
            .read_until(b'\n', &mut line)
            .map_err(|e| format!("line {}: cannot read: {e}", number + 1))?;
        if n == 0 {
            break;
        }
        number += 1;
        totals.add_bytes("bytes read", n as u64, limits)?;
        let text = match line.iter().position(|&b| b == b'#') {
            Some(comment) => &line[..comment],
            None => &line[..],
        };
        let mut words = text
            .split(|b| b.is_ascii_whitespace())
            .filter(|w| !w.is_empty());
        match words.next() {
            Some(b"v") => {
                let mut xyz = [0f32; 3];
                for c in &mut xyz {
                    *c = words
                        .next()
                        .and_then(|w| std::str::from_utf8(w).ok()?.parse().ok())
                        .ok_or_else(|| format!("line {number}: a vertex needs three numbers"))?;
                }
                check(
                    &format!("line {number}: vertices"),
                    pool.len() as u64 + 1,
                    limits.max_file_vertices,
                    "max_file_vertices",
                )?;
                pool.push(Vec3::from_array(xyz));
            }
            Some(b"f") => {
                let corners = words
                    .map(|w| vertex_index(w, pool.len()))
                    .collect::<Option<Vec<u32>>>()
                    .ok_or_else(|| {
                        format!(
                            "line {number}: a face refers to a vertex that is not defined \
                             before it ({} are), or its index is not a number",
                            pool.len()
                        )
                    })?;
                // One or two corners: a point or a line, which cast no shadow.
                if corners.len() < 3 {
                    continue;
                }
                let new = corners.len() as u64 - 2;
                check(
                    &format!("line {number}: triangles of this mesh"),
                    group.triangles.len() as u64 + new,
                    limits.max_triangles_per_mesh,
                    "max_triangles_per_mesh",
                )?;
                totals.add_mesh_part(&format!("line {number}"), new, 0, limits)?;
                let first = group.vertex(corners[0], &pool);
                for pair in corners[1..].windows(2) {
                    let b = group.vertex(pair[0], &pool);
                    let c = group.vertex(pair[1], &pool);
                    group.triangles.push([first, b, c]);
                }
            }
            Some(b"o" | b"g") => {
                // The rest of the line after the one-letter keyword, spaces and all.
                let rest = &text.trim_ascii_start()[1..];
                let name = String::from_utf8_lossy(rest.trim_ascii()).into_owned();
                let name = if name.is_empty() {
                    UNNAMED.into()
                } else {
                    name
                };
                let done = std::mem::replace(&mut group, Group::new(name));
                finish(done, &mut out, &mut totals, limits, number)?;
            }
            _ => {}
        }
    }
    finish(group, &mut out, &mut totals, limits, number)?;
    Ok(out)
}

/// A face corner's vertex as an index into the file's vertices so far: the number before any
/// `/`, from 1, or negative counting back from the last vertex.
fn vertex_index(word: &[u8], defined: usize) -> Option<u32> {
    let number = word.split(|&b| b == b'/').next()?;
    let k: i64 = std::str::from_utf8(number).ok()?.parse().ok()?;
    let index = if k > 0 {
        k - 1
    } else {
        (defined as i64).checked_add(k)?
    };
    (0..defined as i64).contains(&index).then_some(index as u32)
}

/// Ends a group: a mesh and its object, if it has triangles.
fn finish(
    group: Group,
    out: &mut Imported,
    totals: &mut Totals,
    limits: &ImportLimits,
    line: usize,
) -> Result<(), String> {
    if group.triangles.is_empty() {
        return Ok(());
    }
    totals.add_mesh(&format!("line {line}: meshes"), limits)?;
    out.meshes.push(Arc::new(Mesh::new(
        group.name.clone(),
        group.positions,
        group.triangles,
    )));
    out.objects.push(Object::new(
        group.name,
        out.meshes.len() - 1,
        y_up_to_z_up(),
    ));
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn corners_resolve_forward_and_back() {
        assert_eq!(vertex_index(b"1", 3), Some(0));
        assert_eq!(vertex_index(b"3/1/2", 3), Some(2));
        assert_eq!(vertex_index(b"2//7", 3), Some(1));
        assert_eq!(vertex_index(b"-1", 3), Some(2));
        assert_eq!(vertex_index(b"-3", 3), Some(0));
        for bad in [
            &b"0"[..],
            b"4",
            b"-4",
            b"x",
            b"",
            b"/1",
            b"-9223372036854775808",
        ] {
            assert_eq!(vertex_index(bad, 3), None, "{:?}", bad);
        }
    }

    #[test]
    fn polygons_become_fans_and_groups_meshes() {
        let text = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\ng second\nf -1 -2 -3\nl 1 2\n";
        let out = read_obj(text.as_bytes(), &ImportLimits::default()).unwrap();
        assert_eq!(out.meshes.len(), 2);
        assert_eq!(out.meshes[0].name, UNNAMED);
        assert_eq!(out.meshes[0].triangles, vec![[0, 1, 2], [0, 2, 3]]);
        assert_eq!(out.meshes[1].name, "second");
        // Only the three vertices it uses, in the order it uses them.
        assert_eq!(out.meshes[1].positions.len(), 3);
        assert_eq!(out.meshes[1].positions[0], Vec3::new(0.0, 1.0, 0.0));
    }

    #[test]
    fn counts_are_checked_as_they_grow() {
        let limits = ImportLimits {
            max_triangles_per_mesh: 2,
            ..ImportLimits::default()
        };
        let text = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 2 0\nf 1 2 3 4 5\n";
        let err = read_obj(text.as_bytes(), &limits).err().unwrap();
        assert!(
            err.contains("line 6") && err.contains("max_triangles_per_mesh"),
            "{err}"
        );
        let limits = ImportLimits {
            max_file_vertices: 2,
            ..ImportLimits::default()
        };
        let err = read_obj(text.as_bytes(), &limits).err().unwrap();
        assert!(
            err.contains("line 3") && err.contains("max_file_vertices"),
            "{err}"
        );
    }
}
