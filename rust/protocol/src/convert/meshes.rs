//! Meshes and alpha images: uploads decoded and checked (daemon side), and encoded (client side).

use antumbra_core::alpha::AlphaImage;
use antumbra_core::scene::{Mesh, UvMap};

use crate::bytes::{
    bytes_to_corner_normals, bytes_to_corner_uvs, bytes_to_f32s, bytes_to_triangles, bytes_to_u32s,
    bytes_to_vec3s, corner_uvs_to_bytes, f32s_to_bytes, triangles_to_bytes, u32s_to_bytes,
    vec3s_to_bytes,
};
use crate::error::ProtocolError;
use crate::limits::Limits;
use crate::messages::{UploadImage, UploadMesh, UvMapState};

/// Decodes and checks an upload: byte lengths (12 bytes a vertex, 12 a triangle), the triangle
/// limit, finite positions, indices in range, and that `hash` is the content hash of what
/// arrived. Every error names the mesh.
pub fn mesh_from_upload(upload: &UploadMesh, limits: &Limits) -> Result<Mesh, ProtocolError> {
    let name = &upload.name;
    let triangle_count = upload.triangles.len() as u64 / 12;
    if triangle_count > limits.max_triangles_per_mesh {
        return Err(ProtocolError::LimitExceeded {
            what: format!("mesh '{name}': triangles"),
            value: triangle_count,
            limit: limits.max_triangles_per_mesh,
            limit_name: "max_triangles_per_mesh",
        });
    }
    let positions = bytes_to_vec3s(&upload.positions, &format!("mesh '{name}'.positions"))?;
    let triangles = bytes_to_triangles(&upload.triangles, &format!("mesh '{name}'.triangles"))?;
    let normals = bytes_to_corner_normals(&upload.normals, &format!("mesh '{name}'.normals"))?;
    let material_slots = bytes_to_u32s(
        &upload.material_slots,
        &format!("mesh '{name}'.material_slots"),
    )?;
    let uv_maps = uv_maps_from_upload(upload, limits)?;
    let mesh = Mesh::new(name.clone(), positions, triangles)
        .with_normals(normals)
        .with_alpha(material_slots, uv_maps);
    mesh.validate()?;
    let actual = mesh.content_hash();
    if actual != upload.hash {
        return Err(ProtocolError::HashMismatch {
            mesh: name.clone(),
            declared: upload.hash,
            actual,
        });
    }
    Ok(mesh)
}

/// An upload's UV maps: at most `max_uv_maps`, names distinct (a material finds its map by
/// name), whole corners; counts and values are checked with the mesh (`Mesh::validate`).
fn uv_maps_from_upload(upload: &UploadMesh, limits: &Limits) -> Result<Vec<UvMap>, ProtocolError> {
    let name = &upload.name;
    let count = upload.uv_maps.len() as u64;
    if count > limits.max_uv_maps {
        return Err(ProtocolError::LimitExceeded {
            what: format!("mesh '{name}': uv_maps"),
            value: count,
            limit: limits.max_uv_maps,
            limit_name: "max_uv_maps",
        });
    }
    let mut maps: Vec<UvMap> = Vec::with_capacity(upload.uv_maps.len());
    for map in &upload.uv_maps {
        let field = format!("mesh '{name}'.uv_maps['{}']", map.name);
        if maps.iter().any(|m| m.name == map.name) {
            return Err(ProtocolError::invalid(field, "two UV maps have this name"));
        }
        let corners = bytes_to_corner_uvs(&map.corners, &format!("{field}.corners"))?;
        maps.push(UvMap {
            name: map.name.clone(),
            corners,
        });
    }
    Ok(maps)
}

pub fn upload_from_mesh(mesh: &Mesh) -> UploadMesh {
    UploadMesh {
        hash: mesh.content_hash(),
        name: mesh.name.clone(),
        positions: vec3s_to_bytes(&mesh.positions),
        triangles: triangles_to_bytes(&mesh.triangles),
        normals: vec3s_to_bytes(mesh.normals.as_flattened()),
        material_slots: u32s_to_bytes(&mesh.material_slots),
        uv_maps: mesh
            .uv_maps
            .iter()
            .map(|m| UvMapState {
                name: m.name.clone(),
                corners: corner_uvs_to_bytes(&m.corners),
            })
            .collect(),
    }
}

/// How messages name an image: by its hash (images have no name on the wire).
pub fn image_label(hash: u64) -> String {
    format!("image {hash:#018x}")
}

/// Decodes and checks an image upload: the texel limit (before decoding), the byte length,
/// `width * height` finite texels, and that `hash` is the content hash of what arrived.
pub fn image_from_upload(
    upload: &UploadImage,
    limits: &Limits,
) -> Result<AlphaImage, ProtocolError> {
    crate::check::check_image_texels(upload, limits)?;
    let label = image_label(upload.hash);
    let texels = bytes_to_f32s(&upload.texels, &format!("{label}.texels"))?;
    let image = AlphaImage {
        width: upload.width,
        height: upload.height,
        texels,
    };
    image.validate(&label)?;
    let actual = image.content_hash();
    if actual != upload.hash {
        return Err(ProtocolError::ImageHashMismatch {
            declared: upload.hash,
            actual,
        });
    }
    Ok(image)
}

pub fn upload_from_image(image: &AlphaImage) -> UploadImage {
    UploadImage {
        hash: image.content_hash(),
        width: image.width,
        height: image.height,
        texels: f32s_to_bytes(&image.texels),
    }
}
