//! Float EXR files: every plane of a frame as one named 32-bit float channel, losslessly
//! compressed, so the numbers (masks, work counts) survive bit for bit.

use std::collections::HashSet;
use std::path::Path;

use exr::block::lines::LineRefMut;
use exr::image::write::samples::{SamplesWriter, WritableSamples};
use exr::math::RoundingMode;
use exr::meta::attribute::{LevelMode, SampleType};
use exr::meta::header::Header;
use exr::prelude::{
    read, AnyChannel, AnyChannels, Encoding, FlatSamples, Image, Layer, LayerAttributes,
    ReadChannels, ReadLayers, SmallVec, Text, WritableImage,
};

use crate::atomic_file::write_atomic;
use crate::image::ImagePlane;
use crate::{Error, Result};

/// Longest channel name the EXR format allows.
const MAX_NAME_BYTES: usize = 255;

/// Writes `planes` into one EXR file, one F32 channel per plane named `plane.name` (UTF-8).
/// All planes must have the same, non-zero size and distinct names. ZIP compression (lossless).
/// Written atomically.
pub fn write_exr(path: &Path, planes: &[&ImagePlane]) -> Result<()> {
    let first = planes
        .first()
        .ok_or_else(|| Error::invalid(path.display().to_string(), "no image planes to write"))?;
    let mut names = HashSet::new();
    for plane in planes {
        plane.check_size()?;
        if (plane.width, plane.height) != (first.width, first.height) {
            return Err(Error::invalid(
                format!("image plane '{}'", plane.name),
                format!(
                    "size {}x{} differs from plane '{}' ({}x{}); one EXR needs equal sizes",
                    plane.width, plane.height, first.name, first.width, first.height
                ),
            ));
        }
        check_name(&plane.name)?;
        if !names.insert(plane.name.as_str()) {
            return Err(Error::invalid(
                format!("image plane '{}'", plane.name),
                "name used twice; EXR channel names must be unique",
            ));
        }
    }

    let channels: SmallVec<[AnyChannel<PlaneSamples>; 4]> = planes
        .iter()
        .map(|p| {
            let name = Text::from_slice_unchecked(p.name.as_bytes());
            AnyChannel::new(name, PlaneSamples(&p.data))
        })
        .collect();
    let size = (first.width as usize, first.height as usize);
    let layer = Layer::new(
        size,
        LayerAttributes::default(),
        Encoding::SMALL_LOSSLESS,
        AnyChannels::sort(channels),
    );
    let image = Image::from_layer(layer);
    write_atomic(path, |w| {
        image.write().to_buffered(w).map_err(|e| Error::io(path, e))
    })
}

/// A plane's samples as the EXR writer reads them, borrowed: the crate's own `FlatSamples` owns
/// its vector, and copying every plane of a 1920x1080 frame held 75 MB more at a frame's peak.
struct PlaneSamples<'a>(&'a [f32]);

impl<'s> WritableSamples<'s> for PlaneSamples<'_> {
    type Writer = PlaneLines<'s>;

    fn sample_type(&self) -> SampleType {
        SampleType::F32
    }

    fn infer_level_modes(&self) -> (LevelMode, RoundingMode) {
        (LevelMode::Singular, RoundingMode::Down)
    }

    fn create_samples_writer(&'s self, header: &Header) -> Self::Writer {
        PlaneLines {
            width: header.layer_size.width(),
            samples: self.0,
        }
    }
}

/// Hands the writer each line of a plane, as the crate's writer of `FlatSamples` does.
struct PlaneLines<'s> {
    width: usize,
    samples: &'s [f32],
}

impl SamplesWriter for PlaneLines<'_> {
    fn extract_line(&self, line: LineRefMut<'_>) {
        let start = line.location.position.y() * self.width + line.location.position.x();
        let end = start + line.location.sample_count;
        line.write_samples_from_slice(&self.samples[start..end])
            .expect("a line's bytes hold its samples");
    }
}

fn check_name(name: &str) -> Result<()> {
    let problem = if name.is_empty() {
        "empty name; EXR channels need one"
    } else if name.len() > MAX_NAME_BYTES {
        "name longer than 255 bytes, the EXR limit"
    } else if name.contains('\0') {
        "name contains a NUL character"
    } else {
        return Ok(());
    };
    Err(Error::invalid(format!("image plane '{name}'"), problem))
}

/// Reads every channel of every layer of an EXR file as planes, in file order (EXR sorts
/// channels by name). Channel names of named layers become `layer.channel`. F32 samples are
/// returned bit-exactly; F16 and U32 samples are converted to f32.
pub fn read_exr(path: &Path) -> Result<Vec<ImagePlane>> {
    let image = read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .all_layers()
        .all_attributes()
        .from_file(path)
        .map_err(|e| Error::io(path, e))?;
    let mut planes = Vec::new();
    for layer in image.layer_data {
        let (w, h) = (layer.size.0, layer.size.1);
        let prefix = layer
            .attributes
            .layer_name
            .as_ref()
            .map(|n| text_to_string(n.bytes()));
        for channel in layer.channel_data.list {
            let own = text_to_string(channel.name.bytes());
            let name = match &prefix {
                Some(layer_name) => format!("{layer_name}.{own}"),
                None => own,
            };
            let data: Vec<f32> = match channel.sample_data {
                FlatSamples::F32(v) => v,
                FlatSamples::F16(v) => v.into_iter().map(|s| s.to_f32()).collect(),
                FlatSamples::U32(v) => v.into_iter().map(|s| s as f32).collect(),
            };
            let (width, height) = match (u32::try_from(w), u32::try_from(h)) {
                (Ok(width), Ok(height)) if w.checked_mul(h) == Some(data.len()) => (width, height),
                _ => {
                    return Err(Error::invalid(
                        format!("{}: channel '{name}'", path.display()),
                        "subsampled or oversized channels are not supported",
                    ))
                }
            };
            planes.push(ImagePlane {
                name,
                width,
                height,
                data,
            });
        }
    }
    Ok(planes)
}

