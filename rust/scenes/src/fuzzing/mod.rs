//! The bodies of the importers' cargo-fuzz targets (`rust/protocol/fuzz`, targets `obj` and
//! `gltf`), here so that plain `#[test]`s run the same code over the seed corpora
//! (`rust/protocol/fuzz/corpus/{obj,gltf}`) and deterministic mutations without cargo-fuzz.

mod gltf;
mod obj;

use antumbra_core::scene::Animation;
use antumbra_core::Error;

use crate::import::ImportLimits;

pub use self::gltf::{glb, gltf};
pub use self::obj::obj;

/// Limits low enough that no input can make one run slow or big, high enough for every seed.
fn limits() -> ImportLimits {
    ImportLimits {
        max_file_bytes: 1 << 20,
        max_triangles_per_mesh: 20_000,
        max_meshes: 64,
        max_objects: 1024,
        max_file_triangles: 50_000,
        max_file_vertices: 150_000,
    }
}

/// What an import must give: a refusal naming `name`, or two frames of one valid, framed scene
/// with triangles, sharing their meshes.
fn check(name: &str, result: antumbra_core::Result<Box<dyn Animation>>) {
    let anim = match result {
        Ok(anim) => anim,
        Err(Error::Invalid { field, .. }) if field == name => return,
        Err(e) => panic!("an error that does not name {name}: {e:?}"),
    };
    assert_eq!(anim.frame_range(), 1..=2);
    let (a, b) = (anim.frame(1), anim.frame(2));
    assert!(a.triangle_count() > 0, "an import with no triangle");
    if let Err(e) = a.validate() {
        panic!("an imported scene that does not validate: {e}");
    }
    assert_eq!(b.frame, 2);
    assert_eq!(a.meshes.len(), b.meshes.len());
    assert!(a
        .meshes
        .iter()
        .zip(&b.meshes)
        .all(|(x, y)| std::sync::Arc::ptr_eq(x, y)));
    let limits = limits();
    assert!(a.meshes.len() as u64 <= limits.max_meshes);
    assert!(a.objects.len() as u64 <= limits.max_objects);
    for mesh in &a.meshes {
        assert!(mesh.triangles.len() as u64 <= limits.max_triangles_per_mesh);
    }
}
