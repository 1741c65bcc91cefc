//! The counts and sizes an import may reach, checked before anything is allocated for them.

use antumbra_core::scene::limits::{
    limit_exceeded, MAX_FILE_BYTES, MAX_FILE_TRIANGLES, MAX_FILE_VERTICES, MAX_MESHES, MAX_OBJECTS,
    MAX_TRIANGLES_PER_MESH,
};

/// What one import may hold; the default is core's `scene::limits` (those of the daemon's
/// defaults where it has one). The fuzz targets lower them to keep each run small.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ImportLimits {
    /// Bytes read: the file and every external buffer together.
    pub max_file_bytes: u64,
    pub max_triangles_per_mesh: u64,
    pub max_meshes: u64,
    /// Objects (OBJ: one per mesh; glTF: one per node holding a mesh) and glTF nodes visited.
    pub max_objects: u64,
    /// Triangles over all distinct meshes.
    pub max_file_triangles: u64,
    /// Vertices over all distinct meshes (OBJ: the file's whole vertex list).
    pub max_file_vertices: u64,
}

impl Default for ImportLimits {
    fn default() -> Self {
        ImportLimits {
            max_file_bytes: MAX_FILE_BYTES,
            max_triangles_per_mesh: MAX_TRIANGLES_PER_MESH,
            max_meshes: MAX_MESHES,
            max_objects: MAX_OBJECTS,
            max_file_triangles: MAX_FILE_TRIANGLES,
            max_file_vertices: MAX_FILE_VERTICES,
        }
    }
}

/// `Err` with the one wording of a limit when `value` is over `limit`.
pub(super) fn check(what: &str, value: u64, limit: u64, name: &str) -> Result<(), String> {
    if value > limit {
        Err(limit_exceeded(what, value, limit, name))
    } else {
        Ok(())
    }
}

/// Running totals of one import, each checked against its limit as it grows.
#[derive(Debug, Default)]
pub(super) struct Totals {
    pub bytes: u64,
    pub triangles: u64,
    pub vertices: u64,
    pub meshes: u64,
    pub objects: u64,
}

impl Totals {
    /// Counts `n` more bytes read (`what` names the file or buffer).
    pub fn add_bytes(&mut self, what: &str, n: u64, limits: &ImportLimits) -> Result<(), String> {
        self.bytes = self.bytes.saturating_add(n);
        check(what, self.bytes, limits.max_file_bytes, "max_file_bytes")
    }

    /// Counts a mesh of `triangles` and `vertices` before it is read (`what` names it).
    pub fn add_mesh_part(
        &mut self,
        what: &str,
        triangles: u64,
        vertices: u64,
        limits: &ImportLimits,
    ) -> Result<(), String> {
        self.triangles = self.triangles.saturating_add(triangles);
        self.vertices = self.vertices.saturating_add(vertices);
        check(
            &format!("{what}: triangles in the file"),
            self.triangles,
            limits.max_file_triangles,
            "max_file_triangles",
        )?;
        check(
            &format!("{what}: vertices in the file"),
            self.vertices,
            limits.max_file_vertices,
            "max_file_vertices",
        )
    }

    pub fn add_mesh(&mut self, what: &str, limits: &ImportLimits) -> Result<(), String> {
        self.meshes += 1;
        check(what, self.meshes, limits.max_meshes, "max_meshes")
    }

    pub fn add_object(&mut self, what: &str, limits: &ImportLimits) -> Result<(), String> {
        self.objects += 1;
        check(what, self.objects, limits.max_objects, "max_objects")
    }
}
