//! A glTF's buffers: the GLB binary chunk, `data:` URIs (base64), or files inside the glTF's
//! own folder. Every buffer must hold its `byteLength`, and is cut to it.

use std::borrow::Cow;
use std::path::Path;

use base64::engine::general_purpose::{GeneralPurpose, GeneralPurposeConfig};
use base64::engine::DecodePaddingMode;
use base64::Engine;
use gltf::json::Root;

use super::super::file::{open_regular, read_all, resolve_in_folder};
use super::super::limits::{ImportLimits, Totals};

/// Standard base64, padded or not (exporters differ).
const BASE64: GeneralPurpose = GeneralPurpose::new(
    &base64::alphabet::STANDARD,
    GeneralPurposeConfig::new().with_decode_padding_mode(DecodePaddingMode::Indifferent),
);

/// Every buffer's bytes, in order. External files are read only with a `folder` (the glTF's
/// own); without one (bytes from memory, the fuzz targets) they are refused.
pub(super) fn load<'a>(
    root: &Root,
    bin: Option<&'a [u8]>,
    folder: Option<&Path>,
    totals: &mut Totals,
    limits: &ImportLimits,
) -> Result<Vec<Cow<'a, [u8]>>, String> {
    let mut out = Vec::with_capacity(root.buffers.len());
    for (i, buffer) in root.buffers.iter().enumerate() {
        let what = format!("buffer {i}");
        let data: Cow<[u8]> = match buffer.uri.as_deref() {
            None => Cow::Borrowed(bin.ok_or_else(|| {
                format!("{what} has no uri and the file has no GLB binary chunk")
            })?),
            Some(uri) if uri.starts_with("data:") => Cow::Owned(data_uri(uri, &what)?),
            Some(uri) => {
                let folder = folder.ok_or_else(|| {
                    format!("{what}: an external file is not read from bytes in memory")
                })?;
                let path = resolve_in_folder(folder, uri, &what)?;
                let (file, size) =
                    open_regular(&path, totals, limits).map_err(|e| format!("{what}: {e}"))?;
                Cow::Owned(read_all(file, size, &what, limits)?)
            }
        };
        let length = buffer.byte_length.0;
        if (data.len() as u64) < length {
            return Err(format!(
                "{what} holds {} bytes, fewer than its byteLength {length}",
                data.len()
            ));
        }
        out.push(match data {
            Cow::Borrowed(b) => Cow::Borrowed(&b[..length as usize]),
            Cow::Owned(mut b) => {
                b.truncate(length as usize);
                Cow::Owned(b)
            }
        });
    }
    Ok(out)
}

/// The bytes of a `data:[<media type>];base64,<data>` URI; its text is not echoed.
fn data_uri(uri: &str, what: &str) -> Result<Vec<u8>, String> {
    let (header, data) = uri
        .split_once(',')
        .ok_or_else(|| format!("{what}: the data: URI has no ','"))?;
    if !header.ends_with(";base64") {
        return Err(format!("{what}: the data: URI is not base64"));
    }
    BASE64
        .decode(data)
        .map_err(|_| format!("{what}: the data: URI is not valid base64"))
}
