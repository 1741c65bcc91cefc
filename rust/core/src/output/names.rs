//! The names a frame's masks take in every output (EXR channels, PNG files, the protocol's
//! images), made here once: a light's name as given where it is safe and unique, otherwise
//! cleaned, shortened and numbered, so no light name can fail a write or hide another plane.

use crate::render::FrameResult;

/// Longest light part of a mask's name, in bytes: an EXR channel name may have 255, and the
/// `shadow.` prefix and a `#N` suffix must fit beside it.
pub const MAX_LIGHT_NAME_BYTES: usize = 200;

/// A mask's names: its plane (`shadow.<light>`, the EXR channel and protocol image) and its
/// PNG file's part (`shadow_<light>`).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct MaskName {
    pub plane: String,
    pub file: String,
}

/// A name as file names may hold it: letters and digits (any script's, so `Lamp ä` and `Lamp ö`
/// stay apart), `-`, `_` and `.`; anything else is `_`.
pub fn file_safe(name: &str) -> String {
    name.chars()
        .map(|c| {
            if c.is_alphanumeric() || c == '-' || c == '_' || c == '.' {
                c
            } else {
                '_'
            }
        })
        .collect()
}

/// The light part of a plane name: control characters become `_`, and at most
/// [`MAX_LIGHT_NAME_BYTES`] bytes are kept (cut at a character boundary).
fn plane_safe(light: &str) -> String {
    let mut out: String = light
        .chars()
        .map(|c| if c.is_control() { '_' } else { c })
        .collect();
    if out.len() > MAX_LIGHT_NAME_BYTES {
        let mut cut = MAX_LIGHT_NAME_BYTES;
        while !out.is_char_boundary(cut) {
            cut -= 1;
        }
        out.truncate(cut);
    }
    out
}

/// The names of every mask of `result`, in light order. A name already taken (by an earlier
/// mask, by `combined` or by a heat map such as `shadow.N_B`, as a plane or as a file) gets
/// `#2`, `#3`, ... after the light's name.
pub fn mask_names(result: &FrameResult) -> Vec<MaskName> {
    let mut planes: std::collections::HashSet<String> = std::iter::once(&result.combined)
        .chain(
            result
                .heat
                .iter()
                .flat_map(|h| h.primary.iter().chain(h.shadow.iter())),
        )
        .map(|p| p.name.clone())
        .collect();
    let mut files: std::collections::HashSet<String> = planes
        .iter()
        .map(|p| format!("heat_{}", file_safe(p)))
        .collect();
    files.insert("combined".into());
    result
        .masks
        .iter()
        .map(|m| {
            let light = plane_safe(&m.name);
            let mut n = 1;
            loop {
                let light = if n == 1 {
                    light.clone()
                } else {
                    format!("{light}#{n}")
                };
                let name = MaskName {
                    plane: format!("shadow.{light}"),
                    file: format!("shadow_{}", file_safe(&light)),
                };
                if !planes.contains(&name.plane) && !files.contains(&name.file) {
                    planes.insert(name.plane.clone());
                    files.insert(name.file.clone());
                    return name;
                }
                n += 1;
            }
        })
        .collect()
}
