//! The two little-endian files anyone's tracer can read (`--ray-files`, `--write-rays`): triangles
//! (u64 n, then n x 9 f32: three vertices' x y z) and rays (u64 n, then n x 8 f32: ox oy oz
//! tnear dx dy dz tfar). Reading checks everything Embree would assert on, so a bad file is an
//! error naming the file, the item, the field and the limit, never a crash.

use std::fs::File;
use std::io::{BufWriter, Read, Write};
use std::path::Path;

use antumbra_core::geometry::Ray;
use anyhow::{bail, Context, Result};
use glam::Vec3;

/// Embree's `FLT_LARGE`: the largest coordinate magnitude it accepts.
const FLT_LARGE: f32 = 1.844e18;

/// The most triangles or rays a file may announce (3.6 GB of triangles, 3.2 GB of rays).
pub(super) const MAX_ITEMS: u64 = 100_000_000;

const TRIANGLE_FIELDS: [&str; 9] = ["x0", "y0", "z0", "x1", "y1", "z1", "x2", "y2", "z2"];
const RAY_FIELDS: [&str; 8] = ["ox", "oy", "oz", "tnear", "dx", "dy", "dz", "tfar"];

/// The triangles of a triangle file.
pub(super) fn read_triangles(path: &Path) -> Result<Vec<[Vec3; 3]>> {
    let values = read_records(path, "triangles", TRIANGLE_FIELDS.len())?;
    values
        .chunks_exact(9)
        .enumerate()
        .map(|(i, v)| {
            for (field, &x) in TRIANGLE_FIELDS.iter().zip(v) {
                coordinate(x)
                    .with_context(|| format!("{}: triangle {i}, {field}", path.display()))?;
            }
            let p = |k: usize| Vec3::new(v[3 * k], v[3 * k + 1], v[3 * k + 2]);
            Ok([p(0), p(1), p(2)])
        })
        .collect()
}

/// The rays of a ray file.
pub(super) fn read_rays(path: &Path) -> Result<Vec<Ray>> {
    let values = read_records(path, "rays", RAY_FIELDS.len())?;
    values
        .chunks_exact(8)
        .enumerate()
        .map(|(i, v)| ray(v).with_context(|| format!("{}: ray {i}", path.display())))
        .collect()
}

/// One ray's eight values, checked as Embree needs them and antumbra's queries take them.
fn ray(v: &[f32]) -> Result<Ray> {
    for (k, field) in RAY_FIELDS.iter().enumerate() {
        if k != 3 && k != 7 {
            coordinate(v[k]).with_context(|| field.to_string())?;
        }
    }
    let (t_near, t_far) = (v[3], v[7]);
    if !(t_near.is_finite() && t_near >= 0.0) {
        bail!("tnear = {t_near}: must be finite and >= 0");
    }
    if t_far.is_nan() || t_far < t_near {
        bail!("tfar = {t_far}: must be >= tnear = {t_near} (+inf is fine)");
    }
    let direction = Vec3::new(v[4], v[5], v[6]);
    if direction == Vec3::ZERO {
        bail!("dx dy dz = 0 0 0: the direction must not be zero");
    }
    Ok(Ray::new(
        Vec3::new(v[0], v[1], v[2]),
        direction,
        t_near,
        t_far,
    ))
}

fn coordinate(x: f32) -> Result<()> {
    if !x.is_finite() {
        bail!("{x} is not finite");
    }
    if x.abs() > FLT_LARGE {
        bail!("|{x}| is above Embree's limit {FLT_LARGE:e}");
    }
    Ok(())
}

/// The header's n and then n records of `fields` f32 each, as one flat vector; the file must
/// hold exactly that many bytes.
fn read_records(path: &Path, what: &str, fields: usize) -> Result<Vec<f32>> {
    let shown = path.display();
    let mut file = File::open(path).with_context(|| format!("{shown}: cannot open"))?;
    let len = file
        .metadata()
        .with_context(|| format!("{shown}: cannot read its size"))?
        .len();
    let mut header = [0u8; 8];
    if len < 8 {
        bail!("{shown}: {len} bytes, shorter than the 8-byte header (u64 n, little-endian)");
    }
    file.read_exact(&mut header)
        .with_context(|| format!("{shown}: cannot read the header"))?;
    let n = u64::from_le_bytes(header);
    let record = 4 * fields as u64;
    if n > MAX_ITEMS {
        bail!("{shown}: n = {n} {what}, above the limit of {MAX_ITEMS}");
    }
    let expected = 8 + n * record;
    if len < expected {
        bail!(
            "{shown}: truncated: n = {n} {what} need 8 + {n} x {record} = {expected} bytes, the \
             file has {len}"
        );
    }
    if len > expected {
        bail!(
            "{shown}: {} bytes after the n = {n} {what} the header announces ({expected} bytes)",
            len - expected
        );
    }
    let mut bytes = Vec::with_capacity((n * record) as usize);
    file.read_to_end(&mut bytes)
        .with_context(|| format!("{shown}: cannot read"))?;
    if bytes.len() as u64 != n * record {
        bail!("{shown}: changed while being read");
    }
    Ok(bytes
        .chunks_exact(4)
        .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
        .collect())
}

/// Writes `triangles` as a triangle file.
pub(super) fn write_triangles(path: &Path, triangles: &[[Vec3; 3]]) -> Result<()> {
    let values = triangles
        .iter()
        .flat_map(|t| t.iter().flat_map(|v| v.to_array()));
    write_records(path, triangles.len(), values)
}

/// Writes `rays` as a ray file.
pub(super) fn write_rays(path: &Path, rays: &[Ray]) -> Result<()> {
    let values = rays.iter().flat_map(|r| {
        let (o, d) = (r.origin, r.direction);
        [o.x, o.y, o.z, r.t_min, d.x, d.y, d.z, r.t_max]
    });
    write_records(path, rays.len(), values)
}

fn write_records(path: &Path, n: usize, values: impl Iterator<Item = f32>) -> Result<()> {
    let shown = path.display();
    let mut out =
        BufWriter::new(File::create(path).with_context(|| format!("{shown}: cannot create"))?);
    let written = (|| -> std::io::Result<()> {
        out.write_all(&(n as u64).to_le_bytes())?;
        for v in values {
            out.write_all(&v.to_le_bytes())?;
        }
        out.flush()
    })();
    written.with_context(|| format!("{shown}: cannot write"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rays_and_triangles_read_back_as_written() {
        let dir = tempfile::tempdir().unwrap();
        let tris = vec![[Vec3::X, Vec3::Y, Vec3::new(-1.5, 2.0, 1e-7)]; 2];
        let rays = vec![
            Ray::new(Vec3::ONE, -Vec3::Z, 0.0, f32::INFINITY),
            Ray::new(Vec3::ZERO, Vec3::X, 0.25, 0.25),
        ];
        let (t, r) = (dir.path().join("t.bin"), dir.path().join("r.bin"));
        write_triangles(&t, &tris).unwrap();
        write_rays(&r, &rays).unwrap();
        assert_eq!(std::fs::metadata(&t).unwrap().len(), 8 + 2 * 36);
        assert_eq!(read_triangles(&t).unwrap(), tris);
        assert_eq!(read_rays(&r).unwrap(), rays);
    }
}
