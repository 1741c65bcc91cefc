//! The GLB container split by hand: the `gltf` crate's own splitter subtracts before it checks
//! (a declared length under 12 overflows), and its errors echo the bytes it did not expect.

/// The JSON chunk and the optional BIN chunk of a GLB file.
pub(super) fn split(data: &[u8]) -> Result<(&[u8], Option<&[u8]>), String> {
    let bad = |why: &str| format!("not a valid GLB file: {why}");
    let version = word(data, 4).ok_or_else(|| bad("the 12-byte header is cut short"))?;
    if version != 2 {
        return Err(bad(&format!("version {version}, only 2 is read")));
    }
    let length = word(data, 8).ok_or_else(|| bad("the 12-byte header is cut short"))? as usize;
    if length < 12 || length > data.len() {
        return Err(bad(&format!(
            "the header's length {length} is not between 12 and the file's {} bytes",
            data.len()
        )));
    }
    let data = &data[..length];
    let mut at = 12;
    let mut chunks = Vec::new();
    while at < data.len() {
        let (Some(len), Some(kind)) = (word(data, at), word(data, at + 4)) else {
            return Err(bad(&format!("chunk header at byte {at} is cut short")));
        };
        let start = at + 8;
        let end = start
            .checked_add(len as usize)
            .filter(|&end| end <= data.len())
            .ok_or_else(|| bad(&format!("chunk at byte {at} runs past the file's end")))?;
        chunks.push((kind, &data[start..end]));
        // Chunks are 4-byte aligned; a last chunk may omit its padding.
        at = end.next_multiple_of(4);
    }
    const JSON: u32 = u32::from_le_bytes(*b"JSON");
    const BIN: u32 = u32::from_le_bytes(*b"BIN\0");
    match chunks.as_slice() {
        [(JSON, json), rest @ ..] => {
            // Chunks of other types are skipped, as the spec asks.
            let bin = rest.iter().find(|(k, _)| *k == BIN).map(|(_, b)| *b);
            Ok((json, bin))
        }
        _ => Err(bad("the first chunk is not JSON")),
    }
}

/// The little-endian word at `at`, if the data holds it.
fn word(data: &[u8], at: usize) -> Option<u32> {
    let bytes = data.get(at..at.checked_add(4)?)?;
    Some(u32::from_le_bytes(bytes.try_into().ok()?))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn glb(length: u32, chunks: &[(&[u8; 4], &[u8])]) -> Vec<u8> {
        let mut out = b"glTF".to_vec();
        out.extend_from_slice(&2u32.to_le_bytes());
        out.extend_from_slice(&length.to_le_bytes());
        for (kind, body) in chunks {
            out.extend_from_slice(&(body.len() as u32).to_le_bytes());
            out.extend_from_slice(*kind);
            out.extend_from_slice(body);
        }
        out
    }

    #[test]
    fn chunks_are_found_and_lengths_checked() {
        let file = glb(36, &[(b"JSON", b"{}  "), (b"BIN\0", b"abcd")]);
        assert_eq!(split(&file).unwrap(), (&b"{}  "[..], Some(&b"abcd"[..])));
        for length in [0, 11, 37, u32::MAX] {
            let file = glb(length, &[(b"JSON", b"{}  "), (b"BIN\0", b"abcd")]);
            assert!(split(&file).unwrap_err().contains("length"), "{length}");
        }
        assert!(split(&glb(24, &[(b"BIN\0", b"abcd")])).is_err());
        let mut long = glb(24, &[(b"JSON", b"{}  ")]);
        long[12] = 200;
        assert!(split(&long).unwrap_err().contains("past"));
        assert!(split(b"glTF\x02\x00").is_err());
    }
}
