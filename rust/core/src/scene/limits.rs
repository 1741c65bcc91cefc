//! How much one scene may hold: the daemon's default request limits (`antumbra_protocol::Limits`)
//! and the file importers (`antumbra_scenes::load_file`) check the same figures, worded one way.

/// Most triangles in one mesh (the daemon's default `max_triangles_per_mesh`).
pub const MAX_TRIANGLES_PER_MESH: u64 = 50_000_000;
/// Most distinct meshes in one frame (the daemon's default `max_meshes`).
pub const MAX_MESHES: u64 = 100_000;
/// Most objects in one frame (the daemon's default `max_objects`): 2^24, the most the object-id
/// pass tells apart in f32. Instances of shared meshes cost memory per object, not per triangle
/// (two levels), and the memory estimate counts them.
pub const MAX_OBJECTS: u64 = 1 << 24;
/// Most bytes an import reads: the scene file and every external buffer it names together.
/// Checked against a file's size before it is read, so a wrong file is refused at once.
pub const MAX_FILE_BYTES: u64 = 2 << 30;
/// Most triangles an imported file holds over all its distinct meshes: a few meshes at the
/// per-mesh limit, but not one buffer's triangles repeated by thousands of glTF meshes.
pub const MAX_FILE_TRIANGLES: u64 = 2 * MAX_TRIANGLES_PER_MESH;
/// Most vertices an imported file holds over all its meshes: three per triangle.
pub const MAX_FILE_VERTICES: u64 = 3 * MAX_FILE_TRIANGLES;

/// The one wording of a count over its limit: "{what}: {value} exceeds the limit of {limit}
/// ({limit_name})", `limit_name` being the setting or constant that holds it.
pub fn limit_exceeded(what: &str, value: u64, limit: u64, limit_name: &str) -> String {
    format!("{what}: {value} exceeds the limit of {limit} ({limit_name})")
}
