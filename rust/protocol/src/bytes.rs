//! Bulk arrays as little-endian bytes (MessagePack `bin`): one copy each way, no per-number
//! encoding, and a fixed layout that numpy reads with `frombuffer(dtype="<f4")`.
//!
//! Decoding checks that the byte length is a whole number of elements and names `field` if not.

use antumbra_core::scene::TriangleRef;
use glam::Vec3;
use serde_bytes::ByteBuf;

use crate::error::ProtocolError;

fn chunks<'a, const N: usize>(
    bytes: &'a [u8],
    field: &str,
    what: &str,
) -> Result<impl Iterator<Item = [u8; N]> + 'a, ProtocolError> {
    if !bytes.len().is_multiple_of(N) {
        return Err(ProtocolError::invalid(
            field,
            format!("{} bytes is not a multiple of {N} ({what})", bytes.len()),
        ));
    }
    Ok(bytes.chunks_exact(N).map(|c| {
        let mut a = [0u8; N];
        a.copy_from_slice(c);
        a
    }))
}

pub fn f32s_to_bytes(values: &[f32]) -> ByteBuf {
    ByteBuf::from(
        values
            .iter()
            .flat_map(|v| v.to_le_bytes())
            .collect::<Vec<u8>>(),
    )
}

pub fn u32s_to_bytes(values: &[u32]) -> ByteBuf {
    ByteBuf::from(
        values
            .iter()
            .flat_map(|v| v.to_le_bytes())
            .collect::<Vec<u8>>(),
    )
}

/// x, y, z of each vector as f32 LE: 12 bytes a vector.
pub fn vec3s_to_bytes(values: &[Vec3]) -> ByteBuf {
    ByteBuf::from(
        values
            .iter()
            .flat_map(|v| v.to_array())
            .flat_map(f32::to_le_bytes)
            .collect::<Vec<u8>>(),
    )
}

/// Three u32 LE indices per triangle: 12 bytes a triangle.
pub fn triangles_to_bytes(triangles: &[[u32; 3]]) -> ByteBuf {
    ByteBuf::from(
        triangles
            .iter()
            .flatten()
            .flat_map(|i| i.to_le_bytes())
            .collect::<Vec<u8>>(),
    )
}

/// (object, primitive) as two u32 LE: 8 bytes a reference.
pub fn triangle_refs_to_bytes(refs: &[TriangleRef]) -> ByteBuf {
    ByteBuf::from(
        refs.iter()
            .flat_map(|r| [r.object, r.primitive])
            .flat_map(u32::to_le_bytes)
            .collect::<Vec<u8>>(),
    )
}

pub fn bytes_to_f32s(bytes: &[u8], field: &str) -> Result<Vec<f32>, ProtocolError> {
    Ok(chunks::<4>(bytes, field, "f32 values")?
        .map(f32::from_le_bytes)
        .collect())
}

pub fn bytes_to_u32s(bytes: &[u8], field: &str) -> Result<Vec<u32>, ProtocolError> {
    Ok(chunks::<4>(bytes, field, "u32 values")?
        .map(u32::from_le_bytes)
        .collect())
}

pub fn bytes_to_vec3s(bytes: &[u8], field: &str) -> Result<Vec<Vec3>, ProtocolError> {
    Ok(chunks::<12>(bytes, field, "x, y, z as f32")?
        .map(|c| {
            let f = |i: usize| f32::from_le_bytes([c[i], c[i + 1], c[i + 2], c[i + 3]]);
            Vec3::new(f(0), f(4), f(8))
        })
        .collect())
}

/// Corner normals: 3 x, y, z as f32 per triangle, 36 bytes a triangle.
pub fn bytes_to_corner_normals(bytes: &[u8], field: &str) -> Result<Vec<[Vec3; 3]>, ProtocolError> {
    Ok(
        chunks::<36>(bytes, field, "3 normals of x, y, z as f32 per triangle")?
            .map(|c| {
                let f = |i: usize| f32::from_le_bytes([c[i], c[i + 1], c[i + 2], c[i + 3]]);
                [0, 12, 24].map(|k| Vec3::new(f(k), f(k + 4), f(k + 8)))
            })
            .collect(),
    )
}

pub fn bytes_to_triangles(bytes: &[u8], field: &str) -> Result<Vec<[u32; 3]>, ProtocolError> {
    Ok(chunks::<12>(bytes, field, "3 u32 indices per triangle")?
        .map(|c| {
            let u = |i: usize| u32::from_le_bytes([c[i], c[i + 1], c[i + 2], c[i + 3]]);
            [u(0), u(4), u(8)]
        })
        .collect())
}

/// Corner UVs: 3 u, v as f32 per triangle, 24 bytes a triangle.
pub fn bytes_to_corner_uvs(bytes: &[u8], field: &str) -> Result<Vec<[[f32; 2]; 3]>, ProtocolError> {
    Ok(
        chunks::<24>(bytes, field, "3 corners of u, v as f32 per triangle")?
            .map(|c| {
                let f = |i: usize| f32::from_le_bytes([c[i], c[i + 1], c[i + 2], c[i + 3]]);
                [0, 8, 16].map(|k| [f(k), f(k + 4)])
            })
            .collect(),
    )
}

pub fn corner_uvs_to_bytes(corners: &[[[f32; 2]; 3]]) -> ByteBuf {
    f32s_to_bytes(corners.as_flattened().as_flattened())
}

pub fn bytes_to_triangle_refs(
    bytes: &[u8],
    field: &str,
) -> Result<Vec<TriangleRef>, ProtocolError> {
    Ok(
        chunks::<8>(bytes, field, "object and triangle index as u32")?
            .map(|c| TriangleRef {
                object: u32::from_le_bytes([c[0], c[1], c[2], c[3]]),
                primitive: u32::from_le_bytes([c[4], c[5], c[6], c[7]]),
            })
            .collect(),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trips_and_layout() {
        let v = [Vec3::new(1.0, -2.5, f32::MIN_POSITIVE), Vec3::ZERO];
        let b = vec3s_to_bytes(&v);
        assert_eq!(b.len(), 24);
        assert_eq!(&b[0..4], &1.0f32.to_le_bytes());
        assert_eq!(bytes_to_vec3s(&b, "p").unwrap(), v);
        let t = [[0, 1, 2], [u32::MAX, 7, 9]];
        assert_eq!(bytes_to_triangles(&triangles_to_bytes(&t), "t").unwrap(), t);
        let f = [0.5f32, -0.0, f32::INFINITY];
        let back = bytes_to_f32s(&f32s_to_bytes(&f), "f").unwrap();
        assert_eq!(
            back.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
            f.iter().map(|v| v.to_bits()).collect::<Vec<_>>()
        );
        assert_eq!(bytes_to_u32s(&u32s_to_bytes(&[3, 4]), "u").unwrap(), [3, 4]);
        let r = [TriangleRef {
            object: 3,
            primitive: 70000,
        }];
        assert_eq!(
            bytes_to_triangle_refs(&triangle_refs_to_bytes(&r), "v").unwrap(),
            r
        );
    }

    #[test]
    fn bad_lengths_name_the_field() {
        let e = bytes_to_vec3s(&[0; 13], "mesh 'a'.positions").unwrap_err();
        assert!(e.to_string().contains("mesh 'a'.positions"), "{e}");
        assert!(e.to_string().contains("13 bytes"), "{e}");
        assert!(bytes_to_f32s(&[0; 3], "img").is_err());
        assert!(bytes_to_triangle_refs(&[0; 12], "visible").is_err());
    }
}