/// EXR text is bytes; we write UTF-8, other writers may use Latin-1.
fn text_to_string(bytes: &[u8]) -> String {
    match std::str::from_utf8(bytes) {
        Ok(s) => s.to_string(),
        Err(_) => bytes.iter().map(|&b| b as char).collect(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::output::file_names;
    use tempfile::TempDir;

    fn plane(name: &str, w: u32, h: u32, data: Vec<f32>) -> ImagePlane {
        assert_eq!(data.len(), (w * h) as usize);
        ImagePlane {
            name: name.into(),
            width: w,
            height: h,
            data,
        }
    }

    fn bits(p: &ImagePlane) -> Vec<u32> {
        p.data.iter().map(|v| v.to_bits()).collect()
    }

    #[test]
    fn output_exr_round_trip_is_bit_exact() {
        let dir = TempDir::new().unwrap();
        let path = dir.path().join("frame_0001.exr");
        let special = vec![
            0.0,
            -0.0,
            f32::from_bits(1),            // smallest subnormal
            -f32::from_bits(0x007f_ffff), // largest subnormal, negative
            f32::MIN_POSITIVE,
            f32::MAX,
            f32::MIN,
            1.0e30,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::from_bits(0x7fc0_1234), // NaN with a payload
            std::f32::consts::PI,
        ];
        let a = plane("shadow.Sun Lamp", 4, 3, special);
        let b = plane(
            "primary.N_B",
            4,
            3,
            (0..12).map(|i| (i * 37) as f32).collect(),
        );
        let c = plane(
            "combined",
            4,
            3,
            (0..12).map(|i| 1.0 / (i as f32 + 3.0)).collect(),
        );
        let d = plane("licht.Süd", 4, 3, vec![0.25; 12]);
        write_exr(&path, &[&a, &b, &c, &d]).unwrap();

        let mut back = read_exr(&path).unwrap();
        back.sort_by(|x, y| x.name.cmp(&y.name));
        let mut want = vec![a, b, c, d];
        want.sort_by(|x, y| x.name.cmp(&y.name));
        assert_eq!(back.len(), want.len());
        for (got, want) in back.iter().zip(&want) {
            assert_eq!(got.name, want.name);
            assert_eq!((got.width, got.height), (want.width, want.height));
            assert_eq!(bits(got), bits(want), "channel {}", want.name);
        }
        assert_eq!(file_names(dir.path()), vec!["frame_0001.exr".to_string()]);
    }

    #[test]
    fn output_exr_overwrites_atomically() {
        let dir = TempDir::new().unwrap();
        let path = dir.path().join("f.exr");
        let one = plane("a", 2, 1, vec![1.0, 2.0]);
        let two = plane("a", 1, 1, vec![3.0]);
        write_exr(&path, &[&one]).unwrap();
        write_exr(&path, &[&two]).unwrap();
        assert_eq!(read_exr(&path).unwrap(), vec![two]);
        assert_eq!(file_names(dir.path()), vec!["f.exr".to_string()]);
    }

    #[test]
    fn output_exr_mismatched_size_names_the_plane() {
        let dir = TempDir::new().unwrap();
        let path = dir.path().join("f.exr");
        let a = plane("combined", 2, 2, vec![0.0; 4]);
        let b = plane("primary.N_T", 2, 1, vec![0.0; 2]);
        let err = write_exr(&path, &[&a, &b]).unwrap_err();
        assert!(matches!(err, Error::Invalid { .. }), "{err}");
        assert!(err.to_string().contains("primary.N_T"), "{err}");
        assert!(file_names(dir.path()).is_empty());
    }

    #[test]
    fn output_exr_rejects_bad_input() {
        let dir = TempDir::new().unwrap();
        let path = dir.path().join("f.exr");
        assert!(write_exr(&path, &[]).is_err());
        let empty = plane("empty", 0, 0, vec![]);
        assert!(write_exr(&path, &[&empty]).is_err());
        let mut short = plane("short", 2, 1, vec![0.0; 2]);
        short.data.pop();
        assert!(write_exr(&path, &[&short]).is_err());
        let a = plane("same", 1, 1, vec![0.0]);
        let err = write_exr(&path, &[&a, &a]).unwrap_err();
        assert!(err.to_string().contains("same"), "{err}");
        let unnamed = plane("", 1, 1, vec![0.0]);
        assert!(write_exr(&path, &[&unnamed]).is_err());
        let long = plane(&"x".repeat(256), 1, 1, vec![0.0]);
        assert!(write_exr(&path, &[&long]).is_err());
        assert!(file_names(dir.path()).is_empty());

        let missing = read_exr(&dir.path().join("missing.exr")).unwrap_err();
        assert!(matches!(missing, Error::Io { .. }), "{missing}");
        std::fs::write(&path, b"not an exr").unwrap();
        assert!(matches!(read_exr(&path).unwrap_err(), Error::Io { .. }));
    }
}
